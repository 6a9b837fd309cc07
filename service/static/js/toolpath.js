/**
 * Tool paths from trajectory answers: which returned points to draw, their forward kinematics in
 * one batched request (``fkGroups``: several lists of rows, one ``POST .../fk``), the path
 * parameter s of each, and the ideal path (a line, or a ``circ`` arc) a Cartesian plan follows.
 */

import { fkMany, framePoints } from './api.js';
import { arcOf } from './shapes.js';

export const MAX_TOOL_POINTS = 100; // returned points drawn per trajectory (evenly spread)

/** Indices of at most ``most`` of ``n`` points, evenly spread, first and last included. */
export function subsample(n, most) {
  if (n <= most) return Array.from({ length: n }, (_, i) => i);
  const idx = new Set();
  for (let k = 0; k < most; k++) idx.add(Math.round((k * (n - 1)) / (most - 1)));
  return Array.from(idx).sort((a, b) => a - b);
}

/**
 * FK of several lists of joint rows in one request: ``[[answer | null, ...], ...]`` per list.
 * ``frames``: every link frame too (to draw the arm).
 */
export async function fkGroups(groups, frames) {
  const rows = [].concat(...groups);
  const answers = await fkMany(rows, { frames: frames });
  const out = [];
  let k = 0;
  groups.forEach((g) => { out.push(answers.slice(k, k + g.length)); k += g.length; });
  return out;
}

/** s at each time, from the deviation profile's (time_from_start, s) pairs; null without one. */
export function sOfTime(profile) {
  if (!profile || !profile.time_from_start || profile.time_from_start.length < 2) return null;
  const ts = profile.time_from_start;
  const ss = profile.s;
  return (t) => {
    if (t <= ts[0]) return ss[0];
    if (t >= ts[ts.length - 1]) return ss[ss.length - 1];
    let lo = 0;
    let hi = ts.length - 1;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (ts[mid] <= t) lo = mid; else hi = mid;
    }
    const u = (t - ts[lo]) / (ts[hi] - ts[lo] || 1);
    return ss[lo] + u * (ss[hi] - ss[lo]);
  };
}

/**
 * The tool path of ``body`` at point indices ``idx``, from their FK answers ``answers`` (same
 * order): positions ``p``, times ``t``, path parameters ``s`` (from the deviation profile, else
 * projected on ``ideal``), smallest singular values, arm polylines, configuration labels, and the
 * first point's link frames.
 */
export function toolPathOf(body, idx, answers, ideal) {
  const sAt = sOfTime((body.diagnostics || {}).deviation_profile);
  const out = { p: [], t: [], s: [], sigma: [], arm: [], config: [], frames: [] };
  idx.forEach((i, k) => {
    const a = answers[k];
    if (!a) return;
    const p = a.pose.position;
    const t = body.points[i].time_from_start;
    let s = sAt ? sAt(t) : null;
    if (s === null && ideal) s = ideal.project(p);
    out.p.push(p); out.t.push(t); out.s.push(s); out.sigma.push(a.min_singular_value);
    out.arm.push(framePoints(a)); out.config.push(a.configuration || null);
    if (out.frames.length === 0) out.frames.push(a.frames || null); // the first point's frames
  });
  return out;
}

const dist = (a, b) => Math.hypot(...a.map((v, i) => v - b[i]));

/**
 * The ideal path of a Cartesian request from FK(start) ``startFk`` to the goal (``goalFk``: FK of
 * goal joints, or null for a pose goal): {p0, p1, at(s), project(p), pts, startFk, goalFk}.
 * A ``circ`` path is the arc through ``path.interim`` or about ``path.center``.
 */
export function idealPath(req, startFk, goalFk) {
  if (!startFk || (req.goal.positions && !goalFk)) return null;
  const p0 = startFk.pose.position;
  const p1 = goalFk ? goalFk.pose.position : req.goal.pose.position;
  const path = req.path || { type: 'line' };
  const arc = path.type === 'circ' ? arcOf(p0, p1, path) : null;
  let at = (s) => p0.map((v, i) => v + s * (p1[i] - v));
  let project = (p) => {
    const d = p1.map((v, c) => v - p0[c]);
    const dd = d.reduce((acc, v) => acc + v * v, 0);
    return dd > 1e-18 ? d.reduce((acc, v, c) => acc + v * (p[c] - p0[c]), 0) / dd : null;
  };
  let pts = [p0, p1];
  if (arc) {
    at = arc.at;
    pts = Array.from({ length: 61 }, (_, k) => arc.at(k / 60));
    project = (p) => { // nearest of the drawn points: enough to place a hover label
      let best = 0;
      pts.forEach((q, k) => { if (dist(p, q) < dist(p, pts[best])) best = k; });
      return best / 60;
    };
  }
  return { p0: p0, p1: p1, at: at, project: project, pts: pts, shape: arc ? 'circ' : 'line',
    startFk: startFk, goalFk: goalFk && goalFk.frames ? goalFk : null };
}
