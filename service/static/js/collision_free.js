/**
 * The collision-free mode of the joint move form: ``POST /v1/trajectories/collision_free`` (API.md
 * "Collision-free motions") with the form's start, goal and limits and the work cell's obstacles.
 * Drawn: the motion in the Cartesian view (tool path, the found waypoints as markers joined by a
 * dashed line with a faint arm at each, the obstacles, the arm moving along the motion under the
 * slider and ▶ play), every joint against time with the waypoints marked, the clearance, and the
 * planner's figures in the summary. A start or goal in collision is drawn with its arm in red.
 */

import { api, framePoints, problemOf } from './api.js';
import { redrawPath } from './cartesian_view.js';
import { renderClearance } from './clearance.js';
import { fmt } from './dom.js';
import { COLLISION_FREE, collisionFreeRequest } from './joint_form.js';
import { drawJointMotion, limitsOf, noDeviation } from './joint_view.js';
import { renderJoints } from './joints_plot.js';
import { COLORS, FAIL_COLOR, marksOf } from './plot.js';
import { armItem, drawScene, geometryItems, obstacleItems } from './scene.js';
import { isPlanar, robotName } from './state.js';
import { answerStatus, busy, done, pageError, renderProblem, renderSummary, renderWarnings,
  setDownloads, showRequest } from './status.js';
import { showView } from './tabs.js';
import { fkGroups } from './toolpath.js';

const WAYPOINT_COLOR = '#db2777';

/**
 * Scene items of a motion's waypoints from their FK ``answers``: the tool at each waypoint (markers
 * joined by a dashed line) and a faint arm at each interior one. ``label`` names them.
 */
export function waypointItems(answers, label) {
  const found = answers.filter(Boolean);
  if (!found.length) return [];
  const dims = isPlanar() ? 2 : 3;
  const items = [{ name: `${label || 'waypoints'} (${found.length})`, pts: found.map((a) => a.pose.position),
    meta: { role: 'waypoints', count: found.length },
    style: { mode: 'lines+markers', line: { color: WAYPOINT_COLOR, width: 2, dash: 'dash' },
      marker: { size: dims === 3 ? 4 : 8, symbol: 'circle-open', color: WAYPOINT_COLOR },
      text: found.map((_, k) => `waypoint ${k + 1}`), hovertemplate: '%{text}<extra></extra>' } }];
  found.slice(1, -1).forEach((a, k) => {
    const pts = framePoints(a);
    if (pts) {
      items.push(armItem(`arm at waypoint ${k + 2}`, pts, { opacity: 0.3, showlegend: k === 0,
        legendgroup: 'waypoint-arms', line: { color: WAYPOINT_COLOR, width: 3 },
        marker: { size: 2, color: WAYPOINT_COLOR } }, { role: 'waypoint-arm', index: k + 1 }));
    }
  });
  return items;
}

/** The waypoints as knots of the joint plots, each at the time the motion passes nearest it. */
function waypointKnots(body, wps) {
  return wps.map((w, k) => {
    let best = 0;
    let bestD = Infinity;
    body.points.forEach((p, i) => {
      const d = p.positions.reduce((acc, v, j) => acc + (v - w[j]) ** 2, 0);
      if (d < bestD) { bestD = d; best = i; }
    });
    return { t: body.points[best].time_from_start, positions: w, label: `waypoint ${k + 1}`,
      kind: 'waypoints' };
  });
}

function plannerFacts(body) {
  const d = (body && body.diagnostics) || {};
  const p = d.planner || {};
  return [
    ['planner', p.name ? `${p.name} (seed ${p.seed})` : undefined],
    ['iterations', p.iterations],
    ['waypoints', Array.isArray(body && body.waypoints) ? body.waypoints.length : undefined],
    ['path length', d.path_length !== undefined
      ? `${fmt(d.path_length, 4)} rad (${fmt(d.path_length_ratio, 3)}× the straight segment)` : undefined],
    ['certified', d.certified === undefined ? undefined : (d.certified ? 'yes' : 'no')],
  ];
}

/** No motion: the arm at the start and at the goal among the obstacles, the one in collision red. */
async function drawEnds(req, problem) {
  const [[a, b]] = await fkGroups([[req.start.positions, req.goal.positions]], true);
  const items = [];
  [['start', a, COLORS[2]], ['goal', b, '#111']].forEach(([which, fk, color]) => {
    const pts = framePoints(fk);
    if (!pts) return;
    const hit = problem && problem.at === which;
    const c = hit ? FAIL_COLOR : color;
    items.push(armItem(`arm at ${which}${hit ? ' (in collision)' : ''}`, pts,
      { line: { color: c, width: 7 }, marker: { size: 3, color: c } },
      { role: 'arm', which: which, configuration: fk.configuration || null, collides: hit }));
  });
  if (a) items.push(...geometryItems(a.frames, 'collision geometry at start', 'show-geometry'));
  items.push(...obstacleItems());
  if (items.length) drawScene('plot-path', items, null, `${robotName()}-collision-free`);
  redrawPath(() => drawEnds(req, problem)); // the geometry toggle draws this scene again
}

export async function runCollisionFree() {
  const req = collisionFreeRequest();
  const path = COLLISION_FREE;
  showRequest('POST', path, req);
  busy('Searching a collision-free motion …');
  showView('cartesian');
  try {
    const res = await api('POST', path, req);
    setDownloads([{ label: 'Download JSON', filename: `${robotName()}-collision-free.json`, text: res.text }]);
    const body = res.ok ? res.json : null;
    const problem = res.ok ? null : problemOf(res);
    renderProblem(problem, `POST ${path}`);
    const wps = body && Array.isArray(body.waypoints) ? body.waypoints : [];
    answerStatus(res, path, body, problem, body ? ` · ${wps.length} waypoints` : '');
    renderSummary(body, plannerFacts(body));
    renderWarnings(marksOf(body ? body.diagnostics : null, null));
    noDeviation();
    renderClearance('-joint', body ? body.diagnostics : null, req);
    if (body) {
      renderJoints(body, limitsOf(req), waypointKnots(body, wps), null);
      await drawJointMotion(body, null, wps, (answers) => waypointItems(answers));
    } else {
      renderJoints(null, limitsOf(req), null,
        `No motion: ${problem.code || 'error'} — ${problem.detail || ''}`);
      await drawEnds(req, problem);
    }
  } catch (e) {
    pageError(e);
  } finally {
    done();
  }
}
