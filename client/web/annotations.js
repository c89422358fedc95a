// Annotations on the frame (docs/browser-client.md "Annotations"; protocol: docs/protocol.md
// "Annotations"): pins with a comment and freehand strokes, in shot pixels, kept by the server
// with the session and shown to everyone in it as they are made. Anyone may annotate, resolve and
// reopen, viewers included (a review note is not an edit of the rig: no control here is
// data-edit but delete, which is the editors'). Drawn into their own group of the overlay
// (overlay.js calls drawAnnotations on every redraw, so they follow pan and zoom).

import { api } from "./connection.js";
import { Cam } from "./camera.js";
import { $, showMessage, svg } from "./dom.js";
import { canEdit } from "./edits.js";
import { scheduleOverlay } from "./overlay.js";
import { S } from "./state.js";
import { eventToImage, toScreen } from "./viewport.js";

const MAX_POINTS = 2000; // a stroke's, as the server allows (protocol::MAX_ANNOTATION_POINTS)
const A = {
  list: [],          // the session's annotations, as the server lists them
  tool: null,        // null, "pin" or "stroke"
  pending: null,     // a placed pin waiting for its comment: {x, y}
  stroke: null,      // the stroke being drawn: [[x, y], ...] in shot pixels
  highlight: null,   // the id clicked in the list or on the image
  showResolved: false,
};
export const annotationsState = () => A; // for the browser test

export function initAnnotations() {
  $("annoPin").onclick = () => setTool(A.tool === "pin" ? null : "pin");
  $("annoStroke").onclick = () => setTool(A.tool === "stroke" ? null : "stroke");
  $("annoShowResolved").onchange = () => { A.showResolved = $("annoShowResolved").checked; render(); scheduleOverlay(); };
  $("annoAdd").onclick = () => addPin();
  $("annoText").onkeydown = (e) => {
    if (e.key === "Enter") { e.preventDefault(); addPin(); }
    if (e.key === "Escape") { e.preventDefault(); cancelPin(); }
  };
  $("annoCancel").onclick = () => cancelPin();
  // Capture: while a tool is on, a press on the image is the tool's, not a pick, a pan or a
  // handle's drag (viewport.js listens on the same element after this).
  const vp = $("viewport");
  vp.addEventListener("pointerdown", (e) => {
    if (!A.tool || e.button !== 0 || !Cam.W) return;
    const p = clampToShot(eventToImage(e));
    if (!p) return;
    e.preventDefault();
    e.stopImmediatePropagation();
    if (A.tool === "pin") {
      A.pending = { x: p[0], y: p[1] };
      $("annoCommentRow").hidden = false;
      $("annoText").focus();
      scheduleOverlay();
      return;
    }
    A.stroke = [p];
    vp.setPointerCapture(e.pointerId);
  }, true);
  vp.addEventListener("pointermove", (e) => {
    if (!A.stroke) return;
    e.stopImmediatePropagation();
    const p = clampToShot(eventToImage(e), true);
    const last = A.stroke[A.stroke.length - 1];
    // A point every 2 screen pixels or so: smooth enough, far from the server's limit.
    if (Math.hypot(p[0] - last[0], p[1] - last[1]) * S.zoom >= 2) A.stroke.push(p);
    scheduleOverlay();
  }, true);
  const endStroke = (e) => {
    if (!A.stroke) return;
    e.stopImmediatePropagation();
    const points = thin(A.stroke);
    A.stroke = null;
    scheduleOverlay();
    if (points.length >= 2) create({ kind: "stroke", points, color: $("annoColor").value });
  };
  vp.addEventListener("pointerup", endStroke, true);
  vp.addEventListener("pointercancel", (e) => { if (A.stroke) { e.stopImmediatePropagation(); A.stroke = null; scheduleOverlay(); } }, true);
}

