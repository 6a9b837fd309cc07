/**
 * Joint moves and splines (``POST /v1/trajectories/joint`` and ``/spline``): every joint against
 * time (Joints view), the clearance when a work cell was sent, and the tool path with the arm in
 * the Cartesian view (one batched FK request). A 422 ``collision`` draws the same plan without
 * the environment (the motion that was checked) with the first contact marked.
 */

import { api, problemOf } from './api.js';
import { renderPath } from './cartesian_view.js';
import { renderClearance } from './clearance.js';
import { jointRequest } from './joint_form.js';
import { renderJoints } from './joints_plot.js';
import { marksOf, placeholder } from './plot.js';
import { robot, robotName } from './state.js';
import { splineRequest } from './spline_form.js';
import { addConfigurations, answerStatus, busy, done, pageError, renderProblem, renderSummary,
  renderWarnings, setDownloads, showRequest } from './status.js';
import { showView } from './tabs.js';
import { fkGroups, MAX_TOOL_POINTS, subsample, toolPathOf } from './toolpath.js';

/** The robot's limits with the request's own lists where it sent them. */
export function limitsOf(req) {
  const limits = Object.assign({}, robot().limits);
  if (req.limits) {
    const own = (list, fallback) => list.map((v, j) => (Number.isFinite(v) ? v : fallback[j]));
    limits.velocity = own(req.limits.velocity, limits.velocity);
    limits.acceleration = own(req.limits.acceleration, limits.acceleration);
    if (Array.isArray(req.limits.jerk)) limits.jerk = req.limits.jerk;
  }
  return limits;
}

/**
 * The tool path of a joint-space motion in the Cartesian view, from one FK request for the drawn
 * points and the ``extraRows`` (their answers go to ``extraItems(answers, tool)``, which returns
 * more scene items: the waypoints of a collision-free motion). Returns the tool path.
 */
export async function drawJointMotion(body, problem, extraRows, extraItems) {
  const idx = subsample(body.points.length, MAX_TOOL_POINTS);
  const [answers, extra] = await fkGroups([idx.map((i) => body.points[i].positions),
    extraRows || []], true);
  const tool = toolPathOf(body, idx, answers, null);
  tool.s = tool.s.map(() => null);
  renderPath(null, tool, [], null, problem, extraItems ? extraItems(extra, tool) : []);
  addConfigurations(tool.config[0], tool.config[tool.config.length - 1]);
  return tool;
}

/** The deviation and σ plots of the Cartesian view have nothing to show for a joint motion. */
export function noDeviation() {
  ['plot-deviation', 'plot-sigma'].forEach((d) =>
    placeholder(d, 'Plan a Cartesian line to see the deviation and σ'));
}

function knotsOf(req, body, isSpline) {
  const times = req.times || (body.diagnostics && body.diagnostics.knot_times);
  const wps = isSpline ? req.waypoints : [req.start.positions, req.goal.positions];
  const ts = times || (isSpline ? null : [0, body.diagnostics.duration]);
  if (!ts || ts.length !== wps.length) return null;
  return wps.map((q, i) => ({ t: ts[i], positions: q, label: `waypoint ${i + 1}`,
    kind: isSpline ? 'waypoints' : 'start / goal' }));
}

export async function runJoint(kind) {
  const isSpline = kind === 'spline';
  const req = isSpline ? splineRequest() : jointRequest();
  const path = isSpline ? '/v1/trajectories/spline' : '/v1/trajectories/joint';
  showRequest('POST', path, req);
  busy(`Planning ${isSpline ? 'spline' : req.profile} …`);
  showView('joints');
  try {
    const res = await api('POST', path, req);
    const name = `${robotName()}-${isSpline ? `spline-${req.boundary}` : req.profile}`;
    setDownloads([{ label: 'Download JSON', filename: `${name}.json`, text: res.text }]);
    let body = res.ok ? res.json : null;
    const problem = res.ok ? null : problemOf(res);
    let note = null;
    if (problem && problem.code === 'collision' && req.environment) {
      // The checked motion itself: the same request without the environment (public API).
      const free = Object.assign({}, req);
      delete free.environment;
      const again = await api('POST', path, free);
      if (again.ok) {
        body = again.json;
        note = { text: 'Drawn below: the same plan without the environment (the motion that was ' +
          'checked), with the first contact marked on the tool path (Cartesian view).' };
      }
    }
    renderProblem(problem, `POST ${path}`, note);
    answerStatus(res, path, body, problem);
    renderSummary(body);
    renderWarnings(marksOf(body ? body.diagnostics : null, null));
    renderJoints(body, limitsOf(req), body ? knotsOf(req, body, isSpline) : null,
      problem ? `No trajectory: ${problem.code || 'error'} — ${problem.detail || ''}` : null);
    renderClearance('-joint', body && !problem ? body.diagnostics : null, req);
    noDeviation();
    if (body && req.robot) await drawJointMotion(body, problem);
    else placeholder('plot-path', 'No trajectory to draw');
  } catch (e) {
    pageError(e);
  } finally {
    done();
  }
}
