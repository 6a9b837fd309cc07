/**
 * The 3D scenes (tool paths with the arm): scene items ({name, pts: [[x, y, z] | null], style,
 * meta, mesh?}) drawn in 3D with one scale on every axis, x-y for the planar arm, top and side
 * views without WebGL; the arm as a polyline through its link frames, the robot's collision
 * geometry placed by those frames, the work cell's obstacles, the first contact of a collision;
 * a slider (and ▶ play) moving a copy of the arm along the trajectory.
 */

import { $, fmt } from './dom.js';
import { axis, baseLayout, draw, FAIL_COLOR } from './plot.js';
import { boxCorners, boxWire, quatMul, rotate, shapeWire, sphereCloud, sphereWire } from './shapes.js';
import { isPlanar, robot } from './state.js';
import { workcellObstacles } from './workcell.js';

const ARM_COLOR = '#374151';
const ROBOT_ROLES = /^(arm|collision-geometry|ik-ghost|waypoint-arm)/;
let webgl = null;

function webglAvailable() {
  if (webgl === null) {
    try {
      const c = document.createElement('canvas');
      webgl = Boolean(window.WebGLRenderingContext &&
        (c.getContext('webgl') || c.getContext('experimental-webgl')));
    } catch (e) {
      webgl = false;
    }
  }
  return webgl;
}

export function armItem(name, pts, style, meta) {
  return { name: name, pts: pts, meta: Object.assign({ frames: pts.length }, meta),
    style: Object.assign({ mode: 'lines+markers', line: { color: ARM_COLOR, width: 7 },
      marker: { size: 3, color: ARM_COLOR }, hoverinfo: 'name' }, style || {}) };
}

/** Scene items of the work cell's obstacles (wireframe, and a translucent hull in 3D). */
export function obstacleItems() {
  const items = [];
  workcellObstacles().forEach((o) => {
    const c = o.position;
    const hull = o.type === 'box' ? boxCorners(c, o.size) : sphereCloud(c, o.radius);
    const wire = o.type === 'box' ? boxWire(hull) : sphereWire(c, o.radius);
    items.push({ name: `obstacle ${o.name}`, pts: wire, meta: { role: 'obstacle', name: o.name },
      style: { mode: 'lines', line: { color: '#b45309', width: 3 }, hoverinfo: 'name' } });
    items.push({ name: `${o.name} (solid)`, pts: hull, mesh: true, meta: { role: 'obstacle-solid' },
      style: { alphahull: 0, opacity: 0.25, color: '#f59e0b', showlegend: false, hoverinfo: 'skip' } });
  });
  return items;
}

/**
 * The robot's ``collision_geometry`` (link, shape, origin in the link frame) placed by the link
 * frames of one /fk answer, when the checkbox ``toggle`` is on; none where the robot has none.
 */
export function geometryItems(frames, name, toggle) {
  const r = robot();
  const geo = r && r.collision_geometry;
  if (!Array.isArray(geo) || !geo.length || !Array.isArray(frames) || !$(toggle).checked) return [];
  const byName = new Map(frames.map((f) => [f.name, f]));
  const pts = [];
  let count = 0;
  geo.forEach((g) => {
    const f = byName.get(g.link);
    if (!f || !g.shape) return;
    const o = g.origin || { position: [0, 0, 0], orientation: [0, 0, 0, 1] };
    const r0 = rotate(f.orientation, o.position);
    const centre = [0, 1, 2].map((c) => f.position[c] + r0[c]);
    const q = quatMul(f.orientation, o.orientation);
    shapeWire(g.shape).forEach((v) => {
      if (!v) { pts.push(null); return; }
      const w = rotate(q, v);
      pts.push([centre[0] + w[0], centre[1] + w[1], centre[2] + w[2]]);
    });
    pts.push(null);
    count += 1;
  });
  if (!count) return [];
  return [{ name: name, pts: pts, meta: { role: 'collision-geometry', shapes: count },
    style: { mode: 'lines', line: { color: '#0d9488', width: 2 }, opacity: 0.8, hoverinfo: 'name' } }];
}

