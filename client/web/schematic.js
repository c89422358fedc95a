// The Schematic panel (docs/browser-client.md "Placing lights"): the scene seen from the top, the
// side or the front, orthographic, drawn from what the session description knows of it (the
// scene's box and each object's, `bounds` / `objectBounds`, docs/protocol.md "Connection") and the
// rig: the camera and its view, every light with its cone (spot), tube (BendyLight), outline (area
// lights) or direction (directional), and the lights' position handles. A light dragged here
// moves in the view's plane only (top: x and z, side: y and z, front: x and y); the drag sends
// ordinary live edits of `L.position`, one undo step per drag, as a handle drag in the image does.

import { areaFrame, areaOutline, cornerChains } from "./area.js";
import { Cam } from "./camera.js";
import { scheduleRefetch } from "./connection.js";
import { $, SVGNS, showMessage, svg } from "./dom.js";
import { beginGesture, canEdit, endGesture, setLightProp, setPresence } from "./edits.js";
import { V, bezier } from "./linalg.js";
import { footprintOf, handlesOf, lightColor } from "./overlay.js";
import { selectLight } from "./panels.js";
import { AXIS_NAMES, VIEWS, fitMap, fromView, gridStep, mapStillFits, toView } from "./placement.js";
import { S, evaluated } from "./state.js";

// The canvas keeps this many pixels between what it shows and its edges (a handle's circle and
// the start of a label).
const PAD = 22;
// Each view keeps its map (placement.js fitMap) while everything still fits it well, so the
// drawing does not jump after every edit; never during a drag (the pointer would slip).
const maps = { top: null, side: null, front: null };
// The drag going on: {name, view, map, start (world), x0, y0 (canvas pixels at the press), moved}.
let drag = null;

const boxCorners = (b) => {
  const out = [];
  for (let i = 0; i < 8; i++) out.push([b[i & 1 ? 3 : 0], b[i & 2 ? 4 : 1], b[i & 4 ? 5 : 2]]);
  return out;
};
const boxCentre = (b) => [(b[0] + b[3]) / 2, (b[1] + b[4]) / 2, (b[2] + b[5]) / 2];

// A length that reads as "the scene's size": its box's diagonal, else the lights' distance from
// the camera, else 5 units (the page's default for a new light, edits.js addLight).
function sceneSize() {
  const b = S.session?.bounds;
  if (b) return Math.max(1e-3, Math.hypot(b[3] - b[0], b[4] - b[1], b[5] - b[2]));
  const l = (S.rig?.lights ?? []).find((x) => x.position && x.type !== "directional" && x.type !== "environment");
  return l ? Math.max(1e-3, V.len(V.sub(l.position, Cam.pos))) : 5;
}

// How far a spot light's cone is drawn: to the footprint's plane where it meets one (overlay.js
// footprintOf), else to the scene's centre's distance along the axis, at least a tenth of the
// scene's size.
function coneLength(l, u) {
  const fp = footprintOf(l);
  if (fp) return fp.plane.t;
  const c = S.session?.bounds ? boxCentre(S.session.bounds) : V.add(Cam.pos, V.scale(Cam.forward, sceneSize()));
  return Math.max(0.1 * sceneSize(), V.dot(V.sub(c, l.position), u));
}

