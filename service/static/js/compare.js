/**
 * The Compare view: ``POST /v1/compare`` with the Cartesian form's task and the checked methods; a
 * table of the diagnostics (one row per method, "open" plans that method alone), the deviation
 * curves of every method overlaid (a failed method marked at its s) and every method's clearance.
 */

import { api, problemOf } from './api.js';
import { cartesianRequest } from './cartesian_form.js';
import { DEFAULT_TOLERANCE, runCartesian } from './cartesian_view.js';
import { $, el, fmt, num, saveText } from './dom.js';
import { axis, baseLayout, centreNote, COLORS, draw, FAIL_COLOR, sMarks } from './plot.js';
import { isPlanar, robotName } from './state.js';
import { busy, done, pageError, renderProblem, renderSummary, renderWarnings, setDownloads,
  setStatus, showRequest } from './status.js';
import { showView } from './tabs.js';

let download = null;
let last = null; // arguments of the last renderComparePlot, to redraw on the log toggle

function renderCompareTable(results) {
  const table = $('compare-table');
  table.textContent = '';
  const planar = isPlanar();
  const cols = ['method', 'result', 'duration [s]', 'fraction', 'max position dev. [m]',
    planar ? null : 'max orientation dev. [rad]', 'min σ', 'knots', 'compute [ms]', 'warnings']
    .filter(Boolean);
  table.append(el('thead', {}, el('tr', {}, cols.map((c) => el('th', {}, c)))));
  const tbody = el('tbody');
  results.forEach((r, i) => {
    const d = r.diagnostics || {};
    const err = r.error || null;
    const color = COLORS[i % COLORS.length];
    tbody.append(el('tr', { class: r.ok ? 'ok' : 'failed', 'data-method': r.method },
      el('td', {}, el('span', { class: 'swatch', style: `background:${color}` }), r.method, ' ',
        el('button', { type: 'button', class: 'small', title: 'plan this method alone and show it',
          onclick: () => { $('c-method').value = r.method; runCartesian({ method: r.method }); } }, 'open')),
      el('td', { class: r.ok ? 'good' : 'bad' }, r.ok ? '✔ ok' : `✖ ${err && err.code ? err.code : 'failed'}`),
      el('td', {}, fmt(d.duration)),
      el('td', {}, fmt(d.fraction)),
      el('td', {}, fmt(d.max_position_deviation, 3)),
      planar ? null : el('td', {}, fmt(d.max_orientation_deviation, 3)),
      el('td', {}, fmt(d.min_singular_value)),
      el('td', {}, fmt(d.knot_count)),
      el('td', {}, fmt(d.compute_time_ms, 3)),
      el('td', { title: (d.warnings || []).join('\n') }, String((d.warnings || []).length))));
    if (err) {
      const at = err.s !== undefined && err.s !== null ? `at s = ${fmt(err.s, 4)}: ` : '';
      tbody.append(el('tr', { class: 'failed detail', 'data-method-detail': r.method },
        el('td', { colspan: cols.length, class: 'problem-cell' }, `${at}${err.detail || err.title || ''}`)));
    }
  });
  table.append(tbody);
}

function deviationTraces(results, planar, marks) {
  const traces = [];
  results.forEach((r, i) => {
    const color = COLORS[i % COLORS.length];
    const prof = r.diagnostics && r.diagnostics.deviation_profile;
    if (prof && prof.s && prof.s.length) {
      traces.push({ type: 'scatter', mode: 'lines', name: r.method, legendgroup: r.method,
        x: prof.s, y: prof.position, xaxis: 'x', yaxis: 'y', line: { color: color, width: 2 },
        hovertemplate: `${r.method}: %{y:.3g} m<extra>s=%{x:.4f}</extra>` });
      if (!planar) {
        traces.push({ type: 'scatter', mode: 'lines', name: `${r.method} orientation`,
          legendgroup: r.method, showlegend: false, x: prof.s, y: prof.orientation, xaxis: 'x',
          yaxis: 'y2', line: { color: color, width: 2 },
          hovertemplate: `${r.method}: %{y:.3g} rad<extra>s=%{x:.4f}</extra>` });
      }
    }
    if (!r.ok && r.error && r.error.s !== undefined && r.error.s !== null) {
      marks.push({ kind: 'failure', s: r.error.s, label: `✖ ${r.method}`, color: color,
        message: `${r.error.code}: ${r.error.detail}` });
    }
  });
  return traces;
}

