// Indirect editing (docs/browser-client.md "Drag modes"; protocol: docs/protocol.md "Drags"):
// grab a feature of the image (a shadow point, a point of the beam, a highlight, a lit point)
// with the selected light and move it; the server solves for the light. The modes, their labels,
// keys and the light types they apply to are the server's (GET /v1/schema "dragModes", read by
// connection.js loadSchema): the selector and the shortcuts are built from that list, the page
// itself only adds "Direct handles" (the handles of drag.js).
//
// Pacing as for handle drags: the begin, then at most one update in flight; the newest pointer
// position waits for the previous answer (ack or error). The pointer's release sends `end` once
// nothing is in flight, Escape sends `cancel` (the server puts the light back).
//
// Control-point selection (paper 000 section 5, last paragraph; Kasai et al. 4.2.1): in a mode the
// schema marks `selectable`, Shift+click on a BendyLight's control-point handle (or its button in
// the drag toolbar) adds or removes it; a drag then sends the selection as the begin's `points`
// (cp indices 1..2K) and the server moves only those. The selection belongs to one light: it is
// dropped when another light is selected or the light's segment count changes.

import { nextSeq, scheduleRefetch, send } from "./connection.js";
import { $, showMessage } from "./dom.js";
import { canEdit, setPresence } from "./edits.js";
import { scheduleOverlay } from "./overlay.js";
import { S, evaluated, findLight } from "./state.js";

export const DIRECT = "direct"; // the page's own mode: drag the handles
const DIRECT_KEY = "d";

let modes = []; // the schema's dragModes
/** Takes GET /v1/schema's dragModes (absent on an older server: direct handles only). */
export function setDragModes(list) {
  modes = Array.isArray(list) ? list.filter((m) => m && typeof m.name === "string") : [];
  if (S.dragMode !== DIRECT && !modes.some((m) => m.name === S.dragMode)) S.dragMode = DIRECT;
  renderDragModes(true);
}
export const dragModeInfo = (name) => modes.find((m) => m.name === name) ?? null;

// ---- control-point selection ---------------------------------------------------------------

// The light it was made on (name), its number of control points (2K) and the sorted cp indices.
const NO_POINTS = { light: null, count: 0, points: [] };
/** The selected control points of the selected light (sorted cp indices 1..2K; [] for none). */
export function selectedPoints() {
  const sel = S.cpSelection;
  const l = findLight(S.selected);
  const count = l?.type === "bendy" ? l.controlPoints?.length ?? 0 : 0;
  if (sel.points.length && (sel.light !== l?.name || sel.count !== count)) S.cpSelection = { ...NO_POINTS };
  return S.cpSelection.points;
}
/** Whether control points can be chosen now: a `selectable` mode and a BendyLight with a chain. */
export function pointsSelectable() {
  const m = dragModeInfo(S.dragMode);
  const l = findLight(S.selected);
  return !!(m?.selectable && l?.type === "bendy" && l.controlPoints?.length);
}
/** Adds control point i (1..2K) of the selected light to the selection, or removes it. */
export function togglePoint(i) {
  const l = findLight(S.selected);
  if (!pointsSelectable() || !(i >= 1 && i <= l.controlPoints.length)) return false;
  const now = selectedPoints();
  const points = now.includes(i) ? now.filter((p) => p !== i) : [...now, i].sort((a, b) => a - b);
  S.cpSelection = { light: l.name, count: l.controlPoints.length, points };
  renderDragModes();
  scheduleOverlay();
  return true;
}
export function clearPoints() {
  S.cpSelection = { ...NO_POINTS };
  renderDragModes();
  scheduleOverlay();
}

// The toolbar's list: one toggle per control point of the selected BendyLight, and Clear.
function renderPoints() {
  const box = $("dragPoints");
  if (!box) return;
  const l = findLight(S.selected);
  const chosen = selectedPoints();
  if (!pointsSelectable()) { box.replaceChildren(); delete box.dataset.sig; box.hidden = true; return; }
  box.hidden = false;
  const n = l.controlPoints.length;
  if (box.dataset.sig !== `${l.name}|${n}`) {
    box.dataset.sig = `${l.name}|${n}`;
    const label = Object.assign(document.createElement("span"), { className: "hint", id: "dragPointsLabel" });
    box.replaceChildren(label);
    for (let i = 1; i <= n; i++) {
      const b = Object.assign(document.createElement("button"), { textContent: `p${i}`, title: `Move only the selected control points (Shift+click a handle, or here); p${i} of ${l.name}` });
      b.dataset.point = String(i);
      b.onclick = () => togglePoint(i);
      box.append(b);
    }
    const clear = Object.assign(document.createElement("button"), { textContent: "Clear", id: "dragPointsClear", title: "No selection: the drag moves the whole light" });
    clear.onclick = clearPoints;
    box.append(clear);
  }
  for (const b of box.querySelectorAll("button[data-point]")) b.classList.toggle("on", chosen.includes(Number(b.dataset.point)));
  $("dragPointsClear").disabled = !chosen.length;
  $("dragPointsLabel").textContent = chosen.length ? `points ${chosen.map((i) => `p${i}`).join(", ")}:` : "points: all (Shift+click handles to choose)";
}

