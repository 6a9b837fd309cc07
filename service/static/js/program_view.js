/**
 * The Program view: a program's tool path in 3D (one colour per segment, blends dotted, blend
 * spheres, segment goals, the arm, the waypoints of collision-free PTP segments), the speed of
 * every joint and of the tool against time with each segment's and blend's window shaded, the
 * clearance, and a table of the segments. Everything drawn comes from the plan and one batched FK
 * request (tool path, joint goals, waypoints).
 */

import { api, problemOf } from './api.js';
import { renderClearance } from './clearance.js';
import { waypointItems } from './collision_free.js';
import { $, el, fmt } from './dom.js';
import { renderJoints } from './joints_plot.js';
import { axis, baseLayout, COLORS, draw, FAIL_COLOR, marksOf, placeholder } from './plot.js';
import { programRequest, segments } from './program_form.js';
import { armItem, contactItems, drawScene, geometryItems, obstacleItems } from './scene.js';
import { sphereCloud, sphereWire } from './shapes.js';
import { isPlanar, robot, robotName, setToolMid } from './state.js';
import { addConfigurations, answerStatus, busy, done, pageError, renderProblem, renderSummary,
  renderWarnings, setDownloads, setStatus, showRequest } from './status.js';
import { showView } from './tabs.js';
import { fkGroups, MAX_TOOL_POINTS, subsample, toolPathOf } from './toolpath.js';

let last = null; // arguments of the last renderProgramPath, to redraw on the toggles

/** Returned points at segment and blend boundaries, and evenly spread ones: where FK is asked. */
function programIndices(body) {
  const times = body.points.map((pt) => pt.time_from_start);
  const want = new Set(subsample(times.length, 2 * MAX_TOOL_POINTS));
  const bounds = [];
  (body.segments || []).forEach((sg) => {
    bounds.push(sg.start_time, sg.end_time);
    if (sg.blend_out) bounds.push(sg.blend_out.start_time, sg.blend_out.end_time);
  });
  bounds.forEach((t) => {
    let lo = 0;
    let hi = times.length - 1;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (times[mid] <= t) lo = mid; else hi = mid;
    }
    want.add(Math.abs(times[lo] - t) <= Math.abs(times[hi] - t) ? lo : hi);
  });
  return Array.from(want).sort((x, y) => x - y);
}

/** The waypoints a collision-free PTP segment of the answer found (none for other segments). */
const segmentWaypoints = (sg) => {
  const w = sg.waypoints || (sg.diagnostics && sg.diagnostics.waypoints);
  return Array.isArray(w) ? w : [];
};

function segmentAt(sg, t) {
  if (t >= sg.start_time - 1e-9 && t <= sg.end_time + 1e-9) return 'own';
  if (sg.blend_out && t >= sg.blend_out.start_time - 1e-9 && t <= sg.blend_out.end_time + 1e-9) return 'blend';
  return null;
}

function segmentItems(segs, tool, dims) {
  const items = [];
  segs.forEach((sg) => {
    const own = tool.p.filter((_, i) => segmentAt(sg, tool.t[i]) === 'own');
    const blend = tool.p.filter((_, i) => segmentAt(sg, tool.t[i]) === 'blend');
    const color = COLORS[sg.index % COLORS.length];
    if (own.length) {
      items.push({ name: `${sg.index + 1} ${sg.type.toUpperCase()}`, pts: own,
        meta: { role: 'segment', index: sg.index },
        style: { mode: 'lines', line: { color: color, width: dims === 3 ? 6 : 3 } } });
    }
    if (blend.length) {
      items.push({ name: `blend ${sg.index + 1}→${sg.index + 2}`, pts: blend,
        meta: { role: 'blend', index: sg.index },
        style: { mode: 'lines', line: { color: '#111', width: dims === 3 ? 4 : 2, dash: 'dot' } } });
    }
  });
  return items;
}