function renderComparePlot(results, tolerance, emptyMessage) {
  last = [results, tolerance, emptyMessage];
  const planar = isPlanar();
  const yType = $('cmp-log').checked ? { type: 'log', exponentformat: 'power' }
    : { rangemode: 'tozero', exponentformat: 'e' };
  const marks = [];
  const traces = deviationTraces(results, planar, marks);
  traces.push({ type: 'scatter', mode: 'lines', name: `position tolerance ${fmt(tolerance.position)} m`,
    x: [0, 1], y: [tolerance.position, tolerance.position], xaxis: 'x', yaxis: 'y',
    line: { color: '#111', width: 1.5, dash: 'dash' }, meta: { role: 'tolerance' } });
  if (!planar) {
    traces.push({ type: 'scatter', mode: 'lines',
      name: `orientation tolerance ${fmt(tolerance.orientation)} rad`, x: [0, 1],
      y: [tolerance.orientation, tolerance.orientation], xaxis: 'x', yaxis: 'y2',
      line: { color: '#6b7280', width: 1.5, dash: 'dash' }, meta: { role: 'tolerance' } });
  }
  const m = sMarks(marks);
  if (emptyMessage) m.annotations.push(centreNote(emptyMessage, 13));
  const layout = baseLayout({
    xaxis: axis('s (path parameter)', { range: [-0.02, 1.02] }),
    yaxis: axis('position deviation [m]', Object.assign({ domain: planar ? [0, 1] : [0.54, 1] },
      yType)),
    shapes: m.shapes, annotations: m.annotations,
    legend: { font: { size: 11 } }, margin: { l: 70, r: 16, t: 16, b: 44 },
  });
  if (!planar) {
    layout.yaxis2 = axis('orientation deviation [rad]', Object.assign({ domain: [0, 0.44],
      anchor: 'x' }, yType));
    layout.xaxis.anchor = 'y2';
  }
  draw('plot-compare', traces, layout, `${robotName()}-compare-deviation`);
}

/** Every method's smallest distance over time, the requested clearance dashed: shown only when
 * the task carried an environment and some row has a ``clearance_profile``. */
function renderCompareClearance(results, task) {
  const card = $('card-compare-clearance');
  const env = task && task.environment;
  const rows = results.map((r, i) => [r, COLORS[i % COLORS.length]]).filter(([r]) => {
    const prof = r.diagnostics && r.diagnostics.clearance_profile;
    return prof && prof.time_from_start && prof.time_from_start.length;
  });
  card.hidden = !(env && rows.length);
  if (card.hidden) return null;
  const clearance = env.clearance || 0;
  let tEnd = 0;
  const traces = rows.map(([r, color]) => {
    const prof = r.diagnostics.clearance_profile;
    tEnd = Math.max(tEnd, prof.time_from_start[prof.time_from_start.length - 1]);
    const min = r.diagnostics.min_clearance;
    return { type: 'scatter', mode: 'lines', x: prof.time_from_start, y: prof.value,
      name: min !== undefined && min !== null ? `${r.method} (min ${fmt(min, 4)} m)` : r.method,
      line: { color: color, width: 2 }, meta: { role: 'clearance-profile', method: r.method },
      hovertemplate: `${r.method}: %{y:.4f} m<extra>t=%{x:.3f} s</extra>` };
  });
  traces.push({ type: 'scatter', mode: 'lines', name: `clearance ${fmt(clearance)} m`,
    x: [0, tEnd], y: [clearance, clearance],
    line: { color: FAIL_COLOR, width: 1.5, dash: 'dash' }, meta: { role: 'clearance' } });
  return draw('plot-compare-clearance', traces, baseLayout({
    xaxis: axis('time [s]'), yaxis: axis('distance [m]'),
    legend: { orientation: 'h', y: -0.3, yanchor: 'top', font: { size: 11 } },
    margin: { l: 64, r: 16, t: 16, b: 40 },
  }), `${robotName()}-compare-clearance`);
}

export async function runCompare() {
  const task = cartesianRequest();
  delete task.method;
  const control = num('c-control');
  if (control !== undefined) task.control_period = control; // used by the rate methods
  const methods = Array.from(document.querySelectorAll('input[name="c-compare-method"]:checked'))
    .map((n) => n.value);
  const all = Array.from(document.querySelectorAll('input[name="c-compare-method"]')).map((n) => n.value);
  const body = { task: task, methods: methods.length ? methods : all };
  const path = '/v1/compare';
  showRequest('POST', path, body);
  busy(`Comparing ${body.methods.length} methods …`);
  showView('compare');
  try {
    const res = await api('POST', path, body);
    const filename = `${robotName()}-compare.json`;
    setDownloads([{ label: 'Download JSON', filename: filename, text: res.text }]);
    download = { filename: filename, text: res.text };
    $('download-compare').disabled = false;
    renderSummary(null);
    renderWarnings([]);
    const tolerance = Object.assign({}, DEFAULT_TOLERANCE, task.tolerance || {});
    if (!res.ok) {
      const problem = problemOf(res);
      renderProblem(problem, `POST ${path}`);
      setStatus('error', `POST ${path} → ${res.status} ${problem.code || ''}`);
      renderCompareTable([]);
      renderComparePlot([], tolerance, `compare failed: ${problem.code || res.status}`);
      renderCompareClearance([], task);
      return;
    }
    renderProblem(null);
    const results = res.json.results || [];
    const failed = results.filter((r) => !r.ok).length;
    setStatus(failed ? 'warn' : 'ok', `POST ${path} → ${res.status} in ${Math.round(res.ms)} ms · ` +
      `${results.length - failed} of ${results.length} methods planned the line`);
    renderCompareTable(results);
    renderComparePlot(results, tolerance);
    renderCompareClearance(results, task);
  } catch (e) {
    pageError(e);
  } finally {
    done();
  }
}

export function wireCompare() {
  $('c-compare').addEventListener('click', () => runCompare());
  $('cmp-log').addEventListener('change', () => { if (last) renderComparePlot(...last); });
  $('download-compare').addEventListener('click', () => {
    if (download) saveText(download.filename, download.text);
  });
}