/** The first contact of a 422 (or partial) ``collision``: the tool sample nearest its time. */
export function contactItems(failure, tool) {
  if (!failure || failure.code !== 'collision' || !tool || !tool.p.length) return [];
  const t = Number(failure.time_from_start);
  let k = tool.t.length - 1;
  if (Number.isFinite(t)) {
    let best = Infinity;
    tool.t.forEach((tt, i) => { if (Math.abs(tt - t) < best) { best = Math.abs(tt - t); k = i; } });
  }
  const links = Array.isArray(failure.links) ? failure.links.join(' – ') : '';
  const at = failure.s !== undefined && failure.s !== null ? `, s=${fmt(failure.s, 3)}` : '';
  const text = `collision at t=${fmt(t, 4)} s${at}: ${links}, distance ${fmt(failure.distance, 3)} m`;
  const items = [{ name: `✖ collision at t=${fmt(t, 4)} s (${links})`, pts: [tool.p[k]],
    meta: { role: 'collision', time_from_start: t, links: failure.links || null },
    style: { mode: 'markers', text: [text], hovertemplate: '%{text}<extra></extra>',
      marker: { size: 9, symbol: 'x', color: FAIL_COLOR } } }];
  if (tool.arm[k]) {
    items.push(armItem('arm at the contact', tool.arm[k], { line: { color: FAIL_COLOR, width: 6 },
      marker: { size: 3, color: FAIL_COLOR } }, { role: 'arm', which: 'contact' }));
  }
  return items;
}

function sceneLayout(all, dims, flat) {
  const legend = { orientation: 'h', y: -0.02, yanchor: 'top', font: { size: 11 } };
  if (dims === 2) {
    return baseLayout({ xaxis: axis('x [m]'), yaxis: axis('y [m]', { scaleanchor: 'x', scaleratio: 1 }),
      legend: Object.assign({}, legend, { y: -0.1 }), margin: { l: 64, r: 16, t: 16, b: 40 } });
  }
  if (flat) {
    return baseLayout({ grid: { rows: 1, columns: 2, pattern: 'independent' },
      xaxis: axis('x [m] (top view)'), yaxis: axis('y [m]', { scaleanchor: 'x' }),
      xaxis2: axis('x [m] (side view)'), yaxis2: axis('z [m]', { scaleanchor: 'x2' }),
      legend: Object.assign({}, legend, { y: -0.1 }), margin: { l: 64, r: 16, t: 16, b: 40 } });
  }
  const lo = [0, 1, 2].map((c) => Math.min(...all.map((p) => p[c])));
  const hi = [0, 1, 2].map((c) => Math.max(...all.map((p) => p[c])));
  const half = 0.55 * Math.max(1e-3, ...hi.map((v, c) => v - lo[c]));
  const range = (c) => [(lo[c] + hi[c]) / 2 - half, (lo[c] + hi[c]) / 2 + half];
  return baseLayout({
    scene: { aspectmode: 'cube', xaxis: { title: { text: 'x [m]' }, range: range(0) },
      yaxis: { title: { text: 'y [m]' }, range: range(1) },
      zaxis: { title: { text: 'z [m]' }, range: range(2) },
      camera: { eye: { x: 1.5, y: -1.5, z: 1.1 } } },
    legend: legend, margin: { l: 0, r: 0, t: 0, b: 40 } });
}

/**
 * Draw scene ``items`` in ``div``. ``anim`` ({arm: [[pts]], t: [...], config: [...]}) adds the arm
 * moving along the trajectory, driven by the slider under the plot. ``focus``: the view is scaled
 * to the path (everything but the robot's own body: the arm, its collision geometry and ghosts may
 * then reach out of the box).
 */
