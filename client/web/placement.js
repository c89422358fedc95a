// Placing lights (docs/browser-client.md "Placing lights"): the geometry behind framing the view
// on the lights, the arrows at the edge of the view pointing at lights outside it, a spot cone's
// footprint in the image, and the schematic's orthographic top, side and front views.
// Pure: no DOM, so that node can import it (tests/web/placement.test.mjs).

import { V } from "./linalg.js";

// ---- framing ------------------------------------------------------------------------------------

/**
 * The zoom and pan (viewport pixels; screen = pan + image * zoom, as viewport.js) that show every
 * image point of `points` ({x, y} in image pixels) inside a viewport of vw x vh pixels less the
 * margins {left, top, right, bottom}, centred in what remains. The zoom stays in [minZoom,
 * maxZoom]; at the least zoom the points may still overflow (the edge arrows show those).
 */
export function fitView(points, vw, vh, margins, { minZoom = 0.05, maxZoom = 32 } = {}) {
  let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
  for (const p of points) {
    x0 = Math.min(x0, p.x); x1 = Math.max(x1, p.x);
    y0 = Math.min(y0, p.y); y1 = Math.max(y1, p.y);
  }
  const aw = Math.max(1, vw - margins.left - margins.right), ah = Math.max(1, vh - margins.top - margins.bottom);
  const zoom = Math.min(maxZoom, Math.max(minZoom, Math.min(aw / Math.max(x1 - x0, 1e-6), ah / Math.max(y1 - y0, 1e-6))));
  return {
    zoom,
    panX: Math.round(margins.left + (aw - (x1 - x0) * zoom) / 2 - x0 * zoom),
    panY: Math.round(margins.top + (ah - (y1 - y0) * zoom) / 2 - y0 * zoom),
  };
}

/** Whether screen point p lies inside the vw x vh viewport inset by `inset` pixels. */
export const insideView = (p, vw, vh, inset) => p.x >= inset && p.y >= inset && p.x <= vw - inset && p.y <= vh - inset;

/**
 * Where an arrow at the edge of a vw x vh viewport (inset by `inset`) points at a light outside
 * it: for a light in front of the camera, `to` is its screen point and the arrow stands at the
 * nearest point of the inset edge (so it shares the light's height on a side edge); for one
 * behind the camera, `to` is null and `dir` its direction on the screen (its camera-space right
 * and down components), and the arrow stands where the ray from the centre along it leaves.
 * Returns {x, y, angle}, angle in radians from +x towards +y (screen, y down).
 */
export function edgeArrow(vw, vh, inset, to, dir = null) {
  const cx = vw / 2, cy = vh / 2;
  if (to) {
    const x = Math.min(vw - inset, Math.max(inset, to.x)), y = Math.min(vh - inset, Math.max(inset, to.y));
    return { x, y, angle: Math.atan2(to.y - y, to.x - x) };
  }
  const [dx, dy] = dir;
  const tx = dx > 0 ? (vw - inset - cx) / dx : dx < 0 ? (inset - cx) / dx : Infinity;
  const ty = dy > 0 ? (vh - inset - cy) / dy : dy < 0 ? (inset - cy) / dy : Infinity;
  const t = Math.min(tx, ty);
  if (!Number.isFinite(t)) return { x: cx, y: vh - inset, angle: Math.PI / 2 };
  return { x: cx + dx * t, y: cy + dy * t, angle: Math.atan2(dy, dx) };
}

// ---- a cone's footprint -------------------------------------------------------------------------

/**
 * Where the ray o + t d (t > 0) enters the axis-aligned box [minx, miny, minz, maxx, maxy, maxz]
 * (slabs, Kay and Kajiya 1986): {t, axis, sign} with the entered face's outward normal along
 * `axis` with `sign`; null when it misses or starts inside (a light inside an object's box has no
 * face in front of it to stand for the surface).
 */