const typeLabel = (t) => (t === "bendy" ? "BendyLight" : `${t} light`);
/** Why `mode` cannot be used on the selected light now, or null. */
function refusal(mode, l = findLight(S.selected)) {
  if (!l) return "select a light first";
  if (!mode.lights.includes(l.type)) return `${mode.label} does not apply to ${typeLabel(l.type)} '${l.name}' (it works on: ${mode.lights.join(", ")})`;
  return null;
}

/** The selector's options: direct handles and the schema's modes (those not for this light disabled). */
export function renderDragModes(rebuild = false) {
  const sel = $("dragMode");
  if (!sel) return;
  if (rebuild || sel.options.length !== modes.length + 1) {
    sel.innerHTML = "";
    const direct = new Option(`Direct handles (${DIRECT_KEY.toUpperCase()})`, DIRECT);
    direct.title = "Drag the light's handles: its position, axis, control points and radii";
    sel.append(direct);
    for (const m of modes) {
      const o = new Option(`${m.label}${m.shortcut ? ` (${m.shortcut.toUpperCase()})` : ""}`, m.name);
      o.title = `${m.doc}. Grab ${m.needsOccluder ? "a shadowed pixel" : "a lit pixel"}; for ${m.lights.join(", ")} lights (${m.source})`;
      sel.append(o);
    }
  }
  const l = findLight(S.selected);
  for (const o of sel.options) {
    const m = dragModeInfo(o.value);
    o.disabled = !!(m && l && !m.lights.includes(l.type));
  }
  sel.value = S.dragMode;
  const m = dragModeInfo(S.dragMode);
  sel.title = m ? `${m.label}: ${m.doc} (key ${m.shortcut.toUpperCase()})` : "How a drag on the image edits the selected light (keys: D, then each mode's letter)";
  const why = m ? refusal(m, l) : null;
  $("dragHint").textContent = !m ? "" : why ? `⚠ ${why}` : `drag from ${m.needsOccluder ? "a shadowed" : "a lit"} pixel`;
  $("dragHint").classList.toggle("warn", !!why);
  document.body.classList.toggle("dragmode", !!m);
  renderPoints();
}

/** Chooses a mode (DIRECT or a schema name); refuses one that does not apply to the selected light. */
export function setDragMode(name, { fromKey = false } = {}) {
  const m = dragModeInfo(name);
  if (name !== DIRECT && !m) return false;
  if (m && fromKey) {
    const why = refusal(m);
    if (why) { showMessage(why); return false; }
  }
  S.dragMode = name;
  renderDragModes();
  scheduleOverlay(); // the selected control points are drawn in the modes that use them
  return true;
}
/** A plain key (no modifier, not while typing): "d" or a schema mode's shortcut. */
export function dragModeKey(key) {
  if (key === DIRECT_KEY) return setDragMode(DIRECT), true;
  const m = modes.find((x) => x.shortcut && x.shortcut === key);
  if (!m) return false;
  setDragMode(m.name, { fromKey: true });
  return true;
}
export const indirectActive = () => dragModeInfo(S.dragMode) !== null;

// ---- one drag -------------------------------------------------------------------------------

/**
 * Starts a drag of the current mode at image pixel (x, y) (integers, row 0 at the top). False
 * (with a message) when it cannot start.
 */
export function beginIndirect(x, y, pointer) {
  const m = dragModeInfo(S.dragMode);
  if (!m) return false;
  if (!canEdit()) { showMessage(S.connected ? "viewers cannot move lights (this page was opened with a viewer link)" : "not connected"); return false; }
  const l = findLight(S.selected);
  const why = refusal(m, l);
  if (why) { showMessage(why); return false; }
  if (S.indirect) cancelIndirect(); // a begin ends the drag before anyway
  const points = m.selectable && l.type === "bendy" ? selectedPoints().slice() : [];
  const d = { mode: m.name, light: l.name, points, x, y, pointer, sentAt: [x, y], grab: null, refused: false, inFlight: true, queued: null, ending: false,
              updates: 0, changed: 0, lastError: null, solveMs: null, shownErrors: new Set() };
  S.indirect = d;
  const msg = { type: "drag", seq: 0, phase: "begin", mode: m.name, light: l.name, x, y };
  if (points.length) msg.points = points; // only these control points move (absent: the whole light)
  msg.seq = track(d, "begin");
  if (!send(msg)) { S.indirect = null; showMessage("not connected: the drag was not sent"); return false; }
  showInfo(`${m.label}: grabbing (${x}, ${y})${points.length ? ` with ${points.map((i) => `p${i}`).join(", ")}` : ""}…`);
  scheduleOverlay();
  return true;
}

