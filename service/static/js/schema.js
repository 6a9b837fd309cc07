/**
 * The service's own lists, read from ``/openapi.json`` (the schemas' enums come from the service's
 * registries), so the page offers what this service accepts and nothing written here by hand:
 * Cartesian methods, path shapes, speed profiles, joint profiles, spline boundaries, program segment
 * types and their options, the collision-free endpoint when it is served.
 */

import { api, setMaxFkRows } from './api.js';

let doc = { paths: {}, components: { schemas: {} } };

/** Fetch ``/openapi.json`` once (at start); the lists below are empty if it fails. */
export async function loadSchema() {
  const res = await api('GET', '/openapi.json');
  if (res.ok && res.json && res.json.paths) doc = res.json;
  setMaxFkRows(rowBound());
  return res.ok;
}

function resolve(node) {
  let n = node;
  for (let i = 0; n && n.$ref && i < 20; i++) {
    n = n.$ref.replace(/^#\//, '').split('/').reduce((o, k) => (o ? o[k] : undefined), doc);
  }
  return n || {};
}

const members = (node) => [].concat(node.anyOf || [], node.oneOf || [], node.allOf || []).map(resolve);

/** Property ``name`` of an object schema (through ``allOf``/``anyOf``/``oneOf``), or null. */
function property(node, name) {
  const n = resolve(node);
  if (n.properties && n.properties[name]) return resolve(n.properties[name]);
  for (const m of members(n)) {
    const found = property(m, name);
    if (found) return found;
  }
  return null;
}

/** Every value a schema allows when it is a set of strings (``enum``, ``const``, unions). */
function valuesOf(node) {
  if (!node) return [];
  const n = resolve(node);
  if (Array.isArray(n.enum)) return n.enum.filter((v) => v !== null);
  if (n.const !== undefined) return [n.const];
  if (n.type === 'array' && n.items) return valuesOf(n.items);
  const out = [];
  members(n).forEach((m) => valuesOf(m).forEach((v) => { if (!out.includes(v)) out.push(v); }));
  return out;
}

/** Whether the service serves ``POST path``. */
export const hasPath = (path) => Boolean(doc.paths[path] && doc.paths[path].post);

/** The JSON request body schema of ``POST path`` ({} when not served). */
export function requestSchema(path) {
  const op = doc.paths[path] && doc.paths[path].post;
  const content = op && op.requestBody && op.requestBody.content;
  return content && content['application/json'] ? resolve(content['application/json'].schema) : {};
}

/** The allowed values of the field ``props`` (a chain of names) of ``POST path``'s body. */
export function enumAt(path, ...props) {
  let node = requestSchema(path);
  for (const p of props) {
    node = property(node, p);
    if (!node) return [];
  }
  return valuesOf(node);
}

/** Program segment schemas by type (the ``segments`` items' discriminator): {ptp: {...}, ...}. */
export function segmentSchemas() {
  const seg = property(requestSchema('/v1/trajectories/program'), 'segments');
  if (!seg || !seg.items) return {};
  const items = resolve(seg.items);
  const out = {};
  members(items).forEach((m) => {
    const type = valuesOf(property(m, 'type'))[0];
    if (type) out[type] = m;
  });
  return out;
}

/** The allowed values of field ``name`` of a ``type`` segment (``[]`` when it has none). */
export function segmentEnum(type, name) {
  const schema = segmentSchemas()[type];
  return schema ? valuesOf(property(schema, name)) : [];
}

/** Whether a ``type`` segment (or, with ``type`` null, the program body) has field ``name``. */
export function programHas(type, name) {
  const schema = type ? segmentSchemas()[type] : requestSchema('/v1/trajectories/program');
  return Boolean(schema && property(schema, name));
}

/** The most rows one FK request takes (``positions`` as rows), from the FK request schema. */
export function rowBound() {
  const positions = property(requestSchema('/v1/robots/{name}/fk'), 'positions');
  let most = null;
  if (positions) {
    members(positions).forEach((m) => {
      if (m.type === 'array' && m.items && resolve(m.items).type === 'array') most = m.maxItems;
    });
  }
  return most;
}

/** The documented default of the field ``props`` of ``POST path``'s body (undefined if none). */
export function defaultAt(path, ...props) {
  let node = requestSchema(path);
  for (const p of props.slice(0, -1)) {
    node = property(node, p);
    if (!node) return undefined;
  }
  const name = props[props.length - 1];
  const raw = resolve(node).properties && resolve(node).properties[name];
  if (raw && raw.default !== undefined) return raw.default;
  const field = property(node, name);
  return field ? field.default : undefined;
}
