/**
 * The Cartesian view: a plan of the Cartesian form (``POST /v1/trajectories/cartesian``), its tool
 * path beside the ideal path (line or arc) with the arm, the deviation from the path against s
 * with the tolerances, the smallest singular value against s, every warning and the failure marked
 * at its s. The tool path, the arm at start and goal and the knots come from one batched FK request.
 */

import { api, framePoints, problemOf } from './api.js';
import { cartesianRequest } from './cartesian_form.js';
import { renderClearance } from './clearance.js';
import { $, fmt } from './dom.js';
import { renderJoints } from './joints_plot.js';
import { axis, baseLayout, centreNote, COLORS, draw, FAIL_COLOR, marksOf, placeholder, sMarks, WARN_COLOR } from './plot.js';
import { armItem, contactItems, drawScene, geometryItems, obstacleItems } from './scene.js';
import { ikGhosts, isPlanar, robot, robotName, setToolMid } from './state.js';
import { addConfigurations, answerStatus, busy, done, pageError, renderProblem, renderSummary,
  renderWarnings, setDownloads, showRequest } from './status.js';
import { showView } from './tabs.js';
import { fkGroups, idealPath, MAX_TOOL_POINTS, subsample, sOfTime, toolPathOf } from './toolpath.js';

export const DEFAULT_TOLERANCE = { position: 1e-3, orientation: 1e-2 };
let redraw = null; // draws the last scene of plot-path again (the geometry toggle)
let lastDeviation = null;

function markItems(ideal, marks, dims) {
  return marks.filter((m) => m.s !== null).map((m) => ({ name: `${m.label} at s=${fmt(m.s, 3)}`,
    pts: [ideal.at(m.s)], style: { mode: 'markers', text: [m.message],
      marker: { size: dims === 3 ? 7 : 13,
        symbol: m.kind === 'failure' ? 'x' : (dims === 3 ? 'diamond-open' : 'triangle-up'),
        color: m.kind === 'failure' ? FAIL_COLOR : WARN_COLOR },
      hovertemplate: '%{text}<extra></extra>' } }));
}

function endArms(ideal, tool, failure) {
  const items = [];
  const startFk = ideal && ideal.startFk ? ideal.startFk : null;
  const startArm = framePoints(startFk) || (tool && tool.arm[0]);
  const startLabel = startFk ? startFk.configuration : tool && tool.config[0];
  if (startArm) {
    items.push(armItem(`arm at start${startLabel ? ` (${startLabel})` : ''}`, startArm,
      { line: { color: COLORS[2], width: 7 }, marker: { size: 3, color: COLORS[2] } },
      { role: 'arm', which: 'start', configuration: startLabel || null }));
  }
  const goalFk = ideal && ideal.goalFk ? ideal.goalFk : null;
  const last = tool && tool.p.length ? tool.p.length - 1 : -1;
  const goalArm = framePoints(goalFk) || (last >= 0 && !failure ? tool.arm[last] : null);
  const goalLabel = goalFk ? goalFk.configuration : (last >= 0 ? tool.config[last] : null);
  if (goalArm) {
    items.push(armItem(`arm at goal${goalLabel ? ` (${goalLabel})` : ''}`, goalArm,
      { line: { color: '#111', width: 7 }, marker: { size: 3, color: '#111' }, opacity: 0.75 },
      { role: 'arm', which: 'goal', configuration: goalLabel || null }));
  }
  items.push(...geometryItems(startFk ? startFk.frames : tool && tool.frames[0],
    'collision geometry at start', 'show-geometry'));
  return items;
}

/**
 * The tool path (FK of the returned points) beside the ideal path (null for joint moves), the
 * arm at the start and the goal, the moving arm, obstacles, the first contact, and ``extra``
 * scene items (the waypoints of a collision-free motion).
 */
