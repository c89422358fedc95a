// The image viewport: zoom and pan (the image keeps its pixels, 1:1 is native size; the overlay
// is drawn in screen space so handles stay the same size at every zoom), the pointer (handles
// drag, the background pans, a click picks) and picking: what is at a pixel, and the lights that
// reach it.

import { Cam } from "./camera.js";
import { nextSeq, send } from "./connection.js";
import { $, div, showMessage } from "./dom.js";
import { endDrag, moveDrag, startDrag } from "./drag.js";
import { layoutCompare } from "./final.js";
import { canEdit } from "./edits.js";
import { beginIndirect, endIndirect, indirectActive, moveIndirect, pointsSelectable, togglePoint } from "./indirect.js";
import { handlePoints, scheduleOverlay } from "./overlay.js";
import { fitView, insideView } from "./placement.js";
import { selectLight } from "./panels.js";
import { S, evaluated } from "./state.js";

export function applyTransform() {
  $("stage").style.transform = `translate(${S.panX}px, ${S.panY}px) scale(${S.zoom})`;
  $("frame").classList.toggle("pixelated", S.zoom >= 2);
  $("zoomLabel").textContent = `${Math.round(S.zoom * 100)}%`;
  layoutCompare();
  scheduleOverlay();
}
/** Zooms to z keeping the viewport point (cx, cy) over the same image point. */
export function zoomAt(z, cx, cy) {
  z = Math.min(32, Math.max(0.05, z));
  S.panX = cx - (cx - S.panX) * z / S.zoom;
  S.panY = cy - (cy - S.panY) * z / S.zoom;
  S.zoom = z;
  applyTransform();
}
function center() {
  const vp = $("viewport").getBoundingClientRect();
  S.panX = Math.round((vp.width - Cam.W * S.zoom) / 2);
  S.panY = Math.round((vp.height - Cam.H * S.zoom) / 2);
  applyTransform();
}
export function zoomNative() { S.zoom = 1; center(); }
export function zoomFit() {
  const vp = $("viewport").getBoundingClientRect();
  S.zoom = Math.max(0.05, Math.min((vp.width - 16) / Cam.W, (vp.height - 16) / Cam.H));
  center();
}
// Framing the lights keeps every handle this far inside the viewport's edges (a handle's circle,
// and room for the start of its label); with environment lights the band of their gizmos at the
// top (envgizmo.js gizmoPlace: centres 92 px down, radius 30, the name under it) is kept clear too.
const FRAME_MARGIN = 36;
const ENV_GIZMO_BAND = 140;
// Handles that project farther than this many image sizes from the image (a light nearly level
// with the camera, sideways) are left out of a framing: fitting them would shrink the image to a
// dot. Their edge arrows show where they are.
const FRAME_REACH = 12;

// The image points a framing fits: the image's corners (`image`) and the handles of the named
// lights (every light without names).
function framePoints(names, image = true) {
  const pts = image ? [{ x: 0, y: 0 }, { x: Cam.W, y: Cam.H }] : [];
  for (const raw of S.rig?.lights ?? []) {
    if (names && !names.includes(raw.name)) continue;
    for (const p of handlePoints(evaluated(raw))) {
      if (Math.abs(p.x - Cam.W / 2) <= FRAME_REACH * Cam.W && Math.abs(p.y - Cam.H / 2) <= FRAME_REACH * Cam.H) pts.push(p);
    }
  }
  return pts;
}
function frameMargins() {
  const env = (S.rig?.lights ?? []).some((l) => l.type === "environment");
  return { left: FRAME_MARGIN, right: FRAME_MARGIN, bottom: FRAME_MARGIN, top: env ? ENV_GIZMO_BAND : FRAME_MARGIN };
}
/**
 * Frames the lights (the toolbar's "Frame lights", L): the zoom and pan that show the whole image
 * and every light's handles (overlay.js handlePoints; behind the camera left out) inside the
 * viewport, clear of its edges.
 */
