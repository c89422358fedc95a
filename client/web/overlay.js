// The overlay: the selected light's handles (position, axis, BendyLight control points and tube
// radii, an area light's size and roll) and markers for the other lights, area lights' outlines,
// projected with the shot's camera and drawn as SVG in screen space; who else is dragging what.

import { drawAnnotations } from "./annotations.js";
import { areaFrame, areaHandles, areaOutline, cornerChains } from "./area.js";
import { Cam } from "./camera.js";
import { $, SVGNS, showMessage, svg } from "./dom.js";
import { centreHandle, gizmoCurves, gizmoPlace } from "./envgizmo.js";
import { pointsSelectable, selectedPoints } from "./indirect.js";
import { V, bezier } from "./linalg.js";
import { selectLight } from "./panels.js";
import { coneFootprint, edgeArrow, footprintPlane, insideView, outlineRuns, perpendiculars } from "./placement.js";
import { clientColor, editorsOf } from "./presence.js";
import { frameToWorld, lightFrame } from "./rig.js";
import { S, evaluated, findLight } from "./state.js";
import { drawSchematic } from "./schematic.js";
import { frameLight, toScreen } from "./viewport.js";

/** Redraws the overlay at the next animation frame (once however often it is asked). */
export function scheduleOverlay() {
  if (scheduleOverlay.pending) return;
  scheduleOverlay.pending = true;
  requestAnimationFrame(() => { scheduleOverlay.pending = false; drawOverlay(); drawSchematic(); });
}

// What an indirect drag (indirect.js) grabbed, until it ends: the grabbed point (the begin's
// `point`, projected), for shadow modes the occluder point S and the line from S to the pointer
// (the shadow ray the solver makes pass through it), and the pointer itself.
function drawGrab(root) {
  const d = S.indirect;
  if (!d) return;
  const g = svg("g", { class: "grab", "data-grab": d.mode }, root);
  const at = (p) => { const P = Cam.project(p); return P.front ? toScreen(P) : null; };
  const ptr = d.pointer ? toScreen(d.pointer) : null;
  const color = d.refused ? "#f66" : "#5ef";
  const grab = d.grab;
  const gp = grab?.point ? at(grab.point) : toScreen({ x: d.x + 0.5, y: d.y + 0.5 });
  const S_ = grab?.occluder?.S ? at(grab.occluder.S) : null;
  if (S_ && gp) svg("line", { x1: S_.x, y1: S_.y, x2: gp.x, y2: gp.y, stroke: color, "stroke-width": 1, "stroke-dasharray": "2 3", opacity: 0.7 }, g);
  if (S_ && ptr) svg("line", { x1: S_.x, y1: S_.y, x2: ptr.x, y2: ptr.y, stroke: color, "stroke-width": 1.5, class: "grab-ray" }, g);
  else if (gp && ptr) svg("line", { x1: gp.x, y1: gp.y, x2: ptr.x, y2: ptr.y, stroke: color, "stroke-width": 1, "stroke-dasharray": "4 3" }, g);
  if (gp) {
    svg("circle", { cx: gp.x, cy: gp.y, r: 5, fill: "none", stroke: color, "stroke-width": 2, class: "grab-point" }, g);
    svg("text", { x: gp.x + 8, y: gp.y + 14, fill: color }, g).textContent = d.refused ? "refused" : grab ? "grabbed" : "…";
  }
  if (S_) {
    svg("path", { d: `M${S_.x},${S_.y - 6}l6,6l-6,6l-6,-6z`, fill: color, stroke: "#000", "stroke-width": 1, class: "grab-occluder" }, g);
    svg("text", { x: S_.x + 8, y: S_.y - 6, fill: color }, g).textContent = "S";
  }
  if (ptr) svg("circle", { cx: ptr.x, cy: ptr.y, r: 2.5, fill: color }, g);
}