function goalItems(req, goals, dims) {
  const items = [];
  req.segments.forEach((seg, k) => {
    const r = seg.blend_radius;
    if (r && goals[k]) {
      items.push({ name: `blend sphere ${k + 1} (r=${fmt(r, 3)} m)`, pts: sphereWire(goals[k], r),
        meta: { role: 'blend-sphere', index: k, radius: r }, style: { mode: 'lines',
          line: { color: '#6b7280', width: 2 }, opacity: 0.6, hoverinfo: 'name' } });
      items.push({ name: `blend sphere ${k + 1} (solid)`, pts: sphereCloud(goals[k], r), mesh: true,
        meta: { role: 'blend-sphere-solid' },
        style: { alphahull: 0, opacity: 0.12, color: '#6b7280', showlegend: false, hoverinfo: 'skip' } });
    }
    if (seg.interim || seg.center) {
      items.push({ name: `${k + 1} CIRC ${seg.interim ? 'interim' : 'center'}`, pts: [seg.interim || seg.center],
        meta: { role: 'circ-point' }, style: { mode: 'markers',
          marker: { size: dims === 3 ? 5 : 9, symbol: 'circle-open', color: COLORS[k % COLORS.length] } } });
    }
  });
  items.push({ name: 'segment goals', pts: goals.filter(Boolean), meta: { role: 'goals' },
    style: { mode: 'markers', marker: { size: dims === 3 ? 4 : 8, symbol: 'diamond', color: '#111' },
      text: goals.map((g, k) => `goal of segment ${k + 1}`).filter((_, k) => goals[k]),
      hovertemplate: '%{text}<extra></extra>' } });
  return items;
}

function armItems(tool) {
  const items = [];
  if (tool.arm[0]) {
    items.push(armItem(`arm at start${tool.config[0] ? ` (${tool.config[0]})` : ''}`, tool.arm[0],
      { line: { color: COLORS[2], width: 7 }, marker: { size: 3, color: COLORS[2] } },
      { role: 'arm', which: 'start', configuration: tool.config[0] }));
  }
  const end = tool.arm.length - 1;
  if (end > 0 && tool.arm[end]) {
    items.push(armItem(`arm at the end${tool.config[end] ? ` (${tool.config[end]})` : ''}`, tool.arm[end],
      { line: { color: '#111', width: 7 }, marker: { size: 3, color: '#111' }, opacity: 0.75 },
      { role: 'arm', which: 'goal', configuration: tool.config[end] }));
  }
  return items;
}

/**
 * The program's tool path. ``goals``: the tool position at each segment's goal; ``waypoints``:
 * per segment, the FK answers of its collision-free waypoints. "zoom to the path" scales the view
 * to the path, goals, spheres and obstacles (not the arm nor its collision geometry).
 */
function renderProgramPath(body, tool, goals, waypoints, req, failure) {
  last = [body, tool, goals, waypoints, req, failure];
  const dims = isPlanar() ? 2 : 3;
  const items = segmentItems(body.segments || [], tool, dims).concat(goalItems(req, goals, dims));
  waypoints.forEach((answers, k) => {
    if (answers.length) items.push(...waypointItems(answers, `waypoints of segment ${k + 1}`));
  });
  items.push(...armItems(tool),
    ...geometryItems(tool.frames[0], 'collision geometry at start', 'p-show-geometry'),
    ...obstacleItems(), ...contactItems(failure, tool));
  if (failure && failure.code !== 'collision' && tool.p.length) {
    items.push({ name: `✖ ${failure.code || 'failed'} in segment ${(failure.segment || 0) + 1}`,
      pts: [tool.p[tool.p.length - 1]], meta: { role: 'failure' },
      style: { mode: 'markers', marker: { size: 9, symbol: 'x', color: FAIL_COLOR } } });
  }
  setToolMid(tool.p.length ? tool.p[Math.floor(tool.p.length / 2)] : null);
  drawScene('plot-program-path', items, tool.arm.every(Boolean) ? tool : null,
    `${robotName()}-program-path`, $('p-focus').checked);
}

