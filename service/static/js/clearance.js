/**
 * Clearance over time: the smallest robot-obstacle / link-link distance
 * (``diagnostics.clearance_profile``) with the requested ``clearance`` dashed, in the card
 * ``card<suffix>-clearance`` of a view; shown only when the request carried an environment and the
 * answer has a profile.
 */

import { $, fmt } from './dom.js';
import { axis, baseLayout, COLORS, draw, FAIL_COLOR } from './plot.js';
import { robotName } from './state.js';

export function renderClearance(suffix, diag, req) {
  const card = $(`card${suffix}-clearance`);
  const prof = diag && diag.clearance_profile;
  const env = req && req.environment;
  card.hidden = !(env && prof && prof.time_from_start && prof.time_from_start.length);
  if (card.hidden) return null;
  const t = prof.time_from_start;
  const clearance = env.clearance || 0;
  const traces = [
    { type: 'scatter', mode: 'lines', name: 'smallest distance', x: t, y: prof.value,
      line: { color: COLORS[0], width: 2 }, meta: { role: 'clearance-profile' },
      hovertemplate: '%{y:.4f} m<extra>t=%{x:.3f} s</extra>' },
    { type: 'scatter', mode: 'lines', name: `clearance ${fmt(clearance)} m`,
      x: [t[0], t[t.length - 1]], y: [clearance, clearance],
      line: { color: FAIL_COLOR, width: 1.5, dash: 'dash' }, meta: { role: 'clearance' } },
  ];
  if (diag.min_clearance !== undefined && diag.min_clearance !== null) {
    traces[0].name = `smallest distance (min ${fmt(diag.min_clearance, 4)} m)`;
  }
  return draw(`plot${suffix}-clearance`, traces, baseLayout({
    xaxis: axis('time [s]'), yaxis: axis('distance [m]'),
    legend: { orientation: 'h', y: -0.3, yanchor: 'top', font: { size: 11 } },
    margin: { l: 64, r: 16, t: 16, b: 40 },
  }), `${robotName()}-clearance`);
}
