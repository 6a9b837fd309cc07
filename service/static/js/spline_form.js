/**
 * The spline form (``POST /v1/trajectories/spline``): waypoints (add, remove), optional times, the
 * boundary conditions (the service's list) and limits.
 */

import { $, el, fillSelect, num, numberInput } from './dom.js';
import { jointValues, offsetHome } from './cartesian_form.js';
import { enumAt } from './schema.js';
import { robot, robotName } from './state.js';
import { withEnvironment } from './workcell.js';

export function fillSplineChoices() {
  fillSelect($('s-boundary'), enumAt('/v1/trajectories/spline', 'boundary'), 'clamped');
}

function addWaypointRow(wp, t) {
  const table = $('s-table');
  const i = table.rows.length - 1;
  const row = el('tr', { class: 'wp' }, el('th', {}, String(i + 1)),
    el('td', { class: 'time-col' }, numberInput(`s-t-${i}`, t)));
  wp.forEach((v, j) => row.append(el('td', {}, numberInput(`s-wp-${i}-${j}`, v))));
  table.append(row);
}

function syncSplineTimes() {
  const on = $('s-times').checked;
  document.querySelectorAll('#s-table .time-col').forEach((n) => { n.hidden = !on; });
}

export function buildSplineForm(waypoints) {
  const r = robot();
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

export function splineRequest() {
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

export function wireSplineForm() {
  $('s-times').addEventListener('change', syncSplineTimes);
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
}
