/**
 * The program editor (``POST /v1/trajectories/program``): start joints and a list of segments
 * (add, remove, move up and down; goal as a pose or as joints; blend radius on all but the last;
 * CIRC through an interim point or about a centre; speed or velocity scale) and the segment
 * options the service's schema offers (a PTP's profile and ``planner``, a LIN's or CIRC's method
 * and speed profile; a program ``seed``): types and options come from ``/openapi.json``.
 */

import { fk } from './api.js';
import { $, el, fillSelect, num, numberInput, round6 } from './dom.js';
import { COLORS } from './plot.js';
import { enumAt, programHas, segmentEnum, segmentSchemas } from './schema.js';
import { robot, robotName } from './state.js';
import { withEnvironment } from './workcell.js';

const OPTIONS = { ptp: ['profile', 'planner'], lin: ['method', 'speed_profile'],
  circ: ['method', 'speed_profile'] };
let program = []; // the editor's segments (see programSegment)

export const segments = () => program;
export const segmentTypes = () => Object.keys(segmentSchemas());

/** A new editor segment: goal as a pose (lin, circ) or joints (ptp), from ``from``. */
export function programSegment(type, from) {
  return { type: type, goalKind: type === 'ptp' ? 'positions' : 'pose',
    positions: (from && from.positions) || robot().home.slice(),
    pose: from && from.pose ? JSON.parse(JSON.stringify(from.pose)) : null,
    blend: 0, speed: undefined, vscale: undefined, circKind: 'interim', via: null, options: {} };
}

export const programStart = () => robot().joint_names.map((_, j) => num(`p-start-${j}`));

export function setProgramStart(q) {
  q.forEach((v, j) => { $(`p-start-${j}`).value = round6(v); });
}

/** The program-level options of the schema (seed, timing), shown only when offered. */
export function fillProgramChoices() {
  $('p-seed-box').hidden = !programHas(null, 'seed');
  const timings = enumAt('/v1/trajectories/program', 'timing');
  fillSelect($('p-timing'), [''].concat(timings), '');
  $('p-timing-box').hidden = !timings.length;
  ['ptp', 'lin', 'circ'].forEach((t) => {
    const button = $(`p-add-${t}`);
    if (button) button.hidden = !segmentTypes().includes(t);
  });
}

export function buildProgramForm() {
  const r = robot();
  const table = $('p-start');
  table.textContent = '';
  const head = el('tr', {});
  const row = el('tr', {});
  r.joint_names.forEach((name, j) => {
    head.append(el('th', { title: name }, name));
    row.append(el('td', {}, numberInput(`p-start-${j}`, r.home[j])));
  });
  table.append(head, row);
  program = [];
  renderSegments();
}

/** Replace the editor's segments (a preset). */
export function setSegments(list) {
  program = list;
  renderSegments();
}

function segInput(id, value, onchange, attrs) {
  const input = numberInput(id, value, attrs);
  input.addEventListener('change', () => onchange(input.value.trim() === '' ? undefined : Number(input.value)));
  return input;
}

function goalTable(seg, k) {
  if (seg.goalKind === 'pose' && seg.pose) {
    return el('table', { class: 'grid pose' },
      el('tr', {}, ['', 'x', 'y', 'z', 'w'].map((h) => el('th', {}, h))),
      el('tr', {}, el('th', {}, 'position'), [0, 1, 2].map((c) => el('td', {},
        segInput(`p-seg-${k}-p${c}`, seg.pose.position[c], (v) => { seg.pose.position[c] = v; }))), el('td', {})),
      el('tr', {}, el('th', {}, 'quaternion'), [0, 1, 2, 3].map((c) => el('td', {},
        segInput(`p-seg-${k}-q${c}`, seg.pose.orientation[c], (v) => { seg.pose.orientation[c] = v; })))));
  }
  return el('table', { class: 'grid' },
    el('tr', {}, robot().joint_names.map((name) => el('th', { title: name }, name))),
    el('tr', {}, seg.positions.map((v, j) => el('td', {},
      segInput(`p-seg-${k}-q-${j}`, v, (x) => { seg.positions[j] = x; })))));
}

