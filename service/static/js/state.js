/**
 * What the panels share, behind a small explicit interface (every other piece of state belongs to
 * the module that owns it):
 *   - the selected robot (``GET /v1/robots/{name}``): robot(), setRobot(), onRobot(listener);
 *   - where a new obstacle goes (the middle of the last tool path): toolMid(), setToolMid();
 *   - the IK solutions drawn as ghost arms on the Cartesian tool path: ikGhosts(), setIkGhosts().
 */

let current = null;
const listeners = [];
let mid = null;
let ghosts = [];

/** The selected robot's description, or null before one is loaded. */
export const robot = () => current;
export const robotName = () => (current ? current.name : 'robot');
export const isPlanar = () => Boolean(current && current.task_space === 'position_xy');

/** Select ``description``; every ``onRobot`` listener rebuilds its panel for it, in order. */
export async function setRobot(description) {
  current = description;
  ghosts = [];
  for (const fn of listeners) await fn(description);
}
export function onRobot(listener) {
  listeners.push(listener);
}

export const toolMid = () => mid;
export function setToolMid(point) {
  mid = point;
}

export const ikGhosts = () => ghosts;
export function setIkGhosts(list) {
  ghosts = list;
}
