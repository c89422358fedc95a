// Dragging handles (paper 000 section 5, "Direct Control"): a point moves in the plane parallel to
// the image through its current position (constant NDC depth); with Shift it moves along the
// view ray instead (in depth), so its place in the image stays put. An area light's size handles
// follow the pointer along their axis of the emitter (the axis' point nearest to the pointer's
// ray, as a gizmo's axis drag), its corner and roll handles on the emitter's plane.

import { angleStep, clampSize, cornerOf, planeAngleDeg, rayOnAxis, rayOnPlane, turnedRoll, worldToCorner } from "./area.js";
import { Cam } from "./camera.js";
import { scheduleRefetch } from "./connection.js";
import { $ } from "./dom.js";
import { beginGesture, endGesture, setLightProp, setPresence } from "./edits.js";
import { dragSigns, draggedRotation } from "./envgizmo.js";
import { V } from "./linalg.js";
import { envGizmoOf, handlesOf } from "./overlay.js";
import { lightFrame, rangeOf, worldToFrame } from "./rig.js";
import { S, evaluated, findLight } from "./state.js";
import { eventToImage } from "./viewport.js";

// An area light's handles (overlay.js areaHandlesOf) and the property each drags.
const AREA_HANDLES = { width: "size", height: "size", corner: "size", rim: "size", roll: "roll" };

// The ray from the camera through the pointer: origin on the near plane, direction towards NDC
// depth 0.5 (perspective and orthographic alike).
function pointerRay(e) {
  const p = eventToImage(e);
  const o = Cam.unproject(p.x, p.y, -1);
  return { o, d: V.sub(Cam.unproject(p.x, p.y, 0.5), o) };
}

export function startDrag(e, handle, index) {
  const raw = findLight(S.selected);
  if (!raw) return;
  const l = evaluated(raw);
  if (handle === "envRotation") {
    // An environment light's map turns under its gizmo's centre handle (envgizmo.js).
    const g = envGizmoOf(l.name);
    if (!g) return;
    const rotation0 = (l.rotation ?? [0, 0, 0]).slice();
    S.drag = { handle, index, name: l.name, env: { g, rotation0, signs: dragSigns(Cam, rotation0), x0: e.clientX, y0: e.clientY },
               pointerId: e.pointerId, moved: false };
    $("overlay").setPointerCapture?.(e.pointerId);
    beginGesture();
    setPresence(`${l.name}.rotation`);
    return;
  }
  const h = handlesOf(l);
  const areaProp = h.area ? AREA_HANDLES[handle] : undefined;
  const world = handle === "position" ? h.position : handle === "axis" ? h.axis : areaProp ? h.area.handles[handle]
                : handle === "ccp" ? h.cornerPoints?.[index] : handle === "cr" ? h.cornerCentres?.[index] : h.points[index];
  if (!world) return;
  S.drag = { handle, index, name: l.name, world: world.slice(), ndcZ: Cam.project(world).z, startY: e.clientY, lastY: e.clientY,
             pointerId: e.pointerId, moved: false };
  if (areaProp) {
    // The emitter as it was at the press: a resize keeps its centre and axes, a turn its plane.
    // A turn follows the pointer's angle about the centre from where it pressed (on the plane;
    // the handle itself if the plane is seen edge-on), so the press makes no jump.
    const a = h.area.frame;
    const { o, d } = pointerRay(e);
    const hit = rayOnPlane(a, o, d) ?? { x: V.dot(V.sub(world, a.centre), a.right), y: V.dot(V.sub(world, a.centre), a.up) };
    Object.assign(S.drag, { area: a, flip: h.area.flip, roll0: l.roll ?? 0, angle: planeAngleDeg(hit.x, hit.y), turned: 0 });
  }
  $("overlay").setPointerCapture?.(e.pointerId);
  beginGesture();
  const path = areaProp ?? (handle === "cp" ? `cp[${index}]` : handle === "radius" ? `r[${index}]` : handle === "ccp" ? `ccp[${index}]`
                            : handle === "cr" ? `cr[${index}]` : handle === "axis" ? "direction" : "position");
  setPresence(`${l.name}.${path}`);
}

