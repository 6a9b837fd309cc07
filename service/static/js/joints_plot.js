/**
 * The Joints view: position, velocity, acceleration and jerk of every joint against time, one row
 * each in one figure (a click on a joint in the legend hides it in every row), the limits dashed
 * in the joint's colour, and the knots or waypoints marked.
 */

import { $ } from './dom.js';
import { axis, baseLayout, COLORS, draw, extent, padded, placeholder } from './plot.js';
import { robotName } from './state.js';

const QUANTITIES = [
  { key: 'positions', title: 'position', unit: 'rad' },
  { key: 'velocities', title: 'velocity', unit: 'rad/s' },
  { key: 'accelerations', title: 'acceleration', unit: 'rad/s²' },
  { key: 'jerk', title: 'jerk (finite differences of a)', unit: 'rad/s³' },
];

let last = null; // arguments of the last renderJoints, to redraw on the zoom toggle

/** Jerk of joint j at every point: central differences of the returned accelerations. */
function jerkOf(points, j) {
  const n = points.length;
  return points.map((p, i) => {
    if (n < 2) return 0;
    const a = points[Math.max(0, i - 1)];
    const b = points[Math.min(n - 1, i + 1)];
    const dt = b.time_from_start - a.time_from_start;
    return dt > 0 ? (b.accelerations[j] - a.accelerations[j]) / dt : 0;
  });
}

/** [lo, hi] of joint j's limit for quantity ``q``, or null where none is known (jerk). */
function limitOf(limits, key, j) {
  if (key === 'positions') return limits.position[j];
  if (key === 'jerk') {
    if (!Array.isArray(limits.jerk) || !Number.isFinite(limits.jerk[j])) return null;
    return [-limits.jerk[j], limits.jerk[j]];
  }
  const hi = (key === 'velocities' ? limits.velocity : limits.acceleration)[j];
  return [-hi, hi];
}

function knotTraces(knots, names) {
  const x = [];
  const y = [];
  const colors = [];
  const text = [];
  knots.forEach((k) => k.positions.forEach((v, j) => {
    x.push(k.t); y.push(v); colors.push(COLORS[j % COLORS.length]);
    text.push(`${k.label} · ${names[j]}`);
  }));
  return { type: 'scatter', mode: 'markers', name: knots[0].kind || 'knots', x: x, y: y,
    xaxis: 'x', yaxis: 'y', text: text, meta: { role: 'knots' },
    marker: { symbol: 'diamond', size: 8, color: colors, line: { color: '#111', width: 1 } },
    hovertemplate: '%{text}: %{y:.4g} rad' };
}

/**
 * Draw ``body``'s points against time.
 *   limits: {position: [[lo, hi]], velocity: [..], acceleration: [..], jerk?: [..]}
 *   knots: [{t, positions, label, kind}] or null
 */
export function renderJoints(body, limits, knots, emptyMessage) {
  last = [body, limits, knots, emptyMessage];
  if (!body || !body.points || !body.points.length) {
    placeholder('plot-joints', emptyMessage || 'No trajectory');
    return;
  }
  const t = body.points.map((p) => p.time_from_start);
  const names = body.joint_names;
  const [t0, t1] = [t[0], t[t.length - 1]];
  const positionLimitsInView = $('j-zoom-limits').checked;
  const traces = [];
  const layout = baseLayout({
    grid: { rows: QUANTITIES.length, columns: 1, pattern: 'coupled', roworder: 'top to bottom', ygap: 0.1 },
    xaxis: axis('time [s]'),
    hovermode: 'x unified',
    legend: { font: { size: 11 }, tracegroupgap: 2 },
    margin: { l: 70, r: 16, t: 30, b: 44 },
    shapes: [],
  });
  QUANTITIES.forEach((q, row) => {
    const ax = row === 0 ? '' : String(row + 1);
    const data = [];
    const lims = [];
    names.forEach((name, j) => {
      const color = COLORS[j % COLORS.length];
      const y = q.key === 'jerk' ? jerkOf(body.points, j) : body.points.map((p) => p[q.key][j]);
      data.push(...y);
      traces.push({ type: 'scatter', mode: 'lines', name: name, legendgroup: name,
        showlegend: row === 0, x: t, y: y, xaxis: 'x', yaxis: `y${ax}`,
        line: { color: color, width: 2 }, meta: { role: 'joint', quantity: q.title },
        hovertemplate: `%{y:.4g} ${q.unit}` });
      const lim = limitOf(limits, q.key, j);
      if (!lim) return;
      const [lo, hi] = lim;
      lims.push(lo, hi);
      traces.push({ type: 'scatter', mode: 'lines', name: `${name} limits`, legendgroup: name,
        showlegend: false, x: [t0, t1, null, t0, t1], y: [hi, hi, null, lo, lo],
        xaxis: 'x', yaxis: `y${ax}`, line: { color: color, width: 1, dash: 'dash' },
        opacity: 0.75, meta: { role: 'limit', quantity: q.title }, hoverinfo: 'skip' });
    });
    if (knots && knots.length && q.key === 'positions') traces.push(knotTraces(knots, names));
    const inView = q.key !== 'positions' || positionLimitsInView;
    const range = extent(inView ? data.concat(lims) : data);
    layout[`yaxis${ax}`] = axis(`${q.title} [${q.unit}]`, range ? { range: padded(range) } : {});
    (knots || []).forEach((k) => layout.shapes.push({ type: 'line', xref: 'x',
      yref: `y${ax} domain`, x0: k.t, x1: k.t, y0: 0, y1: 1,
      line: { color: '#9aa0a6', width: 1, dash: 'dot' }, layer: 'below' }));
    if (q.key === 'positions') {
      const [lo, hi] = extent(data) || [0, 0];
      const hidden = lims.filter((v) => v < lo || v > hi).length;
      $('j-limits-note').textContent = !inView && hidden
        ? `${hidden} of ${lims.length} position limits lie outside the view` : '';
    }
  });
  draw('plot-joints', traces, layout, `${robotName()}-joints`);
}

export function wireJointsPlot() {
  $('j-zoom-limits').addEventListener('change', () => { if (last) renderJoints(...last); });
}