/** Handle world positions of a light (pass it evaluated at the session time). */
export function handlesOf(l) {
  const f = lightFrame(l);
  const d = Math.max(0.2, V.len(V.sub(l.position, Cam.pos)));
  const out = { frame: f, position: l.position, axis: V.add(l.position, V.scale(f.uL, 0.18 * d)), points: [], radii: [] };
  if (l.type === "bendy" && l.controlPoints?.length) {
    out.points = [l.position, ...l.controlPoints.map((a) => frameToWorld(l, f, a))];
    out.radii = l.radii || [];
  }
  if (l.type === "area" || l.type === "bentArea") out.area = areaHandlesOf(l, d);
  // A bent area light's four corner chains: drawn and dragged like a BendyLight's chain, each
  // point and radius addressing its element of cornerPoints / cornerRadii (handles "ccp", "cr").
  if (l.type === "bentArea") {
    out.chains = cornerChains(l, out.area.frame).map((ch) => ({ ...ch, pointHandle: "ccp", radiusHandle: "cr", label: "c" }));
    out.cornerPoints = [];
    out.cornerCentres = [];
    for (const ch of out.chains) {
      ch.points.forEach((p, i) => { if (i > 0) out.cornerPoints[ch.cp(i)] = p; out.cornerCentres[ch.r(i)] = p; });
    }
  } else if (out.points.length) {
    out.chains = [{ points: out.points, radii: out.radii, cp: (i) => i, r: (i) => i, pointHandle: "cp", radiusHandle: "radius", label: "" }];
  }
  return out;
}

/**
 * Every handle of light `l` (pass it evaluated) as image pixels {x, y}: its position, its axis
 * (not a point light's), the points of its BendyLight or corner chains, an area light's outline
 * and its resize and roll handles. Points behind the camera have no place in the image and are
 * left out; an environment light has none. Framing the lights (viewport.js) fits these.
 */
export function handlePoints(l) {
  if (l.type === "environment") return [];
  const h = handlesOf(l);
  const world = [h.position];
  if (l.type !== "point") world.push(h.axis);
  for (const ch of h.chains ?? []) world.push(...ch.points);
  if (h.area) world.push(...h.area.outline, ...Object.values(h.area.handles));
  return world.map((p) => Cam.project(p)).filter((P) => P.front).map((P) => ({ x: P.x, y: P.y }));
}

// An area light's emitter, outline and handles. The roll handle sits a fixed share of the
// light's distance beyond the top edge (about 20 px at 1:1 with the default lens, as the axis
// handle's 0.18 d is about 50), so it stays apart from the height handle however small the
// emitter looks; where that is outside the viewport (a light near the image's top, the toolbars
// above) and below the bottom edge is not, it goes there instead, and stays on its side during
// its own drag.
function areaHandlesOf(l, d) {
  const a = areaFrame(l);
  const gap = 0.08 * d;
  let flip = false;
  if (S.drag?.handle === "roll" && S.drag.name === l.name) flip = S.drag.flip;
  else {
    const vp = $("viewport");
    const inView = (p) => {
      const P = Cam.project(p);
      if (!P.front) return false;
      const s = toScreen(P);
      return s.x >= 8 && s.y >= 8 && s.x <= vp.clientWidth - 8 && s.y <= vp.clientHeight - 8;
    };
    flip = !inView(areaHandles(a, gap).roll) && inView(areaHandles(a, gap, true).roll);
  }
  return { frame: a, outline: areaOutline(a), handles: areaHandles(a, gap, flip), flip, tick: 0.06 * d };
}

// An area light's outline in the image (every area light; the selected one highlighted, filled
// faintly where the camera sees its emitting side, dashed where it sees its back) and a short
// tick along the normal from its centre, towards the side it lights.
function drawAreaOutline(l, area, color, selected, parent) {
  const pts = area.outline.map((p) => Cam.project(p));
  if (pts.some((P) => !P.front)) return;
  const scr = pts.map(toScreen);
  const front = V.dot(V.sub(Cam.pos, area.frame.centre), area.frame.normal) > 0;
  svg("polygon", { points: scr.map((p) => `${p.x},${p.y}`).join(" "), stroke: color, "stroke-width": selected ? 2 : 1.25,
                   fill: front ? color : "none", "fill-opacity": selected ? 0.12 : 0.06, opacity: selected ? 1 : l.enabled ? 0.7 : 0.35,
                   ...(front ? {} : { "stroke-dasharray": "5 3" }), class: "area-outline", "data-area-outline": l.name,
                   "data-shape": area.frame.disk ? "disk" : "rect" }, parent);
  const C = Cam.project(area.frame.centre), T = Cam.project(V.add(area.frame.centre, V.scale(area.frame.normal, area.tick)));
  if (C.front && T.front) {
    const sc = toScreen(C), st = toScreen(T);
    svg("line", { x1: sc.x, y1: sc.y, x2: st.x, y2: st.y, stroke: color, "stroke-width": 1.5, opacity: selected ? 1 : l.enabled ? 0.7 : 0.35,
                  class: "area-normal" }, parent);
  }
}