export function renderPath(ideal, tool, marks, knotsTool, failure, extra) {
  redraw = () => renderPath(ideal, tool, marks, knotsTool, failure, extra);
  if (!ideal && !(tool && tool.p.length)) {
    placeholder('plot-path', 'No path: the start (or goal) joints were refused');
    return;
  }
  const items = [];
  const add = (name, pts, style, meta) => items.push({ name: name, pts: pts, style: style, meta: meta });
  const dims = isPlanar() ? 2 : 3;
  if (ideal) {
    add(ideal.shape === 'circ' ? 'ideal arc' : 'ideal line', ideal.pts, { mode: 'lines', opacity: 0.45,
      line: { color: '#6b7280', width: dims === 3 ? 12 : 8 }, hoverinfo: 'skip' });
  }
  if (tool && tool.p.length) {
    add('tool path', tool.p, { mode: 'lines+markers', line: { color: COLORS[0], width: 2 },
      marker: { size: dims === 3 ? 2.5 : 4, color: COLORS[0] },
      text: tool.s.map((s, k) => `t=${fmt(tool.t[k], 4)} s, s=${s === null ? '?' : fmt(s, 3)}`),
      hovertemplate: '%{text}<extra>tool</extra>' });
  }
  if (knotsTool && knotsTool.length) {
    add('knots', knotsTool, { mode: 'markers',
      marker: { symbol: 'diamond', size: dims === 3 ? 4 : 8, color: '#111' } });
  }
  const p0 = ideal ? ideal.p0 : tool.p[0];
  const p1 = ideal ? ideal.p1 : tool.p[tool.p.length - 1];
  add('start', [p0], { mode: 'markers', marker: { size: dims === 3 ? 6 : 11, color: COLORS[2] } });
  add('goal', [p1], { mode: 'markers', marker: { size: dims === 3 ? 6 : 11, color: '#111',
    symbol: dims === 3 ? 'square' : 'star' } });
  if (ideal) items.push(...markItems(ideal, marks, dims));
  items.push(...endArms(ideal, tool, failure));
  ikGhosts().forEach((g) => items.push(armItem(`IK ${g.label}`, g.pts,
    { opacity: 0.35, line: { color: '#0891b2', width: 4, dash: 'dot' }, marker: { size: 2, color: '#0891b2' } },
    { role: 'ik-ghost', configuration: g.label })));
  items.push(...(extra || []), ...obstacleItems(), ...contactItems(failure, tool));
  setToolMid(tool && tool.p.length ? tool.p[Math.floor(tool.p.length / 2)] : p0);
  drawScene('plot-path', items, tool && tool.arm.every(Boolean) ? tool : null,
    `${robotName()}-tool-path`);
}

/** Draw the last scene of the tool path plot again (``fn``: how, for a scene drawn elsewhere). */
export function redrawPath(fn) {
  if (typeof fn === 'function') redraw = fn;
  else if (redraw) redraw();
}

export function renderDeviation(diag, tolerance, marks, emptyMessage) {
  lastDeviation = [diag, tolerance, marks, emptyMessage];
  const yType = $('dev-log').checked ? { type: 'log', exponentformat: 'power' }
    : { rangemode: 'tozero', exponentformat: 'e' };
  const planar = isPlanar();
  const prof = diag && diag.deviation_profile;
  const has = Boolean(prof && prof.s && prof.s.length);
  const traces = [];
  if (has) {
    traces.push({ type: 'scatter', mode: 'lines', name: 'position deviation', x: prof.s,
      y: prof.position, line: { color: COLORS[0], width: 2 }, xaxis: 'x', yaxis: 'y',
      hovertemplate: '%{y:.3g} m<extra>s=%{x:.4f}</extra>' });
    if (!planar) {
      traces.push({ type: 'scatter', mode: 'lines', name: 'orientation deviation', x: prof.s,
        y: prof.orientation, line: { color: COLORS[1], width: 2 }, xaxis: 'x', yaxis: 'y2',
        hovertemplate: '%{y:.3g} rad<extra>s=%{x:.4f}</extra>' });
    }
  }
  traces.push({ type: 'scatter', mode: 'lines', name: `position tolerance ${fmt(tolerance.position)} m`,
    x: [0, 1], y: [tolerance.position, tolerance.position], xaxis: 'x', yaxis: 'y',
    line: { color: FAIL_COLOR, width: 1.5, dash: 'dash' }, meta: { role: 'tolerance' } });
  if (!planar) {
    traces.push({ type: 'scatter', mode: 'lines',
      name: `orientation tolerance ${fmt(tolerance.orientation)} rad`, x: [0, 1],
      y: [tolerance.orientation, tolerance.orientation], xaxis: 'x', yaxis: 'y2',
      line: { color: '#a855f7', width: 1.5, dash: 'dash' }, meta: { role: 'tolerance' } });
  }
  const m = sMarks(marks.filter((k) => k.s !== null));
  if (!has && emptyMessage) m.annotations.push(centreNote(emptyMessage));
  const layout = baseLayout({
    xaxis: axis('s (path parameter)', { range: [-0.02, 1.02] }),
    yaxis: axis('position [m]', Object.assign({ domain: planar ? [0, 1] : [0.54, 1],
      title: { text: 'position [m]', standoff: 4, font: { size: 11 } } }, yType)),
    shapes: m.shapes, annotations: m.annotations,
    legend: { orientation: 'h', y: -0.2, yanchor: 'top', font: { size: 11 } },
    margin: { l: 70, r: 16, t: 22, b: 40 },
  });
  if (!planar) {
    layout.yaxis2 = axis('orientation [rad]', Object.assign({ domain: [0, 0.44], anchor: 'x',
      title: { text: 'orientation [rad]', standoff: 4, font: { size: 11 } } }, yType));
    layout.xaxis.anchor = 'y2';
  }
  draw('plot-deviation', traces, layout, `${robotName()}-deviation`);
}