// The world shapes of a light in the schematic: polylines (closed or not) and the point of its
// position handle (null: it has none, a directional light).
function shapesOf(l) {
  const lines = [];
  const h = l.type === "directional" || l.type === "environment" ? null : handlesOf(l);
  if (l.type === "spot") {
    // The cone as its axis, its rim at the drawn length and four edge lines to the rim (the
    // silhouette of a cone seen from the side lies close to two of them, and seen along the axis
    // the rim shows it).
    const f = h.frame, len = coneLength(l, f.uL);
    const rad = len * Math.tan((l.coneAngle * Math.PI) / 180);
    const c = V.add(l.position, V.scale(f.uL, len));
    const rim = [];
    for (let i = 0; i <= 48; i++) {
      const a = (2 * Math.PI * i) / 48;
      rim.push(V.add(c, V.add(V.scale(f.vL, rad * Math.cos(a)), V.scale(f.wL, rad * Math.sin(a)))));
    }
    lines.push({ points: rim, kind: "cone" });
    for (let i = 0; i < 48; i += 12) lines.push({ points: [l.position, rim[i]], kind: "cone" });
    lines.push({ points: [l.position, c], kind: "axis" });
  } else if (l.type === "directional") {
    // No place: an arrow along its direction through the scene's centre, from outside the box.
    const d = V.norm(l.direction ?? [0, -1, 0]), s = sceneSize();
    const c = S.session?.bounds ? boxCentre(S.session.bounds) : V.add(Cam.pos, V.scale(Cam.forward, s));
    lines.push({ points: [V.sub(c, V.scale(d, 0.75 * s)), V.sub(c, V.scale(d, 0.45 * s))], kind: "arrow" });
  } else if (h && l.type !== "point") {
    // Its axis, as the image's axis handle shows it.
    lines.push({ points: [h.position, h.axis], kind: "axis" });
  }
  if (h?.area) lines.push({ points: [...h.area.outline, h.area.outline[0]], kind: "outline" });
  for (const ch of h?.chains ?? []) {
    // The tube: its spline and, either side of it, the radius R(t) (docs/lighting.md "The tube":
    // the same quadratic weights as the points), offset across the spline in the view itself
    // (drawTube), plus the straight extension past the last point, widening as R'(1) says.
    const curve = [];
    for (let k = 0; 2 * k + 2 < ch.points.length; k++) {
      for (let i = k ? 1 : 0; i <= 16; i++) {
        const t = i / 16, r = ch.radii;
        const rr = r.length === ch.points.length ? (1 - t) ** 2 * r[2 * k] + 2 * (1 - t) * t * r[2 * k + 1] + t * t * r[2 * k + 2] : 0;
        curve.push({ p: bezier(ch.points[2 * k], ch.points[2 * k + 1], ch.points[2 * k + 2], t), r: rr });
      }
    }
    const n = ch.points.length;
    if (n >= 3 && ch.radii.length === n) {
      const end = ch.points[n - 1], step = V.sub(end, ch.points[n - 2]), len = V.len(step);
      if (len > 1e-9) {
        const ext = 0.3 * V.len(V.sub(end, ch.points[0]));
        const u = V.scale(step, 1 / len);
        curve.push({ p: V.add(end, V.scale(u, ext)), r: ch.radii[n - 1] + ((ch.radii[n - 1] - ch.radii[n - 2]) / len) * ext, extension: true });
      }
    }
    lines.push({ tube: curve, kind: "tube" });
  }
  return { lines, position: h ? h.position : null };
}

// The view points a map must show: the scene's box, the camera, each light's shapes but cones.
function viewPoints(view, lights) {
  const pts = [];
  if (S.session?.bounds) for (const c of boxCorners(S.session.bounds)) pts.push(toView(view, c));
  if (Cam.pos) pts.push(toView(view, Cam.pos));
  for (const { shapes } of lights) {
    if (shapes.position) pts.push(toView(view, shapes.position));
    // Not a cone's rim: a wide cone reaching the floor would shrink the scene to a corner.
    for (const ln of shapes.lines) {
      if (ln.kind !== "cone") for (const p of ln.points ?? ln.tube.map((q) => q.p)) pts.push(toView(view, p));
    }
  }
  return pts.filter(([a, b]) => Number.isFinite(a) && Number.isFinite(b));
}

