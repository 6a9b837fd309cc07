/**
 * Presets: example tasks that fill a form (Cartesian lines, a joint move around an obstacle, motion
 * programs). A preset on another robot selects it first, asking the FK its segments need in the
 * same request as the robot's own (``selectRobot``'s ``warm`` rows).
 */

import { fk } from './api.js';
import { buildCartesianForm, setPose, syncCartesian } from './cartesian_form.js';
import { $, el } from './dom.js';
import { buildJointForm, syncJointTiming } from './joint_form.js';
import { programSegment, setProgramStart, setSegments } from './program_form.js';
import { selectRobot } from './robot.js';
import { hasPath } from './schema.js';
import { robotName } from './state.js';
import { addObstacle, clearObstacles } from './workcell.js';

const PI = Math.PI;
const UR5_HOME = [0, -PI / 3, PI / 2, -2 * PI / 3, -PI / 2, 0];
const PANDA_HOME = [0, -PI / 4, 0, -3 * PI / 4, 0, PI / 2, PI / 4];

/**
 * Joints of the planar 2R arm (links 1.0 m and 0.8 m) with its tool at (x, y) and the elbow label
 * ``label`` as the service gives it (docs/robots.md: ``down`` is q2 in [0, pi], ``up`` q2 < 0).
 */
export function planarJoints(x, y, label) {
  const l1 = 1.0;
  const l2 = 0.8;
  const c = (x * x + y * y - l1 * l1 - l2 * l2) / (2 * l1 * l2);
  const q2 = (label === 'up' ? -1 : 1) * Math.acos(Math.min(1, Math.max(-1, c)));
  return [Math.atan2(y, x) - Math.atan2(l2 * Math.sin(q2), l1 + l2 * Math.cos(q2)), q2];
}

export const PRESETS = [
  { id: 'ur5-line', label: 'UR5: 23 cm line, tool turning 0.29 rad', robot: 'ur5',
    start: UR5_HOME, goal: { positions: [0.3, -1.2, 1.8, -2.2, -1.3, 0.4] }, method: 'sampled',
    speeds: [0.2, 0.8] },
  { id: 'planar-hole', label: 'Planar 2R: line through the unreachable hole (elbow down)',
    robot: 'planar_2r', start: planarJoints(-0.8, 0.05, 'down'), configuration: 'down',
    goal: { pose: { position: [0.8, 0.05, 0], orientation: [0, 0, 0, 1] } }, method: 'sampled' },
  { id: 'puma-through', label: 'PUMA 560: through the wrist singularity', robot: 'puma560',
    start: [0, PI / 4, -PI, 0, 0.3, 0], goal: { positions: [0, PI / 4, -PI, 0, -0.3, 0] },
    method: 'sampled' },
  { id: 'puma-near', label: 'PUMA 560: near the wrist singularity (slow-down)', robot: 'puma560',
    start: [0, PI / 4, -PI, 0.4, 0.1, -0.4], goal: { positions: [0.05, PI / 4, -PI, -0.4, -0.1, 0.4] },
    method: 'sampled' },
  { id: 'panda-line', label: 'Panda: line to a pose', robot: 'panda', start: PANDA_HOME,
    goal: { pose: { position: [0.507, 0.15, 0.39],
      orientation: [0.97047, -0.189358, -0.083476, -0.123949] } }, method: 'sampled' },
  { id: 'ur5-short', label: 'UR5: duration too short (joint_rate_limit)', robot: 'ur5',
    start: UR5_HOME, goal: { positions: [0.3, -1.2, 1.8, -2.2, -1.3, 0.4] }, method: 'sampled',
    duration: 0.1 },
];

export const JOINT_PRESETS = [
  { id: 'ur5-around-ball', label: 'UR5: past a ball (collision-free where served)', robot: 'ur5',
    start: UR5_HOME, goal: [1.2, -1.3, 1.9, -2.2, -1.4, 0.4],
    obstacles: [{ type: 'sphere', position: [-0.423, -0.43, 0.191], size: 0.05 }], clearance: 0.02 },
];

