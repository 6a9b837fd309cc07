/**
 * Plotly helpers every plot uses: colours, layout and axes, drawing into a div, a placeholder,
 * the marks of warnings and failures at their path parameter s.
 */

import { $ } from './dom.js';

export const COLORS = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2',
  '#7f7f7f', '#bcbd22', '#17becf'];
export const FAIL_COLOR = '#d62728';
export const WARN_COLOR = '#e08a00';

export function plotConfig(filename) {
  return { responsive: true, displaylogo: false,
    toImageButtonOptions: { format: 'png', filename: filename, scale: 2 } };
}

export function baseLayout(extra) {
  return Object.assign({
    margin: { l: 64, r: 16, t: 28, b: 44 },
    font: { family: 'system-ui, -apple-system, "Segoe UI", sans-serif', size: 12 },
    paper_bgcolor: '#fff', plot_bgcolor: '#fff',
    hovermode: 'closest',
    legend: { font: { size: 11 } },
  }, extra || {});
}

export function axis(title, extra) {
  return Object.assign({ title: { text: title, standoff: 6 }, zeroline: false,
    gridcolor: '#e6e8eb', linecolor: '#9aa0a6', showline: true, automargin: true }, extra || {});
}

export function draw(div, traces, layout, filename) {
  return window.Plotly.react($(div), traces, layout, plotConfig(filename || div));
}

export function placeholder(div, message) {
  return draw(div, [], baseLayout({
    xaxis: { visible: false }, yaxis: { visible: false },
    annotations: [{ text: message, showarrow: false, xref: 'paper', yref: 'paper', x: 0.5,
      y: 0.5, font: { size: 13, color: '#6b7280' } }],
  }));
}

/** An annotation in the middle of a plot (a message where there is no curve). */
export const centreNote = (text, size) => ({ text: text, showarrow: false, xref: 'paper',
  yref: 'paper', x: 0.5, y: 0.5, font: { size: size || 12, color: '#6b7280' } });

/** [lo, hi] of the finite numbers in ``values``, or null. */
export function extent(values) {
  let lo = Infinity;
  let hi = -Infinity;
  values.forEach((v) => {
    if (v !== null && Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  });
  return lo <= hi ? [lo, hi] : null;
}

export function padded(range) {
  const span = range[1] - range[0] || Math.max(1e-3, Math.abs(range[0]) * 0.1);
  return [range[0] - 0.08 * span, range[1] + 0.08 * span];
}

/** Vertical lines and labels at each marked s: warnings (orange) and the failure (red). */
export function sMarks(marks, yref) {
  const shapes = [];
  const annotations = [];
  marks.forEach((m) => {
    const color = m.color || (m.kind === 'failure' ? FAIL_COLOR : WARN_COLOR);
    if (m.s1 !== undefined && m.s1 > m.s) {
      shapes.push({ type: 'rect', xref: 'x', yref: 'paper', x0: m.s, x1: m.s1, y0: 0, y1: 1,
        fillcolor: color, opacity: 0.08, line: { width: 0 }, layer: 'below' });
    }
    shapes.push({ type: 'line', xref: 'x', yref: 'paper', x0: m.s, x1: m.s, y0: 0, y1: 1,
      line: { color: color, width: m.kind === 'failure' ? 2 : 1.5,
        dash: m.kind === 'failure' ? 'solid' : 'dot' } });
    // Inside the plot, below the mode bar; staggered so labels at nearby s stay readable.
    annotations.push({ x: m.s, xref: 'x', y: 1 - 0.085 * (annotations.length % 5),
      yref: yref || 'paper', yanchor: 'top', xanchor: m.s > 0.8 ? 'right' : 'left',
      xshift: m.s > 0.8 ? -3 : 3, text: m.label, showarrow: false,
      font: { size: 11, color: color }, hovertext: m.message, bgcolor: 'rgba(255,255,255,0.85)' });
  });
  return { shapes: shapes, annotations: annotations };
}

/** Warnings and the failure of a plan, each at its s (parsed from "s=0.123" in the message). */
export function marksOf(diag, problem) {
  const marks = [];
  ((diag && diag.warnings) || []).forEach((w, i) => {
    const found = Array.from(String(w).matchAll(/\bs\s*=\s*(-?\d*\.?\d+(?:e-?\d+)?)/g))
      .map((m) => Number(m[1])).filter((v) => Number.isFinite(v));
    const between = /between s\s*=\s*(-?\d*\.?\d+).*?and s\s*=\s*(-?\d*\.?\d+)/.exec(w);
    const mark = { kind: 'warning', label: `W${i + 1}`, message: w, index: i + 1,
      s: found.length ? found[0] : null };
    if (between) mark.s1 = Number(between[2]);
    marks.push(mark);
  });
  const failure = problem || (diag && diag.failure);
  if (failure && failure.s !== undefined && failure.s !== null) {
    marks.push({ kind: 'failure', label: `✖ ${failure.code || 'failed'}`, s: failure.s,
      message: failure.detail || failure.title || '' });
  }
  return marks;
}
