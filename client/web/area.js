// Area lights in the image (docs/browser-client.md "Handles in the image"): the emitter's frame,
// its outline, the resize and roll handles' places and what a drag of each makes of the pointer.
// The frame is lightmath::areaFrame's (server/include/dfb/lightmath/AreaLight.h; docs/lighting.md
// "Area light"): the light frame (rig.js lightFrame: n = uL, up' = vL, right = wL) turned by
// `roll` degrees about n, right_r = right cos + up' sin, up_r = up' cos - right sin.
// Pure: no DOM, so that node can import it (tests/web/).

import { V } from "./linalg.js";
import { lightFrame } from "./rig.js";

/** Vertices of a disk's outline: a regular polygon, close to the ellipse it projects to. */
export const DISK_SEGMENTS = 32;

/**
 * The emitter of area light `l` (pass it evaluated at the session time): centre, unit normal
 * (the emitting side), unit right and up (roll applied), width and height in scene units (a
 * disk: both its diameter, size[0]), and whether it is a disk.
 */
export function areaFrame(l) {
  const f = lightFrame(l);
  const a = ((l.roll ?? 0) * Math.PI) / 180;
  const c = Math.cos(a), s = Math.sin(a);
  const size = l.size ?? [1, 1];
  const disk = l.shape === "disk";
  return {
    centre: l.position, normal: f.uL,
    right: V.add(V.scale(f.wL, c), V.scale(f.vL, s)),
    up: V.sub(V.scale(f.vL, c), V.scale(f.wL, s)),
    width: size[0], height: disk ? size[0] : size[1], disk,
  };
}

/** The world point centre + x right + y up of the emitter's plane. */
export const onPlane = (a, x, y) => V.add(a.centre, V.add(V.scale(a.right, x), V.scale(a.up, y)));

/**
 * The outline in world space: a rectangle's corners (right-up, left-up, left-down, right-down),
 * or a disk's DISK_SEGMENTS rim points from `right` (angle 0) towards `up`.
 */
export function areaOutline(a) {
  if (!a.disk) {
    const x = a.width / 2, y = a.height / 2;
    return [onPlane(a, x, y), onPlane(a, -x, y), onPlane(a, -x, -y), onPlane(a, x, -y)];
  }
  const R = a.width / 2;
  return Array.from({ length: DISK_SEGMENTS }, (_, k) => {
    const t = (2 * Math.PI * k) / DISK_SEGMENTS;
    return onPlane(a, R * Math.cos(t), R * Math.sin(t));
  });
}

/**
 * The handles' world points: `width` (a rectangle's right-edge midpoint: size[0]), `height` (its
 * top-edge midpoint: size[1]), `corner` (its right-up corner: both), `rim` (a disk's rim on
 * `right`: the diameter) and `roll`: on the up axis, `gap` beyond the top edge (below the bottom
 * edge when `flip`), turned about the centre. Missing entries do not apply to the shape.
 */
export function areaHandles(a, gap, flip = false) {
  const x = a.width / 2, y = a.height / 2;
  const roll = onPlane(a, 0, flip ? -(y + gap) : y + gap);
  if (a.disk) return { rim: onPlane(a, x, 0), roll };
  return { width: onPlane(a, x, 0), height: onPlane(a, 0, y), corner: onPlane(a, x, y), roll };
}

/** The emitter plane's point (x, y in its frame) under the ray o + s d, s > 0; null when none. */
export function rayOnPlane(a, o, d) {
  const dn = V.dot(d, a.normal);
  // Within ~3 degrees of edge-on the hit runs away with the pointer: no answer rather than a jump.
  if (Math.abs(dn) < 0.05 * V.len(d)) return null;
  const s = V.dot(V.sub(a.centre, o), a.normal) / dn;
  if (!(s > 0)) return null;
  const q = V.sub(V.add(o, V.scale(d, s)), a.centre);
  return { x: V.dot(q, a.right), y: V.dot(q, a.up) };
}

/**
 * The parameter t of the point centre + t axis (axis unit) nearest to the ray o + s d: where the
 * pointer is along a handle's axis (a gizmo's axis drag). Null when the axis points along the
 * ray (within ~3 degrees): the pointer says nothing about t then.
 */