/** Joint speeds |q'| and the tool speed against time; segment and blend windows shaded. */
function renderProgramSpeed(body, tool, failure) {
  const t = body.points.map((p) => p.time_from_start);
  const traces = body.joint_names.map((name, j) => ({ type: 'scatter', mode: 'lines', name: name, x: t,
    y: body.points.map((p) => Math.abs(p.velocities[j])), xaxis: 'x', yaxis: 'y',
    line: { color: COLORS[j % COLORS.length], width: 1.5 }, meta: { role: 'joint-speed' },
    hovertemplate: `${name}: %{y:.3g} rad/s<extra></extra>` }));
  const ts = [];
  const vs = [];
  for (let i = 1; i < tool.p.length; i++) {
    const dt = tool.t[i] - tool.t[i - 1];
    if (dt <= 0) continue;
    ts.push((tool.t[i] + tool.t[i - 1]) / 2);
    vs.push(Math.hypot(...tool.p[i].map((v, c) => v - tool.p[i - 1][c])) / dt);
  }
  traces.push({ type: 'scatter', mode: 'lines', name: 'tool speed', x: ts, y: vs, xaxis: 'x', yaxis: 'y2',
    line: { color: '#111', width: 2 }, meta: { role: 'tool-speed' },
    hovertemplate: 'tool: %{y:.3g} m/s<extra>t=%{x:.3f} s</extra>' });
  const shapes = [];
  const annotations = [];
  (body.segments || []).forEach((sg) => {
    const color = COLORS[sg.index % COLORS.length];
    shapes.push({ type: 'rect', xref: 'x', yref: 'paper', x0: sg.start_time, x1: sg.end_time, y0: 0, y1: 1,
      fillcolor: color, opacity: 0.1, line: { width: 0 }, layer: 'below', name: `segment ${sg.index + 1}` });
    annotations.push({ x: (sg.start_time + sg.end_time) / 2, xref: 'x', y: 1, yref: 'paper',
      yanchor: 'bottom', text: `${sg.index + 1} ${sg.type.toUpperCase()}`, showarrow: false,
      font: { size: 11, color: color } });
    if (sg.blend_out) {
      shapes.push({ type: 'rect', xref: 'x', yref: 'paper', x0: sg.blend_out.start_time,
        x1: sg.blend_out.end_time, y0: 0, y1: 1, fillcolor: '#111', opacity: 0.12, line: { width: 0 },
        layer: 'below', name: `blend ${sg.index + 1}` });
    }
  });
  if (failure && Number.isFinite(failure.time_from_start)) {
    shapes.push({ type: 'line', xref: 'x', yref: 'paper', x0: failure.time_from_start,
      x1: failure.time_from_start, y0: 0, y1: 1, line: { color: FAIL_COLOR, width: 2 }, name: 'failure' });
  }
  draw('plot-program-speed', traces, baseLayout({
    grid: { rows: 2, columns: 1, pattern: 'coupled', roworder: 'top to bottom', ygap: 0.12 },
    xaxis: axis('time [s] (segments shaded in their colour, blends grey)'),
    yaxis: axis('|joint speed| [rad/s]', { rangemode: 'tozero' }),
    yaxis2: axis('tool speed [m/s]', { rangemode: 'tozero' }),
    shapes: shapes, annotations: annotations, hovermode: 'x unified',
    margin: { l: 70, r: 16, t: 30, b: 44 }, legend: { font: { size: 11 } },
  }), `${robotName()}-program-speed`);
}

function renderProgramTable(segs, failure) {
  const table = $('program-table');
  table.textContent = '';
  table.append(el('thead', {}, el('tr', {}, ['#', 'type', 'start [s]', 'end [s]', 'blend window [s]',
    'length [m]', 'max position dev. [m]', 'min σ'].map((c) => el('th', {}, c)))));
  const tbody = el('tbody');
  segs.forEach((sg) => {
    const d = sg.diagnostics || {};
    const planner = d.planner && d.planner.name ? ` · ${d.planner.name}` : '';
    tbody.append(el('tr', { 'data-segment': String(sg.index) },
      el('td', {}, el('span', { class: 'swatch', style: `background:${COLORS[sg.index % COLORS.length]}` }),
        String(sg.index + 1)),
      el('td', {}, sg.type + planner + (d.skipped ? ' (skipped)' : '')),
      el('td', {}, fmt(sg.start_time)), el('td', {}, fmt(sg.end_time)),
      el('td', {}, sg.blend_out ? `${fmt(sg.blend_out.start_time)} – ${fmt(sg.blend_out.end_time)}` : '—'),
      el('td', {}, fmt(d.length)), el('td', {}, fmt(d.max_position_deviation, 3)),
      el('td', {}, fmt(d.min_singular_value))));
  });
  if (failure && failure.segment !== undefined) {
    tbody.append(el('tr', { class: 'failed' }, el('td', {}, String(failure.segment + 1)),
      el('td', { colspan: 7, class: 'problem-cell' }, `✖ ${failure.code}: ${failure.detail || ''}`)));
  }
  table.append(tbody);
}

