/**
 * Small DOM and number helpers shared by every panel: element lookup and creation, number inputs,
 * number formatting, a file download.
 */

export const $ = (id) => document.getElementById(id);

/** ``v`` with ``digits`` significant digits (exponent form below 1e-3 and from 1e5); '—' if none. */
export function fmt(v, digits) {
  if (v === null || v === undefined || Number.isNaN(v)) return '—';
  if (typeof v !== 'number') return String(v);
  const d = digits || 4;
  if (v === 0) return '0';
  const a = Math.abs(v);
  if (a < 1e-3 || a >= 1e5) return v.toExponential(d - 2);
  return String(Number(v.toPrecision(d)));
}

export const round6 = (v) => Math.round(v * 1e6) / 1e6;
export const clip = (v, lo, hi) => Math.min(hi, Math.max(lo, v));

/** ``<tag>`` with attributes (``text``, ``class``, ``on<event>`` handlers, others as attributes). */
export function el(tag, attrs, ...children) {
  const node = document.createElement(tag);
  Object.entries(attrs || {}).forEach(([k, v]) => {
    if (v === undefined || v === null || v === false) return;
    if (k === 'text') node.textContent = v;
    else if (k === 'class') node.className = v;
    else if (k.startsWith('on')) node.addEventListener(k.slice(2), v);
    else node.setAttribute(k, v === true ? '' : v);
  });
  children.flat().forEach((c) => {
    if (c !== null && c !== undefined) node.append(c instanceof Node ? c : String(c));
  });
  return node;
}

export const numberInput = (id, value, attrs) =>
  el('input', Object.assign({ type: 'number', step: 'any', id: id,
    value: value === undefined || value === null ? '' : round6(value) }, attrs || {}));

/** The number in input ``id``: undefined when empty; NaN is sent as null (the service names it). */
export function num(id) {
  const node = $(id);
  if (!node || node.value.trim() === '') return undefined;
  return Number(node.value);
}

/** The value of the checked radio button of group ``name``. */
export const checked = (name) => document.querySelector(`input[name="${name}"]:checked`).value;

/** ``<option>``s of ``values`` in ``select`` (its value kept when still offered, else ``preferred``). */
export function fillSelect(select, values, preferred) {
  const keep = select.value;
  select.textContent = '';
  values.forEach((v) => select.append(el('option', { value: v }, v)));
  if (values.includes(keep)) select.value = keep;
  else if (values.includes(preferred)) select.value = preferred;
}

export function saveText(filename, text) {
  const url = URL.createObjectURL(new Blob([text], { type: 'application/json' }));
  const a = el('a', { href: url, download: filename });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 1000);
}