/** Selects of the segment options the schema offers for ``seg.type`` ('' = the default). */
function optionRow(seg, k) {
  const selects = (OPTIONS[seg.type] || []).map((name) => {
    const values = segmentEnum(seg.type, name);
    if (!values.length) return null;
    const select = el('select', { id: `p-seg-${k}-${name}`, 'aria-label': name },
      [''].concat(values).map((v) => el('option', { value: v, selected: (seg.options[name] || '') === v },
        v || `${name.replace('_', ' ')}: default`)));
    select.addEventListener('change', () => {
      if (select.value) seg.options[name] = select.value; else delete seg.options[name];
    });
    return select;
  }).filter(Boolean);
  return selects.length ? el('div', { class: 'row options' }, selects) : null;
}

function segmentHead(seg, k, n) {
  const move = (d) => {
    const j = k + d;
    if (j < 0 || j >= n) return;
    [program[k], program[j]] = [program[j], program[k]];
    renderSegments();
  };
  const type = el('select', { id: `p-seg-${k}-type`, 'aria-label': 'segment type' },
    segmentTypes().map((t) => el('option', { value: t, selected: t === seg.type }, t.toUpperCase())));
  type.addEventListener('change', () => {
    seg.type = type.value;
    seg.options = {};
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
  return el('div', { class: 'seg-head' }, el('strong', {}, String(k + 1)), type, kind,
    el('label', { class: 'inline' }, 'blend r [m]', blend),
    el('span', { class: 'spacer' }),
    el('button', { type: 'button', title: 'move up', onclick: () => move(-1), disabled: k === 0 }, '↑'),
    el('button', { type: 'button', title: 'move down', onclick: () => move(1), disabled: k === n - 1 }, '↓'),
    el('button', { type: 'button', title: 'remove', id: `p-seg-${k}-remove`,
      onclick: () => { program.splice(k, 1); renderSegments(); } }, '✕'));
}

export function renderSegments() {
  const box = $('p-segments');
  box.textContent = '';
  const n = program.length;
  program.forEach((seg, k) => {
    const card = el('div', { class: 'segment', 'data-segment': String(k),
      style: `--seg:${COLORS[k % COLORS.length]}` }, segmentHead(seg, k, n), goalTable(seg, k));
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
    const options = optionRow(seg, k);
    if (options) card.append(options);
    box.append(card);
  });
  if (!n) box.append(el('p', { class: 'muted' }, 'No segments: add one, or pick a preset.'));
}

export async function addSegment(type) {
  const last = program[program.length - 1];
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
  program.push(seg);
  renderSegments();
}

export function programRequest() {
  const n = program.length;
  const list = program.map((seg, k) => {
    const out = { type: seg.type,
      goal: seg.goalKind === 'pose' ? { pose: seg.pose } : { positions: seg.positions } };
    if (seg.type === 'ptp' && seg.vscale !== undefined) out.velocity_scale = seg.vscale;
    if (seg.type !== 'ptp' && seg.speed !== undefined) out.max_linear_speed = seg.speed;
    if (seg.type === 'circ') out[seg.circKind] = seg.via;
    if (k < n - 1 && seg.blend) out.blend_radius = seg.blend;
    Object.entries(seg.options || {}).forEach(([name, v]) => { if (v) out[name] = v; });
    return out;
  });
  const req = { robot: robotName(), start: { positions: programStart() }, segments: list };
  const period = num('p-period');
  if (period !== undefined) req.sample_period = period;
  const seed = num('p-seed');
  if (seed !== undefined && !$('p-seed-box').hidden) req.seed = seed;
  if ($('p-timing').value && !$('p-timing-box').hidden) req.timing = $('p-timing').value;
  if ($('p-partial').checked) req.allow_partial = true;
  return withEnvironment(req);
}

export function wireProgramForm() {
  ['ptp', 'lin', 'circ'].forEach((t) => $(`p-add-${t}`).addEventListener('click', () => addSegment(t)));
}