export function rayBox(o, d, box) {
  let tEnter = -Infinity, tExit = Infinity, axis = -1, sign = 0;
  for (let k = 0; k < 3; k++) {
    const lo = box[k], hi = box[3 + k];
    if (Math.abs(d[k]) < 1e-12) {
      if (o[k] < lo || o[k] > hi) return null;
      continue;
    }
    // The face the ray enters on this axis is the one its direction points away from; taking it by
    // the direction's sign (not by comparing the two t) keeps it right for a flat box (lo = hi,
    // a ground plane or a table top baked as one sheet).
    const up = d[k] > 0;
    const t0 = ((up ? lo : hi) - o[k]) / d[k], t1 = ((up ? hi : lo) - o[k]) / d[k];
    if (t0 > tEnter) { tEnter = t0; axis = k; sign = up ? -1 : 1; }
    tExit = Math.min(tExit, t1);
  }
  if (axis < 0 || tEnter > tExit || tEnter <= 0) return null;
  return { t: tEnter, axis, sign };
}

/**
 * The plane a cone's footprint is drawn on: the face of the first object box (the session's
 * objectBounds) that the axis o + t d (d unit) enters and that can hold the footprint, else the
 * ground, the horizontal plane through the scene's lowest point (`bounds`), when the axis points
 * down, else the first face it enters at all. The footprint's radius at t is r0 + g t (a spot:
 * r0 = 0, g = tan(coneAngle)); a face narrower, in its smaller direction, than that radius
 * cannot hold it: the beam spills past it (a small object in front of the table it stands on) and
 * most of its light lands behind. {point, normal, t, object} (object: the box's index, -1 for
 * the ground); null when nothing is in front.
 */
export function footprintPlane(o, d, objectBounds, bounds, { r0 = 0, g = 0 } = {}) {
  const hits = [];
  (objectBounds ?? []).forEach((box, i) => {
    const hit = box ? rayBox(o, d, box) : null;
    if (hit) hits.push({ ...hit, box, object: i });
  });
  hits.sort((p, q) => p.t - q.t);
  const plane = (hit) => {
    const normal = [0, 0, 0];
    normal[hit.axis] = hit.sign;
    return { point: V.add(o, V.scale(d, hit.t)), normal, t: hit.t, object: hit.object };
  };
  for (const hit of hits) {
    const [a, b] = [0, 1, 2].filter((k) => k !== hit.axis);
    if (Math.min(hit.box[3 + a] - hit.box[a], hit.box[3 + b] - hit.box[b]) >= r0 + g * hit.t) return plane(hit);
  }
  if (bounds && d[1] < -1e-6) {
    const t = (bounds[1] - o[1]) / d[1];
    if (t > 0) return { point: V.add(o, V.scale(d, t)), normal: [0, 1, 0], t, object: -1 };
  }
  return hits.length ? plane(hits[0]) : null;
}

/** Two unit vectors completing unit u to an orthonormal frame. */
export function perpendiculars(u) {
  const a = Math.abs(u[1]) < 0.9 ? [0, 1, 0] : [1, 0, 0];
  const v = V.norm(V.cross(u, a));
  return [v, V.cross(u, v)];
}

/**
 * The outline where a cone meets `plane` ({point, normal}): the cone's edge is the rays
 * o + r0 e + t (u + g e), t >= 0, for the unit directions e about the unit axis u (v, w span
 * them): a spot light's cone has r0 = 0 and g = tan(coneAngle); a BendyLight's straight
 * extension past its last control point starts at the last radius r0 and widens by g per unit
 * along it (docs/lighting.md "The tube"). Returns `n` world points, null where an edge ray meets
 * the plane behind its start or farther than `maxT` along the axis (a cone that opens past the
 * plane's horizon has no closed footprint): the caller draws the runs between nulls.
 */
export function coneFootprint(o, u, v, w, r0, g, plane, { n = 64, maxT = Infinity } = {}) {
  const out = [];
  for (let i = 0; i < n; i++) {
    const a = (2 * Math.PI * i) / n;
    const e = V.add(V.scale(v, Math.cos(a)), V.scale(w, Math.sin(a)));
    const start = V.add(o, V.scale(e, r0));
    const dir = V.add(u, V.scale(e, g));
    const dn = V.dot(dir, plane.normal);
    const t = Math.abs(dn) < 1e-9 ? -1 : V.dot(V.sub(plane.point, start), plane.normal) / dn;
    out.push(t > 0 && t <= maxT ? V.add(start, V.scale(dir, t)) : null);
  }
  return out;
}

