/**
 * The joint move form (``POST /v1/trajectories/joint``): profile, start, goal, a duration or the
 * limits (jerk limits for ``jerk_limited``). With "collision-free" ticked (shown only when the
 * service serves ``POST /v1/trajectories/collision_free``) the same start and goal go to that
 * endpoint instead, with the work cell, its timing law, a seed and a planning time.
 */

import { $, checked, el, fillSelect, num, numberInput } from './dom.js';
import { jointValues, limitHint, offsetHome } from './cartesian_form.js';
import { defaultAt, enumAt, hasPath } from './schema.js';
import { robot, robotName } from './state.js';
import { withEnvironment } from './workcell.js';

export const COLLISION_FREE = '/v1/trajectories/collision_free';

/** The robot's jerk limit of joint j (where the maker publishes none: 20 times a max). */
function robotJerk(j) {
  const r = robot();
  const jerk = r.limits.jerk;
  return Array.isArray(jerk) && Number.isFinite(jerk[j]) ? jerk[j] : 20 * r.limits.acceleration[j];
}

/** Whether the collision-free mode is on (and offered by this service). */
export const collisionFree = () => hasPath(COLLISION_FREE) && $('j-collision-free').checked;

/** The profiles and the collision-free mode's timing laws, from the service's schema. */
export function fillJointChoices() {
  fillSelect($('j-profile'), enumAt('/v1/trajectories/joint', 'profile'), 'quintic');
  $('j-cf-row').hidden = !hasPath(COLLISION_FREE);
  fillSelect($('j-cf-timing'), enumAt(COLLISION_FREE, 'timing'), defaultAt(COLLISION_FREE, 'timing'));
}

export function syncJointTiming() {
  const free = collisionFree();
  const jerk = free ? $('j-cf-timing').value === 'jerk_limited' : $('j-profile').value === 'jerk_limited';
  const limits = free || checked('j-timing') === 'limits';
  $('j-profile-row').hidden = free;
  $('j-timing-row').hidden = free;
  $('j-cf-box').hidden = !free;
  $('j-duration-box').hidden = limits;
  $('j-plan').textContent = free ? 'Plan collision-free motion' : 'Plan joint move';
  document.querySelectorAll('#j-table input.limit').forEach((n) => { n.disabled = !limits && !jerk; });
  document.querySelectorAll('#j-table .jerk-col').forEach((n) => { n.hidden = !jerk; });
}

export function buildJointForm(start, goal) {
  const r = robot();
  const table = $('j-table');
  table.textContent = '';
  table.append(el('tr', {}, el('th', {}, 'joint'), el('th', {}, 'start'), el('th', {}, 'goal'),
    el('th', {}, 'v max'), el('th', {}, 'a max'), el('th', { class: 'jerk-col' }, 'j max')));
  const q0 = start || r.home;
  const q1 = goal || offsetHome([0.6, -0.4, 0.5]);
  r.joint_names.forEach((name, j) => {
    table.append(el('tr', {}, el('th', { title: `${name} ${limitHint(j)}` }, name),
      el('td', {}, numberInput(`j-start-${j}`, q0[j])),
      el('td', {}, numberInput(`j-goal-${j}`, q1[j])),
      el('td', {}, numberInput(`j-vmax-${j}`, r.limits.velocity[j], { class: 'limit' })),
      el('td', {}, numberInput(`j-amax-${j}`, r.limits.acceleration[j], { class: 'limit' })),
      el('td', { class: 'jerk-col' }, numberInput(`j-jmax-${j}`, robotJerk(j), { class: 'jerk' }))));
  });
  syncJointTiming();
}

export function jointRequest() {
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

/** The collision-free request (API.md "Collision-free motions") of the form and the work cell. */
export function collisionFreeRequest() {
  const req = {
    robot: robotName(),
    start: { positions: jointValues('j-start') },
    goal: { positions: jointValues('j-goal') },
    limits: { velocity: jointValues('j-vmax'), acceleration: jointValues('j-amax') },
  };
  const timing = $('j-cf-timing').value;
  if (timing && timing !== defaultAt(COLLISION_FREE, 'timing')) req.timing = timing;
  if (timing === 'jerk_limited') req.limits.jerk = jointValues('j-jmax');
  const seed = num('j-cf-seed');
  if (seed !== undefined) req.seed = seed;
  const budget = num('j-cf-time');
  if (budget !== undefined) req.max_planning_time = budget;
  const period = num('j-period');
  if (period !== undefined) req.sample_period = period;
  return withEnvironment(req);
}

export function wireJointForm() {
  document.querySelectorAll('input[name="j-timing"]').forEach((n) =>
    n.addEventListener('change', syncJointTiming));
  ['j-profile', 'j-collision-free', 'j-cf-timing'].forEach((id) =>
    $(id).addEventListener('change', syncJointTiming));
}