export function drawScene(div, items, anim, filename, focus) {
  const dims = isPlanar() ? 2 : 3;
  const flat = dims === 3 && !webglAvailable();
  const comps = (pts) => Array.from({ length: 3 }, (_, c) => pts.map((p) => (p ? p[c] : null)));
  const all = [];
  items.filter((it) => !focus || !(it.meta && ROBOT_ROLES.test(it.meta.role || '')))
    .forEach((it) => it.pts.forEach((p) => { if (p) all.push(p); }));
  if (!all.length) items.forEach((it) => it.pts.forEach((p) => { if (p) all.push(p); }));
  if (anim && anim.arm.length) {
    const k = Math.floor((anim.arm.length - 1) / 2);
    items.push(armItem('arm (slider)', anim.arm[k] || [], { opacity: 0.9,
      line: { color: '#7c3aed', width: 7 }, marker: { size: 3, color: '#7c3aed' } },
    { role: 'arm-moving' }));
  }
  const traces = [];
  const moving = [];
  items.forEach((it) => {
    if (it.mesh && (dims === 2 || flat)) return;
    const [x, y, z] = comps(it.pts);
    if (it.mesh) {
      traces.push(Object.assign({ type: 'mesh3d', name: it.name, x: x, y: y, z: z,
        meta: it.meta || null }, it.style));
      return;
    }
    const base = Object.assign({ name: it.name, x: x, y: y, meta: it.meta || null }, it.style);
    if (it.meta && it.meta.role === 'arm-moving') moving.push(traces.length);
    if (dims === 2) { traces.push(Object.assign(base, { type: 'scatter' })); return; }
    if (!flat) { traces.push(Object.assign(base, { type: 'scatter3d', z: z })); return; }
    traces.push(Object.assign({}, base, { type: 'scatter', xaxis: 'x', yaxis: 'y' }));
    if (it.meta && it.meta.role === 'arm-moving') moving.push(traces.length);
    traces.push(Object.assign({}, base, { type: 'scatter', y: z, xaxis: 'x2', yaxis: 'y2',
      showlegend: false }));
  });
  const node = $(div);
  node.armAnim = anim && anim.arm.length ? { arm: anim.arm, t: anim.t, config: anim.config,
    moving: moving, flat: flat, dims: dims } : null;
  const drawn = draw(div, traces, sceneLayout(all, dims, flat), filename);
  setupArmBar(div);
  return drawn;
}

// ---------------------------------------------------------------- the arm slider under a scene
let armTimer = null;

function setupArmBar(div) {
  const bar = document.querySelector(`.arm-bar[data-plot="${div}"]`);
  if (!bar) return;
  const a = $(div).armAnim;
  const slider = bar.querySelector('.arm-slider');
  bar.hidden = !a;
  if (!a) return;
  slider.max = String(a.arm.length - 1);
  slider.value = String(Math.floor((a.arm.length - 1) / 2));
  showArm(div, Number(slider.value));
}

function showArm(div, k) {
  const node = $(div);
  const a = node.armAnim;
  if (!a || !a.arm[k]) return;
  const pts = a.arm[k];
  const xs = pts.map((p) => p[0]);
  const ys = pts.map((p) => p[1]);
  const zs = pts.map((p) => p[2]);
  const bar = document.querySelector(`.arm-bar[data-plot="${div}"]`);
  bar.querySelector('.arm-time').textContent = `t = ${fmt(a.t[k], 4)} s${a.config[k] ? ` · ${a.config[k]}` : ''}`;
  if (!a.moving.length) return;
  if (a.dims === 3 && !a.flat) window.Plotly.restyle(node, { x: [xs], y: [ys], z: [zs] }, a.moving);
  else if (a.flat) window.Plotly.restyle(node, { x: [xs, xs], y: [ys, zs] }, a.moving);
  else window.Plotly.restyle(node, { x: [xs], y: [ys] }, a.moving);
}

/** Play the arm of ``div`` from the start (a second call stops it). */
export function playArm(div) {
  const bar = document.querySelector(`.arm-bar[data-plot="${div}"]`);
  const slider = bar.querySelector('.arm-slider');
  if (armTimer) { clearInterval(armTimer); armTimer = null; return; }
  const a = $(div).armAnim;
  if (!a) return;
  let k = 0;
  armTimer = setInterval(() => {
    slider.value = String(k);
    showArm(div, k);
    k += 1;
    if (k >= a.arm.length) { clearInterval(armTimer); armTimer = null; }
  }, 60);
}

export function wireArmBars() {
  document.querySelectorAll('.arm-bar').forEach((bar) => {
    const div = bar.dataset.plot;
    const slider = bar.querySelector('.arm-slider');
    bar.hidden = true;
    slider.addEventListener('input', () => showArm(div, Number(slider.value)));
    bar.querySelector('.arm-play').addEventListener('click', () => playArm(div));
  });
}