export function renderSigma(diag, tool, marks, emptyMessage) {
  const prof = diag && diag.singular_value_profile;
  const sAt = sOfTime(diag && diag.deviation_profile);
  let x = null;
  let y = null;
  if (prof && prof.value && prof.value.length && sAt) {
    x = prof.time_from_start.map(sAt);
    y = prof.value;
  } else if (tool && tool.s.length && tool.s.every((s) => s !== null)) {
    x = tool.s; // fallback: the FK answers' own smallest singular values
    y = tool.sigma;
  }
  const traces = [];
  if (x) {
    traces.push({ type: 'scatter', mode: 'lines', name: 'smallest singular value', x: x, y: y,
      line: { color: COLORS[4], width: 2 }, hovertemplate: '%{y:.4g}<extra>s=%{x:.4f}</extra>' });
  }
  const m = sMarks(marks.filter((k) => k.s !== null));
  if (!x && emptyMessage) m.annotations.push(centreNote(emptyMessage));
  draw('plot-sigma', traces, baseLayout({
    xaxis: axis('s (path parameter)', { range: [-0.02, 1.02] }),
    yaxis: axis('σ min of the task Jacobian', { rangemode: 'tozero' }),
    shapes: m.shapes, annotations: m.annotations, showlegend: false,
    margin: { l: 70, r: 16, t: 22, b: 44 },
  }), `${robotName()}-singular-value`);
}

/** The same request with ``allow_partial``: the planned prefix of a plan that failed at s > 0. */
async function prefixOf(path, req, problem, base) {
  if (!(problem && problem.s !== undefined && problem.s !== null && problem.s > 0 &&
      $('c-prefix').checked && !req.allow_partial)) return null;
  const partial = await api('POST', path, Object.assign({}, req, { allow_partial: true }));
  if (!(partial.ok && partial.json.points && partial.json.points.length)) return null;
  return { body: partial.json, download: { label: 'Download prefix JSON', filename: `${base}-prefix.json`,
    text: partial.text }, note: { text: 'Drawn below: the planned prefix up to s = ' +
    `${fmt(partial.json.diagnostics.fraction, 4)} (the same request with allow_partial).` } };
}

/** Draw a Cartesian answer: one FK request for the ends, the tool path and the knots. */
async function drawAnswer(req, body, problem, failure, marks) {
  const idx = body ? subsample(body.points.length, MAX_TOOL_POINTS) : [];
  const knotIdx = body && body.knots ? subsample(body.knots.length, MAX_TOOL_POINTS) : [];
  const [[startFk], goal, answers, knotAnswers] = await fkGroups([
    [req.start.positions], req.goal.positions ? [req.goal.positions] : [],
    idx.map((i) => body.points[i].positions), knotIdx.map((i) => body.knots[i].positions)], true);
  const ideal = idealPath(req, startFk, goal[0] || null);
  const tool = body ? toolPathOf(body, idx, answers, ideal) : null;
  const knotsTool = knotAnswers.filter(Boolean).map((a) => a.pose.position);
  const diag = body ? body.diagnostics : null;
  const tolerance = Object.assign({}, DEFAULT_TOLERANCE, req.tolerance || {});
  const empty = problem ? `no trajectory: ${problem.code || 'error'}` : 'no deviation data';
  renderPath(ideal, tool, marks, knotsTool, failure);
  addConfigurations(ideal && ideal.startFk ? ideal.startFk.configuration : null,
    ideal && ideal.goalFk ? ideal.goalFk.configuration : (tool && !failure ? tool.config[tool.config.length - 1] : null));
  renderDeviation(diag, tolerance, marks, empty);
  renderSigma(diag, tool, marks, empty);
  renderClearance('', diag, req);
  const knots = body && body.knots ? body.knots.map((k, i) => ({ t: k.time_from_start,
    positions: k.positions, label: `knot ${i + 1} (s=${fmt(k.s, 3)})`, kind: 'knots' })) : null;
  renderJoints(body, robot().limits, knots,
    problem ? `No trajectory: ${problem.code || 'error'} — ${problem.detail || ''}` : 'No trajectory');
}

export async function runCartesian(override) {
  const req = Object.assign(cartesianRequest(), override || {});
  const path = '/v1/trajectories/cartesian';
  showRequest('POST', path, req);
  busy(`Planning ${req.method} …`);
  showView('cartesian');
  try {
    const res = await api('POST', path, req);
    const base = `${robotName()}-${req.method}`;
    const downloads = [{ label: 'Download JSON', filename: `${base}.json`, text: res.text }];
    let body = res.ok ? res.json : null;
    const problem = res.ok ? null : problemOf(res);
    const prefix = await prefixOf(path, req, problem, base);
    if (prefix) {
      body = prefix.body;
      downloads.push(prefix.download);
    }
    setDownloads(downloads);
    const diag = body ? body.diagnostics : null;
    const failure = problem || (diag && diag.failure ? Object.assign({ title: 'Partial plan' }, diag.failure) : null);
    const marks = marksOf(diag, failure);
    if (problem) renderProblem(problem, `POST ${path}`, prefix ? prefix.note : null);
    else if (failure) renderProblem(failure, 'allow_partial: the planned prefix is drawn', { partial: true });
    else renderProblem(null);
    answerStatus(res, path, body, problem);
    renderSummary(body);
    renderWarnings(marks);
    await drawAnswer(req, body, problem, failure, marks);
  } catch (e) {
    pageError(e);
  } finally {
    done();
  }
}

export function wireCartesianView() {
  $('dev-log').addEventListener('change', () => { if (lastDeviation) renderDeviation(...lastDeviation); });
}