// One step of an area light's size or roll handle. Sizes stay in the schema's range of `size`
// (never 0 or less); the other component is the light's current one.
function moveAreaHandle(e, d, l) {
  const a = d.area;
  const { o, d: dir } = pointerRay(e);
  d.moved = true;
  if (d.handle === "roll") {
    const hit = rayOnPlane(a, o, dir);
    if (!hit) return;
    const angle = planeAngleDeg(hit.x, hit.y);
    d.turned += angleStep(d.angle, angle);
    d.angle = angle;
    const { min, max } = rangeOf("roll");
    setLightProp(d.name, "roll", Number(turnedRoll(d.roll0, d.turned, min, max).toFixed(3)), { live: true });
    return;
  }
  const { min, max } = rangeOf("size");
  const size = (l.size ?? [a.width, a.height]).slice();
  if (d.handle === "corner") {
    const hit = rayOnPlane(a, o, dir);
    if (!hit) return;
    size[0] = clampSize(2 * Math.abs(hit.x), min, max);
    size[1] = clampSize(2 * Math.abs(hit.y), min, max);
  } else {
    const t = rayOnAxis(a.centre, d.handle === "height" ? a.up : a.right, o, dir);
    if (t === null) return;
    size[d.handle === "height" ? 1 : 0] = clampSize(2 * t, min, max);
  }
  setLightProp(d.name, "size", size, { live: true });
}

export function moveDrag(e) {
  const d = S.drag;
  const raw = findLight(d.name);
  if (!raw) return endDrag(null);
  const l = evaluated(raw);
  if (d.env) {
    d.moved = true;
    const { g, rotation0, signs, x0, y0 } = d.env;
    setLightProp(d.name, "rotation", draggedRotation(rotation0, e.clientX - x0, e.clientY - y0, g.r, signs), { live: true });
    return;
  }
  if (d.area) return moveAreaHandle(e, d, l);
  const f = lightFrame(l);
  let world;
  if (e.shiftKey && d.handle !== "radius") {
    // In depth: along the ray from the camera through the point; up the screen = away.
    const ray = V.sub(d.world, Cam.pos);
    const dist = V.len(ray);
    const step = -(e.clientY - d.lastY) * 0.004 * dist;
    world = V.add(d.world, V.scale(V.norm(ray), Math.max(step, 0.05 * dist - dist)));
    d.ndcZ = Cam.project(world).z;
  } else {
    const p = eventToImage(e);
    world = Cam.unproject(p.x, p.y, d.ndcZ);
  }
  d.lastY = e.clientY;
  d.moved = true;
  const round = (v) => v.map((x) => Number(x.toFixed(5)));
  if (d.handle === "position") {
    d.world = world;
    setLightProp(d.name, "position", round(world), { live: true });
  } else if (d.handle === "axis") {
    d.world = world;
    const dir = V.sub(world, l.position);
    if (V.len(dir) > 1e-6) setLightProp(d.name, "direction", round(V.norm(dir)), { live: true });
  } else if (d.handle === "cp") {
    d.world = world;
    setLightProp(d.name, `cp[${d.index}]`, round(worldToFrame(l, f, world)), { live: true });
  } else if (d.handle === "radius") {
    const centre = handlesOf(l).points[d.index];
    const r = V.len(V.sub(world, centre));
    setLightProp(d.name, `r[${d.index}]`, Number(r.toFixed(5)), { live: true });
  } else if (d.handle === "ccp") {
    // A bent area light's corner point: relative to its corner, in the emitter's frame.
    d.world = world;
    const h = handlesOf(l);
    const K2 = (l.cornerPoints?.length ?? 0) / 4;
    setLightProp(d.name, `ccp[${d.index}]`, round(worldToCorner(h.area.frame, cornerOf(h.area.frame, Math.floor(d.index / K2)), world)), { live: true });
  } else if (d.handle === "cr") {
    const centre = handlesOf(l).cornerCentres[d.index];
    const r = V.len(V.sub(world, centre));
    setLightProp(d.name, `cr[${d.index}]`, Number(r.toFixed(5)), { live: true });
  }
}

export function endDrag() {
  if (!S.drag) return;
  S.drag = null;
  endGesture();
  setPresence(null);
  scheduleRefetch(200);
}