/** The pointer moved to pixel (x, y): sent now, or when the update in flight is answered. */
export function moveIndirect(x, y, pointer) {
  const d = S.indirect;
  if (!d || d.refused) return;
  d.pointer = pointer;
  scheduleOverlay();
  const last = d.queued ?? d.sentAt;
  if (last && last[0] === x && last[1] === y) return;
  d.queued = [x, y];
  flush(d);
}
/** The pointer was released: the newest position is sent, then `end`. */
export function endIndirect() {
  const d = S.indirect;
  if (!d) return;
  d.ending = true;
  flush(d);
}
/** Escape: `cancel` now (the server restores the light as it was at the begin). */
export function cancelIndirect() {
  const d = S.indirect;
  if (!d) return false;
  d.queued = null;
  if (!d.refused) { const seq = track(d, "cancel"); send({ type: "drag", seq, phase: "cancel" }); }
  finish(d, "cancelled");
  return true;
}

function flush(d) {
  if (d.inFlight || d.done) return;
  if (d.refused) { if (d.ending) finish(d, null); return; }
  if (d.queued) {
    const [x, y] = d.queued;
    d.queued = null;
    d.sentAt = [x, y];
    d.inFlight = true;
    const seq = track(d, "update");
    if (!send({ type: "drag", seq, phase: "update", x, y })) { d.inFlight = false; finish(d, null); }
    return;
  }
  if (d.ending) {
    const seq = track(d, "end");
    send({ type: "drag", seq, phase: "end" });
    finish(d, "ended");
  }
}

function finish(d, how) {
  d.done = true;
  if (S.indirect === d) S.indirect = null;
  S.lastIndirect = { mode: d.mode, light: d.light, points: d.points, x: d.x, y: d.y, grab: d.grab, refused: d.refused, updates: d.updates,
                     changed: d.changed, lastError: d.lastError, ended: how };
  if (how) {
    const m = dragModeInfo(d.mode);
    showInfo(`${m?.label ?? d.mode} ${how}: ${d.changed} change${d.changed === 1 ? "" : "s"}${d.solveMs !== null ? ` · last solve ${d.solveMs.toFixed(1)} ms` : ""}`);
  }
  setPresence(null);
  scheduleRefetch(200);
  scheduleOverlay();
}

// A drag message's sequence number, with what to do with its answer (connection.js onAck/onError
// call the pending entry's onAck/onError).
function track(d, phase) {
  const seq = nextSeq("drag");
  const p = S.pending.get(seq);
  p.onAck = (msg) => answered(d, phase, msg, null);
  p.onError = (msg) => answered(d, phase, null, msg);
  return seq;
}
function answered(d, phase, ack, err) {
  if (err) {
    d.lastError = `${err.code}: ${err.message}`;
    if (phase === "begin") d.refused = true;
    // One message per distinct error in a drag (the pointer over the background repeats it).
    if (!d.shownErrors.has(d.lastError)) { d.shownErrors.add(d.lastError); showMessage(d.lastError); }
  } else if (phase === "begin") {
    d.grab = ack.drag ?? null;
  } else if (phase === "update") {
    d.updates++;
    if (ack.drag?.changed !== false) d.changed++;
    if (typeof ack.drag?.solveMs === "number") d.solveMs = ack.drag.solveMs;
    // The server sends the solved light to the others, not to us: read it back.
    scheduleRefetch(0);
  }
  if (phase === "begin" || phase === "update") {
    d.inFlight = false;
    if (S.indirect === d) {
      if (phase === "begin" && !err) showInfo(`${dragModeInfo(d.mode)?.label ?? d.mode}: grabbed (${d.x}, ${d.y}) on ${d.light}`);
      flush(d);
    } else if (d.ending && !d.done) {
      flush(d);
    }
  }
  scheduleOverlay();
}

function showInfo(text) { const el = $("dragInfo"); if (el) el.textContent = text; }

/** The light as the page holds it, for the cue's label. */
export const indirectLight = () => (S.indirect ? evaluated(findLight(S.indirect.light)) : null);

/** The connection was lost: the server forgets the drag with the connection. */
export function abortIndirect() {
  const d = S.indirect;
  if (!d) return;
  d.queued = null;
  d.done = true;
  S.indirect = null;
  scheduleOverlay();
}
