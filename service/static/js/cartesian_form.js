/**
 * The Cartesian form (``POST /v1/trajectories/cartesian``): start and goal joints or a goal pose,
 * the method, the path shape (line, or an arc through an interim point or about a centre), the
 * tolerances, tool speeds or a duration, the speed profile, and the configuration labels of the
 * start and goal joints. Methods, shapes and profiles are the service's (``schema.js``).
 */

import { fkMany } from './api.js';
import { $, checked, clip, el, fillSelect, fmt, num, numberInput, round6 } from './dom.js';
import { defaultAt, enumAt } from './schema.js';
import { robot, robotName, setIkGhosts } from './state.js';
import { withEnvironment } from './workcell.js';

const PATH = '/v1/trajectories/cartesian';
export const RATE_METHODS = ['resolved_rate', 'resolved_rate_dls'];

export const jointValues = (prefix) => robot().joint_names.map((_, j) => num(`${prefix}-${j}`));

/** The robot's home moved by ``delta`` (cycled over the joints), kept 5 % inside the limits. */
export function offsetHome(delta) {
  const r = robot();
  return r.home.map((q, j) => {
    const [lo, hi] = r.limits.position[j];
    const margin = 0.05 * (hi - lo);
    return clip(q + delta[j % delta.length], lo + margin, hi - margin);
  });
}

export function limitHint(j) {
  const [lo, hi] = robot().limits.position[j];
  return `[${fmt(lo, 3)}, ${fmt(hi, 3)}]`;
}

/** The service's methods, shapes and profiles in the selects (once the schema is loaded). */
export function fillCartesianChoices() {
  const methods = enumAt(PATH, 'method');
  fillSelect($('c-method'), methods, 'sampled');
  const box = $('c-compare-methods');
  box.textContent = '';
  methods.forEach((m) => box.append(el('label', { class: 'inline' },
    el('input', { type: 'checkbox', value: m, checked: true, name: 'c-compare-method' }), m)));
  fillSelect($('c-path'), enumAt(PATH, 'path', 'type'), 'line');
  $('c-path-row').hidden = $('c-path').options.length < 2;
  fillSelect($('c-speed-profile'), enumAt(PATH, 'speed_profile'), defaultAt(PATH, 'speed_profile'));
  $('c-speed-profile-row').hidden = $('c-speed-profile').options.length < 2;
}

export function buildCartesianForm(start, goal) {
  const r = robot();
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
}

export function setPose(pose) {
  ['c-px', 'c-py', 'c-pz'].forEach((id, i) => { $(id).value = round6(pose.position[i]); });
  ['c-qx', 'c-qy', 'c-qz', 'c-qw'].forEach((id, i) => { $(id).value = round6(pose.orientation[i]); });
}

export function formPose() {
  return {
    position: ['c-px', 'c-py', 'c-pz'].map((id) => num(id) || 0),
    orientation: ['c-qx', 'c-qy', 'c-qz', 'c-qw'].map((id) => num(id) || 0),
  };
}

export function syncCartesian() {
  const pose = checked('c-goal-kind') === 'pose';
  $('c-pose-box').hidden = !pose;
  const duration = checked('c-timing') === 'duration';
  $('c-speeds').hidden = duration;
  $('c-duration-box').hidden = !duration;
  $('c-via-box').hidden = $('c-path').value !== 'circ';
}

/** Start and goal joints' FK in one request: the labels shown, the pose fields (``fillPose``). */
export async function updateConfigs(fillPose) {
  const r = robot();
  const [a, b] = await fkMany([jointValues('c-start'), jointValues('c-goal')]);
  if (fillPose && b) setPose(b.pose);
  if (!r || !(r.configurations || []).length) {
    $('c-configs').textContent = '';
    return;
  }
  $('c-configs').textContent = `configuration: start ${a ? a.configuration : '?'} · goal joints ${b ? b.configuration : '?'}`;
}

/** A first guess of an arc's interim point: off the chord's middle, in the plane of the motion. */
async function suggestVia() {
  if ([0, 1, 2].some((c) => num(`c-via-${c}`) !== undefined)) return;
  const [a, b] = await fkMany([jointValues('c-start'), jointValues('c-goal')]);
  if (!a) return;
  const p0 = a.pose.position;
  const p1 = checked('c-goal-kind') === 'pose' ? formPose().position : (b ? b.pose.position : null);
  if (!p1) return;
  const d = p1.map((v, i) => v - p0[i]);
  const up = Math.abs(d[2]) < 0.9 * Math.hypot(...d) ? [0, 0, 1] : [1, 0, 0];
  const side = [d[1] * up[2] - d[2] * up[1], d[2] * up[0] - d[0] * up[2], d[0] * up[1] - d[1] * up[0]];
  const n = Math.hypot(...side) || 1;
  const k = 0.35 * Math.hypot(...d) / n;
  [0, 1, 2].forEach((c) => { $(`c-via-${c}`).value = round6((p0[c] + p1[c]) / 2 + k * side[c]); });
}

export function cartesianRequest() {
  const req = { robot: robotName(), start: { positions: jointValues('c-start') } };
  req.goal = checked('c-goal-kind') === 'pose' ? { pose: formPose() } : { positions: jointValues('c-goal') };
  req.method = $('c-method').value;
  if ($('c-path').value && $('c-path').value !== 'line') {
    req.path = { type: $('c-path').value };
    req.path[$('c-via-kind').value] = [0, 1, 2].map((c) => num(`c-via-${c}`));
  }
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
  const profile = $('c-speed-profile').value;
  if (profile && profile !== defaultAt(PATH, 'speed_profile')) req.speed_profile = profile;
  const period = num('c-period');
  if (period !== undefined) req.sample_period = period;
  const control = num('c-control');
  if (control !== undefined && RATE_METHODS.includes(req.method)) req.control_period = control;
  if ($('c-partial').checked) req.allow_partial = true;
  return withEnvironment(req);
}

export function wireCartesianForm() {
  document.querySelectorAll('input[name="c-goal-kind"], input[name="c-timing"]').forEach((n) =>
    n.addEventListener('change', syncCartesian));
  $('c-path').addEventListener('change', () => {
    syncCartesian();
    if ($('c-path').value === 'circ') suggestVia();
  });
  $('c-pose-from-goal').addEventListener('click', async () => {
    const [b] = await fkMany([jointValues('c-goal')]);
    if (b) setPose(b.pose);
    setIkGhosts([]);
    $('c-ik-list').hidden = true;
  });
  $('c-joints').addEventListener('change', () => { setIkGhosts([]); updateConfigs(false); });
  syncCartesian();
}