export function frameLights() { frameNamed(null); }
/** Frames the image and one light's handles (a click on its edge arrow). */
export function frameLight(name) { frameNamed([name]); }
function frameNamed(names) {
  if (!Cam.W) return;
  const vp = $("viewport").getBoundingClientRect();
  const f = fitView(framePoints(names), vp.width, vp.height, frameMargins());
  Object.assign(S, { zoom: f.zoom, panX: f.panX, panY: f.panY });
  applyTransform();
}
/**
 * Whether a handle of some light lies outside the viewport (less a few pixels) at the current
 * zoom and pan: the first load frames the lights then, instead of showing the image alone.
 */
export function handlesOutOfView() {
  const vp = $("viewport").getBoundingClientRect();
  return framePoints(null, false).some((p) => !insideView(toScreen(p), vp.width, vp.height, 10));
}
export const vpCenter = () => { const r = $("viewport").getBoundingClientRect(); return [r.width / 2, r.height / 2]; };

// Screen (viewport-relative) <-> image pixel coordinates.
export const toScreen = (p) => ({ x: S.panX + p.x * S.zoom, y: S.panY + p.y * S.zoom });
export function eventToImage(e) {
  const r = $("viewport").getBoundingClientRect();
  return { x: (e.clientX - r.left - S.panX) / S.zoom, y: (e.clientY - r.top - S.panY) / S.zoom };
}

/** The shot's pixel under an image point (integers, row 0 at the top), or null outside the image. */
export function pixelAt(p) {
  const x = Math.floor(p.x), y = Math.floor(p.y);
  return !Cam.W || x < 0 || y < 0 || x >= Cam.W || y >= Cam.H ? null : { x, y };
}
function pickAt(p) {
  const px = pixelAt(p);
  if (!px) return;
  const { x, y } = px;
  if (!send({ type: "pick", seq: nextSeq("pick"), x, y })) showMessage("not connected: cannot pick");
}
/** Shows a pick answer in the Pick panel (and its marker in the overlay). */
export function onPick(msg) {
  S.pending.delete(msg.seq);
  S.pickResult = msg;
  const box = $("pick");
  box.className = "";
  const f3 = (v) => v.map((x) => x.toFixed(3)).join(", ");
  if (!msg.hit) {
    box.innerHTML = "";
    box.append(Object.assign(div("hint"), { textContent: `pixel (${msg.x}, ${msg.y}): background, nothing was baked there` }));
  } else {
    box.innerHTML = `<dl><dt>pixel</dt><dd id="pickPixel"></dd><dt>object</dt><dd id="pickObject"></dd>
      <dt>position</dt><dd id="pickPosition"></dd><dt>normal</dt><dd id="pickNormal"></dd><dt>lights</dt><dd id="pickLights"></dd></dl>`;
    $("pickPixel").textContent = `(${msg.x}, ${msg.y})`;
    $("pickObject").textContent = msg.object ?? `object ${msg.objectId}`;
    $("pickPosition").textContent = f3(msg.position);
    $("pickNormal").textContent = f3(msg.normal);
    const lights = $("pickLights");
    if (!msg.lights.length) lights.textContent = "none reaches it";
    for (const l of msg.lights) {
      const b = Object.assign(document.createElement("button"), { textContent: l.name, title: `radiance ${f3(l.radiance)}: select this light` });
      b.className = "pickLight";
      b.style.margin = "0 4px 2px 0";
      b.onclick = () => selectLight(l.name);
      lights.append(b);
    }
  }
  $("pickPanel").scrollIntoView({ block: "nearest" });
  scheduleOverlay();
}

// The index of the control-point handle drawn under the pointer (within 9 px of its centre; the
// handles let the pointer through in a drag mode, so they are found by position), or 0.
function cpHandleAt(e) {
  const r = $("viewport").getBoundingClientRect();
  const x = e.clientX - r.left, y = e.clientY - r.top;
  let best = 0, bestD = 9;
  for (const h of $("overlay").querySelectorAll('[data-handle="cp"]')) {
    const d = Math.hypot(Number(h.getAttribute("cx")) - x, Number(h.getAttribute("cy")) - y);
    if (d <= bestD) { bestD = d; best = Number(h.dataset.index); }
  }
  return best;
}