/** One FK request: the drawn points, every joint goal, every collision-free segment's waypoints. */
async function drawProgram(req, body, failure) {
  const idx = programIndices(body);
  const jointGoals = req.segments.map((seg) => (seg.goal.positions ? [seg.goal.positions] : []));
  const wps = (body.segments || []).map(segmentWaypoints);
  const answers = await fkGroups([idx.map((i) => body.points[i].positions), ...jointGoals, ...wps], true);
  const tool = toolPathOf(body, idx, answers[0], null);
  const goals = req.segments.map((seg, k) => (seg.goal.pose ? seg.goal.pose.position
    : (answers[1 + k][0] ? answers[1 + k][0].pose.position : null)));
  const waypoints = answers.slice(1 + req.segments.length);
  renderProgramPath(body, tool, goals, waypoints, req, failure);
  renderProgramSpeed(body, tool, failure);
  renderClearance('-program', body.diagnostics, req);
  renderProgramTable(body.segments || [], failure);
  const knots = (body.segments || []).map((sg) => {
    const pt = body.points.find((x) => x.time_from_start >= sg.end_time - 1e-12) || body.points[body.points.length - 1];
    return { t: sg.end_time, positions: pt.positions, label: `end of segment ${sg.index + 1}`, kind: 'segment ends' };
  });
  renderJoints(body, robot().limits, knots, 'No program');
  addConfigurations(tool.config[0], tool.config[tool.config.length - 1]);
}

function noProgram(req, problem) {
  placeholder('plot-program-path', `No program: ${problem ? problem.code : 'no points'}`);
  placeholder('plot-program-speed', 'No program');
  renderClearance('-program', null, req);
  renderProgramTable([], problem);
  renderJoints(null, robot().limits, null, 'No program');
}

export async function runProgram() {
  if (!segments().length) {
    setStatus('error', 'The program has no segments: add one or pick a preset.');
    return;
  }
  const req = programRequest();
  const path = '/v1/trajectories/program';
  showRequest('POST', path, req);
  busy(`Running a program of ${req.segments.length} segments …`);
  showView('program');
  try {
    const res = await api('POST', path, req);
    const downloads = [{ label: 'Download JSON', filename: `${robotName()}-program.json`, text: res.text }];
    let body = res.ok ? res.json : null;
    const problem = res.ok ? null : problemOf(res);
    let note = null;
    if (problem && problem.segment !== undefined && !req.allow_partial) {
      const partial = await api('POST', path, Object.assign({}, req, { allow_partial: true }));
      if (partial.ok && partial.json.points && partial.json.points.length > 1) {
        body = partial.json;
        downloads.push({ label: 'Download prefix JSON', filename: `${robotName()}-program-prefix.json`,
          text: partial.text });
        note = { text: `Drawn below: the program up to segment ${problem.segment + 1} ` +
          '(the same request with allow_partial).' };
      }
    }
    setDownloads(downloads);
    const diag = body ? body.diagnostics : null;
    const failure = problem || (diag && diag.failure ? Object.assign({ title: 'Partial program' }, diag.failure) : null);
    if (problem) renderProblem(problem, `POST ${path}`, note);
    else if (failure) renderProblem(failure, 'allow_partial: the program up to the failure', { partial: true });
    else renderProblem(null);
    answerStatus(res, path, body, problem, body ? ` · ${body.segments.length} segments` : '');
    renderSummary(body, diag ? [['stops', diag.stops]] : []);
    renderWarnings(marksOf(diag, null).filter((m) => m.kind === 'warning'));
    if (!body || !body.points || !body.points.length) noProgram(req, problem);
    else await drawProgram(req, body, failure);
  } catch (e) {
    pageError(e);
  } finally {
    done();
  }
}

export function redrawProgramPath() {
  if (last) renderProgramPath(...last);
}

export function wireProgramView() {
  $('p-focus').addEventListener('change', redrawProgramPath);
  $('p-show-geometry').addEventListener('change', redrawProgramPath);
}
