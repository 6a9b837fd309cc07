/*
 * Trajectory Service playground: plain JavaScript (ES2017), no build step.
 *
 * Calls only the public API of shared/API.md (/v1/robots, /v1/robots/{name}/fk,
 * /v1/trajectories/{joint,spline,cartesian}, /v1/compare), like any other client, and draws what
 * comes back with Plotly (served by the service from the Python plotly package).
 *
 * For the browser test and for people alike: <body data-state> is "busy" while a request runs and
 * "done" after, and <body data-run> counts finished runs.
 */
'use strict';

(function () {
  // ---------------------------------------------------------------- constants and small helpers
  const COLORS = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2',
    '#7f7f7f', '#bcbd22', '#17becf'];
  const METHODS = ['sampled', 'bounded_deviation', 'bounded_deviation_nlp', 'resolved_rate',
    'resolved_rate_dls'];
  const RATE_METHODS = ['resolved_rate', 'resolved_rate_dls'];
  const DEFAULT_TOLERANCE = { position: 1e-3, orientation: 1e-2 };
  const MAX_FK_POINTS = 100; // tool positions computed per trajectory (POST /fk per point)
  const FK_CONCURRENCY = 6;
  const FAIL_COLOR = '#d62728';
  const WARN_COLOR = '#e08a00';

  const $ = (id) => document.getElementById(id);
  const state = {
    robots: [],
    robot: null, // GET /v1/robots/{name}
    downloads: [], // [{label, filename, text}]
    compareDownload: null,
    runs: 0,
    webgl: null,
    obstacles: [], // [{name, type: 'box' | 'sphere', position: [x, y, z], size: [..3] | radius}]
    obstacleCount: 0,
    ikGhosts: [], // [{label, pts}]: every IK solution of the goal pose, drawn as ghost arms
    program: [], // segments of the program editor (see programSegment)
    lastToolMid: null,
  };

  function fmt(v, digits) {
    if (v === null || v === undefined || Number.isNaN(v)) return '—';
    if (typeof v !== 'number') return String(v);
    const d = digits || 4;
    if (v === 0) return '0';
    const a = Math.abs(v);
    if (a < 1e-3 || a >= 1e5) return v.toExponential(d - 2);
    return String(Number(v.toPrecision(d)));
  }
  const round6 = (v) => Math.round(v * 1e6) / 1e6;
  const clip = (v, lo, hi) => Math.min(hi, Math.max(lo, v));
  const el = (tag, attrs, ...children) => {
    const node = document.createElement(tag);
    Object.entries(attrs || {}).forEach(([k, v]) => {
      if (v === undefined || v === null || v === false) return;
      if (k === 'text') node.textContent = v;
      else if (k === 'class') node.className = v;
      else if (k.startsWith('on')) node.addEventListener(k.slice(2), v);
      else node.setAttribute(k, v === true ? '' : v);
    });
    children.flat().forEach((c) => {
      if (c !== null && c !== undefined) node.append(c instanceof Node ? c : String(c));
    });
    return node;
  };
  const numberInput = (id, value, attrs) =>
    el('input', Object.assign({ type: 'number', step: 'any', id: id,
      value: value === undefined || value === null ? '' : round6(value) }, attrs || {}));
  function num(id) {
    const node = $(id);
    if (!node || node.value.trim() === '') return undefined;
    return Number(node.value); // NaN is sent as null: the service answers 422 naming the field
  }
  const checked = (name) => document.querySelector(`input[name="${name}"]:checked`).value;
  const isPlanar = () => state.robot && state.robot.task_space === 'position_xy';

  // ---------------------------------------------------------------- HTTP
  async function api(method, path, body) {
    const started = performance.now();
    const init = { method: method, headers: { accept: 'application/json' } };
    if (body !== undefined) {
      init.headers['content-type'] = 'application/json';
      init.body = JSON.stringify(body);
    }
    try {
      const res = await fetch(path, init);
      const text = await res.text();
      let json = null;
      try { json = JSON.parse(text); } catch (e) { json = null; }
      return { ok: res.ok, status: res.status, json: json, text: text, path: path,
        ms: performance.now() - started };
    } catch (e) {
      const problem = { title: 'Network error', code: 'network', status: 0,
        detail: `the service did not answer ${method} ${path}: ${e.message}` };
      return { ok: false, status: 0, json: problem, text: JSON.stringify(problem), path: path,
        ms: performance.now() - started };
    }
  }

  async function mapLimit(items, limit, fn) {
    const out = new Array(items.length);
    let next = 0;
    async function worker() {
      while (next < items.length) {
        const i = next++;
        out[i] = await fn(items[i], i);
      }
    }
    await Promise.all(Array.from({ length: Math.min(limit, items.length) }, worker));
    return out;
  }

  function problemOf(res) {
    if (res.json && typeof res.json === 'object' && !Array.isArray(res.json)) return res.json;
    return { title: 'HTTP error', status: res.status, detail: res.text.slice(0, 500) };
  }

  // ---------------------------------------------------------------- busy state, status, downloads
  function busy(message) {
    document.body.dataset.state = 'busy';
    setStatus('busy', message);
    document.querySelectorAll('.plan-form button').forEach((b) => { b.disabled = true; });
  }
  function done() {
    state.runs += 1;
    document.body.dataset.run = String(state.runs);
    document.body.dataset.state = 'done';
    document.querySelectorAll('.plan-form button').forEach((b) => { b.disabled = false; });
  }
  function pageError(e) {
    // A bug of this page (not an answer of the service): say so instead of leaving a stale view.
    console.error(e);
    setStatus('error', `The page failed to draw the answer: ${e && e.message ? e.message : e}`);
  }
  function setStatus(kind, text) {
    const node = $('status');
    node.className = `status ${kind}`;
    node.textContent = text;
  }
  function showRequest(method, path, body) {
    $('request-json').textContent = `${method} ${path}\n${JSON.stringify(body, null, 2)}`;
  }
  function setDownloads(items) {
    state.downloads = items;
    const box = document.querySelector('.downloads');
    box.textContent = '';
    if (!items.length) {
      box.append(el('button', { type: 'button', id: 'download-json', disabled: true }, 'Download JSON'));
      return;
    }
    items.forEach((item, i) => {
      box.append(el('button', {
        type: 'button', id: i === 0 ? 'download-json' : `download-json-${i}`,
        title: `save ${item.filename}`, onclick: () => saveText(item.filename, item.text),
      }, item.label));
    });
  }
  function saveText(filename, text) {
    const url = URL.createObjectURL(new Blob([text], { type: 'application/json' }));
    const a = el('a', { href: url, download: filename });
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 1000);
  }
  const robotName = () => (state.robot ? state.robot.name : 'robot');

  // ---------------------------------------------------------------- views
  function showView(name) {
    document.querySelectorAll('#view-tabs button').forEach((b) => {
      b.classList.toggle('active', b.dataset.view === name);
    });
    document.querySelectorAll('.view').forEach((v) => { v.hidden = v.dataset.view !== name; });
    document.querySelectorAll(`#view-${name} .plot`).forEach((div) => {
      if (div.data) Plotly.Plots.resize(div);
    });
  }
  function showFormTab(name) {
    document.querySelectorAll('#form-tabs button').forEach((b) => {
      b.classList.toggle('active', b.dataset.tab === name);
    });
    document.querySelectorAll('.plan-form').forEach((f) => { f.hidden = f.dataset.tab !== name; });
  }

  // ---------------------------------------------------------------- plotting helpers
  function plotConfig(filename) {
    return { responsive: true, displaylogo: false,
      toImageButtonOptions: { format: 'png', filename: filename, scale: 2 } };
  }
  function baseLayout(extra) {
    return Object.assign({
      margin: { l: 64, r: 16, t: 28, b: 44 },
      font: { family: 'system-ui, -apple-system, "Segoe UI", sans-serif', size: 12 },
      paper_bgcolor: '#fff', plot_bgcolor: '#fff',
      hovermode: 'closest',
      legend: { font: { size: 11 } },
    }, extra || {});
  }
  function axis(title, extra) {
    return Object.assign({ title: { text: title, standoff: 6 }, zeroline: false,
      gridcolor: '#e6e8eb', linecolor: '#9aa0a6', showline: true, automargin: true }, extra || {});
  }
  function draw(div, traces, layout, filename) {
    return Plotly.react($(div), traces, layout, plotConfig(filename || div));
  }
  function placeholder(div, message) {
    return draw(div, [], baseLayout({
      xaxis: { visible: false }, yaxis: { visible: false },
      annotations: [{ text: message, showarrow: false, xref: 'paper', yref: 'paper', x: 0.5,
        y: 0.5, font: { size: 13, color: '#6b7280' } }],
    }));
  }

  /** Vertical lines and labels at each marked s: warnings (orange) and the failure (red). */
  function sMarks(marks, yref) {
    const shapes = [];
    const annotations = [];
    marks.forEach((m) => {
      const color = m.color || (m.kind === 'failure' ? FAIL_COLOR : WARN_COLOR);
      if (m.s1 !== undefined && m.s1 > m.s) {
        shapes.push({ type: 'rect', xref: 'x', yref: 'paper', x0: m.s, x1: m.s1, y0: 0, y1: 1,
          fillcolor: color, opacity: 0.08, line: { width: 0 }, layer: 'below' });
      }
      shapes.push({ type: 'line', xref: 'x', yref: 'paper', x0: m.s, x1: m.s, y0: 0, y1: 1,
        line: { color: color, width: m.kind === 'failure' ? 2 : 1.5,
          dash: m.kind === 'failure' ? 'solid' : 'dot' } });
      // Inside the plot, below the mode bar; staggered so labels at nearby s stay readable.
      annotations.push({ x: m.s, xref: 'x', y: 1 - 0.085 * (annotations.length % 5),
        yref: yref || 'paper', yanchor: 'top', xanchor: m.s > 0.8 ? 'right' : 'left',
        xshift: m.s > 0.8 ? -3 : 3, text: m.label, showarrow: false,
        font: { size: 11, color: color }, hovertext: m.message, bgcolor: 'rgba(255,255,255,0.85)' });
    });
    return { shapes: shapes, annotations: annotations };
  }

  /** Warnings and the failure of a plan, each at its s (parsed from "s=0.123" in the message). */
  function marksOf(diag, problem) {
    const marks = [];
    ((diag && diag.warnings) || []).forEach((w, i) => {
      const found = Array.from(String(w).matchAll(/\bs\s*=\s*(-?\d*\.?\d+(?:e-?\d+)?)/g))
        .map((m) => Number(m[1])).filter((v) => Number.isFinite(v));
      const between = /between s\s*=\s*(-?\d*\.?\d+).*?and s\s*=\s*(-?\d*\.?\d+)/.exec(w);
      const mark = { kind: 'warning', label: `W${i + 1}`, message: w, index: i + 1,
        s: found.length ? found[0] : null };
      if (between) mark.s1 = Number(between[2]);
      marks.push(mark);
    });
    const failure = problem || (diag && diag.failure);
    if (failure && failure.s !== undefined && failure.s !== null) {
      marks.push({ kind: 'failure', label: `✖ ${failure.code || 'failed'}`, s: failure.s,
        message: failure.detail || failure.title || '' });
    }
    return marks;
  }

  // ---------------------------------------------------------------- robots and forms
  async function loadRobots() {
    const res = await api('GET', '/v1/robots');
    if (!res.ok) {
      renderProblem(problemOf(res), 'GET /v1/robots');
      return;
    }
    state.robots = res.json;
    const select = $('robot');
    select.textContent = '';
    res.json.forEach((r) => select.append(el('option', { value: r.name }, r.name)));
    const first = res.json.find((r) => r.name === 'ur5') || res.json[0];
    if (first) {
      select.value = first.name;
      await selectRobot(first.name);
    }
  }

  async function selectRobot(name) {
    const res = await api('GET', `/v1/robots/${encodeURIComponent(name)}`);
    if (!res.ok) {
      renderProblem(problemOf(res), `GET /v1/robots/${name}`);
      return;
    }
    state.robot = res.json;
    $('robot').value = name;
    const r = res.json;
    $('robot-info').textContent = `${r.dof} joints · task space ${r.task_space} · ` +
      `${r.base_frame} → ${r.tip_frame}`;
    buildCartesianForm();
    buildJointForm();
    buildSplineForm();
    buildProgramForm();
    $('geometry-toggle').hidden = !(Array.isArray(r.collision_geometry) && r.collision_geometry.length);
    // The pose fields start at FK(goal joints), so switching to a pose goal is one click.
    const a = await fk(jointValues('c-goal'));
    if (a) setPose(a.pose);
    state.ikGhosts = [];
    $('c-ik-list').hidden = true;
    updateConfigs();
  }

  function offsetHome(delta) {
    const r = state.robot;
    return r.home.map((q, j) => {
      const [lo, hi] = r.limits.position[j];
      const margin = 0.05 * (hi - lo);
      return clip(q + delta[j % delta.length], lo + margin, hi - margin);
    });
  }

  function limitHint(j) {
    const [lo, hi] = state.robot.limits.position[j];
    return `[${fmt(lo, 3)}, ${fmt(hi, 3)}]`;
  }

  function buildCartesianForm(start, goal) {
    const r = state.robot;
    const table = $('c-joints');
    table.textContent = '';
    table.append(el('tr', {}, el('th', {}, 'joint'), el('th', {}, 'start'), el('th', {}, 'goal'),
      el('th', { class: 'hint' }, 'limits')));
    const q0 = start || r.home;
    const q1 = goal || offsetHome([0.3, -0.2, 0.25]);
    r.joint_names.forEach((name, j) => {
      table.append(el('tr', {}, el('th', { title: name }, name),
        el('td', {}, numberInput(`c-start-${j}`, q0[j])),
        el('td', {}, numberInput(`c-goal-${j}`, q1[j])),
        el('td', { class: 'hint' }, limitHint(j))));
    });
    const box = $('c-compare-methods');
    if (!box.childElementCount) {
      METHODS.forEach((m) => box.append(el('label', { class: 'inline' },
        el('input', { type: 'checkbox', value: m, checked: true, name: 'c-compare-method' }), m)));
    }
  }

  function buildJointForm() {
    const r = state.robot;
    const table = $('j-table');
    table.textContent = '';
    table.append(el('tr', {}, el('th', {}, 'joint'), el('th', {}, 'start'), el('th', {}, 'goal'),
      el('th', {}, 'v max'), el('th', {}, 'a max'), el('th', { class: 'jerk-col' }, 'j max')));
    const goal = offsetHome([0.6, -0.4, 0.5]);
    r.joint_names.forEach((name, j) => {
      table.append(el('tr', {}, el('th', { title: `${name} ${limitHint(j)}` }, name),
        el('td', {}, numberInput(`j-start-${j}`, r.home[j])),
        el('td', {}, numberInput(`j-goal-${j}`, goal[j])),
        el('td', {}, numberInput(`j-vmax-${j}`, r.limits.velocity[j], { class: 'limit' })),
        el('td', {}, numberInput(`j-amax-${j}`, r.limits.acceleration[j], { class: 'limit' })),
        el('td', { class: 'jerk-col' }, numberInput(`j-jmax-${j}`, robotJerk(j), { class: 'jerk' }))));
    });
    syncJointTiming();
  }

  function buildSplineForm(waypoints) {
    const r = state.robot;
    const wps = waypoints || [r.home, offsetHome([0.4, -0.3, 0.3]), offsetHome([0.8, 0.2, -0.3])];
    const table = $('s-table');
    table.textContent = '';
    const head = el('tr', {}, el('th', {}, '#'), el('th', { class: 'time-col' }, 't [s]'));
    r.joint_names.forEach((name) => head.append(el('th', { title: name }, name)));
    table.append(head);
    wps.forEach((wp, i) => addWaypointRow(wp, i * 1.5));
    const limits = $('s-limits');
    limits.textContent = '';
    const lh = el('tr', {}, el('th', {}, ''));
    r.joint_names.forEach((name) => lh.append(el('th', { title: name }, name)));
    limits.append(lh);
    [['v max', 'velocity', 's-vmax'], ['a max', 'acceleration', 's-amax']].forEach(([label, key, id]) => {
      const row = el('tr', {}, el('th', {}, label));
      r.limits[key].forEach((v, j) => row.append(el('td', {}, numberInput(`${id}-${j}`, v))));
      limits.append(row);
    });
    syncSplineTimes();
  }

  function addWaypointRow(wp, t) {
    const table = $('s-table');
    const i = table.rows.length - 1;
    const row = el('tr', { class: 'wp' }, el('th', {}, String(i + 1)),
      el('td', { class: 'time-col' }, numberInput(`s-t-${i}`, t)));
    wp.forEach((v, j) => row.append(el('td', {}, numberInput(`s-wp-${i}-${j}`, v))));
    table.append(row);
  }

  /** The robot's jerk limit of joint j (null where the maker publishes none: then 20 a max). */
  function robotJerk(j) {
    const r = state.robot;
    const jerk = r.limits.jerk;
    return Array.isArray(jerk) && Number.isFinite(jerk[j]) ? jerk[j] : 20 * r.limits.acceleration[j];
  }
  function syncJointTiming() {
    const limits = checked('j-timing') === 'limits';
    const jerk = $('j-profile').value === 'jerk_limited';
    $('j-duration-box').hidden = limits;
    document.querySelectorAll('#j-table input.limit').forEach((n) => { n.disabled = !limits && !jerk; });
    document.querySelectorAll('#j-table .jerk-col').forEach((n) => { n.hidden = !jerk; });
  }
  function syncSplineTimes() {
    const on = $('s-times').checked;
    document.querySelectorAll('#s-table .time-col').forEach((n) => { n.hidden = !on; });
  }
  function syncCartesian() {
    const pose = checked('c-goal-kind') === 'pose';
    $('c-pose-box').hidden = !pose;
    const duration = checked('c-timing') === 'duration';
    $('c-speeds').hidden = duration;
    $('c-duration-box').hidden = !duration;
  }

  // ---------------------------------------------------------------- requests from the forms
  const jointValues = (prefix) => state.robot.joint_names.map((_, j) => num(`${prefix}-${j}`));

  function cartesianRequest() {
    const req = { robot: robotName(), start: { positions: jointValues('c-start') } };
    if (checked('c-goal-kind') === 'pose') {
      req.goal = { pose: {
        position: ['c-px', 'c-py', 'c-pz'].map((id) => num(id) || 0),
        orientation: ['c-qx', 'c-qy', 'c-qz', 'c-qw'].map((id) => num(id) || 0),
      } };
    } else {
      req.goal = { positions: jointValues('c-goal') };
    }
    req.method = $('c-method').value;
    req.tolerance = { position: num('c-tol-pos'), orientation: num('c-tol-ori') };
    if (req.tolerance.position === undefined) delete req.tolerance.position;
    if (req.tolerance.orientation === undefined) delete req.tolerance.orientation;
    if (checked('c-timing') === 'duration') {
      req.duration = num('c-duration');
    } else {
      const v = num('c-vlin');
      const w = num('c-vang');
      if (v !== undefined) req.max_linear_speed = v;
      if (w !== undefined) req.max_angular_speed = w;
    }
    const period = num('c-period');
    if (period !== undefined) req.sample_period = period;
    const control = num('c-control');
    if (control !== undefined && RATE_METHODS.includes(req.method)) req.control_period = control;
    if ($('c-partial').checked) req.allow_partial = true;
    return withEnvironment(req);
  }

  function jointRequest() {
    const req = {
      robot: robotName(),
      profile: $('j-profile').value,
      start: { positions: jointValues('j-start') },
      goal: { positions: jointValues('j-goal') },
    };
    if (checked('j-timing') === 'duration') req.duration = num('j-duration');
    else req.limits = { velocity: jointValues('j-vmax'), acceleration: jointValues('j-amax') };
    if (req.profile === 'jerk_limited') {
      // limits.jerk only with jerk_limited (the other profiles' schema has no jerk).
      req.limits = { velocity: jointValues('j-vmax'), acceleration: jointValues('j-amax'),
        jerk: jointValues('j-jmax') };
    }
    const period = num('j-period');
    if (period !== undefined) req.sample_period = period;
    return withEnvironment(req);
  }

  function splineRequest() {
    const rows = $('s-table').rows.length - 1;
    const req = {
      robot: robotName(),
      waypoints: Array.from({ length: rows }, (_, i) => jointValues(`s-wp-${i}`)),
      boundary: $('s-boundary').value,
      limits: { velocity: jointValues('s-vmax'), acceleration: jointValues('s-amax') },
    };
    if ($('s-times').checked) req.times = Array.from({ length: rows }, (_, i) => num(`s-t-${i}`));
    const period = num('s-period');
    if (period !== undefined) req.sample_period = period;
    return withEnvironment(req);
  }

  // ---------------------------------------------------------------- problem, summary, warnings
  function renderProblem(problem, where, note) {
    const box = $('problem');
    box.textContent = '';
    if (!problem) {
      box.hidden = true;
      return;
    }
    box.hidden = false;
    box.className = note && note.partial ? 'problem partial' : 'problem';
    const s = problem.s;
    const head = el('div', { class: 'problem-head' },
      el('span', { class: 'code', id: 'problem-code' }, problem.code || 'error'),
      el('strong', {}, problem.title || 'Request failed'),
      problem.status ? el('span', { class: 'muted' }, `HTTP ${problem.status}`) : null,
      where ? el('span', { class: 'muted' }, where) : null);
    box.append(head);
    box.append(el('p', { class: 'detail', id: 'problem-detail' }, problem.detail || ''));
    if (s !== undefined && s !== null) {
      box.append(el('p', { class: 'where', id: 'problem-s' },
        `Where on the line: s = ${fmt(s, 4)} (${(100 * s).toFixed(1)} % of the way from the start)`));
    }
    const extras = Object.entries(problem).filter(([k]) =>
      !['type', 'title', 'status', 'detail', 'code', 's', 'errors'].includes(k));
    if (extras.length) {
      box.append(el('p', { class: 'muted' },
        extras.map(([k, v]) => `${k}: ${typeof v === 'number' ? fmt(v, 5) : JSON.stringify(v)}`)
          .join(' · ')));
    }
    if (Array.isArray(problem.errors) && problem.errors.length) {
      box.append(el('ul', { class: 'errors' }, problem.errors.map((e) =>
        el('li', {}, el('code', {}, (e.loc || []).join('.')), ` ${e.msg || ''}`))));
    }
    if (note && note.text) box.append(el('p', { class: 'note' }, note.text));
  }

  function renderSummary(body, extra) {
    const box = $('summary');
    box.textContent = '';
    if (!body) {
      box.hidden = true;
      return;
    }
    const d = body.diagnostics || {};
    const r = state.robot;
    const items = [
      ['method', d.method],
      ['duration', d.duration !== undefined ? `${fmt(d.duration)} s` : undefined],
      ['points', body.points ? body.points.length : undefined],
      ['compute', d.compute_time_ms !== undefined ? `${fmt(d.compute_time_ms, 3)} ms` : undefined],
      ['fraction', d.fraction],
      ['max position deviation', d.max_position_deviation !== undefined && d.max_position_deviation !== null ? `${fmt(d.max_position_deviation, 3)} m` : undefined],
      ['max orientation deviation', d.max_orientation_deviation !== undefined && d.max_orientation_deviation !== null && !isPlanar() ? `${fmt(d.max_orientation_deviation, 3)} rad` : undefined],
      ['min singular value', d.min_singular_value],
      ['knots', d.knot_count],
    ];
    if (r && Array.isArray(d.peak_velocity) && d.peak_velocity.length === r.dof) {
      const vr = Math.max(...d.peak_velocity.map((v, j) => Math.abs(v) / r.limits.velocity[j]));
      const ar = Math.max(...d.peak_acceleration.map((v, j) => Math.abs(v) / r.limits.acceleration[j]));
      items.push(['peak |v| / limit', `${(100 * vr).toFixed(1)} %`]);
      items.push(['peak |a| / limit', `${(100 * ar).toFixed(1)} %`]);
    }
    if (d.min_clearance !== undefined && d.min_clearance !== null) {
      items.push(['min clearance', `${fmt(d.min_clearance, 3)} m`]);
      if (d.closest && Array.isArray(d.closest.links)) {
        items.push(['closest', `${d.closest.links.join(' – ')} at t=${fmt(d.closest.time_from_start, 3)} s`]);
      }
    }
    if (Array.isArray(d.peak_jerk) && d.peak_jerk.length) {
      items.push(['peak |jerk|', `${fmt(Math.max(...d.peak_jerk.map(Math.abs)), 4)} rad/s³`]);
    }
    (extra || []).forEach((e) => items.push(e));
    items.filter(([, v]) => v !== undefined && v !== null).forEach(([k, v]) => {
      box.append(el('div', { class: 'kv' }, el('span', { class: 'k' }, k),
        el('span', { class: 'v' }, typeof v === 'number' ? fmt(v) : String(v))));
    });
    box.append(el('span', { id: 'summary-end', hidden: true }));
    const rest = Object.assign({}, d);
    delete rest.deviation_profile;
    delete rest.singular_value_profile;
    box.append(el('details', { class: 'all-diag' }, el('summary', {}, 'all diagnostics'),
      el('pre', {}, JSON.stringify(rest, null, 2))));
    box.hidden = false;
  }

  /** Configuration labels of start and goal (from /fk), added to the summary once known. */
  function addConfigurations(start, goal) {
    const anchor = $('summary-end');
    if (!anchor) return;
    [['start configuration', start, 'summary-config-start'], ['goal configuration', goal, 'summary-config-goal']]
      .forEach(([k, v, id]) => {
        if (!v) return;
        anchor.before(el('div', { class: 'kv', id: id }, el('span', { class: 'k' }, k),
          el('span', { class: 'v' }, v)));
      });
  }

  function renderWarnings(marks) {
    const list = $('warnings');
    list.textContent = '';
    const warns = marks.filter((m) => m.kind === 'warning');
    warns.forEach((m) => list.append(el('li', {},
      el('span', { class: 'tag' }, m.label),
      m.s !== null ? el('span', { class: 'at' }, `s = ${fmt(m.s, 3)}`) : null,
      ` ${m.message}`)));
    list.hidden = !warns.length;
  }

  // ---------------------------------------------------------------- joint plots
  const QUANTITIES = [
    { key: 'positions', title: 'position', unit: 'rad' },
    { key: 'velocities', title: 'velocity', unit: 'rad/s' },
    { key: 'accelerations', title: 'acceleration', unit: 'rad/s²' },
    { key: 'jerk', title: 'jerk (finite differences of a)', unit: 'rad/s³' },
  ];

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
  let lastJoints = null; // arguments of the last renderJoints, to redraw on the zoom toggle

  /** [lo, hi] of the finite numbers in ``values``, or null. */
  function extent(values) {
    let lo = Infinity;
    let hi = -Infinity;
    values.forEach((v) => {
      if (v !== null && Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
    });
    return lo <= hi ? [lo, hi] : null;
  }
  function padded(range) {
    const span = range[1] - range[0] || Math.max(1e-3, Math.abs(range[0]) * 0.1);
    return [range[0] - 0.08 * span, range[1] + 0.08 * span];
  }

  /**
   * Position, velocity and acceleration of every joint against time, one row each (one figure, so a
   * click on a joint in the legend hides it in all three), the limits as dashed lines in the
   * joint's colour, and the knots or waypoints (markers at their time and position).
   *   limits: {position: [[lo, hi]], velocity: [..], acceleration: [..]}
   *   knots: [{t, positions, label, kind}] or null
   */
  function renderJoints(body, limits, knots, emptyMessage) {
    lastJoints = [body, limits, knots, emptyMessage];
    if (!body || !body.points || !body.points.length) {
      placeholder('plot-joints', emptyMessage || 'No trajectory');
      return;
    }
    const t = body.points.map((p) => p.time_from_start);
    const names = body.joint_names;
    const t0 = t[0];
    const t1 = t[t.length - 1];
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
        let lo;
        let hi;
        if (q.key === 'positions') [lo, hi] = limits.position[j];
        else if (q.key === 'jerk') {
          if (!Array.isArray(limits.jerk) || !Number.isFinite(limits.jerk[j])) return; // none known
          hi = limits.jerk[j];
          lo = -hi;
        } else {
          hi = (q.key === 'velocities' ? limits.velocity : limits.acceleration)[j];
          lo = -hi;
        }
        lims.push(lo, hi);
        traces.push({ type: 'scatter', mode: 'lines', name: `${name} limits`, legendgroup: name,
          showlegend: false, x: [t0, t1, null, t0, t1], y: [hi, hi, null, lo, lo],
          xaxis: 'x', yaxis: `y${ax}`, line: { color: color, width: 1, dash: 'dash' },
          opacity: 0.75, meta: { role: 'limit', quantity: q.title }, hoverinfo: 'skip' });
      });
      if (knots && knots.length && q.key === 'positions') {
        const x = [];
        const y = [];
        const colors = [];
        const text = [];
        knots.forEach((k) => k.positions.forEach((v, j) => {
          x.push(k.t); y.push(v); colors.push(COLORS[j % COLORS.length]);
          text.push(`${k.label} · ${names[j]}`);
        }));
        traces.push({ type: 'scatter', mode: 'markers', name: knots[0].kind || 'knots', x: x, y: y,
          xaxis: 'x', yaxis: 'y', text: text, meta: { role: 'knots' },
          marker: { symbol: 'diamond', size: 8, color: colors, line: { color: '#111', width: 1 } },
          hovertemplate: '%{text}: %{y:.4g} rad' });
      }
      const inView = q.key !== 'positions' || positionLimitsInView;
      const range = extent(inView ? data.concat(lims) : data);
      layout[`yaxis${ax}`] = axis(`${q.title} [${q.unit}]`, range ? { range: padded(range) } : {});
      if (knots && knots.length) {
        knots.forEach((k) => layout.shapes.push({ type: 'line', xref: 'x', yref: `y${ax} domain`,
          x0: k.t, x1: k.t, y0: 0, y1: 1, line: { color: '#9aa0a6', width: 1, dash: 'dot' },
          layer: 'below' }));
      }
      if (q.key === 'positions') {
        const [lo, hi] = extent(data) || [0, 0];
        const hidden = lims.filter((v) => v < lo || v > hi).length;
        $('j-limits-note').textContent = !inView && hidden
          ? `${hidden} of ${lims.length} position limits lie outside the view` : '';
      }
    });
    draw('plot-joints', traces, layout, `${robotName()}-joints`);
  }

  // ---------------------------------------------------------------- Cartesian geometry
  async function fk(positions, frames) {
    const req = { positions: positions };
    if (frames) req.frames = true; // every link frame in kinematic order: the arm's polyline
    const res = await api('POST', `/v1/robots/${encodeURIComponent(robotName())}/fk`, req);
    return res.ok ? res.json : null;
  }
  const framePoints = (a) => (a && Array.isArray(a.frames) ? a.frames.map((f) => f.position) : null);

  /** The ideal line: FK(start) to the goal pose (FK(goal.positions) for a joint goal). */
  async function lineOf(req) {
    const [a, b] = await Promise.all([
      fk(req.start.positions, true),
      req.goal.positions ? fk(req.goal.positions, true) : Promise.resolve({ pose: req.goal.pose }),
    ]);
    if (!a || !b) return null;
    const p0 = a.pose.position;
    const p1 = b.pose.position;
    return { p0: p0, p1: p1, at: (s) => p0.map((v, i) => v + s * (p1[i] - v)),
      startFk: a, goalFk: b.frames ? b : null };
  }

  function subsample(n, most) {
    if (n <= most) return Array.from({ length: n }, (_, i) => i);
    const idx = new Set();
    for (let k = 0; k < most; k++) idx.add(Math.round((k * (n - 1)) / (most - 1)));
    return Array.from(idx).sort((a, b) => a - b);
  }

  /** s at each time, from the deviation profile's (time_from_start, s) pairs. */
  function sOfTime(profile) {
    if (!profile || !profile.time_from_start || profile.time_from_start.length < 2) return null;
    const ts = profile.time_from_start;
    const ss = profile.s;
    return (t) => {
      if (t <= ts[0]) return ss[0];
      if (t >= ts[ts.length - 1]) return ss[ss.length - 1];
      let lo = 0;
      let hi = ts.length - 1;
      while (hi - lo > 1) {
        const mid = (lo + hi) >> 1;
        if (ts[mid] <= t) lo = mid; else hi = mid;
      }
      const u = (t - ts[lo]) / (ts[hi] - ts[lo] || 1);
      return ss[lo] + u * (ss[hi] - ss[lo]);
    };
  }

  /** Tool positions of at most MAX_FK_POINTS returned points (POST /fk per point, a few at a time). */
  async function toolPath(body, line, indices) {
    const points = body.points;
    const idx = indices || subsample(points.length, MAX_FK_POINTS);
    const poses = await mapLimit(idx, FK_CONCURRENCY, (i) => fk(points[i].positions, true));
    const diag = body.diagnostics || {};
    const sAt = sOfTime(diag.deviation_profile);
    const out = { p: [], t: [], s: [], sigma: [], arm: [], config: [], frames: [] };
    idx.forEach((i, k) => {
      if (!poses[k]) return;
      const p = poses[k].pose.position;
      const t = points[i].time_from_start;
      let s = sAt ? sAt(t) : null;
      if (s === null && line) {
        const d = line.p1.map((v, c) => v - line.p0[c]);
        const dd = d.reduce((acc, v) => acc + v * v, 0);
        s = dd > 1e-18 ? d.reduce((acc, v, c) => acc + v * (p[c] - line.p0[c]), 0) / dd : null;
      }
      out.p.push(p); out.t.push(t); out.s.push(s); out.sigma.push(poses[k].min_singular_value);
      out.arm.push(framePoints(poses[k])); out.config.push(poses[k].configuration || null);
      if (out.frames.length === 0) out.frames.push(poses[k].frames || null); // the first point's frames
    });
    return out;
  }

  function webglAvailable() {
    if (state.webgl === null) {
      try {
        const c = document.createElement('canvas');
        state.webgl = !!(window.WebGLRenderingContext &&
          (c.getContext('webgl') || c.getContext('experimental-webgl')));
      } catch (e) {
        state.webgl = false;
      }
    }
    return state.webgl;
  }

  // ---------------------------------------------------------------- 3D scenes: arm, obstacles, spheres
  const ARM_COLOR = '#374151';

  /** Unit quaternion (x, y, z, w) applied to a vector. */
  function rotate(qt, v) {
    const [x, y, z, w] = qt;
    const tx = 2 * (y * v[2] - z * v[1]);
    const ty = 2 * (z * v[0] - x * v[2]);
    const tz = 2 * (x * v[1] - y * v[0]);
    return [v[0] + w * tx + (y * tz - z * ty), v[1] + w * ty + (z * tx - x * tz),
      v[2] + w * tz + (x * ty - y * tx)];
  }
  /** Three great circles of a sphere, as one polyline with null breaks. */
  function sphereWire(c, r) {
    const pts = [];
    [[0, 1], [0, 2], [1, 2]].forEach(([i, j]) => {
      for (let k = 0; k <= 40; k++) {
        const a = (2 * PI * k) / 40;
        const p = c.slice();
        p[i] += r * Math.cos(a);
        p[j] += r * Math.sin(a);
        pts.push(p);
      }
      pts.push(null);
    });
    return pts;
  }
  function sphereCloud(c, r) {
    const pts = [];
    for (let i = 0; i <= 8; i++) {
      const th = (PI * i) / 8;
      for (let k = 0; k < 16; k++) {
        const ph = (2 * PI * k) / 16;
        pts.push([c[0] + r * Math.sin(th) * Math.cos(ph), c[1] + r * Math.sin(th) * Math.sin(ph),
          c[2] + r * Math.cos(th)]);
      }
    }
    return pts;
  }
  function boxCorners(c, size, qt) {
    const out = [];
    [-1, 1].forEach((sx) => [-1, 1].forEach((sy) => [-1, 1].forEach((sz) => {
      const v = rotate(qt || [0, 0, 0, 1], [sx * size[0] / 2, sy * size[1] / 2, sz * size[2] / 2]);
      out.push([c[0] + v[0], c[1] + v[1], c[2] + v[2]]);
    })));
    return out;
  }
  function boxWire(corners) {
    const edges = [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5],
      [2, 6], [3, 7]];
    const pts = [];
    edges.forEach(([i, j]) => pts.push(corners[i], corners[j], null));
    return pts;
  }

  /** Scene items of the work cell's obstacles (wireframe, and a translucent hull in 3D). */
  function obstacleItems() {
    const items = [];
    state.obstacles.forEach((o) => {
      const c = o.position;
      const hull = o.type === 'box' ? boxCorners(c, o.size) : sphereCloud(c, o.radius);
      const wire = o.type === 'box' ? boxWire(hull) : sphereWire(c, o.radius);
      items.push({ name: `obstacle ${o.name}`, pts: wire, meta: { role: 'obstacle', name: o.name },
        style: { mode: 'lines', line: { color: '#b45309', width: 3 }, hoverinfo: 'name' } });
      items.push({ name: `${o.name} (solid)`, pts: hull, mesh: true, meta: { role: 'obstacle-solid' },
        style: { alphahull: 0, opacity: 0.25, color: '#f59e0b', showlegend: false, hoverinfo: 'skip' } });
    });
    return items;
  }

  /** Quaternion product a * b, both (x, y, z, w). */
  function quatMul(a, b) {
    const [ax, ay, az, aw] = a;
    const [bx, by, bz, bw] = b;
    return [aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
      aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz];
  }
  /** Wireframe of one collision shape in its own frame (capsule and cylinder along local z). */
  function shapeWire(shape) {
    const ring = (r, z, plane) => {
      const out = [];
      for (let k = 0; k <= 24; k++) {
        const a = (2 * PI * k) / 24;
        out.push(plane === 'xy' ? [r * Math.cos(a), r * Math.sin(a), z] : null);
      }
      out.push(null);
      return out;
    };
    const arc = (r, z, sign, axis) => {
      const out = [];
      for (let k = 0; k <= 12; k++) {
        const a = (PI * k) / 12;
        const u = r * Math.cos(a);
        const w = z + sign * r * Math.sin(a);
        out.push(axis === 'x' ? [u, 0, w] : [0, u, w]);
      }
      out.push(null);
      return out;
    };
    if (shape.type === 'sphere') return sphereWire([0, 0, 0], shape.radius);
    if (shape.type === 'box') return boxWire(boxCorners([0, 0, 0], shape.size));
    if (shape.type === 'capsule' || shape.type === 'cylinder') {
      const r = shape.radius;
      const h = shape.length / 2;
      const pts = ring(r, h, 'xy').concat(ring(r, -h, 'xy'));
      [0, 1, 2, 3].forEach((k) => {
        const a = (PI * k) / 2;
        pts.push([r * Math.cos(a), r * Math.sin(a), -h], [r * Math.cos(a), r * Math.sin(a), h], null);
      });
      if (shape.type === 'capsule') {
        ['x', 'y'].forEach((ax) => pts.push(...arc(r, h, 1, ax), ...arc(r, -h, -1, ax)));
      }
      return pts;
    }
    return [];
  }
  /**
   * The robot's ``collision_geometry`` (GET /v1/robots/{name}, API.md round 2: link, shape, origin
   * in the link frame) placed by the link frames of one /fk answer; none where the robot has none.
   */
  function geometryItems(frames, name) {
    const geo = state.robot && state.robot.collision_geometry;
    if (!Array.isArray(geo) || !geo.length || !Array.isArray(frames) || !$('show-geometry').checked) return [];
    const byName = new Map(frames.map((f) => [f.name, f]));
    const pts = [];
    let count = 0;
    geo.forEach((g) => {
      const f = byName.get(g.link);
      if (!f || !g.shape) return;
      const o = g.origin || { position: [0, 0, 0], orientation: [0, 0, 0, 1] };
      const r0 = rotate(f.orientation, o.position);
      const centre = [0, 1, 2].map((c) => f.position[c] + r0[c]);
      const q = quatMul(f.orientation, o.orientation);
      shapeWire(g.shape).forEach((v) => {
        if (!v) { pts.push(null); return; }
        const w = rotate(q, v);
        pts.push([centre[0] + w[0], centre[1] + w[1], centre[2] + w[2]]);
      });
      pts.push(null);
      count += 1;
    });
    if (!count) return [];
    return [{ name: name, pts: pts, meta: { role: 'collision-geometry', shapes: count },
      style: { mode: 'lines', line: { color: '#0d9488', width: 2 }, opacity: 0.8, hoverinfo: 'name' } }];
  }

  function armItem(name, pts, style, meta) {
    return { name: name, pts: pts, meta: Object.assign({ frames: pts.length }, meta),
      style: Object.assign({ mode: 'lines+markers', line: { color: ARM_COLOR, width: 7 },
        marker: { size: 3, color: ARM_COLOR }, hoverinfo: 'name' }, style || {}) };
  }

  /** The first contact of a 422 (or partial) ``collision``: the tool sample nearest its time. */
  function contactItems(failure, tool) {
    if (!failure || failure.code !== 'collision' || !tool || !tool.p.length) return [];
    const t = Number(failure.time_from_start);
    let k = tool.t.length - 1;
    if (Number.isFinite(t)) {
      let best = Infinity;
      tool.t.forEach((tt, i) => { if (Math.abs(tt - t) < best) { best = Math.abs(tt - t); k = i; } });
    }
    const links = Array.isArray(failure.links) ? failure.links.join(' – ') : '';
    const text = `collision at t=${fmt(t, 4)} s${failure.s !== undefined && failure.s !== null ? `, s=${fmt(failure.s, 3)}` : ''}: ${links}, distance ${fmt(failure.distance, 3)} m`;
    const items = [{ name: `✖ collision at t=${fmt(t, 4)} s (${links})`, pts: [tool.p[k]],
      meta: { role: 'collision', time_from_start: t, links: failure.links || null },
      style: { mode: 'markers', text: [text], hovertemplate: '%{text}<extra></extra>',
        marker: { size: 9, symbol: 'x', color: FAIL_COLOR } } }];
    if (tool.arm[k]) {
      items.push(armItem('arm at the contact', tool.arm[k], { line: { color: FAIL_COLOR, width: 6 },
        marker: { size: 3, color: FAIL_COLOR } }, { role: 'arm', which: 'contact' }));
    }
    return items;
  }

  /**
   * Draw scene items ({name, pts: [[x, y, z] | null], style, meta, mesh?}) in ``div``: 3D with one
   * scale on every axis, x-y for the planar arm, top and side views without WebGL. ``anim``
   * ({arm: [[pts]], t: [...], config: [...]}) adds the arm moving along the trajectory, driven by
   * the slider under the plot.
   */
  function drawScene(div, items, anim, filename, focus) {
    const dims = isPlanar() ? 2 : 3;
    const flat = dims === 3 && !webglAvailable();
    const comps = (pts) => Array.from({ length: 3 }, (_, c) => pts.map((p) => (p ? p[c] : null)));
    const all = [];
    // ``focus``: scale the view to the path alone (the arm may then reach out of the box).
    items.filter((it) => !focus || !(it.meta && /^arm/.test(it.meta.role || '')))
      .forEach((it) => it.pts.forEach((p) => { if (p) all.push(p); }));
    if (anim && anim.arm.length) {
      const k = Math.floor((anim.arm.length - 1) / 2);
      items.push(armItem('arm (slider)', anim.arm[k] || [], { opacity: 0.9,
        line: { color: '#7c3aed', width: 7 }, marker: { size: 3, color: '#7c3aed' } },
      { role: 'arm-moving' }));
    }
    const traces = [];
    const moving = [];
    items.forEach((it) => {
      if (it.mesh && (dims === 2 || flat)) return;
      const [x, y, z] = comps(it.pts);
      if (it.mesh) {
        traces.push(Object.assign({ type: 'mesh3d', name: it.name, x: x, y: y, z: z,
          meta: it.meta || null }, it.style));
        return;
      }
      const base = Object.assign({ name: it.name, x: x, y: y, meta: it.meta || null }, it.style);
      if (it.meta && it.meta.role === 'arm-moving') moving.push(traces.length);
      if (dims === 2) { traces.push(Object.assign(base, { type: 'scatter' })); return; }
      if (!flat) { traces.push(Object.assign(base, { type: 'scatter3d', z: z })); return; }
      traces.push(Object.assign({}, base, { type: 'scatter', xaxis: 'x', yaxis: 'y' }));
      if (it.meta && it.meta.role === 'arm-moving') moving.push(traces.length);
      traces.push(Object.assign({}, base, { type: 'scatter', y: z, xaxis: 'x2', yaxis: 'y2',
        showlegend: false }));
    });
    const legend = { orientation: 'h', y: -0.02, yanchor: 'top', font: { size: 11 } };
    let layout;
    if (dims === 2) {
      layout = baseLayout({ xaxis: axis('x [m]'), yaxis: axis('y [m]', { scaleanchor: 'x', scaleratio: 1 }),
        legend: Object.assign({}, legend, { y: -0.1 }), margin: { l: 64, r: 16, t: 16, b: 40 } });
    } else if (flat) {
      layout = baseLayout({ grid: { rows: 1, columns: 2, pattern: 'independent' },
        xaxis: axis('x [m] (top view)'), yaxis: axis('y [m]', { scaleanchor: 'x' }),
        xaxis2: axis('x [m] (side view)'), yaxis2: axis('z [m]', { scaleanchor: 'x2' }),
        legend: Object.assign({}, legend, { y: -0.1 }), margin: { l: 64, r: 16, t: 16, b: 40 } });
    } else {
      const lo = [0, 1, 2].map((c) => Math.min(...all.map((p) => p[c])));
      const hi = [0, 1, 2].map((c) => Math.max(...all.map((p) => p[c])));
      const half = 0.55 * Math.max(1e-3, ...hi.map((v, c) => v - lo[c]));
      const range = (c) => [(lo[c] + hi[c]) / 2 - half, (lo[c] + hi[c]) / 2 + half];
      layout = baseLayout({
        scene: { aspectmode: 'cube', xaxis: { title: { text: 'x [m]' }, range: range(0) },
          yaxis: { title: { text: 'y [m]' }, range: range(1) },
          zaxis: { title: { text: 'z [m]' }, range: range(2) },
          camera: { eye: { x: 1.5, y: -1.5, z: 1.1 } } },
        legend: legend, margin: { l: 0, r: 0, t: 0, b: 40 } });
    }
    const node = $(div);
    node.armAnim = anim && anim.arm.length ? { arm: anim.arm, t: anim.t, config: anim.config,
      moving: moving, flat: flat, dims: dims } : null;
    const drawn = draw(div, traces, layout, filename);
    setupArmBar(div);
    return drawn;
  }

  let armTimer = null;
  function setupArmBar(div) {
    const bar = document.querySelector(`.arm-bar[data-plot="${div}"]`);
    if (!bar) return;
    const a = $(div).armAnim;
    const slider = bar.querySelector('.arm-slider');
    bar.hidden = !a;
    if (!a) return;
    slider.max = String(a.arm.length - 1);
    slider.value = String(Math.floor((a.arm.length - 1) / 2));
    showArm(div, Number(slider.value));
  }
  function showArm(div, k) {
    const node = $(div);
    const a = node.armAnim;
    if (!a || !a.arm[k]) return;
    const pts = a.arm[k];
    const xs = pts.map((p) => p[0]);
    const ys = pts.map((p) => p[1]);
    const zs = pts.map((p) => p[2]);
    const bar = document.querySelector(`.arm-bar[data-plot="${div}"]`);
    bar.querySelector('.arm-time').textContent = `t = ${fmt(a.t[k], 4)} s${a.config[k] ? ` · ${a.config[k]}` : ''}`;
    if (!a.moving.length) return;
    if (a.dims === 3 && !a.flat) Plotly.restyle(node, { x: [xs], y: [ys], z: [zs] }, a.moving);
    else if (a.flat) Plotly.restyle(node, { x: [xs, xs], y: [ys, zs] }, a.moving);
    else Plotly.restyle(node, { x: [xs], y: [ys] }, a.moving);
  }
  function wireArmBars() {
    document.querySelectorAll('.arm-bar').forEach((bar) => {
      const div = bar.dataset.plot;
      const slider = bar.querySelector('.arm-slider');
      bar.hidden = true;
      slider.addEventListener('input', () => showArm(div, Number(slider.value)));
      bar.querySelector('.arm-play').addEventListener('click', () => {
        if (armTimer) { clearInterval(armTimer); armTimer = null; return; }
        const a = $(div).armAnim;
        if (!a) return;
        let k = 0;
        armTimer = setInterval(() => {
          slider.value = String(k);
          showArm(div, k);
          k += 1;
          if (k >= a.arm.length) { clearInterval(armTimer); armTimer = null; }
        }, 60);
      });
    });
  }

  // ---------------------------------------------------------------- Cartesian plots
  /**
   * The tool path (FK of the returned points) beside the ideal line (null for joint moves), the
   * arm at the start and the goal, the moving arm, obstacles and the first contact.
   */
  let lastPath = null; // arguments of the last renderPath, to redraw on the geometry toggle

  function renderPath(line, tool, marks, knotsTool, failure) {
    lastPath = [line, tool, marks, knotsTool, failure];
    if (!line && !(tool && tool.p.length)) {
      placeholder('plot-path', 'No line: the start (or goal) joints were refused');
      return;
    }
    const items = [];
    const add = (name, pts, style, meta) => items.push({ name: name, pts: pts, style: style, meta: meta });
    const dims = isPlanar() ? 2 : 3;
    if (line) {
      add('ideal line', [line.p0, line.p1], { mode: 'lines', opacity: 0.45,
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
    const p0 = line ? line.p0 : tool.p[0];
    const p1 = line ? line.p1 : tool.p[tool.p.length - 1];
    add('start', [p0], { mode: 'markers', marker: { size: dims === 3 ? 6 : 11, color: COLORS[2] } });
    add('goal', [p1], { mode: 'markers', marker: { size: dims === 3 ? 6 : 11, color: '#111',
      symbol: dims === 3 ? 'square' : 'star' } });
    if (line) {
      marks.filter((m) => m.s !== null).forEach((m) => {
        add(`${m.label} at s=${fmt(m.s, 3)}`, [line.at(m.s)], { mode: 'markers', text: [m.message],
          marker: { size: dims === 3 ? 7 : 13, symbol: m.kind === 'failure' ? 'x' : (dims === 3 ? 'diamond-open' : 'triangle-up'),
            color: m.kind === 'failure' ? FAIL_COLOR : WARN_COLOR },
          hovertemplate: '%{text}<extra></extra>' });
      });
    }
    // The arm: link frame origins in kinematic order (POST /fk with frames), at start and goal.
    const startFk = line && line.startFk ? line.startFk : null;
    const startArm = framePoints(startFk) || (tool && tool.arm[0]);
    const startLabel = startFk ? startFk.configuration : tool && tool.config[0];
    if (startArm) {
      items.push(armItem(`arm at start${startLabel ? ` (${startLabel})` : ''}`, startArm,
        { line: { color: COLORS[2], width: 7 }, marker: { size: 3, color: COLORS[2] } },
        { role: 'arm', which: 'start', configuration: startLabel || null }));
    }
    const goalFk = line && line.goalFk ? line.goalFk : null;
    const last = tool && tool.p.length ? tool.p.length - 1 : -1;
    const goalArm = framePoints(goalFk) || (last >= 0 && !failure ? tool.arm[last] : null);
    const goalLabel = goalFk ? goalFk.configuration : (last >= 0 ? tool.config[last] : null);
    if (goalArm) {
      items.push(armItem(`arm at goal${goalLabel ? ` (${goalLabel})` : ''}`, goalArm,
        { line: { color: '#111', width: 7 }, marker: { size: 3, color: '#111' }, opacity: 0.75 },
        { role: 'arm', which: 'goal', configuration: goalLabel || null }));
    }
    geometryItems(startFk ? startFk.frames : tool && tool.frames[0], 'collision geometry at start')
      .forEach((it) => items.push(it));
    (state.ikGhosts || []).forEach((g) => items.push(armItem(`IK ${g.label}`, g.pts,
      { opacity: 0.35, line: { color: '#0891b2', width: 4, dash: 'dot' }, marker: { size: 2, color: '#0891b2' } },
      { role: 'ik-ghost', configuration: g.label })));
    obstacleItems().forEach((it) => items.push(it));
    contactItems(failure, tool).forEach((it) => items.push(it));
    state.lastToolMid = tool && tool.p.length ? tool.p[Math.floor(tool.p.length / 2)] : p0;
    drawScene('plot-path', items, tool && tool.arm.every(Boolean) ? tool : null,
      `${robotName()}-tool-path`);
  }

  let lastDeviation = null; // arguments of the last renderDeviation, to redraw on the log toggle

  function renderDeviation(diag, tolerance, marks, emptyMessage) {
    lastDeviation = [diag, tolerance, marks, emptyMessage];
    const log = $('dev-log').checked;
    const yType = log ? { type: 'log', exponentformat: 'power' } : { rangemode: 'tozero', exponentformat: 'e' };
    const planar = isPlanar();
    const prof = diag && diag.deviation_profile;
    const traces = [];
    if (prof && prof.s && prof.s.length) {
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
    if (!(prof && prof.s && prof.s.length) && emptyMessage) {
      m.annotations.push({ text: emptyMessage, showarrow: false, xref: 'paper', yref: 'paper',
        x: 0.5, y: 0.5, font: { size: 12, color: '#6b7280' } });
    }
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

  /**
   * The smallest robot-obstacle / link-link distance over time (``diagnostics.clearance_profile``)
   * with the requested ``clearance`` dashed, in the card ``card<suffix>-clearance``: shown only when
   * the request carried an environment and the answer has a profile.
   */
  function renderClearance(suffix, diag, req) {
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

  function renderSigma(diag, tool, marks, emptyMessage) {
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
    if (!x && emptyMessage) {
      m.annotations.push({ text: emptyMessage, showarrow: false, xref: 'paper', yref: 'paper',
        x: 0.5, y: 0.5, font: { size: 12, color: '#6b7280' } });
    }
    draw('plot-sigma', traces, baseLayout({
      xaxis: axis('s (path parameter)', { range: [-0.02, 1.02] }),
      yaxis: axis('σ min of the task Jacobian', { rangemode: 'tozero' }),
      shapes: m.shapes, annotations: m.annotations, showlegend: false,
      margin: { l: 70, r: 16, t: 22, b: 44 },
    }), `${robotName()}-singular-value`);
  }

  // ---------------------------------------------------------------- runs
  function robotLimits() {
    return state.robot.limits;
  }

  async function runCartesian(override) {
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
      let prefixNote = null;
      if (problem && problem.s !== undefined && problem.s !== null && problem.s > 0 &&
          $('c-prefix').checked && !req.allow_partial) {
        // Draw what could be planned: the same request with allow_partial (public API).
        const partial = await api('POST', path, Object.assign({}, req, { allow_partial: true }));
        if (partial.ok && partial.json.points && partial.json.points.length) {
          body = partial.json;
          downloads.push({ label: 'Download prefix JSON', filename: `${base}-prefix.json`,
            text: partial.text });
          prefixNote = { text: `Drawn below: the planned prefix up to s = ` +
            `${fmt(partial.json.diagnostics.fraction, 4)} (the same request with allow_partial).` };
        }
      }
      setDownloads(downloads);
      const diag = body ? body.diagnostics : null;
      const failure = problem || (diag && diag.failure ? Object.assign({ title: 'Partial plan' }, diag.failure) : null);
      const marks = marksOf(diag, failure);
      if (problem) renderProblem(problem, `POST ${path}`, prefixNote);
      else if (failure) {
        renderProblem(failure, 'allow_partial: the planned prefix is drawn', { partial: true });
      } else renderProblem(null);
      setStatus(res.ok ? 'ok' : 'error', res.ok
        ? `POST ${path} → ${res.status} in ${Math.round(res.ms)} ms · ${body.points.length} points over ${fmt(diag.duration)} s`
        : `POST ${path} → ${res.status} ${problem.code || ''} in ${Math.round(res.ms)} ms`);
      renderSummary(body);
      renderWarnings(marks);

      const line = await lineOf(req);
      const tool = body ? await toolPath(body, line) : null;
      let knotsTool = null;
      if (body && body.knots && body.knots.length) {
        const idx = subsample(body.knots.length, MAX_FK_POINTS);
        const poses = await mapLimit(idx, FK_CONCURRENCY, (i) => fk(body.knots[i].positions));
        knotsTool = poses.filter(Boolean).map((p) => p.pose.position);
      }
      const tolerance = Object.assign({}, DEFAULT_TOLERANCE, req.tolerance || {});
      const empty = problem ? `no trajectory: ${problem.code || 'error'}` : 'no deviation data';
      renderPath(line, tool, marks, knotsTool, failure);
      addConfigurations(line && line.startFk ? line.startFk.configuration : null,
        line && line.goalFk ? line.goalFk.configuration : (tool && !failure ? tool.config[tool.config.length - 1] : null));
      renderDeviation(diag, tolerance, marks, empty);
      renderSigma(diag, tool, marks, empty);
      renderClearance('', diag, req);
      const knots = body && body.knots ? body.knots.map((k, i) => ({ t: k.time_from_start,
        positions: k.positions, label: `knot ${i + 1} (s=${fmt(k.s, 3)})`, kind: 'knots' })) : null;
      renderJoints(body, robotLimits(), knots,
        problem ? `No trajectory: ${problem.code || 'error'} — ${problem.detail || ''}` : 'No trajectory');
    } catch (e) {
      pageError(e);
    } finally {
      done();
    }
  }

  async function runJoint(kind) {
    const isSpline = kind === 'spline';
    const req = isSpline ? splineRequest() : jointRequest();
    const path = isSpline ? '/v1/trajectories/spline' : '/v1/trajectories/joint';
    showRequest('POST', path, req);
    busy(`Planning ${isSpline ? 'spline' : req.profile} …`);
    showView('joints');
    try {
      const res = await api('POST', path, req);
      const name = `${robotName()}-${isSpline ? `spline-${req.boundary}` : req.profile}`;
      setDownloads([{ label: 'Download JSON', filename: `${name}.json`, text: res.text }]);
      let body = res.ok ? res.json : null;
      const problem = res.ok ? null : problemOf(res);
      let note = null;
      if (problem && problem.code === 'collision' && req.environment) {
        // The checked motion itself: the same request without the environment (public API).
        const free = Object.assign({}, req);
        delete free.environment;
        const again = await api('POST', path, free);
        if (again.ok) {
          body = again.json;
          note = { text: 'Drawn below: the same plan without the environment (the motion that was ' +
            'checked), with the first contact marked on the tool path (Cartesian view).' };
        }
      }
      renderProblem(problem, `POST ${path}`, note);
      setStatus(res.ok ? 'ok' : 'error', res.ok
        ? `POST ${path} → ${res.status} in ${Math.round(res.ms)} ms · ${body.points.length} points over ${fmt(body.diagnostics.duration)} s`
        : `POST ${path} → ${res.status} ${problem.code || ''} in ${Math.round(res.ms)} ms`);
      renderSummary(body);
      renderWarnings(marksOf(body ? body.diagnostics : null, null));
      const limits = Object.assign({}, robotLimits());
      if (req.limits) {
        limits.velocity = req.limits.velocity.map((v, j) => (Number.isFinite(v) ? v : limits.velocity[j]));
        limits.acceleration = req.limits.acceleration.map((v, j) => (Number.isFinite(v) ? v : limits.acceleration[j]));
        if (Array.isArray(req.limits.jerk)) limits.jerk = req.limits.jerk;
      }
      let knots = null;
      if (body) {
        const times = req.times || (body.diagnostics && body.diagnostics.knot_times);
        const wps = isSpline ? req.waypoints : [req.start.positions, req.goal.positions];
        const ts = times || (isSpline ? null : [0, body.diagnostics.duration]);
        if (ts && ts.length === wps.length) {
          knots = wps.map((q, i) => ({ t: ts[i], positions: q, label: `waypoint ${i + 1}`,
            kind: isSpline ? 'waypoints' : 'start / goal' }));
        }
      }
      renderJoints(body, limits, knots,
        problem ? `No trajectory: ${problem.code || 'error'} — ${problem.detail || ''}` : null);
      renderClearance('-joint', body && !problem ? body.diagnostics : null, req);
      ['plot-deviation', 'plot-sigma'].forEach((d) =>
        placeholder(d, 'Plan a Cartesian line to see the deviation and σ'));
      if (body && req.robot) {
        // The tool path and the arm of the joint-space motion (Cartesian view).
        const tool = await toolPath(body, null);
        tool.s = tool.s.map(() => null);
        renderPath(null, tool, [], null, problem);
        addConfigurations(tool.config[0], tool.config[tool.config.length - 1]);
      } else {
        placeholder('plot-path', 'No trajectory to draw');
      }
    } catch (e) {
      pageError(e);
    } finally {
      done();
    }
  }


  // ---------------------------------------------------------------- work cell (environment)
  /** The request's ``environment``: only once the user added an obstacle (feature detection). */
  function environment() {
    if (!state.obstacles.length) return undefined;
    const env = {
      obstacles: state.obstacles.map((o) => ({ name: o.name,
        shape: o.type === 'box' ? { type: 'box', size: o.size } : { type: 'sphere', radius: o.radius },
        pose: { position: o.position, orientation: [0, 0, 0, 1] } })),
    };
    const clearance = num('env-clearance');
    if (clearance !== undefined && clearance > 0) env.clearance = clearance;
    return env;
  }
  function withEnvironment(req) {
    const env = environment();
    if (env) req.environment = env;
    return req;
  }
  function addObstacle(type) {
    state.obstacleCount += 1;
    const at = (state.lastToolMid || [0.4, 0, 0.3]).map(round6);
    state.obstacles.push(type === 'box'
      ? { name: `box${state.obstacleCount}`, type: 'box', position: at, size: [0.1, 0.1, 0.1] }
      : { name: `sphere${state.obstacleCount}`, type: 'sphere', position: at, radius: 0.05 });
    renderObstacles();
  }
  function renderObstacles() {
    const table = $('env-table');
    table.textContent = '';
    if (state.obstacles.length) {
      table.append(el('tr', {}, ['name', 'x', 'y', 'z', 'size [m]', ''].map((h) => el('th', {}, h))));
    }
    const numberCell = (o, get, set, id) => {
      const input = numberInput(id, get());
      input.addEventListener('change', () => { set(Number(input.value)); });
      return el('td', {}, input);
    };
    state.obstacles.forEach((o, i) => {
      const name = el('input', { type: 'text', value: o.name, id: `env-name-${i}`, size: 7 });
      name.addEventListener('change', () => { o.name = name.value; });
      const sizes = o.type === 'box'
        ? el('td', {}, el('div', { class: 'triple' }, [0, 1, 2].map((c) => {
          const input = numberInput(`env-size-${i}-${c}`, o.size[c], { title: ['x', 'y', 'z'][c] + ' edge' });
          input.addEventListener('change', () => { o.size[c] = Number(input.value); });
          return input;
        })))
        : numberCell(o, () => o.radius, (v) => { o.radius = v; }, `env-radius-${i}`);
      table.append(el('tr', { 'data-obstacle': o.name }, el('td', {}, name),
        [0, 1, 2].map((c) => numberCell(o, () => o.position[c], (v) => { o.position[c] = v; }, `env-pos-${i}-${c}`)),
        sizes,
        el('td', {}, el('button', { type: 'button', class: 'small', title: 'remove',
          onclick: () => { state.obstacles.splice(i, 1); renderObstacles(); } }, '✕'))));
    });
    $('env-note').textContent = state.obstacles.length
      ? `${state.obstacles.length} obstacle(s): every plan request carries this environment (a box is an axis-aligned box about its centre).`
      : 'No obstacles: requests carry no environment.';
  }

  // ---------------------------------------------------------------- IK: every solution of a pose
  async function ikAll() {
    const pose = {
      position: ['c-px', 'c-py', 'c-pz'].map((id) => num(id) || 0),
      orientation: ['c-qx', 'c-qy', 'c-qz', 'c-qw'].map((id) => num(id) || 0),
    };
    const path = `/v1/robots/${encodeURIComponent(robotName())}/ik`;
    const req = { pose: pose, seed: jointValues('c-start'), all: true };
    showRequest('POST', path, req);
    const box = $('c-ik-list');
    box.hidden = false;
    box.textContent = 'solving …';
    const res = await api('POST', path, req);
    box.textContent = '';
    if (!res.ok) {
      const problem = problemOf(res);
      box.append(el('p', { class: 'muted' }, `${problem.code || res.status}: ${problem.detail || ''}`));
      state.ikGhosts = [];
      return;
    }
    const sols = res.json.solutions || [];
    box.append(el('p', { class: 'muted', id: 'c-ik-count' },
      `${sols.length} solution(s), ${res.json.solver} solver, nearest the start joints first:`));
    sols.forEach((sol, k) => box.append(el('div', { class: 'ik-row', 'data-configuration': sol.configuration || '' },
      el('code', { title: sol.positions.map((v) => fmt(v, 4)).join(', ') }, sol.configuration || `solution ${k + 1}`),
      el('button', { type: 'button', class: 'small', id: `c-ik-use-${k}`,
        onclick: () => useSolution(sol) }, 'use as goal joints'))));
    const arms = await mapLimit(sols, FK_CONCURRENCY, (sol) => fk(sol.positions, true));
    state.ikGhosts = arms.map((a, k) => ({ label: sols[k].configuration || `solution ${k + 1}`,
      pts: framePoints(a) })).filter((g) => g.pts);
    const start = await fk(jointValues('c-start'), true);
    showView('cartesian');
    renderPath({ p0: start.pose.position, p1: pose.position, at: () => pose.position,
      startFk: start, goalFk: null }, null, [], null, null);
  }
  function useSolution(sol) {
    sol.positions.forEach((v, j) => { $(`c-goal-${j}`).value = round6(v); });
    $('c-goal-joints').checked = true;
    syncCartesian();
    updateConfigs();
  }
  /** Labels of the Cartesian form's start and goal joints (from /fk). */
  async function updateConfigs() {
    if (!state.robot || !(state.robot.configurations || []).length) {
      $('c-configs').textContent = '';
      return;
    }
    const [a, b] = await Promise.all([fk(jointValues('c-start')), fk(jointValues('c-goal'))]);
    $('c-configs').textContent = `configuration: start ${a ? a.configuration : '?'} · goal joints ${b ? b.configuration : '?'}`;
  }

  // ---------------------------------------------------------------- compare
  async function runCompare() {
    const task = cartesianRequest();
    delete task.method;
    const control = num('c-control');
    if (control !== undefined) task.control_period = control; // used by the rate methods
    const methods = Array.from(document.querySelectorAll('input[name="c-compare-method"]:checked'))
      .map((n) => n.value);
    const body = { task: task, methods: methods.length ? methods : METHODS };
    const path = '/v1/compare';
    showRequest('POST', path, body);
    busy(`Comparing ${body.methods.length} methods …`);
    showView('compare');
    try {
      const res = await api('POST', path, body);
      const filename = `${robotName()}-compare.json`;
      setDownloads([{ label: 'Download JSON', filename: filename, text: res.text }]);
      state.compareDownload = { filename: filename, text: res.text };
      $('download-compare').disabled = false;
      renderSummary(null);
      renderWarnings([]);
      const tolerance = Object.assign({}, DEFAULT_TOLERANCE, task.tolerance || {});
      if (!res.ok) {
        const problem = problemOf(res);
        renderProblem(problem, `POST ${path}`);
        setStatus('error', `POST ${path} → ${res.status} ${problem.code || ''}`);
        renderCompareTable([]);
        renderCompareplot([], tolerance, `compare failed: ${problem.code || res.status}`);
        renderCompareClearance([], task);
        return;
      }
      renderProblem(null);
      const results = res.json.results || [];
      const failed = results.filter((r) => !r.ok).length;
      setStatus(failed ? 'warn' : 'ok', `POST ${path} → ${res.status} in ${Math.round(res.ms)} ms · ` +
        `${results.length - failed} of ${results.length} methods planned the line`);
      renderCompareTable(results);
      renderCompareplot(results, tolerance);
      renderCompareClearance(results, task);
    } catch (e) {
      pageError(e);
    } finally {
      done();
    }
  }

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

  let lastCompare = null; // arguments of the last renderCompareplot, to redraw on the log toggle

  function renderCompareplot(results, tolerance, emptyMessage) {
    lastCompare = [results, tolerance, emptyMessage];
    const planar = isPlanar();
    const yType = $('cmp-log').checked ? { type: 'log', exponentformat: 'power' }
      : { rangemode: 'tozero', exponentformat: 'e' };
    const traces = [];
    const marks = [];
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
    if (emptyMessage) {
      m.annotations.push({ text: emptyMessage, showarrow: false, xref: 'paper', yref: 'paper',
        x: 0.5, y: 0.5, font: { size: 13, color: '#6b7280' } });
    }
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

  /**
   * Every method's smallest distance over time (``diagnostics.clearance_profile`` of each row) with
   * the requested ``clearance`` dashed, in ``card-compare-clearance``: shown only when the task
   * carried an environment and some row has a profile.
   */
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

  // ---------------------------------------------------------------- presets
  function elbowUp(x, y) { // planar 2R preset (1.0 m and 0.8 m links), positive elbow
    const l1 = 1.0;
    const l2 = 0.8;
    const q2 = Math.acos((x * x + y * y - l1 * l1 - l2 * l2) / (2 * l1 * l2));
    return [Math.atan2(y, x) - Math.atan2(l2 * Math.sin(q2), l1 + l2 * Math.cos(q2)), q2];
  }
  const PI = Math.PI;
  const UR5_HOME = [0, -PI / 3, PI / 2, -2 * PI / 3, -PI / 2, 0];
  const PRESETS = [
    { id: 'ur5-line', label: 'UR5: 23 cm line, tool turning 0.29 rad', robot: 'ur5',
      start: UR5_HOME, goal: { positions: [0.3, -1.2, 1.8, -2.2, -1.3, 0.4] }, method: 'sampled',
      speeds: [0.2, 0.8] },
    { id: 'planar-hole', label: 'Planar 2R: line through the unreachable hole', robot: 'planar_2r',
      start: elbowUp(-0.8, 0.05),
      goal: { pose: { position: [0.8, 0.05, 0], orientation: [0, 0, 0, 1] } }, method: 'sampled' },
    { id: 'puma-through', label: 'PUMA 560: through the wrist singularity', robot: 'puma560',
      start: [0, PI / 4, -PI, 0, 0.3, 0], goal: { positions: [0, PI / 4, -PI, 0, -0.3, 0] },
      method: 'sampled' },
    { id: 'puma-near', label: 'PUMA 560: near the wrist singularity (slow-down)', robot: 'puma560',
      start: [0, PI / 4, -PI, 0.4, 0.1, -0.4], goal: { positions: [0.05, PI / 4, -PI, -0.4, -0.1, 0.4] },
      method: 'sampled' },
    { id: 'panda-line', label: 'Panda: line to a pose', robot: 'panda',
      start: [0, -PI / 4, 0, -3 * PI / 4, 0, PI / 2, PI / 4],
      goal: { pose: { position: [0.507, 0.15, 0.39],
        orientation: [0.97047, -0.189358, -0.083476, -0.123949] } }, method: 'sampled' },
    { id: 'ur5-short', label: 'UR5: duration too short (joint_rate_limit)', robot: 'ur5',
      start: UR5_HOME, goal: { positions: [0.3, -1.2, 1.8, -2.2, -1.3, 0.4] }, method: 'sampled',
      duration: 0.1 },
  ];

  async function applyPreset(id) {
    const p = PRESETS.find((x) => x.id === id);
    if (!p) return;
    if (robotName() !== p.robot) await selectRobot(p.robot);
    buildCartesianForm(p.start, p.goal.positions || null);
    if (p.goal.pose) {
      $('c-goal-pose').checked = true;
      setPose(p.goal.pose);
    } else {
      $('c-goal-joints').checked = true;
    }
    $('c-method').value = p.method;
    document.querySelector(`input[name="c-timing"][value="${p.duration ? 'duration' : 'speeds'}"]`).checked = true;
    if (p.duration) $('c-duration').value = p.duration;
    $('c-vlin').value = p.speeds ? p.speeds[0] : '';
    $('c-vang').value = p.speeds ? p.speeds[1] : '';
    $('c-partial').checked = false;
    syncCartesian();
  }

  function setPose(pose) {
    ['c-px', 'c-py', 'c-pz'].forEach((id, i) => { $(id).value = round6(pose.position[i]); });
    ['c-qx', 'c-qy', 'c-qz', 'c-qw'].forEach((id, i) => { $(id).value = round6(pose.orientation[i]); });
  }

  // ---------------------------------------------------------------- motion programs
  const SEG_TYPES = ['ptp', 'lin', 'circ'];

  /** A new editor segment: goal as a pose (lin, circ) or joints (ptp), from ``from``. */
  function programSegment(type, from) {
    const seg = { type: type, goalKind: type === 'ptp' ? 'positions' : 'pose',
      positions: (from && from.positions) || state.robot.home.slice(),
      pose: from && from.pose ? JSON.parse(JSON.stringify(from.pose)) : null,
      blend: 0, speed: undefined, vscale: undefined, circKind: 'interim', via: null };
    return seg;
  }

  function programStart() { return jointValues('p-start'); }

  function buildProgramForm() {
    const r = state.robot;
    const table = $('p-start');
    table.textContent = '';
    const head = el('tr', {});
    const row = el('tr', {});
    r.joint_names.forEach((name, j) => {
      head.append(el('th', { title: name }, name));
      row.append(el('td', {}, numberInput(`p-start-${j}`, r.home[j])));
    });
    table.append(head, row);
    state.program = [];
    renderSegments();
  }

  function segInput(id, value, onchange, attrs) {
    const input = numberInput(id, value, attrs);
    input.addEventListener('change', () => onchange(input.value.trim() === '' ? undefined : Number(input.value)));
    return input;
  }

  function renderSegments() {
    const box = $('p-segments');
    box.textContent = '';
    const n = state.program.length;
    state.program.forEach((seg, k) => {
      const color = COLORS[k % COLORS.length];
      const move = (d) => {
        const j = k + d;
        if (j < 0 || j >= n) return;
        [state.program[k], state.program[j]] = [state.program[j], state.program[k]];
        renderSegments();
      };
      const type = el('select', { id: `p-seg-${k}-type`, 'aria-label': 'segment type' },
        SEG_TYPES.map((t) => el('option', { value: t, selected: t === seg.type }, t.toUpperCase())));
      type.addEventListener('change', () => {
        seg.type = type.value;
        if (seg.type === 'circ') seg.goalKind = 'pose';
        if (seg.type === 'circ' && !seg.via) seg.via = (seg.pose ? seg.pose.position : [0, 0, 0]).slice();
        renderSegments();
      });
      const kind = el('select', { id: `p-seg-${k}-goal-kind`, 'aria-label': 'goal kind' },
        [['pose', 'goal pose'], ['positions', 'goal joints']].filter(([v]) => seg.type !== 'circ' || v === 'pose')
          .map(([v, label]) => el('option', { value: v, selected: v === seg.goalKind }, label)));
      kind.addEventListener('change', async () => {
        seg.goalKind = kind.value;
        if (seg.goalKind === 'pose' && !seg.pose) {
          const a = await fk(seg.positions);
          if (a) seg.pose = a.pose;
        }
        renderSegments();
      });
      const blend = segInput(`p-seg-${k}-blend`, k < n - 1 ? seg.blend : '', (v) => { seg.blend = v || 0; },
        { disabled: k === n - 1, title: 'blend radius [m] (not on the last segment)', style: 'width:64px' });
      const head = el('div', { class: 'seg-head' }, el('strong', {}, String(k + 1)), type, kind,
        el('label', { class: 'inline' }, 'blend r [m]', blend),
        el('span', { class: 'spacer' }),
        el('button', { type: 'button', title: 'move up', onclick: () => move(-1), disabled: k === 0 }, '↑'),
        el('button', { type: 'button', title: 'move down', onclick: () => move(1), disabled: k === n - 1 }, '↓'),
        el('button', { type: 'button', title: 'remove', id: `p-seg-${k}-remove`,
          onclick: () => { state.program.splice(k, 1); renderSegments(); } }, '✕'));
      const card = el('div', { class: 'segment', 'data-segment': String(k), style: `--seg:${color}` }, head);
      if (seg.goalKind === 'pose' && seg.pose) {
        const t = el('table', { class: 'grid pose' },
          el('tr', {}, ['', 'x', 'y', 'z', 'w'].map((h) => el('th', {}, h))),
          el('tr', {}, el('th', {}, 'position'), [0, 1, 2].map((c) => el('td', {},
            segInput(`p-seg-${k}-p${c}`, seg.pose.position[c], (v) => { seg.pose.position[c] = v; }))), el('td', {})),
          el('tr', {}, el('th', {}, 'quaternion'), [0, 1, 2, 3].map((c) => el('td', {},
            segInput(`p-seg-${k}-q${c}`, seg.pose.orientation[c], (v) => { seg.pose.orientation[c] = v; })))));
        card.append(t);
      } else {
        const t = el('table', { class: 'grid' },
          el('tr', {}, state.robot.joint_names.map((name) => el('th', { title: name }, name))),
          el('tr', {}, seg.positions.map((v, j) => el('td', {},
            segInput(`p-seg-${k}-q-${j}`, v, (x) => { seg.positions[j] = x; })))));
        card.append(t);
      }
      if (seg.type === 'circ') {
        const ck = el('select', { id: `p-seg-${k}-circ-kind` },
          ['interim', 'center'].map((v) => el('option', { value: v, selected: v === seg.circKind }, v)));
        ck.addEventListener('change', () => { seg.circKind = ck.value; });
        card.append(el('div', { class: 'row' }, ck, [0, 1, 2].map((c) =>
          segInput(`p-seg-${k}-via${c}`, seg.via[c], (v) => { seg.via[c] = v; }, { style: 'width:80px' }))));
      }
      const extra = seg.type === 'ptp'
        ? el('label', { class: 'inline' }, 'velocity scale', segInput(`p-seg-${k}-vscale`, seg.vscale,
          (v) => { seg.vscale = v; }, { placeholder: '1', style: 'width:64px' }))
        : el('label', { class: 'inline' }, 'max linear speed [m/s]', segInput(`p-seg-${k}-speed`, seg.speed,
          (v) => { seg.speed = v; }, { placeholder: '0.25', style: 'width:64px' }));
      card.append(el('div', { class: 'row' }, extra));
      box.append(card);
    });
    if (!n) box.append(el('p', { class: 'muted' }, 'No segments: add one, or pick a preset.'));
  }

  async function addSegment(type) {
    const last = state.program[state.program.length - 1];
    let from = last ? { positions: last.positions.slice(), pose: last.pose } : null;
    if (!from) {
      const q = programStart();
      const a = await fk(q);
      from = { positions: q, pose: a ? a.pose : null };
    }
    if (!from.pose) {
      const a = await fk(from.positions);
      from.pose = a ? a.pose : { position: [0, 0, 0], orientation: [0, 0, 0, 1] };
    }
    const seg = programSegment(type, from);
    if (type === 'circ') seg.via = from.pose.position.slice();
    state.program.push(seg);
    renderSegments();
  }

  function programRequest() {
    const n = state.program.length;
    const segments = state.program.map((seg, k) => {
      const out = { type: seg.type,
        goal: seg.goalKind === 'pose' ? { pose: seg.pose } : { positions: seg.positions } };
      if (seg.type === 'ptp' && seg.vscale !== undefined) out.velocity_scale = seg.vscale;
      if (seg.type !== 'ptp' && seg.speed !== undefined) out.max_linear_speed = seg.speed;
      if (seg.type === 'circ') out[seg.circKind] = seg.via;
      if (k < n - 1 && seg.blend) out.blend_radius = seg.blend;
      return out;
    });
    const req = { robot: robotName(), start: { positions: programStart() }, segments: segments };
    const period = num('p-period');
    if (period !== undefined) req.sample_period = period;
    if ($('p-partial').checked) req.allow_partial = true;
    return withEnvironment(req);
  }

  const PANDA_HOME = [0, -PI / 4, 0, -3 * PI / 4, 0, PI / 2, PI / 4];
  const PROGRAM_PRESETS = [
    { id: 'ur5-weld', label: 'UR5: weld seam, 4 rounded corners (examples/ur5_weld_seam.py)', robot: 'ur5',
      start: UR5_HOME, period: 0.004,
      build: (p0, down) => {
        const X = [0.1, 0, 0];
        const Y = [0, 0.12, 0];
        const add = (a, b, f) => a.map((v, i) => v + (f || 1) * b[i]);
        const A = add(p0, X, -1);
        const B = add(p0, X);
        const C = add(B, Y);
        const D = add(A, Y);
        return [B, C, D, A, p0].map((p, k) => ({ type: 'lin', pose: { position: p, orientation: down },
          speed: 0.1, blend: k < 4 ? 0.03 : 0 }));
      } },
    { id: 'panda-pick', label: 'Panda: pick and place (examples/panda_pick_place.py)', robot: 'panda',
      start: PANDA_HOME, period: 0.005,
      build: (p0, down) => {
        const pick = [0.5, -0.2, 0.15];
        const place = [0.45, 0.25, 0.2];
        const up = (p) => [p[0], p[1], p[2] + 0.15];
        const pose = (p) => ({ position: p, orientation: down });
        return [
          { type: 'ptp', goalKind: 'pose', pose: pose(up(pick)), vscale: 0.8 },
          { type: 'lin', pose: pose(pick), speed: 0.2 },
          { type: 'lin', pose: pose(up(pick)), speed: 0.3, blend: 0.05 },
          { type: 'ptp', goalKind: 'pose', pose: pose(up(place)), blend: 0.05 },
          { type: 'lin', pose: pose(place), speed: 0.2 },
        ];
      } },
    { id: 'ur5-circ', label: 'UR5: LIN, half circle (CIRC through a point), LIN back', robot: 'ur5',
      start: UR5_HOME, period: 0.005,
      build: (p0, down) => {
        const B = [p0[0] + 0.1, p0[1], p0[2]];
        const C = [B[0], B[1] + 0.12, B[2]];
        const via = [B[0] + 0.06, B[1] + 0.06, B[2]];
        return [
          { type: 'lin', pose: { position: B, orientation: down }, speed: 0.1, blend: 0.02 },
          { type: 'circ', pose: { position: C, orientation: down }, speed: 0.1, blend: 0.02, via: via },
          { type: 'lin', pose: { position: [p0[0], p0[1] + 0.12, p0[2]], orientation: down }, speed: 0.1 },
        ];
      } },
  ];

  async function applyProgramPreset(id) {
    const p = PROGRAM_PRESETS.find((x) => x.id === id);
    if (!p) return;
    if (robotName() !== p.robot) await selectRobot(p.robot);
    p.start.forEach((v, j) => { $(`p-start-${j}`).value = round6(v); });
    const a = await fk(p.start);
    state.program = p.build(a.pose.position, a.pose.orientation).map((s) => Object.assign(
      programSegment(s.type, null), { goalKind: s.goalKind || 'pose', pose: s.pose, speed: s.speed,
        vscale: s.vscale, blend: s.blend || 0, via: s.via || null }));
    $('p-period').value = p.period;
    renderSegments();
  }

  /** Returned points at segment and blend boundaries, and evenly spread ones: where FK is asked. */
  function programIndices(body) {
    const times = body.points.map((pt) => pt.time_from_start);
    const want = new Set(subsample(times.length, 2 * MAX_FK_POINTS));
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

  async function runProgram() {
    if (!state.program.length) {
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
      setStatus(res.ok ? 'ok' : 'error', res.ok
        ? `POST ${path} → ${res.status} in ${Math.round(res.ms)} ms · ${body.points.length} points over ` +
          `${fmt(diag.duration)} s · ${body.segments.length} segments`
        : `POST ${path} → ${res.status} ${problem.code || ''} in ${Math.round(res.ms)} ms`);
      renderSummary(body, diag ? [['stops', diag.stops]] : []);
      renderWarnings(marksOf(diag, null).filter((m) => m.kind === 'warning'));
      if (!body || !body.points || !body.points.length) {
        placeholder('plot-program-path', `No program: ${problem ? problem.code : 'no points'}`);
        placeholder('plot-program-speed', 'No program');
        renderClearance('-program', null, req);
        renderProgramTable([], problem);
        renderJoints(null, robotLimits(), null, 'No program');
        return;
      }
      const tool = await toolPath(body, null, programIndices(body));
      const goals = await programGoals(req);
      renderProgramPath(body, tool, goals, req, failure);
      renderProgramSpeed(body, tool, failure);
      renderClearance('-program', diag, req);
      renderProgramTable(body.segments || [], failure);
      const knots = (body.segments || []).map((sg) => {
        const t = sg.end_time;
        const pt = body.points.find((x) => x.time_from_start >= t - 1e-12) || body.points[body.points.length - 1];
        return { t: t, positions: pt.positions, label: `end of segment ${sg.index + 1}`, kind: 'segment ends' };
      });
      renderJoints(body, robotLimits(), knots, 'No program');
      addConfigurations(tool.config[0], tool.config[tool.config.length - 1]);
    } catch (e) {
      pageError(e);
    } finally {
      done();
    }
  }

  /** The tool position at each segment's goal (FK of joint goals), for blend spheres and markers. */
  async function programGoals(req) {
    return mapLimit(req.segments, FK_CONCURRENCY, async (seg) => {
      if (seg.goal.pose) return seg.goal.pose.position;
      const a = await fk(seg.goal.positions);
      return a ? a.pose.position : null;
    });
  }

  function segmentAt(segs, t) {
    for (let k = 0; k < segs.length; k++) {
      const sg = segs[k];
      if (t >= sg.start_time - 1e-9 && t <= sg.end_time + 1e-9) return { k: k, blend: false };
      if (sg.blend_out && t >= sg.blend_out.start_time - 1e-9 && t <= sg.blend_out.end_time + 1e-9) {
        return { k: k, blend: true };
      }
    }
    return null;
  }

  let lastProgramPath = null; // arguments of the last renderProgramPath, to redraw on the zoom toggle

  function renderProgramPath(body, tool, goals, req, failure) {
    lastProgramPath = [body, tool, goals, req, failure];
    const segs = body.segments || [];
    const dims = isPlanar() ? 2 : 3;
    const items = [];
    segs.forEach((sg, k) => {
      const own = [];
      const blend = [];
      tool.t.forEach((t, i) => {
        const at = segmentAt([sg], t);
        if (at && !at.blend) own.push(tool.p[i]);
        if (at && at.blend) blend.push(tool.p[i]);
      });
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
    const goalPts = goals.filter(Boolean);
    items.push({ name: 'segment goals', pts: goalPts, meta: { role: 'goals' },
      style: { mode: 'markers', marker: { size: dims === 3 ? 4 : 8, symbol: 'diamond', color: '#111' },
        text: goals.map((g, k) => `goal of segment ${k + 1}`).filter((_, k) => goals[k]),
        hovertemplate: '%{text}<extra></extra>' } });
    if (tool.arm[0]) {
      items.push(armItem(`arm at start${tool.config[0] ? ` (${tool.config[0]})` : ''}`, tool.arm[0],
        { line: { color: COLORS[2], width: 7 }, marker: { size: 3, color: COLORS[2] } },
        { role: 'arm', which: 'start', configuration: tool.config[0] }));
    }
    const last = tool.arm.length - 1;
    if (last > 0 && tool.arm[last]) {
      items.push(armItem(`arm at the end${tool.config[last] ? ` (${tool.config[last]})` : ''}`, tool.arm[last],
        { line: { color: '#111', width: 7 }, marker: { size: 3, color: '#111' }, opacity: 0.75 },
        { role: 'arm', which: 'goal', configuration: tool.config[last] }));
    }
    geometryItems(tool.frames[0], 'collision geometry at start').forEach((it) => items.push(it));
    obstacleItems().forEach((it) => items.push(it));
    contactItems(failure, tool).forEach((it) => items.push(it));
    if (failure && failure.code !== 'collision' && tool.p.length) {
      items.push({ name: `✖ ${failure.code || 'failed'} in segment ${(failure.segment || 0) + 1}`,
        pts: [tool.p[tool.p.length - 1]], meta: { role: 'failure' },
        style: { mode: 'markers', marker: { size: 9, symbol: 'x', color: FAIL_COLOR } } });
    }
    state.lastToolMid = tool.p.length ? tool.p[Math.floor(tool.p.length / 2)] : null;
    drawScene('plot-program-path', items, tool.arm.every(Boolean) ? tool : null,
      `${robotName()}-program-path`, $('p-focus').checked);
  }

  /** Joint speeds |q'| and the tool speed against time; segment and blend windows shaded. */
  function renderProgramSpeed(body, tool, failure) {
    const segs = body.segments || [];
    const t = body.points.map((p) => p.time_from_start);
    const traces = [];
    body.joint_names.forEach((name, j) => {
      traces.push({ type: 'scatter', mode: 'lines', name: name, x: t,
        y: body.points.map((p) => Math.abs(p.velocities[j])), xaxis: 'x', yaxis: 'y',
        line: { color: COLORS[j % COLORS.length], width: 1.5 }, meta: { role: 'joint-speed' },
        hovertemplate: `${name}: %{y:.3g} rad/s<extra></extra>` });
    });
    const ts = [];
    const vs = [];
    for (let i = 1; i < tool.p.length; i++) {
      const dt = tool.t[i] - tool.t[i - 1];
      if (dt <= 0) continue;
      const d = Math.hypot(...tool.p[i].map((v, c) => v - tool.p[i - 1][c]));
      ts.push((tool.t[i] + tool.t[i - 1]) / 2);
      vs.push(d / dt);
    }
    traces.push({ type: 'scatter', mode: 'lines', name: 'tool speed', x: ts, y: vs, xaxis: 'x', yaxis: 'y2',
      line: { color: '#111', width: 2 }, meta: { role: 'tool-speed' },
      hovertemplate: 'tool: %{y:.3g} m/s<extra>t=%{x:.3f} s</extra>' });
    const shapes = [];
    const annotations = [];
    segs.forEach((sg) => {
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
      const color = COLORS[sg.index % COLORS.length];
      tbody.append(el('tr', { 'data-segment': String(sg.index) },
        el('td', {}, el('span', { class: 'swatch', style: `background:${color}` }), String(sg.index + 1)),
        el('td', {}, sg.type + (d.skipped ? ' (skipped)' : '')),
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

  // ---------------------------------------------------------------- wiring
  function wire() {
    document.querySelectorAll('#form-tabs button').forEach((b) =>
      b.addEventListener('click', () => showFormTab(b.dataset.tab)));
    document.querySelectorAll('#view-tabs button').forEach((b) =>
      b.addEventListener('click', () => showView(b.dataset.view)));
    document.querySelectorAll('button.png').forEach((b) => b.addEventListener('click', () => {
      const div = $(b.dataset.plot);
      if (!div.data) return;
      Plotly.downloadImage(div, { format: 'png', filename: `${robotName()}-${b.dataset.plot}`,
        width: div.clientWidth, height: div.clientHeight, scale: 2 });
    }));
    $('download-compare').addEventListener('click', () => {
      if (state.compareDownload) saveText(state.compareDownload.filename, state.compareDownload.text);
    });
    $('robot').addEventListener('change', (e) => {
      $('c-preset').value = '';
      $('p-preset').value = '';
      selectRobot(e.target.value);
    });
    const presets = $('c-preset');
    PRESETS.forEach((p) => presets.append(el('option', { value: p.id }, p.label)));
    presets.addEventListener('change', (e) => applyPreset(e.target.value));
    document.querySelectorAll('input[name="c-goal-kind"], input[name="c-timing"]').forEach((n) =>
      n.addEventListener('change', syncCartesian));
    document.querySelectorAll('input[name="j-timing"]').forEach((n) =>
      n.addEventListener('change', syncJointTiming));
    $('s-times').addEventListener('change', syncSplineTimes);
    $('j-profile').addEventListener('change', syncJointTiming);
    $('j-zoom-limits').addEventListener('change', () => { if (lastJoints) renderJoints(...lastJoints); });
    $('cmp-log').addEventListener('change', () => { if (lastCompare) renderCompareplot(...lastCompare); });
    $('dev-log').addEventListener('change', () => { if (lastDeviation) renderDeviation(...lastDeviation); });
    $('p-focus').addEventListener('change', () => { if (lastProgramPath) renderProgramPath(...lastProgramPath); });
    $('show-geometry').addEventListener('change', () => {
      if (lastPath) renderPath(...lastPath);
      if (lastProgramPath) renderProgramPath(...lastProgramPath);
    });
    $('s-add').addEventListener('click', () => {
      const rows = $('s-table').rows.length - 1;
      const last = jointValues(`s-wp-${rows - 1}`);
      const lastT = num(`s-t-${rows - 1}`) || 0;
      addWaypointRow(last.map((v) => (Number.isFinite(v) ? v + 0.2 : 0)), lastT + 1.5);
      syncSplineTimes();
    });
    $('s-remove').addEventListener('click', () => {
      const table = $('s-table');
      if (table.rows.length > 3) table.deleteRow(table.rows.length - 1);
    });
    $('c-pose-from-goal').addEventListener('click', async () => {
      const a = await fk(jointValues('c-goal'));
      if (a) setPose(a.pose);
      state.ikGhosts = [];
      $('c-ik-list').hidden = true;
    });
    $('form-cartesian').addEventListener('submit', (e) => { e.preventDefault(); runCartesian(); });
    $('form-joint').addEventListener('submit', (e) => { e.preventDefault(); runJoint('joint'); });
    $('form-spline').addEventListener('submit', (e) => { e.preventDefault(); runJoint('spline'); });
    $('form-program').addEventListener('submit', (e) => { e.preventDefault(); runProgram(); });
    ['ptp', 'lin', 'circ'].forEach((t) => $(`p-add-${t}`).addEventListener('click', () => addSegment(t)));
    const pp = $('p-preset');
    PROGRAM_PRESETS.forEach((x) => pp.append(el('option', { value: x.id }, x.label)));
    pp.addEventListener('change', (e) => applyProgramPreset(e.target.value));
    $('c-compare').addEventListener('click', () => runCompare());
    $('c-ik-all').addEventListener('click', () => ikAll());
    $('c-joints').addEventListener('change', () => { state.ikGhosts = []; updateConfigs(); });
    $('env-add-box').addEventListener('click', () => addObstacle('box'));
    $('env-add-sphere').addEventListener('click', () => addObstacle('sphere'));
    wireArmBars();
    renderObstacles();
    syncCartesian();
  }

  async function main() {
    document.body.dataset.state = 'busy';
    wire();
    ['plot-path', 'plot-deviation', 'plot-sigma'].forEach((d) =>
      placeholder(d, 'Plan a Cartesian line to see the tool path, deviation and σ'));
    placeholder('plot-joints', 'Plan a motion to see its joints');
    placeholder('plot-compare', 'Compare methods to see their deviation curves');
    placeholder('plot-program-path', 'Run a program (Program tab) to see its tool path');
    placeholder('plot-program-speed', 'Run a program to see where it slows down');
    try {
      await loadRobots();
    } finally {
      document.body.dataset.state = 'ready';
    }
  }

  if (typeof Plotly === 'undefined') {
    document.addEventListener('DOMContentLoaded', () => setStatus('error',
      'Plotly did not load from /static/plotly.min.js: install the Python plotly package.'));
  } else {
    main();
  }
}());