/** The zoom buttons, the wheel and the pointer in the viewport. */
export function initViewport() {
  $("zoomIn").onclick = () => zoomAt(S.zoom * 1.25, ...vpCenter());
  $("zoomOut").onclick = () => zoomAt(S.zoom / 1.25, ...vpCenter());
  $("zoom1").onclick = zoomNative;
  $("zoomFit").onclick = zoomFit;
  $("frameLights").onclick = frameLights;
  $("handlesToggle").onclick = () => { S.showHandles = !S.showHandles; $("handlesToggle").classList.toggle("on", S.showHandles); scheduleOverlay(); };
  $("viewport").addEventListener("wheel", (e) => {
    e.preventDefault();
    const r = $("viewport").getBoundingClientRect();
    zoomAt(S.zoom * Math.exp(-e.deltaY * 0.0015), e.clientX - r.left, e.clientY - r.top);
  }, { passive: false });

  // Handles drag, background drags pan, a click picks. In a drag mode (indirect.js) a press on
  // the image grabs what it shows instead (the handles do not take the pointer then), and
  // Shift+click on a BendyLight control-point handle selects it (or deselects it).
  let press = null;
  $("viewport").addEventListener("pointerdown", (e) => {
    const t = e.target;
    if (e.button === 0 && e.shiftKey && indirectActive() && !S.drag && !S.indirect && pointsSelectable()) {
      const i = cpHandleAt(e);
      if (i) { e.preventDefault(); togglePoint(i); return; }
    }
    if (e.button === 0 && indirectActive() && !S.drag) {
      const p = eventToImage(e);
      const px = pixelAt(p);
      if (px) {
        e.preventDefault();
        if (beginIndirect(px.x, px.y, p)) $("viewport").setPointerCapture(e.pointerId);
        return;
      }
    }
    if (t.classList?.contains("handle")) {
      e.preventDefault();
      if (!canEdit()) return showMessage(S.connected ? "viewers cannot move lights (this page was opened with a viewer link)" : "not connected");
      startDrag(e, t.dataset.handle, Number(t.dataset.index ?? 0));
      $("viewport").setPointerCapture(e.pointerId);
      return;
    }
    if (e.button !== 0 && e.button !== 1) return;
    press = { x: e.clientX, y: e.clientY, panX: S.panX, panY: S.panY, panning: false };
    $("viewport").setPointerCapture(e.pointerId);
  });
  $("viewport").addEventListener("pointermove", (e) => {
    if (S.drag) { moveDrag(e); return; }
    if (S.indirect) {
      // Off the image the newest pixel inside it is kept (the server refuses pixels outside).
      const p = eventToImage(e);
      const px = pixelAt({ x: Math.min(Math.max(p.x, 0), Cam.W - 0.5), y: Math.min(Math.max(p.y, 0), Cam.H - 0.5) });
      if (px) moveIndirect(px.x, px.y, p);
      return;
    }
    if (!press) return;
    const dx = e.clientX - press.x, dy = e.clientY - press.y;
    if (!press.panning && Math.hypot(dx, dy) > 3) { press.panning = true; $("viewport").classList.add("panning"); }
    if (press.panning) { S.panX = press.panX + dx; S.panY = press.panY + dy; applyTransform(); }
  });
  $("viewport").addEventListener("pointerup", (e) => {
    if (S.drag) { endDrag(); return; }
    if (S.indirect) { endIndirect(); return; }
    if (!press) return;
    const wasPan = press.panning;
    press = null;
    $("viewport").classList.remove("panning");
    if (!wasPan && e.button === 0) pickAt(eventToImage(e));
  });
  $("viewport").addEventListener("pointercancel", () => { if (S.drag) endDrag(); if (S.indirect) endIndirect(); press = null; });
}