export function rayOnAxis(centre, axis, o, d) {
  const dd = V.dot(d, d), ad = V.dot(axis, d);
  const w = V.sub(centre, o);
  const denom = dd - ad * ad; // |d|^2 sin^2 of the angle between axis and ray
  if (denom < 0.0025 * dd) return null;
  return (ad * V.dot(d, w) - dd * V.dot(axis, w)) / denom;
}

/**
 * The angle in degrees of the plane point (x, y) measured as roll is: the up axis of the light's
 * frame turned by roll r lies at angle r (atan2(-x, y) in the unturned frame; any fixed turn of
 * the frame shifts every angle alike, so differences are roll differences in any frame).
 */
export const planeAngleDeg = (x, y) => (Math.atan2(-x, y) * 180) / Math.PI;

/** b - a in degrees, wrapped to (-180, 180]: one step of a turn followed across +-180. */
export function angleStep(a, b) {
  let d = (b - a) % 360;
  if (d > 180) d -= 360;
  if (d <= -180) d += 360;
  return d;
}

/** A roll after turning `delta` degrees from `roll0`, brought into the schema's [lo, hi] by whole turns. */
export function turnedRoll(roll0, delta, lo = -360, hi = 360) {
  let r = roll0 + delta;
  while (r > hi) r -= 360;
  while (r < lo) r += 360;
  return Math.min(hi, Math.max(lo, r));
}

// The least 32-bit float at or above x (x > 0).
function floatAtOrAbove(x) {
  const f = new Float32Array([x]);
  if (f[0] < x) new Uint32Array(f.buffer)[0] += 1; // positive floats order as their bits
  return f[0];
}

/**
 * A size component clamped to the schema's [min, max], never zero or less, rounded for the wire.
 * The least size is the least 32-bit float at or above min: the server keeps sizes as floats,
 * and min = 1e-4 itself would be read back as 9.9999997e-5, below the range, so that the rig's
 * GET would no longer PUT back (a whole-rig Add or Delete refused).
 */
export function clampSize(v, min, max) {
  const lo = floatAtOrAbove(Math.max(min ?? 1e-4, 1e-6));
  const r = Number(Math.min(max ?? 1e7, Math.max(lo, v)).toFixed(5));
  return r >= lo ? r : lo;
}

// ---- bent area lights (docs/lighting.md "Bent area light") ----------------------------------

/** Corner c (0..3) of a bent area light's rectangle: (-w/2, -h/2), (+w/2, -h/2), (-w/2, +h/2), (+w/2, +h/2) (Rig.h). */
export const cornerOf = (a, c) => onPlane(a, (c & 1 ? 0.5 : -0.5) * a.width, (c & 2 ? 0.5 : -0.5) * a.height);

/** A corner chain's point (a, b, c') of the emitter's frame (corner + a normal + b up + c' right) in world space. */
export const cornerToWorld = (a, corner, q) =>
  V.add(corner, V.add(V.scale(a.normal, q[0]), V.add(V.scale(a.up, q[1]), V.scale(a.right, q[2]))));

/** The inverse: a world point as (a, b, c') relative to `corner`. */
export const worldToCorner = (a, corner, p) => {
  const d = V.sub(p, corner);
  return [V.dot(d, a.normal), V.dot(d, a.up), V.dot(d, a.right)];
};

/**
 * The four corner chains of bent area light `l` (evaluated) in world space: per corner its points
 * p0..p2K (p0 the corner) and radii r0..r2K, with `cp` the flat index of p[i >= 1] in
 * cornerPoints (c 2K + i - 1) and `r` that of r[i] in cornerRadii (c (2K + 1) + i).
 */
export function cornerChains(l, a) {
  const pts = l.cornerPoints ?? [], radii = l.cornerRadii ?? [];
  const K2 = pts.length / 4;
  if (!Number.isInteger(K2) || K2 < 2) return [];
  return [0, 1, 2, 3].map((c) => {
    const corner = cornerOf(a, c);
    return {
      points: [corner, ...pts.slice(c * K2, (c + 1) * K2).map((q) => cornerToWorld(a, corner, q))],
      radii: radii.slice(c * (K2 + 1), (c + 1) * (K2 + 1)),
      cp: (i) => c * K2 + i - 1,
      r: (i) => c * (K2 + 1) + i,
    };
  });
}
