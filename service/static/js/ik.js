/**
 * "every IK solution of this pose": ``POST /v1/robots/{name}/ik`` with ``"all": true`` for the
 * Cartesian form's goal pose; each solution's label listed, drawn as a dotted ghost arm (their FK
 * and the start's in one request), and "use as goal joints" makes it the goal.
 */

import { api, fkMany, framePoints, problemOf } from './api.js';
import { formPose, jointValues, syncCartesian, updateConfigs } from './cartesian_form.js';
import { renderPath } from './cartesian_view.js';
import { $, el, fmt, round6 } from './dom.js';
import { robotName, setIkGhosts } from './state.js';
import { showRequest } from './status.js';
import { showView } from './tabs.js';

function useSolution(sol) {
  sol.positions.forEach((v, j) => { $(`c-goal-${j}`).value = round6(v); });
  $('c-goal-joints').checked = true;
  syncCartesian();
  updateConfigs(false);
}

export async function ikAll() {
  const pose = formPose();
  const path = `/v1/robots/${encodeURIComponent(robotName())}/ik`;
  const start = jointValues('c-start');
  const req = { pose: pose, seed: start, all: true };
  showRequest('POST', path, req);
  const box = $('c-ik-list');
  box.hidden = false;
  box.textContent = 'solving …';
  const res = await api('POST', path, req);
  box.textContent = '';
  if (!res.ok) {
    const problem = problemOf(res);
    box.append(el('p', { class: 'muted' }, `${problem.code || res.status}: ${problem.detail || ''}`));
    setIkGhosts([]);
    return;
  }
  const sols = res.json.solutions || [];
  box.append(el('p', { class: 'muted', id: 'c-ik-count' },
    `${sols.length} solution(s), ${res.json.solver} solver, nearest the start joints first:`));
  sols.forEach((sol, k) => box.append(el('div', { class: 'ik-row', 'data-configuration': sol.configuration || '' },
    el('code', { title: sol.positions.map((v) => fmt(v, 4)).join(', ') }, sol.configuration || `solution ${k + 1}`),
    el('button', { type: 'button', class: 'small', id: `c-ik-use-${k}`,
      onclick: () => useSolution(sol) }, 'use as goal joints'))));
  const arms = await fkMany([start, ...sols.map((s) => s.positions)], { frames: true });
  const startFk = arms[0];
  setIkGhosts(arms.slice(1).map((a, k) => ({ label: sols[k].configuration || `solution ${k + 1}`,
    pts: framePoints(a) })).filter((g) => g.pts));
  if (!startFk) return;
  showView('cartesian');
  renderPath({ p0: startFk.pose.position, p1: pose.position, at: () => pose.position,
    project: () => null, pts: [startFk.pose.position, pose.position], shape: 'line',
    startFk: startFk, goalFk: null }, null, [], null, null);
}

export function wireIk() {
  $('c-ik-all').addEventListener('click', () => ikAll());
}
