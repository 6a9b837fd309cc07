/**
 * The HTTP layer: every request of the page goes through ``api`` (JSON in, JSON or problem+json
 * out, never a throw), and forward kinematics through ``fkMany``: one ``POST
 * /v1/robots/{name}/fk`` with ``"positions": [[...], ...]`` for any number of rows (chunked at
 * the schema's row bound), answers cached per robot and joint values, so a drawn tool path costs
 * one request, and a preset's start computed before is not asked again.
 */

import { robotName } from './state.js';

export async function api(method, path, body) {
  const started = performance.now();
  const init = { method: method, headers: { accept: 'application/json' } };
  if (body !== undefined) {
    init.headers['content-type'] = 'application/json';
    init.body = JSON.stringify(body);
  }
  try {
    const res = await fetch(path, init);
    const text = await res.text();
    let json = null;
    try { json = JSON.parse(text); } catch (e) { json = null; }
    return { ok: res.ok, status: res.status, json: json, text: text, path: path,
      ms: performance.now() - started };
  } catch (e) {
    const problem = { title: 'Network error', code: 'network', status: 0,
      detail: `the service did not answer ${method} ${path}: ${e.message}` };
    return { ok: false, status: 0, json: problem, text: JSON.stringify(problem), path: path,
      ms: performance.now() - started };
  }
}

/** The problem+json body of a failed answer (or one made from its status and text). */
export function problemOf(res) {
  if (res.json && typeof res.json === 'object' && !Array.isArray(res.json)) return res.json;
  return { title: 'HTTP error', status: res.status, detail: res.text.slice(0, 500) };
}

// ---------------------------------------------------------------- forward kinematics, batched
const FK_CACHE_SIZE = 4000;
const cache = new Map(); // `${robot}|${frames}|${q}` -> answer of one row
let maxRows = 1000; // the schema's bound on rows (schema.js sets it from /openapi.json)

export function setMaxFkRows(n) {
  if (Number.isInteger(n) && n > 0) maxRows = n;
}

const keyOf = (robot, frames, q) => `${robot}|${frames ? 1 : 0}|${q.join(',')}`;

function remember(key, answer) {
  if (cache.size >= FK_CACHE_SIZE) cache.delete(cache.keys().next().value);
  cache.set(key, answer);
}

function cached(robot, q, frames) {
  // An answer with the link frames also answers a request without them.
  return cache.get(keyOf(robot, true, q)) || (frames ? undefined : cache.get(keyOf(robot, false, q)));
}

/** One request for ``rows``; on a 422 naming a row (``positions.<k>``), that row is dropped and
 * the rest asked again. Returns answers in order, null for a refused row. */
async function request(robot, rows, frames) {
  const out = new Array(rows.length).fill(null);
  let left = rows.map((q, k) => k);
  while (left.length) {
    const body = { positions: left.map((k) => rows[k]) };
    if (frames) body.frames = true;
    const res = await api('POST', `/v1/robots/${encodeURIComponent(robot)}/fk`, body);
    if (res.ok && res.json && Array.isArray(res.json.results)) {
      res.json.results.forEach((a, i) => { out[left[i]] = a; });
      return out;
    }
    const loc = res.json && Array.isArray(res.json.errors) && res.json.errors[0]
      ? res.json.errors[0].loc || [] : [];
    const bad = loc[1] === 'positions' && Number.isInteger(loc[2]) ? loc[2] : null;
    if (bad === null || left.length < 2) return out;
    left = left.filter((_, i) => i !== bad);
  }
  return out;
}

/**
 * FK of many joint rows of the selected robot: ``[answer | null]`` in order (null for a row with
 * a missing number or refused by the service). ``frames``: with every link frame (to draw the arm).
 * Rows already answered are not asked again; the others go in one request per ``maxRows``.
 */
export async function fkMany(rows, options) {
  const frames = Boolean(options && options.frames);
  const robot = robotName();
  const out = rows.map((q) => (Array.isArray(q) && q.every(Number.isFinite) ? cached(robot, q, frames) : null));
  const missing = [];
  const seen = new Map();
  rows.forEach((q, k) => {
    if (out[k] !== undefined) return;
    const key = keyOf(robot, frames, q);
    if (!seen.has(key)) { seen.set(key, missing.length); missing.push(q); }
  });
  for (let i = 0; i < missing.length; i += maxRows) {
    const chunk = missing.slice(i, i + maxRows);
    const answers = await request(robot, chunk, frames);
    chunk.forEach((q, k) => { if (answers[k]) remember(keyOf(robot, frames, q), answers[k]); });
  }
  return rows.map((q, k) => (out[k] !== undefined ? out[k] : cached(robot, q, frames) || null));
}

/** FK of one joint row (``fkMany`` of one). */
export async function fk(q, frames) {
  return (await fkMany([q], { frames: frames }))[0];
}

export const framePoints = (a) => (a && Array.isArray(a.frames) ? a.frames.map((f) => f.position) : null);
