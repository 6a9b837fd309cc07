/**
 * The robot picker: ``GET /v1/robots`` fills it; selecting a robot loads its description
 * (``GET /v1/robots/{name}``), makes it the shared robot (every panel rebuilds for it through
 * ``state.onRobot``) and asks the FK of the Cartesian form's start and goal, plus ``warm`` rows a
 * preset will need, in one request.
 */

import { api, fkMany, problemOf } from './api.js';
import { jointValues, updateConfigs } from './cartesian_form.js';
import { $, el } from './dom.js';
import { setRobot } from './state.js';
import { renderProblem } from './status.js';

export async function selectRobot(name, warm) {
  const res = await api('GET', `/v1/robots/${encodeURIComponent(name)}`);
  if (!res.ok) {
    renderProblem(problemOf(res), `GET /v1/robots/${name}`);
    return false;
  }
  const r = res.json;
  $('robot').value = name;
  $('robot-info').textContent = `${r.dof} joints · task space ${r.task_space} · ` +
    `${r.base_frame} → ${r.tip_frame}`;
  const hasGeometry = Array.isArray(r.collision_geometry) && r.collision_geometry.length > 0;
  $('geometry-toggle').hidden = !hasGeometry;
  $('p-geometry-toggle').hidden = !hasGeometry;
  await setRobot(r);
  await fkMany([jointValues('c-start'), jointValues('c-goal'), ...(warm || [])]);
  await updateConfigs(true); // answered from the request above: the labels, the goal pose fields
  $('c-ik-list').hidden = true;
  return true;
}

export async function loadRobots() {
  const res = await api('GET', '/v1/robots');
  if (!res.ok) {
    renderProblem(problemOf(res), 'GET /v1/robots');
    return;
  }
  const select = $('robot');
  select.textContent = '';
  res.json.forEach((r) => select.append(el('option', { value: r.name }, r.name)));
  const first = res.json.find((r) => r.name === 'ur5') || res.json[0];
  if (first) await selectRobot(first.name);
}