/** Redraws the schematic (overlay.js scheduleOverlay calls it with the overlay). */
export function drawSchematic() {
  const root = $("schematic");
  if (!root) return;
  const w = root.clientWidth, hgt = root.clientHeight;
  root.innerHTML = "";
  const viewName = S.schematicView;
  for (const b of document.querySelectorAll("#schematicViews button")) b.classList.toggle("on", b.dataset.view === viewName);
  if (!S.rig || !Cam.W || !w || !hgt) return;
  const view = VIEWS[viewName];
  const lights = S.rig.lights.filter((l) => l.type !== "environment").map((raw) => {
    const l = evaluated(raw);
    return { l, shapes: shapesOf(l) };
  });
  let map = drag ? drag.map : maps[viewName];
  if (!drag && (!map || map.w !== w || map.h !== hgt || !mapStillFits(map, viewPoints(view, lights), w, hgt, PAD))) {
    map = { ...fitMap(viewPoints(view, lights), w, hgt, PAD), w, h: hgt };
    maps[viewName] = map;
  }
  root.dataset.view = viewName;
  root.dataset.scale = String(map.scale);
  const at = (p) => { const [a, b] = toView(view, p); return { x: map.ox + a * map.scale, y: map.oy + b * map.scale }; };
  const poly = (pts) => pts.map(at).map((q) => `${q.x.toFixed(1)},${q.y.toFixed(1)}`).join(" ");

  // A grid of round world units, and the view's axes named at the bottom left.
  const step = gridStep(Math.max(w, hgt) / map.scale, 10);
  const grid = svg("g", { class: "sch-grid", stroke: "#2c2e32", "stroke-width": 1 }, root);
  for (let x = Math.ceil(-map.ox / map.scale / step) * step; map.ox + x * map.scale <= w; x += step) {
    const sx = map.ox + x * map.scale;
    svg("line", { x1: sx, y1: 0, x2: sx, y2: hgt, ...(Math.abs(x) < step / 2 ? { stroke: "#45484e" } : {}) }, grid);
  }
  for (let y = Math.ceil(-map.oy / map.scale / step) * step; map.oy + y * map.scale <= hgt; y += step) {
    const sy = map.oy + y * map.scale;
    svg("line", { x1: 0, y1: sy, x2: w, y2: sy, ...(Math.abs(y) < step / 2 ? { stroke: "#45484e" } : {}) }, grid);
  }
  const sign = (k) => (view.signs[k] > 0 ? "" : "−");
  svg("text", { x: 6, y: hgt - 6, fill: "#888", class: "sch-axes" }, root).textContent =
    `${view.label}: ${sign(0)}${AXIS_NAMES[view.axes[0]]} →  ${sign(1) ? "" : "−"}${AXIS_NAMES[view.axes[1]]} ↑  · grid ${Number(step.toPrecision(3))}`;

  // The objects' boxes (what the shot sees of each) and the scene's, dashed.
  const rect = (b, attrs, parent) => {
    const pts = boxCorners(b).map(at);
    const x0 = Math.min(...pts.map((q) => q.x)), x1 = Math.max(...pts.map((q) => q.x));
    const y0 = Math.min(...pts.map((q) => q.y)), y1 = Math.max(...pts.map((q) => q.y));
    return svg("rect", { x: x0, y: y0, width: Math.max(x1 - x0, 1), height: Math.max(y1 - y0, 1), ...attrs }, parent);
  };
  const objects = svg("g", { class: "sch-objects" }, root);
  (S.session?.objectBounds ?? []).forEach((b, i) => {
    if (!b) return;
    const name = S.session.objects?.[i] ?? `object ${i + 1}`;
    const r = rect(b, { fill: "#7a8599", "fill-opacity": 0.12, stroke: "#7a8599", "stroke-width": 1, "data-object": name }, objects);
    r.append(Object.assign(document.createElementNS(SVGNS, "title"), { textContent: name }));
  });
  if (S.session?.bounds) rect(S.session.bounds, { fill: "none", stroke: "#8a8f99", "stroke-width": 1, "stroke-dasharray": "4 3", class: "sch-bounds" }, root);

  // The camera: its position and the edges of its view, out to the scene's far side.
  const cam = svg("g", { class: "sch-camera", stroke: "#6cf", "stroke-width": 1, fill: "none" }, root);
  const reach = S.session?.bounds ? Math.max(...boxCorners(S.session.bounds).map((c) => V.dot(V.sub(c, Cam.pos), Cam.forward))) : sceneSize();
  if (reach > 0) {
    const far = [[0, 0], [Cam.W, 0], [Cam.W, Cam.H], [0, Cam.H]].map(([x, y]) => {
      const d = V.sub(Cam.unproject(x, y, 0.5), Cam.unproject(x, y, -1));
      const o = Cam.unproject(x, y, -1);
      const t = (reach - V.dot(V.sub(o, Cam.pos), Cam.forward)) / V.dot(d, Cam.forward);
      return V.add(o, V.scale(d, t));
    });
    for (const f of far) svg("polyline", { points: poly([Cam.pos, f]), opacity: 0.35, "stroke-dasharray": "3 3" }, cam);
    svg("polyline", { points: poly([...far, far[0]]), opacity: 0.35 }, cam);
  }
  const cp = at(Cam.pos);
  svg("circle", { cx: cp.x, cy: cp.y, r: 4, fill: "#6cf", stroke: "none" }, cam);
  svg("text", { x: cp.x + 7, y: cp.y + 12, fill: "#6cf", stroke: "none" }, cam).textContent = "camera";

  // The lights, the selected one last (on top).
  lights.sort((p, q) => (p.l.name === S.selected) - (q.l.name === S.selected));
  for (const { l, shapes } of lights) {
    const selected = l.name === S.selected;
    const color = lightColor(l);
    const g = svg("g", { class: "sch-light", "data-schematic-light": l.name, opacity: l.enabled ? 1 : 0.5 }, root);
    for (const ln of shapes.lines) {
      if (ln.kind === "tube") { drawTube(ln.tube, at, map.scale, color, selected, g); continue; }
      const attrs = { points: poly(ln.points), fill: "none", stroke: color, "stroke-width": selected ? 1.5 : 1, class: `sch-${ln.kind}` };
      // Cones overlap a lot (a wide fill's reaches past the scene): faint but the selected one's.
      if (ln.kind === "cone") Object.assign(attrs, { opacity: selected ? 0.6 : 0.25 });
      if (ln.kind === "axis") Object.assign(attrs, { "stroke-dasharray": "2 3" });
      svg("polyline", attrs, g);
      if (ln.kind === "arrow") {
        const [a, b] = ln.points.map(at);
        const ang = (Math.atan2(b.y - a.y, b.x - a.x) * 180) / Math.PI;
        svg("path", { d: "M7,0L-4,-5L-4,5z", transform: `translate(${b.x},${b.y}) rotate(${ang})`, fill: color }, g);
        svg("text", { x: a.x + 4, y: a.y - 4, fill: color }, g).textContent = l.name;
      }
    }
    if (!shapes.position) continue;
    const p = at(shapes.position);
    const hnd = svg("circle", { cx: p.x, cy: p.y, r: selected ? 6 : 5, fill: selected ? color : "#222", stroke: selected ? "#000" : color,
                                "stroke-width": 1.5, class: "sch-handle", "data-name": l.name }, g);
    const [a0, a1] = view.axes.map((k) => AXIS_NAMES[k]);
    hnd.append(Object.assign(document.createElementNS(SVGNS, "title"), {
      textContent: `${l.name} (${shapes.position.map((v) => v.toFixed(2)).join(", ")}): drag to move it in ${a0} and ${a1}` }));
    svg("text", { x: p.x + 8, y: p.y - 6, fill: color, ...(selected ? { "font-weight": "bold" } : {}) }, g).textContent = l.name;
  }
}