// The selected area light's resize and roll handles (drag.js: "width", "height", "corner", "rim",
// "roll").
function drawAreaHandles(l, area, color, g) {
  const titled = (el, text) => el.append(Object.assign(document.createElementNS(SVGNS, "title"), { textContent: text }));
  const at = (p) => { const P = Cam.project(p); return P.front ? toScreen(P) : null; };
  const size = (v) => Number(v).toFixed(3);
  const tips = {
    width: `width = ${size(area.frame.width)}: drag to resize (about the centre)`,
    height: `height = ${size(area.frame.height)}: drag to resize (about the centre)`,
    corner: `size = ${size(area.frame.width)} x ${size(area.frame.height)}: drag to resize both (about the centre)`,
    rim: `diameter = ${size(area.frame.width)}: drag to resize (about the centre)`,
  };
  for (const [name, p] of Object.entries(area.handles)) {
    const s = at(p);
    if (!s || name === "roll") continue;
    const el = name === "corner"
      ? svg("path", { d: `M${s.x - 5},${s.y}l5,-5l5,5l-5,5z`, fill: "#222", stroke: color, "stroke-width": 1.5, class: "handle", "data-handle": name }, g)
      : svg("rect", { x: s.x - 4, y: s.y - 4, width: 8, height: 8, fill: "#222", stroke: color, "stroke-width": 1.5, class: "handle", "data-handle": name }, g);
    titled(el, tips[name]);
  }
  // Roll: a ring on a dashed stem from the edge it stands beyond.
  const r = at(area.handles.roll);
  const e = at(V.add(area.frame.centre, V.scale(area.frame.up, (area.flip ? -0.5 : 0.5) * area.frame.height)));
  if (r) {
    if (e) svg("line", { x1: e.x, y1: e.y, x2: r.x, y2: r.y, stroke: color, "stroke-width": 1, "stroke-dasharray": "2 2" }, g);
    const el = svg("circle", { cx: r.x, cy: r.y, r: 5, fill: "#222", stroke: color, "stroke-width": 2, class: "handle", "data-handle": "roll" }, g);
    titled(el, `roll = ${Number(l.roll ?? 0).toFixed(1)}°: drag around the centre to turn the light about its normal`);
  }
}
/** The gizmo of the k-th environment light of the rig (envgizmo.js), or null for another light. */
export function envGizmoOf(name) {
  const envs = (S.rig?.lights ?? []).filter((l) => l.type === "environment");
  const k = envs.findIndex((l) => l.name === name);
  return k < 0 ? null : gizmoPlace(k, $("viewport").clientWidth);
}

// Environment lights: a small sphere each in the top-right corner (envgizmo.js) with the map's
// equator, centre meridian and top pole as the camera sees them; the selected one has the
// rotation handle at the map's centre. Others select on a click.
function drawEnvGizmo(l, color, selected, others, root) {
  const g = envGizmoOf(l.name);
  const rotation = l.rotation ?? [0, 0, 0];
  const el = svg("g", { class: selected ? "env-gizmo" : "env-gizmo pickable", "data-env-gizmo": l.name, opacity: l.enabled ? 1 : 0.5,
                         ...(selected ? { "data-light": l.name } : { "data-select": l.name }) }, root);
  svg("circle", { cx: g.cx, cy: g.cy, r: g.r, fill: "rgba(20,20,24,0.55)", stroke: color, "stroke-width": selected ? 2 : 1.25 }, el);
  const c = gizmoCurves(g, Cam, rotation);
  // Each curve in runs of the same side: solid in front, dashed behind.
  for (const curve of [c.equator, c.meridian]) {
    let run = [curve[0]];
    const flush = () => {
      if (run.length > 1) {
        svg("polyline", { points: run.map((p) => `${p.x},${p.y}`).join(" "), fill: "none", stroke: color, "stroke-width": 1,
                          opacity: run[0].front ? 0.9 : 0.35, ...(run[0].front ? {} : { "stroke-dasharray": "2 2" }) }, el);
      }
    };
    for (let i = 1; i < curve.length; i++) {
      run.push(curve[i]);
      if (curve[i].front !== run[0].front) { flush(); run = [curve[i]]; }
    }
    flush();
  }
  svg("circle", { cx: c.top.x, cy: c.top.y, r: 2.5, fill: color, opacity: c.top.front ? 1 : 0.4, class: "env-top" }, el);
  svg("text", { x: g.cx - g.r, y: g.cy + g.r + 13, fill: color, ...(selected ? { "font-weight": "bold" } : {}) }, el).textContent =
    l.name + (others.length ? ` (${others.map((o) => o.name).join(", ")})` : "");
  const h = centreHandle(g, Cam, rotation);
  if (!selected) {
    el.addEventListener("pointerdown", (e) => { e.stopPropagation(); selectLight(l.name); });
    return;
  }
  const hc = svg("circle", { cx: h.x, cy: h.y, r: 6, fill: h.front ? color : "#222", stroke: h.front ? "#000" : color, "stroke-width": 1.5,
                             class: "handle", "data-handle": "envRotation" }, el);
  const fmt = (v) => Number(v ?? 0).toFixed(1);
  hc.append(Object.assign(document.createElementNS(SVGNS, "title"), {
    textContent: `rotation = [${rotation.map(fmt).join(", ")}]: the map's centre; drag to turn the map (left/right: yaw, up/down: pitch)` }));
}