/** Turns the pin or stroke tool on ("pin", "stroke") or off (null). */
export function setTool(tool) {
  A.tool = tool;
  if (tool !== "pin") cancelPin();
  $("annoPin").classList.toggle("on", tool === "pin");
  $("annoStroke").classList.toggle("on", tool === "stroke");
  document.body.classList.toggle("annotating", !!tool);
}
export const annotationTool = () => A.tool;

/** After the welcome: the session's annotations (an `annotations` message keeps them current). */
export async function refreshAnnotations() {
  try { onAnnotations(await api("GET", "annotations")); } catch (e) { /* offline, or an older server */ }
}

/** An `annotations` message (or the GET answer): the whole list. */
export function onAnnotations(msg) {
  A.list = msg.annotations ?? [];
  if (A.highlight != null && !A.list.some((a) => a.id === A.highlight)) A.highlight = null;
  render();
  scheduleOverlay();
}

// A point of the image in shot pixels, or null outside it; `clamp` keeps a stroke that leaves
// the image on its edge. Rounded to 1/100 pixel: the list stays short to send.
function clampToShot(p, clamp = false) {
  if (!clamp && (p.x < 0 || p.y < 0 || p.x > Cam.W || p.y > Cam.H)) return null;
  const r = (v, hi) => Math.round(Math.min(Math.max(v, 0), hi) * 100) / 100;
  return [r(p.x, Cam.W), r(p.y, Cam.H)];
}
// At most MAX_POINTS, evenly kept, the last one always.
function thin(points) {
  if (points.length <= MAX_POINTS) return points;
  const step = points.length / (MAX_POINTS - 1);
  const out = [];
  for (let i = 0; i < MAX_POINTS - 1; i++) out.push(points[Math.floor(i * step)]);
  out.push(points[points.length - 1]);
  return out;
}

function cancelPin() {
  A.pending = null;
  $("annoCommentRow").hidden = true;
  $("annoText").value = "";
  scheduleOverlay();
}

async function addPin() {
  if (!A.pending) return showMessage("click the image where the pin goes first");
  const text = $("annoText").value.trim();
  if (!text) return showMessage("a pin needs a comment");
  const ok = await create({ kind: "pin", points: [[A.pending.x, A.pending.y]], text, color: $("annoColor").value });
  if (ok) cancelPin();
}

async function create(body) {
  try {
    const a = await api("POST", "annotations", body, { "X-Dfb-Name": S.name ?? "" });
    A.highlight = a.id;
    return true;
  } catch (e) {
    showMessage(`annotation: ${e.message}`);
    return false;
  }
}

async function act(method, resource, what) {
  try { await api(method, resource, undefined, { "X-Dfb-Name": S.name ?? "" }); } catch (e) { showMessage(`${what}: ${e.message}`); }
}

const when = (iso) => {
  const d = new Date(iso);
  return Number.isNaN(d.getTime()) ? iso : d.toLocaleString([], { month: "short", day: "numeric", hour: "2-digit", minute: "2-digit" });
};
const visible = (a) => A.showResolved || !a.resolved;
const colorOf = (a) => a.color ?? (a.kind === "pin" ? "#ffcc00" : "#ff5e5e");