// A BendyLight's tube in the view: its spline solid, and the radius either side of it, offset
// perpendicular to the spline as drawn (the outline of the tube seen from this side where the
// spline runs across the view; where it points at the viewer the tube shows as its circles).
function drawTube(curve, at, scale, color, selected, g) {
  const spine = curve.filter((q) => !q.extension).map((q) => at(q.p));
  svg("polyline", { points: spine.map((q) => `${q.x},${q.y}`).join(" "), fill: "none", stroke: color, "stroke-width": selected ? 2 : 1.25,
                    class: "sch-spline" }, g);
  const scr = curve.map((q) => ({ ...at(q.p), r: q.r * scale }));
  const left = [], right = [];
  for (let i = 0; i < scr.length; i++) {
    const a = scr[Math.max(0, i - 1)], b = scr[Math.min(scr.length - 1, i + 1)];
    const dx = b.x - a.x, dy = b.y - a.y, len = Math.hypot(dx, dy);
    if (!(len > 1e-6)) continue;
    const nx = -dy / len, ny = dx / len, q = scr[i];
    left.push(`${q.x + nx * q.r},${q.y + ny * q.r}`);
    right.push(`${q.x - nx * q.r},${q.y - ny * q.r}`);
  }
  for (const side of [left, right]) {
    svg("polyline", { points: side.join(" "), fill: "none", stroke: color, "stroke-width": 1, opacity: 0.6, class: "sch-tube" }, g);
  }
}

// Canvas pixels of a pointer event.
function local(e) {
  const r = $("schematic").getBoundingClientRect();
  return { x: e.clientX - r.left, y: e.clientY - r.top };
}

/** The view buttons and the pointer on the schematic. */
export function initSchematic() {
  for (const b of document.querySelectorAll("#schematicViews button")) {
    b.onclick = () => { S.schematicView = b.dataset.view; drawSchematic(); };
  }
  const root = $("schematic");
  root.addEventListener("pointerdown", (e) => {
    const t = e.target;
    if (e.button !== 0 || !t.classList?.contains("sch-handle")) return;
    e.preventDefault();
    const name = t.dataset.name;
    selectLight(name);
    const raw = S.rig?.lights.find((l) => l.name === name);
    const viewName = S.schematicView;
    if (!raw || !maps[viewName]) return;
    const p = local(e);
    drag = { name, view: VIEWS[viewName], map: maps[viewName], start: evaluated(raw).position.slice(), x0: p.x, y0: p.y, moved: false };
    root.setPointerCapture(e.pointerId);
  });
  root.addEventListener("pointermove", (e) => {
    if (!drag) return;
    const p = local(e);
    const dx = p.x - drag.x0, dy = p.y - drag.y0;
    if (!drag.moved) {
      if (Math.hypot(dx, dy) < 2) return;
      if (!canEdit()) {
        showMessage(S.connected ? "viewers cannot move lights (this page was opened with a viewer link)" : "not connected");
        drag = null;
        return;
      }
      drag.moved = true;
      beginGesture();
      setPresence(`${drag.name}.position`);
    }
    // The view's two axes follow the pointer from where it pressed; the third component is the
    // light's own, untouched (not even rounded), so a top-view drag leaves its height exactly.
    const { view, map, start } = drag;
    const hv = toView(view, start);
    const moved = fromView(view, [hv[0] + dx / map.scale, hv[1] + dy / map.scale], start);
    for (const k of view.axes) moved[k] = Number(moved[k].toFixed(5));
    setLightProp(drag.name, "position", moved, { live: true });
  });
  const end = () => {
    if (!drag) return;
    const moved = drag.moved;
    drag = null;
    if (!moved) return;
    endGesture();
    setPresence(null);
    scheduleRefetch(200);
  };
  root.addEventListener("pointerup", end);
  root.addEventListener("pointercancel", end);
}