// A position handle is "in view" when its whole circle (7 px) and a little more is inside the
// viewport; arrows stand this far inside the edge.
const IN_VIEW_INSET = 10;
const ARROW_INSET = 14;

// Arrows on the edge of the viewport pointing at each light whose position is outside it (or
// behind the camera), coloured as its marker and titled with its name. A click selects the
// light and frames it (viewport.js frameLight); a light behind the camera cannot be framed: the
// click selects it and says where to move it. Arrows that would overlap are spread along the edge.
function drawEdgeArrows(root, lights, colorOf) {
  const vp = $("viewport");
  const vw = vp.clientWidth, vh = vp.clientHeight;
  const placed = [];
  for (const l of lights) {
    if (l.type === "environment") continue;
    const P = Cam.project(l.position);
    const s = P.front ? toScreen(P) : null;
    if (s && insideView(s, vw, vh, IN_VIEW_INSET)) continue;
    const d = V.sub(l.position, Cam.pos);
    const a = s ? edgeArrow(vw, vh, ARROW_INSET, s) : edgeArrow(vw, vh, ARROW_INSET, null, [V.dot(d, Cam.right), -V.dot(d, Cam.up)]);
    const sideEdge = a.x <= ARROW_INSET + 0.5 || a.x >= vw - ARROW_INSET - 0.5;
    while (placed.some((q) => Math.hypot(q.x - a.x, q.y - a.y) < 16)) {
      if (sideEdge) a.y = a.y + 18 > vh - ARROW_INSET ? a.y - 36 : a.y + 18;
      else a.x = a.x + 18 > vw - ARROW_INSET ? a.x - 36 : a.x + 18;
    }
    placed.push(a);
    const color = colorOf(l);
    const g = svg("g", { class: "pickable edge-arrow", "data-offscreen": l.name, ...(s ? {} : { "data-behind": "" }) }, root);
    const deg = (a.angle * 180) / Math.PI;
    svg("path", { d: "M9,0L-6,-7L-2.5,0L-6,7z", transform: `translate(${a.x},${a.y}) rotate(${deg})`, fill: color, stroke: "#000",
                  "stroke-width": 1, opacity: l.enabled ? 1 : 0.5 }, g);
    // The name inside the view, away from the edge the arrow stands on.
    const c = Math.cos(a.angle), n = Math.sin(a.angle);
    const anchor = c > 0.5 ? "end" : c < -0.5 ? "start" : "middle";
    const tx = a.x - c * 14, ty = a.y - n * 14 + (n > 0.5 ? -4 : n < -0.5 ? 10 : 4);
    svg("text", { x: tx, y: ty, fill: color, "text-anchor": anchor, opacity: l.enabled ? 1 : 0.5 }, g).textContent = l.name;
    g.append(Object.assign(document.createElementNS(SVGNS, "title"), {
      textContent: s ? `${l.name} is outside the view: click to frame it` : `${l.name} is behind the camera: click to select it (the Schematic panel shows where it is)` }));
    g.addEventListener("pointerdown", (e) => {
      e.stopPropagation();
      selectLight(l.name);
      if (s) frameLight(l.name);
      else showMessage(`'${l.name}' is behind the camera: no view of the image shows it; move it in the Schematic panel`, "info");
    });
  }
}

