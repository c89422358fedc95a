// The overlay: the selected light's handles (position, axis, BendyLight control points and tube
// radii, an area light's size and roll) and markers for the other lights, area lights' outlines,
// projected with the shot's camera and drawn as SVG in screen space; who else is dragging what.

import { areaFrame, areaHandles, areaOutline, cornerChains } from "./area.js";
import { Cam } from "./camera.js";
import { $, SVGNS, svg } from "./dom.js";
import { centreHandle, gizmoCurves, gizmoPlace } from "./envgizmo.js";
import { pointsSelectable, selectedPoints } from "./indirect.js";
import { V, bezier } from "./linalg.js";
import { selectLight } from "./panels.js";
import { clientColor, editorsOf } from "./presence.js";
import { frameToWorld, lightFrame } from "./rig.js";
import { S, evaluated, findLight } from "./state.js";
import { toScreen } from "./viewport.js";

/** Redraws the overlay at the next animation frame (once however often it is asked). */
export function scheduleOverlay() {
  if (scheduleOverlay.pending) return;
  scheduleOverlay.pending = true;
  requestAnimationFrame(() => { scheduleOverlay.pending = false; drawOverlay(); });
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

// The projected radius of a sphere of radius r at p: a circle around the handle.
function radiusHandlePoint(p, r) { return V.add(p, V.scale(Cam.right, r)); }

function drawOverlay() {
  const root = $("overlay");
  root.innerHTML = "";
  if (!S.rig || !Cam.W) return;
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
    const color = others.length ? clientColor(others[0].id) : selected ? "#f0b34a" : "#ccc";
    if (l.type === "environment") { drawEnvGizmo(l, color, selected, others, root); continue; }
    const h = handlesOf(l);
    const P = Cam.project(h.position);
    const ps = toScreen(P);
    if (h.area) drawAreaOutline(l, h.area, color, selected, root);
    if (!selected) {
      if (!P.front) continue;
      // Other lights: a small marker that selects them.
      const g = svg("g", { class: "pickable", "data-select": l.name }, root);
      svg("circle", { cx: ps.x, cy: ps.y, r: 5, fill: "none", stroke: color, "stroke-width": 1.5, opacity: l.enabled ? 1 : 0.5 }, g);
      svg("text", { x: ps.x + 8, y: labelY(ps.x + 8, ps.y + 4), fill: color }, g).textContent = l.name + (others.length ? ` (${others.map((c) => c.name).join(", ")})` : "");
      g.addEventListener("pointerdown", (e) => { e.stopPropagation(); selectLight(l.name); });
      continue;
    }
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
      const ph = svg("circle", { cx: ps.x, cy: ps.y, r: 7, fill: color, stroke: "#000", "stroke-width": 1.5, class: "handle", "data-handle": "position" }, g);
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
}
