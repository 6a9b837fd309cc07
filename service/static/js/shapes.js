/**
 * Geometry for the 3D scenes: quaternions, wireframes and point clouds of spheres, boxes,
 * capsules and cylinders, and the circle arc of a ``circ`` path (for the ideal path drawn beside
 * the tool path). Points are [x, y, z]; a null breaks a polyline.
 */

const PI = Math.PI;
const sub = (a, b) => a.map((v, i) => v - b[i]);
const add = (a, b) => a.map((v, i) => v + b[i]);
const scale = (a, k) => a.map((v) => v * k);
const dot = (a, b) => a.reduce((acc, v, i) => acc + v * b[i], 0);
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => Math.sqrt(dot(a, a));

/** Unit quaternion (x, y, z, w) applied to a vector. */
export function rotate(qt, v) {
  const [x, y, z, w] = qt;
  const tx = 2 * (y * v[2] - z * v[1]);
  const ty = 2 * (z * v[0] - x * v[2]);
  const tz = 2 * (x * v[1] - y * v[0]);
  return [v[0] + w * tx + (y * tz - z * ty), v[1] + w * ty + (z * tx - x * tz),
    v[2] + w * tz + (x * ty - y * tx)];
}

/** Quaternion product a * b, both (x, y, z, w). */
export function quatMul(a, b) {
  const [ax, ay, az, aw] = a;
  const [bx, by, bz, bw] = b;
  return [aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
    aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz];
}

/** Three great circles of a sphere, as one polyline with null breaks. */
export function sphereWire(c, r) {
  const pts = [];
  [[0, 1], [0, 2], [1, 2]].forEach(([i, j]) => {
    for (let k = 0; k <= 40; k++) {
      const a = (2 * PI * k) / 40;
      const p = c.slice();
      p[i] += r * Math.cos(a);
      p[j] += r * Math.sin(a);
      pts.push(p);
    }
    pts.push(null);
  });
  return pts;
}

/** Points on a sphere (for a translucent hull, ``alphahull: 0``). */
export function sphereCloud(c, r) {
  const pts = [];
  for (let i = 0; i <= 8; i++) {
    const th = (PI * i) / 8;
    for (let k = 0; k < 16; k++) {
      const ph = (2 * PI * k) / 16;
      pts.push([c[0] + r * Math.sin(th) * Math.cos(ph), c[1] + r * Math.sin(th) * Math.sin(ph),
        c[2] + r * Math.cos(th)]);
    }
  }
  return pts;
}

export function boxCorners(c, size, qt) {
  const out = [];
  [-1, 1].forEach((sx) => [-1, 1].forEach((sy) => [-1, 1].forEach((sz) => {
    const v = rotate(qt || [0, 0, 0, 1], [sx * size[0] / 2, sy * size[1] / 2, sz * size[2] / 2]);
    out.push([c[0] + v[0], c[1] + v[1], c[2] + v[2]]);
  })));
  return out;
}

export function boxWire(corners) {
  const edges = [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5],
    [2, 6], [3, 7]];
  const pts = [];
  edges.forEach(([i, j]) => pts.push(corners[i], corners[j], null));
  return pts;
}

function ring(r, z) {
  const out = [];
  for (let k = 0; k <= 24; k++) {
    const a = (2 * PI * k) / 24;
    out.push([r * Math.cos(a), r * Math.sin(a), z]);
  }
  out.push(null);
  return out;
}

function halfCircle(r, z, sign, axisName) {
  const out = [];
  for (let k = 0; k <= 12; k++) {
    const a = (PI * k) / 12;
    const u = r * Math.cos(a);
    const w = z + sign * r * Math.sin(a);
    out.push(axisName === 'x' ? [u, 0, w] : [0, u, w]);
  }
  out.push(null);
  return out;
}

/** Wireframe of one collision shape in its own frame (capsule and cylinder along local z). */
export function shapeWire(shape) {
  if (shape.type === 'sphere') return sphereWire([0, 0, 0], shape.radius);
  if (shape.type === 'box') return boxWire(boxCorners([0, 0, 0], shape.size));
  if (shape.type === 'capsule' || shape.type === 'cylinder') {
    const r = shape.radius;
    const h = shape.length / 2;
    const pts = ring(r, h).concat(ring(r, -h));
    [0, 1, 2, 3].forEach((k) => {
      const a = (PI * k) / 2;
      pts.push([r * Math.cos(a), r * Math.sin(a), -h], [r * Math.cos(a), r * Math.sin(a), h], null);
    });
    if (shape.type === 'capsule') {
      ['x', 'y'].forEach((ax) => pts.push(...halfCircle(r, h, 1, ax), ...halfCircle(r, -h, -1, ax)));
    }
    return pts;
  }
  return [];
}

/**
 * The arc of a ``circ`` path from ``p0`` to ``p1``: through ``via.interim`` (the arc containing it)
 * or about ``via.center`` (the shorter arc). ``at(s)`` is the point at fraction s of the angle;
 * null when the three points give no circle.
 */
export function arcOf(p0, p1, via) {
  let c;
  let n;
  if (via.interim) {
    const a = sub(via.interim, p0);
    const b = sub(p1, p0);
    n = cross(a, b);
    const nn = dot(n, n);
    if (nn < 1e-18) return null;
    // circumcentre of p0, interim, p1
    c = add(p0, scale(add(scale(cross(n, a), dot(b, b)), scale(cross(b, n), dot(a, a))), 1 / (2 * nn)));
  } else if (via.center) {
    c = via.center;
    n = cross(sub(p0, c), sub(p1, c));
    if (norm(n) < 1e-12) return null;
  } else {
    return null;
  }
  const u = sub(p0, c);
  const r = norm(u);
  const e1 = scale(u, 1 / r);
  const e2 = scale(cross(scale(n, 1 / norm(n)), e1), 1);
  const angleOf = (p) => {
    const v = sub(p, c);
    const a = Math.atan2(dot(v, e2), dot(v, e1));
    return a < 0 ? a + 2 * PI : a;
  };
  // With an interim point the arc runs from p0 through it, in the sense of n: p1's angle.
  const total = angleOf(p1);
  const at = (s) => add(c, add(scale(e1, r * Math.cos(s * total)), scale(e2, r * Math.sin(s * total))));
  return { center: c, radius: r, angle: total, at: at };
}