/** The runs of consecutive non-null points of a closed outline (one closed run when none is null). */
export function outlineRuns(points) {
  const n = points.length;
  if (points.every(Boolean)) return [{ points: [...points, points[0]], closed: true }];
  const first = points.findIndex((p) => !p);
  if (first < 0) return [];
  const runs = [];
  let run = [];
  for (let k = 1; k <= n; k++) {
    const p = points[(first + k) % n];
    if (p) run.push(p);
    else { if (run.length > 1) runs.push({ points: run, closed: false }); run = []; }
  }
  return runs;
}

// ---- orthographic schematic views ---------------------------------------------------------------

/**
 * The schematic's views: a world point's two screen axes (world component and sign; screen y
 * points down) and the component the view does not show. Top looks down -Y (x right, z down),
 * side looks from +X along -X (-z right, y up), front looks from +Z along -Z (x right, y up), so
 * that the top view sits above the front view and the side view to its right, as in a drawing.
 */
export const VIEWS = {
  top: { label: "Top", axes: [0, 2], signs: [1, 1], depth: 1 },
  side: { label: "Side", axes: [2, 1], signs: [-1, -1], depth: 0 },
  front: { label: "Front", axes: [0, 1], signs: [1, -1], depth: 2 },
};
export const AXIS_NAMES = ["x", "y", "z"];

/** A world point in a view's coordinates [h, v] (world units; v grows down the screen). */
export const toView = (view, p) => [view.signs[0] * p[view.axes[0]], view.signs[1] * p[view.axes[1]]];

/** The world point at view coordinates `hv` whose third component (the view's depth) is `p`'s. */
export function fromView(view, hv, p) {
  const q = p.slice();
  q[view.axes[0]] = view.signs[0] * hv[0];
  q[view.axes[1]] = view.signs[1] * hv[1];
  return q;
}

/**
 * The map from view coordinates to a w x h canvas that shows the view points `pts` ([h, v])
 * whole, `pad` pixels from the edges, centred, with one scale for both axes: {scale, ox, oy}
 * with screen = o + hv * scale.
 */
export function fitMap(pts, w, h, pad) {
  let h0 = Infinity, v0 = Infinity, h1 = -Infinity, v1 = -Infinity;
  for (const [a, b] of pts) { h0 = Math.min(h0, a); h1 = Math.max(h1, a); v0 = Math.min(v0, b); v1 = Math.max(v1, b); }
  if (!Number.isFinite(h0)) { h0 = v0 = -1; h1 = v1 = 1; }
  // A single point or a line still gets an area of a scene unit around it.
  const span = Math.max(h1 - h0, v1 - v0, 1e-3);
  const dh = Math.max(h1 - h0, span * 0.25), dv = Math.max(v1 - v0, span * 0.25);
  const scale = Math.min((w - 2 * pad) / dh, (h - 2 * pad) / dv);
  return { scale, ox: w / 2 - ((h0 + h1) / 2) * scale, oy: h / 2 - ((v0 + v1) / 2) * scale };
}

/**
 * Whether an existing map still suits `pts`: all inside the canvas less `pad`, and filling at
 * least `fill` of it in one direction. Keeping it spares the view a jump after every edit.
 */
export function mapStillFits(map, pts, w, h, pad, fill = 0.5) {
  if (!map) return false;
  let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
  for (const [a, b] of pts) {
    const x = map.ox + a * map.scale, y = map.oy + b * map.scale;
    x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y);
  }
  if (!Number.isFinite(x0)) return true;
  if (x0 < pad / 2 || y0 < pad / 2 || x1 > w - pad / 2 || y1 > h - pad / 2) return false;
  return (x1 - x0) >= fill * (w - 2 * pad) || (y1 - y0) >= fill * (h - 2 * pad);
}

/** A "nice" grid step (1, 2 or 5 times a power of ten) near span / lines. */
export function gridStep(span, lines = 8) {
  const raw = Math.max(span, 1e-9) / lines;
  const p = 10 ** Math.floor(Math.log10(raw));
  const m = raw / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}