function render() {
  const ul = $("annotationList");
  ul.innerHTML = "";
  for (const a of A.list) {
    if (!visible(a)) continue;
    const li = document.createElement("li");
    li.dataset.annotation = a.id;
    li.classList.toggle("resolved", a.resolved);
    li.classList.toggle("highlight", a.id === A.highlight);
    li.title = "Show it on the image";
    li.onclick = () => { A.highlight = A.highlight === a.id ? null : a.id; render(); scheduleOverlay(); };
    const swatch = Object.assign(document.createElement("span"), { className: "swatch", textContent: a.kind === "pin" ? "●" : "~" });
    swatch.style.color = colorOf(a);
    const text = document.createElement("div");
    text.className = "entry";
    text.append(Object.assign(document.createElement("div"), { className: "atext", textContent: a.text || "(stroke)" }),
                Object.assign(document.createElement("div"), {
                  className: "hint",
                  textContent: `#${a.id} · v${a.rigVersion} · ${a.by} · ${when(a.time)}${a.resolved ? ` · resolved by ${a.resolvedBy}` : ""}`,
                }));
    const actions = document.createElement("div");
    actions.className = "actions";
    const button = (label, title, onclick) => Object.assign(document.createElement("button"), {
      textContent: label, title, onclick: (e) => { e.stopPropagation(); onclick(); },
    });
    actions.append(a.resolved ? button("Reopen", "Mark it open again", () => act("POST", `annotations/${a.id}/reopen`, "reopen"))
                              : button("Resolve", "Mark it done (hidden unless “show resolved”)", () => act("POST", `annotations/${a.id}/resolve`, "resolve")));
    // Deleting is the editors' (viewers resolve instead): the page disables it for viewers.
    const del = button("×", "Delete this annotation (editors)", () => act("DELETE", `annotations/${a.id}`, "delete"));
    del.dataset.edit = "";
    del.disabled = !canEdit();
    actions.append(del);
    li.append(swatch, text, actions);
    ul.append(li);
  }
  const hidden = A.list.length - A.list.filter(visible).length;
  $("annoEmpty").hidden = A.list.length > 0;
  $("annoHidden").hidden = hidden === 0;
  $("annoHidden").textContent = `${hidden} resolved hidden`;
}

/** Draws the annotations into `root` (a group of the overlay), in screen space. */
export function drawAnnotations(root) {
  if (!Cam.W) return;
  const g = svg("g", { class: "annotations" }, root);
  const path = (pts) => pts.map((p, i) => { const s = toScreen({ x: p[0], y: p[1] }); return `${i ? "L" : "M"}${s.x.toFixed(1)},${s.y.toFixed(1)}`; }).join("");
  for (const a of A.list) {
    if (!visible(a)) continue;
    const hi = a.id === A.highlight;
    const item = svg("g", { class: `anno ${a.kind}${a.resolved ? " resolved" : ""}${hi ? " highlight" : ""}`, "data-annotation": a.id }, g);
    item.onclick = () => { A.highlight = hi ? null : a.id; render(); scheduleOverlay(); };
    const c = colorOf(a);
    if (a.kind === "stroke") {
      const d = path(a.points);
      if (hi) svg("path", { d, fill: "none", stroke: "#fff", "stroke-width": 6, "stroke-linecap": "round", "stroke-linejoin": "round", opacity: 0.6 }, item);
      svg("path", { d, fill: "none", stroke: c, "stroke-width": 2.5, "stroke-linecap": "round", "stroke-linejoin": "round" }, item);
      if (a.text) { const s = toScreen({ x: a.points[0][0], y: a.points[0][1] }); svg("text", { x: s.x + 6, y: s.y - 6, fill: c }, item).textContent = a.text; }
      continue;
    }
    // A pin: its point is the tip; the head sits above it, the comment beside the head.
    const s = toScreen({ x: a.points[0][0], y: a.points[0][1] });
    svg("path", { d: `M${s.x},${s.y}l-5,-11a6,6 0 1,1 10,0z`, fill: c, stroke: hi ? "#fff" : "#000", "stroke-width": hi ? 2 : 1 }, item);
    svg("text", { x: s.x + 9, y: s.y - 12, fill: c }, item).textContent = hi || a.text.length <= 40 ? a.text : `${a.text.slice(0, 39)}…`;
  }
  if (A.pending) {
    const s = toScreen(A.pending);
    svg("path", { d: `M${s.x},${s.y}l-5,-11a6,6 0 1,1 10,0z`, fill: "none", stroke: $("annoColor").value, "stroke-width": 2, "stroke-dasharray": "3 2", class: "anno-pending" }, g);
  }
  if (A.stroke?.length > 1) svg("path", { d: path(A.stroke), fill: "none", stroke: $("annoColor").value, "stroke-width": 2.5, "stroke-linecap": "round", class: "anno-drawing" }, g);
}
