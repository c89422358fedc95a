// Dragging handles (paper 000 section 5, "Direct Control"): a point moves in the plane parallel to
// the image through its current position (constant NDC depth); with Shift it moves along the
// view ray instead (in depth), so its place in the image stays put.

import { Cam } from "./camera.js";
import { scheduleRefetch } from "./connection.js";
import { $ } from "./dom.js";
import { beginGesture, endGesture, setLightProp, setPresence } from "./edits.js";
import { V } from "./linalg.js";
import { handlesOf } from "./overlay.js";
import { lightFrame, worldToFrame } from "./rig.js";
import { S, evaluated, findLight } from "./state.js";
import { eventToImage } from "./viewport.js";

export function startDrag(e, handle, index) {
  const raw = findLight(S.selected);
  if (!raw) return;
  const l = evaluated(raw);
  const h = handlesOf(l);
  const world = handle === "position" ? h.position : handle === "axis" ? h.axis : h.points[index];
  S.drag = { handle, index, name: l.name, world: world.slice(), ndcZ: Cam.project(world).z, startY: e.clientY, lastY: e.clientY,
             pointerId: e.pointerId, moved: false };
  $("overlay").setPointerCapture?.(e.pointerId);
  beginGesture();
  const path = handle === "cp" ? `cp[${index}]` : handle === "radius" ? `r[${index}]` : handle === "axis" ? "direction" : "position";
  setPresence(`${l.name}.${path}`);
}

export function moveDrag(e) {
  const d = S.drag;
  const raw = findLight(d.name);
  if (!raw) return endDrag(null);
  const l = evaluated(raw);
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
  }
}

export function endDrag() {
  if (!S.drag) return;
  S.drag = null;
  endGesture();
  setPresence(null);
  scheduleRefetch(200);
}