function weld(p0, down) {
  const X = [0.1, 0, 0];
  const Y = [0, 0.12, 0];
  const add = (a, b, f) => a.map((v, i) => v + (f || 1) * b[i]);
  const A = add(p0, X, -1);
  const B = add(p0, X);
  const C = add(B, Y);
  const D = add(A, Y);
  return [B, C, D, A, p0].map((p, k) => ({ type: 'lin', pose: { position: p, orientation: down },
    speed: 0.1, blend: k < 4 ? 0.03 : 0 }));
}

function pickAndPlace(p0, down) {
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
}

function linCircLin(p0, down) {
  const B = [p0[0] + 0.1, p0[1], p0[2]];
  const C = [B[0], B[1] + 0.12, B[2]];
  const via = [B[0] + 0.06, B[1] + 0.06, B[2]];
  return [
    { type: 'lin', pose: { position: B, orientation: down }, speed: 0.1, blend: 0.02 },
    { type: 'circ', pose: { position: C, orientation: down }, speed: 0.1, blend: 0.02, via: via },
    { type: 'lin', pose: { position: [p0[0], p0[1] + 0.12, p0[2]], orientation: down }, speed: 0.1 },
  ];
}

export const PROGRAM_PRESETS = [
  { id: 'ur5-weld', label: 'UR5: weld seam, 4 rounded corners (examples/ur5_weld_seam.py)',
    robot: 'ur5', start: UR5_HOME, period: 0.004, build: weld },
  { id: 'panda-pick', label: 'Panda: pick and place (examples/panda_pick_place.py)', robot: 'panda',
    start: PANDA_HOME, period: 0.005, build: pickAndPlace },
  { id: 'ur5-circ', label: 'UR5: LIN, half circle (CIRC through a point), LIN back', robot: 'ur5',
    start: UR5_HOME, period: 0.005, build: linCircLin },
];

async function onRobot(name, warm) {
  return robotName() === name || selectRobot(name, warm);
}

export async function applyPreset(id) {
  const p = PRESETS.find((x) => x.id === id);
  if (!p || !(await onRobot(p.robot, [p.start]))) return;
  buildCartesianForm(p.start, p.goal.positions || null);
  if (p.goal.pose) {
    $('c-goal-pose').checked = true;
    setPose(p.goal.pose);
  } else {
    $('c-goal-joints').checked = true;
  }
  $('c-method').value = p.method;
  $('c-path').value = 'line';
  document.querySelector(`input[name="c-timing"][value="${p.duration ? 'duration' : 'speeds'}"]`).checked = true;
  if (p.duration) $('c-duration').value = p.duration;
  $('c-vlin').value = p.speeds ? p.speeds[0] : '';
  $('c-vang').value = p.speeds ? p.speeds[1] : '';
  $('c-partial').checked = false;
  syncCartesian();
}

export async function applyJointPreset(id) {
  const p = JOINT_PRESETS.find((x) => x.id === id);
  if (!p || !(await onRobot(p.robot))) return;
  buildJointForm(p.start, p.goal);
  clearObstacles();
  p.obstacles.forEach((o) => addObstacle(o.type, o.position, o.size));
  $('env-clearance').value = p.clearance;
  $('j-collision-free').checked = hasPath('/v1/trajectories/collision_free');
  syncJointTiming();
}

export async function applyProgramPreset(id) {
  const p = PROGRAM_PRESETS.find((x) => x.id === id);
  if (!p || !(await onRobot(p.robot, [p.start]))) return;
  setProgramStart(p.start);
  const a = await fk(p.start); // asked with the robot (or before): no request of its own
  if (!a) return;
  setSegments(p.build(a.pose.position, a.pose.orientation).map((s) => Object.assign(
    programSegment(s.type, null), { goalKind: s.goalKind || 'pose', pose: s.pose, speed: s.speed,
      vscale: s.vscale, blend: s.blend || 0, via: s.via || null })));
  $('p-period').value = p.period;
}

/** Fill the three preset pickers and wire them. */
export function wirePresets() {
  [['c-preset', PRESETS, applyPreset], ['j-preset', JOINT_PRESETS, applyJointPreset],
    ['p-preset', PROGRAM_PRESETS, applyProgramPreset]].forEach(([id, list, apply]) => {
    const select = $(id);
    list.forEach((p) => select.append(el('option', { value: p.id }, p.label)));
    select.addEventListener('change', (e) => apply(e.target.value));
  });
}