/**
 * The footprint of a spot light's cone, or of a BendyLight's cone past its last control point,
 * on the plane of the first object box its axis meets that is wide enough to hold it
 * (placement.js footprintPlane: the shot's per-object boxes, else the ground under the scene, else
 * the first box it meets at all): {plane, outer, inner} as world outlines
 * (inner: the edge of the penumbra, spot lights only), or null when no plane is in front. The
 * page has no depth of its own: on a flat object the box's face is its surface; on a rounded one
 * the outline is where the beam would meet the box, an approximation (docs/browser-client.md).
 */
export function footprintOf(l) {
  let o, u, v, w, r0 = 0, g, inner = null;
  if (l.type === "spot") {
    const f = lightFrame(l);
    o = l.position; u = f.uL; v = f.vL; w = f.wL;
    const RAD = Math.PI / 180;
    g = Math.tan(l.coneAngle * RAD);
    if (l.penumbra > 0 && l.coneAngle - l.penumbra > 0.05) inner = Math.tan((l.coneAngle - l.penumbra) * RAD);
  } else if (l.type === "bendy") {
    // The straight extension (docs/lighting.md "The tube"): from p2K along P'(1) = 2 (p2K - p2K-1)
    // with R'(1) = 2 (r2K - r2K-1), so the radius grows by (r2K - r2K-1) / |p2K - p2K-1| per unit.
    const pts = handlesOf(l).points, r = l.radii ?? [];
    const n = pts.length;
    if (n < 3 || r.length !== n) return null;
    const step = V.sub(pts[n - 1], pts[n - 2]);
    const len = V.len(step);
    if (!(len > 1e-9)) return null;
    o = pts[n - 1]; u = V.scale(step, 1 / len); [v, w] = perpendiculars(u);
    r0 = r[n - 1]; g = (r[n - 1] - r[n - 2]) / len;
  } else {
    return null;
  }
  const plane = footprintPlane(o, u, S.session?.objectBounds, S.session?.bounds, { r0, g });
  if (!plane) return null;
  // Edge rays that meet the plane far beyond the axis are past its horizon: cut them.
  const maxT = 8 * plane.t + 4 * r0;
  return { plane, outer: coneFootprint(o, u, v, w, r0, g, plane, { maxT }),
           inner: inner === null ? null : coneFootprint(o, u, v, w, 0, inner, plane, { maxT }) };
}

// A world outline as polylines in the image: its runs (placement.js outlineRuns), each split
// where a point is behind the camera.
function drawWorldOutline(points, attrs, parent) {
  for (const run of outlineRuns(points)) {
    let part = [];
    const flush = () => {
      if (part.length > 1) svg("polyline", { points: part.map((p) => `${p.x},${p.y}`).join(" "), fill: "none", ...attrs }, parent);
      part = [];
    };
    for (const p of run.points) {
      const P = Cam.project(p);
      if (P.front) part.push(toScreen(P)); else flush();
    }
    flush();
  }
}

// The selected spot or BendyLight's footprint: the cone's edge solid, the penumbra's dashed.
function drawFootprint(l, color, parent) {
  const fp = footprintOf(l);
  if (!fp) return;
  const on = fp.plane.object >= 0 ? S.session?.objects?.[fp.plane.object] ?? `object ${fp.plane.object + 1}` : "ground";
  const g = svg("g", { class: "footprint", "data-footprint": l.name, "data-footprint-on": on, opacity: l.enabled ? 0.9 : 0.45 }, parent);
  drawWorldOutline(fp.outer, { stroke: color, "stroke-width": 1.5, "stroke-dasharray": "7 4", class: "footprint-edge" }, g);
  if (fp.inner) drawWorldOutline(fp.inner, { stroke: color, "stroke-width": 1, "stroke-dasharray": "2 4", opacity: 0.7 }, g);
  const c = Cam.project(fp.plane.point);
  if (c.front) {
    const sc = toScreen(c);
    svg("path", { d: `M${sc.x - 4},${sc.y}h8M${sc.x},${sc.y - 4}v8`, stroke: color, "stroke-width": 1.25 }, g);
  }
}

// The projected radius of a sphere of radius r at p: a circle around the handle.
function radiusHandlePoint(p, r) { return V.add(p, V.scale(Cam.right, r)); }

/** A light's colour in the image and the schematic: an editor's while someone edits it, the accent when selected. */
export function lightColor(l) {
  const others = editorsOf(l.name);
  return others.length ? clientColor(others[0].id) : l.name === S.selected ? "#f0b34a" : "#ccc";
}

