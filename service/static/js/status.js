/**
 * The result bar and the panels above the plots: busy state (``<body data-state>`` is "busy" while
 * a request runs, "done" after; ``<body data-run>`` counts finished runs, for people and for the
 * browser test alike), the status line, the last request, downloads, the problem box, the summary
 * of the diagnostics and the list of warnings.
 */

import { $, el, fmt, saveText } from './dom.js';
import { isPlanar, robot } from './state.js';

let runs = 0;

export function setStatus(kind, text) {
  const node = $('status');
  node.className = `status ${kind}`;
  node.textContent = text;
}

export function busy(message) {
  document.body.dataset.state = 'busy';
  setStatus('busy', message);
  document.querySelectorAll('.plan-form button').forEach((b) => { b.disabled = true; });
}

export function done() {
  runs += 1;
  document.body.dataset.run = String(runs);
  document.body.dataset.state = 'done';
  document.querySelectorAll('.plan-form button').forEach((b) => { b.disabled = false; });
}

/** A bug of this page (not an answer of the service): say so instead of leaving a stale view. */
export function pageError(e) {
  console.error(e);
  setStatus('error', `The page failed to draw the answer: ${e && e.message ? e.message : e}`);
}

/** The status line of a plan's answer: code, time, points and duration. */
export function answerStatus(res, path, body, problem, extra) {
  setStatus(res.ok ? 'ok' : 'error', res.ok
    ? `POST ${path} → ${res.status} in ${Math.round(res.ms)} ms · ${body.points.length} points over ` +
      `${fmt(body.diagnostics.duration)} s${extra || ''}`
    : `POST ${path} → ${res.status} ${problem.code || ''} in ${Math.round(res.ms)} ms`);
}

export function showRequest(method, path, body) {
  $('request-json').textContent = `${method} ${path}\n${JSON.stringify(body, null, 2)}`;
}

/** Download buttons of the last answer(s): [{label, filename, text}]. */
export function setDownloads(items) {
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

/** The problem box: code, title, detail, where on the path (s), other members, field errors. */
export function renderProblem(problem, where, note) {
  const box = $('problem');
  box.textContent = '';
  if (!problem) {
    box.hidden = true;
    return;
  }
  box.hidden = false;
  box.className = note && note.partial ? 'problem partial' : 'problem';
  const s = problem.s;
  box.append(el('div', { class: 'problem-head' },
    el('span', { class: 'code', id: 'problem-code' }, problem.code || 'error'),
    el('strong', {}, problem.title || 'Request failed'),
    problem.status ? el('span', { class: 'muted' }, `HTTP ${problem.status}`) : null,
    where ? el('span', { class: 'muted' }, where) : null));
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

const known = (v) => v !== undefined && v !== null;

function summaryItems(d) {
  const r = robot();
  const items = [
    ['method', d.method],
    ['duration', known(d.duration) ? `${fmt(d.duration)} s` : undefined],
    ['compute', known(d.compute_time_ms) ? `${fmt(d.compute_time_ms, 3)} ms` : undefined],
    ['fraction', d.fraction],
    ['max position deviation', known(d.max_position_deviation) ? `${fmt(d.max_position_deviation, 3)} m` : undefined],
    ['max orientation deviation', known(d.max_orientation_deviation) && !isPlanar() ? `${fmt(d.max_orientation_deviation, 3)} rad` : undefined],
    ['min singular value', d.min_singular_value],
    ['knots', d.knot_count],
  ];
  if (r && Array.isArray(d.peak_velocity) && d.peak_velocity.length === r.dof) {
    const vr = Math.max(...d.peak_velocity.map((v, j) => Math.abs(v) / r.limits.velocity[j]));
    const ar = Math.max(...d.peak_acceleration.map((v, j) => Math.abs(v) / r.limits.acceleration[j]));
    items.push(['peak |v| / limit', `${(100 * vr).toFixed(1)} %`]);
    items.push(['peak |a| / limit', `${(100 * ar).toFixed(1)} %`]);
  }
  if (known(d.min_clearance)) {
    items.push(['min clearance', `${fmt(d.min_clearance, 3)} m`]);
    if (d.closest && Array.isArray(d.closest.links)) {
      items.push(['closest', `${d.closest.links.join(' – ')} at t=${fmt(d.closest.time_from_start, 3)} s`]);
    }
  }
  if (Array.isArray(d.peak_jerk) && d.peak_jerk.length) {
    items.push(['peak |jerk|', `${fmt(Math.max(...d.peak_jerk.map(Math.abs)), 4)} rad/s³`]);
  }
  return items;
}

/** The key figures of an answer's diagnostics (and ``extra`` [key, value] pairs), all of them
 * under "all diagnostics". */
export function renderSummary(body, extra) {
  const box = $('summary');
  box.textContent = '';
  if (!body) {
    box.hidden = true;
    return;
  }
  const d = body.diagnostics || {};
  const items = summaryItems(d);
  items.splice(2, 0, ['points', body.points ? body.points.length : undefined]);
  (extra || []).forEach((e) => items.push(e));
  items.filter(([, v]) => known(v)).forEach(([k, v]) => {
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
export function addConfigurations(start, goal) {
  const anchor = $('summary-end');
  if (!anchor) return;
  [['start configuration', start, 'summary-config-start'], ['goal configuration', goal, 'summary-config-goal']]
    .forEach(([k, v, id]) => {
      if (!v) return;
      anchor.before(el('div', { class: 'kv', id: id }, el('span', { class: 'k' }, k),
        el('span', { class: 'v' }, v)));
    });
}

export function renderWarnings(marks) {
  const list = $('warnings');
  list.textContent = '';
  const warns = marks.filter((m) => m.kind === 'warning');
  warns.forEach((m) => list.append(el('li', {},
    el('span', { class: 'tag' }, m.label),
    m.s !== null ? el('span', { class: 'at' }, `s = ${fmt(m.s, 3)}`) : null,
    ` ${m.message}`)));
  list.hidden = !warns.length;
}
