/**
 * The work cell panel: obstacles (boxes and spheres) and a clearance, sent as ``environment`` with
 * every plan request once an obstacle is added (none is sent without obstacles).
 */

import { $, el, num, numberInput, round6 } from './dom.js';
import { toolMid } from './state.js';

const obstacles = []; // [{name, type: 'box' | 'sphere', position: [x, y, z], size: [..3] | radius}]
let count = 0;

/** The obstacles as the panel holds them (read-only for the scene). */
export const workcellObstacles = () => obstacles;

/** The request's ``environment``, or undefined without obstacles. */
export function environment() {
  if (!obstacles.length) return undefined;
  const env = {
    obstacles: obstacles.map((o) => ({ name: o.name,
      shape: o.type === 'box' ? { type: 'box', size: o.size } : { type: 'sphere', radius: o.radius },
      pose: { position: o.position, orientation: [0, 0, 0, 1] } })),
  };
  const clearance = num('env-clearance');
  if (clearance !== undefined && clearance > 0) env.clearance = clearance;
  return env;
}

/** ``req`` with the work cell's ``environment`` when there is one. */
export function withEnvironment(req) {
  const env = environment();
  if (env) req.environment = env;
  return req;
}

/** Add an obstacle: ``at`` (default: the middle of the last tool path), ``size`` per type. */
export function addObstacle(type, at, size) {
  count += 1;
  const where = (at || toolMid() || [0.4, 0, 0.3]).map(round6);
  obstacles.push(type === 'box'
    ? { name: `box${count}`, type: 'box', position: where, size: size || [0.1, 0.1, 0.1] }
    : { name: `sphere${count}`, type: 'sphere', position: where, radius: size || 0.05 });
  renderObstacles();
}

/** Remove every obstacle (a preset that brings its own). */
export function clearObstacles() {
  obstacles.splice(0, obstacles.length);
  renderObstacles();
}

function numberCell(get, set, id, attrs) {
  const input = numberInput(id, get(), attrs);
  input.addEventListener('change', () => { set(Number(input.value)); });
  return input;
}

export function renderObstacles() {
  const table = $('env-table');
  table.textContent = '';
  if (obstacles.length) {
    table.append(el('tr', {}, ['name', 'x', 'y', 'z', 'size [m]', ''].map((h) => el('th', {}, h))));
  }
  obstacles.forEach((o, i) => {
    const name = el('input', { type: 'text', value: o.name, id: `env-name-${i}`, size: 7 });
    name.addEventListener('change', () => { o.name = name.value; });
    const sizes = o.type === 'box'
      ? el('div', { class: 'triple' }, [0, 1, 2].map((c) => numberCell(() => o.size[c],
        (v) => { o.size[c] = v; }, `env-size-${i}-${c}`, { title: `${['x', 'y', 'z'][c]} edge` })))
      : numberCell(() => o.radius, (v) => { o.radius = v; }, `env-radius-${i}`);
    table.append(el('tr', { 'data-obstacle': o.name }, el('td', {}, name),
      [0, 1, 2].map((c) => el('td', {},
        numberCell(() => o.position[c], (v) => { o.position[c] = v; }, `env-pos-${i}-${c}`))),
      el('td', {}, sizes),
      el('td', {}, el('button', { type: 'button', class: 'small', title: 'remove',
        onclick: () => { obstacles.splice(i, 1); renderObstacles(); } }, '✕'))));
  });
  $('env-note').textContent = obstacles.length
    ? `${obstacles.length} obstacle(s): every plan request carries this environment (a box is an axis-aligned box about its centre).`
    : 'No obstacles: requests carry no environment.';
}

export function wireWorkcell() {
  $('env-add-box').addEventListener('click', () => addObstacle('box'));
  $('env-add-sphere').addEventListener('click', () => addObstacle('sphere'));
  renderObstacles();
}