function drawOverlay() {
  const root = $("overlay");
  root.innerHTML = "";
  if (!S.rig || !Cam.W) return;
  drawAnnotations(root); // under the handles, which stay grabbable over a pin
  if (S.pickResult?.hit) {
    const s = toScreen({ x: S.pickResult.x + 0.5, y: S.pickResult.y + 0.5 });
    svg("path", { d: `M${s.x - 7},${s.y}h5m4,0h5M${s.x},${s.y - 7}v5m0,4v5`, stroke: "#0ff", "stroke-width": 1.5 }, root);
  }
  drawGrab(root);
  if (!S.showHandles) return;
  // Labels of lights at (nearly) one place (a duplicate in place) are stacked, not overprinted.
  const placed = [];
  const labelY = (x, y) => {
    while (placed.some((p) => Math.abs(p.x - x) < 60 && Math.abs(p.y - y) < 12)) y += 13;
    placed.push({ x, y });
    return y;
  };
  // The selected light is drawn last (its handles on top of any marker) but its label placed first.
  const lights = [...S.rig.lights].sort((p, q) => (p.name === S.selected) - (q.name === S.selected));
  const sel = findLight(S.selected);
  let selectedLabelY = null;
  if (sel && sel.type !== "environment") {
    const sp = toScreen(Cam.project(evaluated(sel).position));
    selectedLabelY = labelY(sp.x + 10, sp.y + 4);
  }
  for (const raw of lights) {
    const l = evaluated(raw);
    const selected = l.name === S.selected;
    const others = editorsOf(l.name);
    const color = lightColor(l);
    if (l.type === "environment") { drawEnvGizmo(l, color, selected, others, root); continue; }
    const h = handlesOf(l);
    const P = Cam.project(h.position);
    const ps = toScreen(P);
    if (h.area) drawAreaOutline(l, h.area, color, selected, root);
    if (!selected) {
      if (!P.front) continue;
      // Other lights: a small marker that selects them.
      const g = svg("g", { class: "pickable", "data-select": l.name }, root);
      svg("circle", { cx: ps.x, cy: ps.y, r: 5, fill: "none", stroke: color, "stroke-width": 1.5, opacity: l.enabled ? 1 : 0.5,
                      "data-handle": "position", "data-name": l.name }, g);
      svg("text", { x: ps.x + 8, y: labelY(ps.x + 8, ps.y + 4), fill: color }, g).textContent = l.name + (others.length ? ` (${others.map((c) => c.name).join(", ")})` : "");
      g.addEventListener("pointerdown", (e) => { e.stopPropagation(); selectLight(l.name); });
      continue;
    }
    drawFootprint(l, color, root);
    const g = svg("g", { "data-light": l.name }, root);
    const line = (a, b, attrs) => {
      const A = Cam.project(a), B = Cam.project(b);
      if (!A.front || !B.front) return;
      const sa = toScreen(A), sb = toScreen(B);
      svg("line", { x1: sa.x, y1: sa.y, x2: sb.x, y2: sb.y, stroke: color, "stroke-width": 1.5, ...attrs }, g);
    };
    for (const ch of h.chains ?? []) {
      // The spline (solid), its control polygon (dashed) and the straight extension past the end.
      const pts = [];
      for (let k = 0; 2 * k + 2 < ch.points.length; k++) {
        for (let i = 0; i <= 16; i++) pts.push(bezier(ch.points[2 * k], ch.points[2 * k + 1], ch.points[2 * k + 2], i / 16));
      }
      const scr = pts.map((p) => Cam.project(p)).filter((p) => p.front).map(toScreen);
      svg("polyline", { points: scr.map((p) => `${p.x},${p.y}`).join(" "), fill: "none", stroke: color, "stroke-width": 2 }, g);
      for (let i = 0; i + 1 < ch.points.length; i++) line(ch.points[i], ch.points[i + 1], { "stroke-dasharray": "3 3", opacity: 0.6 });
      const n = ch.points.length, end = ch.points[n - 1], tan = V.norm(V.sub(end, ch.points[n - 2]));
      line(end, V.add(end, V.scale(tan, V.len(V.sub(end, ch.points[0])) * 0.3)), { "stroke-dasharray": "1 4", opacity: 0.6 });
      // Control points selected for a drag mode (indirect.js; BendyLights): filled, with a ring.
      const chosen = ch.pointHandle === "cp" && pointsSelectable() ? selectedPoints() : [];
      ch.points.forEach((p, i) => {
        const Pp = Cam.project(p);
        if (!Pp.front) return;
        const sp = toScreen(Pp);
        const r = ch.radii[i] ?? 0;
        const Rp = toScreen(Cam.project(radiusHandlePoint(p, r)));
        const rad = Math.hypot(Rp.x - sp.x, Rp.y - sp.y);
        svg("circle", { cx: sp.x, cy: sp.y, r: rad, fill: "none", stroke: color, "stroke-width": 1, opacity: 0.45 }, g);
        const name = `${ch.label}${ch.label ? ch.cp(i) : `p${i}`}`;
        if (i > 0) {
          const on = chosen.includes(i);
          if (on) svg("circle", { cx: sp.x, cy: sp.y, r: 10, fill: "none", stroke: "#5ef", "stroke-width": 2, class: "cp-ring" }, g);
          const hc = svg("circle", { cx: sp.x, cy: sp.y, r: 6, fill: on ? "#5ef" : "#222", stroke: color, "stroke-width": 2,
                                     class: on ? "handle cp-selected" : "handle", "data-handle": ch.pointHandle, "data-index": ch.cp(i) }, g);
          hc.append(Object.assign(document.createElementNS(SVGNS, "title"), {
            textContent: ch.label ? `corner point ccp[${ch.cp(i)}]: drag in the image plane, Shift+drag in depth`
                                  : `p${i}${on ? " (selected)" : ""}: drag in the image plane, Shift+drag in depth; in a drag mode Shift+click selects it` }));
          svg("text", { x: sp.x + 8, y: sp.y - 6, fill: color }, g).textContent = ch.label ? `ccp${ch.cp(i)}` : name;
        }
        const rh = svg("rect", { x: Rp.x - 4, y: Rp.y - 4, width: 8, height: 8, fill: "#222", stroke: color, "stroke-width": 1.5,
                                 class: "handle", "data-handle": ch.radiusHandle, "data-index": ch.r(i) }, g);
        rh.append(Object.assign(document.createElementNS(SVGNS, "title"), {
          textContent: `${ch.label ? `cr[${ch.r(i)}]` : `r${i}`} = ${r.toFixed(3)}: drag to change the tube radius` }));
      });
    }
    if (h.area) drawAreaHandles(l, h.area, color, g);
    // Axis: the light's direction (turning it turns the whole BendyLight tube). A point light
    // shines every way: no axis.
    if (l.type !== "point") line(h.position, h.axis, {});
    const A = Cam.project(h.axis);
    if (A.front && l.type !== "point") {
      const sa = toScreen(A);
      const ah = svg("circle", { cx: sa.x, cy: sa.y, r: 5, fill: color, stroke: "#000", "stroke-width": 1, class: "handle", "data-handle": "axis" }, g);
      ah.append(Object.assign(document.createElementNS(SVGNS, "title"), { textContent: "axis: drag to aim the light" }));
    }
    if (P.front) {
      const ph = svg("circle", { cx: ps.x, cy: ps.y, r: 7, fill: color, stroke: "#000", "stroke-width": 1.5, class: "handle", "data-handle": "position",
                                 "data-name": l.name }, g);
      ph.append(Object.assign(document.createElementNS(SVGNS, "title"), { textContent: `${l.name}: drag to move (Shift: in depth)` }));
      const who = others.length ? ` · ✎ ${others.map((c) => c.name).join(", ")}` : "";
      svg("text", { x: ps.x + 10, y: selectedLabelY ?? ps.y + 4, fill: color, "font-weight": "bold" }, g).textContent = l.name + who;
    }
    // Mark the handle another artist is dragging (their presence names it).
    for (const c of others) {
      const m = /\.cp\[(\d+)\]$/.exec(c.editing || "");
      if (m && h.points[Number(m[1])]) {
        const sp = toScreen(Cam.project(h.points[Number(m[1])]));
        svg("circle", { cx: sp.x, cy: sp.y, r: 11, fill: "none", stroke: clientColor(c.id), "stroke-width": 2, "stroke-dasharray": "4 2" }, g);
        svg("text", { x: sp.x - 10, y: sp.y + 22, fill: clientColor(c.id) }, g).textContent = c.name;
      }
    }
  }
  drawEdgeArrows(root, S.rig.lights.map(evaluated), lightColor);
}
