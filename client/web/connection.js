// The connection to the server (protocol v1, docs/protocol.md): the WebSocket (hello with the
// name, welcome, acks, changes, errors, presence, picks and binary frames; reconnect with
// back-off) and the plain HTTP endpoints of the session (the rig, history, whole-rig replacement).

import { Cam } from "./camera.js";
import { $, showMessage } from "./dom.js";
import { flushLive, sendView, applyChange } from "./edits.js";
import { endDrag } from "./drag.js";
import { onFinal, onLiveFrame, refreshFinal } from "./final.js";
import { refreshHistoryList } from "./history.js";
import { onAnnotations, refreshAnnotations } from "./annotations.js";
import { onLibrary, refreshLibrary } from "./library.js";
import { abortIndirect, setDragModes } from "./indirect.js";
import { scheduleOverlay } from "./overlay.js";
import { refreshUi, renderLights, renderView, setRig, updateEditable } from "./panels.js";
import { renderClients, renderShare } from "./presence.js";
import { setSchema } from "./rig.js";
import { S, findLight } from "./state.js";
import { frameLights, handlesOutOfView, onPick, zoomNative } from "./viewport.js";

function wsUrl() {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  return `${scheme}://${location.host}/v1/sessions/${encodeURIComponent(S.sessionId)}/ws?token=${encodeURIComponent(S.token)}`;
}
/** Sends one message; false when not connected. */
export function send(msg) {
  if (!S.ws || S.ws.readyState !== WebSocket.OPEN) return false;
  S.ws.send(JSON.stringify(msg));
  return true;
}
function setStatus(text, cls) {
  $("status").textContent = text;
  $("status").className = cls;
}

/** Opens the WebSocket of the page's session (and again after every loss of it). */
export function connect() {
  if (!S.sessionId || !S.token) {
    // Nothing to retry: say what to open instead of "Disconnected".
    setStatus("no session", "disconnected");
    $("offlineTitle").textContent = "This address opens no session";
    $("retryText").textContent = "Open the editor or viewer link dfb-server printed when it started: it ends in ?session=…&token=…";
    return;
  }
  const ws = new WebSocket(wsUrl());
  ws.binaryType = "arraybuffer";
  S.ws = ws;
  ws.onopen = () => send({ type: "hello", protocol: 1, name: S.name });
  ws.onmessage = (ev) => {
    if (typeof ev.data === "string") {
      let msg;
      try { msg = JSON.parse(ev.data); } catch { return showMessage(`server sent a text message that is not JSON: ${ev.data.slice(0, 200)}`); }
      onText(msg);
    } else {
      onFrame(ev.data);
    }
  };
  ws.onclose = (ev) => {
    if (S.ws !== ws) return;
    const wasConnected = S.connected;
    S.connected = false;
    S.ws = null;
    S.pending.clear();
    S.live = { inFlight: false, queued: null };
    S.clients = []; // presence is unknown until the welcome
    renderClients();
    renderLights();
    if (S.drag) endDrag(null);
    abortIndirect();
    document.body.classList.add("offline");
    // Back off from 0.5 s to 5 s so that a restarting server is found quickly but not hammered.
    const delay = Math.min(5000, 500 * 2 ** Math.min(S.attempts, 4));
    S.attempts++;
    setStatus("disconnected", "disconnected");
    $("offlineTitle").textContent = "Disconnected from the server";
    $("retryText").textContent = `${wasConnected ? "The connection was lost" : "Cannot reach the server"}` +
      `${ev.code && ev.code !== 1006 ? ` (code ${ev.code})` : ""}. Reconnecting (attempt ${S.attempts})…`;
    updateEditable();
    setTimeout(connect, delay);
  };
}

function onText(msg) {
  switch (msg.type) {
  case "welcome": return onWelcome(msg);
  case "ack": return onAck(msg);
  case "change": return onChange(msg);
  case "error": return onError(msg);
  case "presence": S.clients = msg.clients; renderClients(); renderLights(); scheduleOverlay(); return;
  case "pick": return onPick(msg);
  case "final": return onFinal(msg);
  case "library": return onLibrary(msg);
  case "annotations": return onAnnotations(msg);
  default: return; // newer servers may add message types: ignore what we do not know
  }
}

function onWelcome(msg) {
  S.connected = true;
  S.attempts = 0;
  S.clientId = msg.client;
  S.role = msg.role;
  S.session = msg.session;
  S.history = msg.history || { undo: 0, redo: 0 };
  S.clients = msg.clients || [];
  S.viewerToken = msg.viewerToken ?? null; // editors only
  Cam.set(msg.session);
  document.body.classList.remove("offline");
  document.body.classList.toggle("viewer", S.role !== "editor");
  setStatus(`connected · ${S.role}`, "connected");
  $("sessionName").textContent = `${msg.sessionId} · ${msg.session.width}×${msg.session.height}`;
  $("frame").width = msg.session.width;
  $("frame").height = msg.session.height;
  setRig(msg.rig);
  if (!S.schemaLoaded) loadSchema().then((ok) => ok && refreshUi(true)); // the server was down when the page asked
  // The first load shows the image at native size, or, when a light's handle would be outside
  // the viewport there, the image and every light's handles (handles out of reach cannot be
  // grabbed). Reconnecting keeps the artist's zoom.
  if (!S.fitted) { S.fitted = true; zoomNative(); if (handlesOutOfView()) frameLights(); }
  // A reconnect keeps this page's own view (the server starts every client on its default view).
  const view = {};
  if (S.viewChanged && msg.view.output !== S.view.output && (S.view.output === "beauty" || findLight(S.view.output.split(":")[1]) || S.view.output.startsWith("layer:"))) view.output = S.view.output;
  if (S.viewChanged && msg.view.exposure !== S.view.exposure) view.exposure = S.view.exposure;
  if (S.viewChanged && msg.view.viewTransform !== S.view.viewTransform) view.viewTransform = S.view.viewTransform;
  if (S.viewChanged && (msg.view.background ?? false) !== (S.view.background ?? false)) view.background = S.view.background;
  if (Object.keys(view).length) sendView(view);
  else S.view = { ...S.view, ...msg.view };
  S.shownOutput = msg.view.output;
  renderView();
  renderClients();
  renderShare();
  updateEditable();
  refreshHistory();
  refreshFinal();
  refreshLibrary();
  refreshAnnotations();
}

/** A new sequence number for a message, remembered until its ack or error. */
export function nextSeq(kind, live = false, version = null) {
  const seq = ++S.seq;
  S.pending.set(seq, { t: performance.now(), kind, live, version });
  return seq;
}

function onAck(msg) {
  const p = S.pending.get(msg.seq);
  S.pending.delete(msg.seq);
  if (msg.view) {
    // Frames after this ack are in this view (the server sends text before frames).
    S.view = { ...S.view, ...msg.view };
    S.shownOutput = msg.view.output;
    renderView();
  }
  if (!p) return;
  if (p.kind !== "view") {
    for (const c of p.renames || []) applyChange(S.rig, c, true);
    if (p.renames?.length) refreshUi(true);
    S.latencyByVersion.set(msg.rigVersion, p.t);
    if (S.rig) S.rig.version = Math.max(S.rig.version, msg.rigVersion);
    // The server reports every newer change to the same property; our own earlier, not yet
    // acknowledged edits are among them and are no news.
    const others = (msg.overwrote || []).filter((o) => o.by !== S.clientId);
    if (others.length) {
      const who = (id) => S.clients.find((c) => c.id === id)?.name ?? (id ? `client ${id}` : "http");
      showMessage(`your edit overwrote changes made meanwhile: ${others.map((o) => `${o.path} by ${who(o.by)} (v${o.version})`).join(", ")}`, "info");
    }
    // A chain change that would have folded a BendyLight's tube stopped short of the fold: the
    // server's values replace ours (the handle lands where it stopped) and the page says why.
    if (msg.limited?.length) {
      for (const l of msg.limited) for (const c of l.changes) applyChange(S.rig, c, true);
      // Once per drag: every step past the fold is limited again.
      const g = p.live ? S.live.gesture : null;
      if (!g?.limitShown) showMessage(msg.limited.map((l) => l.message).join("; "), "info");
      if (g) g.limitShown = true;
      refreshUi();
    }
    refreshHistory();
  }
  if (p.live) { S.live.inFlight = false; flushLive(); }
  p.onAck?.(msg); // a drag's phases (indirect.js)
  // Undo and redo change what only the server knows (the change goes to the others, not to us).
  if (p.refetch || msg.kind) scheduleRefetch(0);
}

function onChange(msg) {
  if (!S.rig) return;
  if (msg.rig) {
    setRig(msg.rig);
  } else {
    let complete = true;
    for (const c of msg.changes) complete = applyChange(S.rig, c, true) && complete;
    S.rig.version = Math.max(S.rig.version, msg.rigVersion);
    if (!complete) scheduleRefetch(); else scheduleRefetch(1500); // warnings are the server's
    refreshUi();
  }
  refreshHistory();
}

function onError(msg) {
  const p = msg.seq !== undefined ? S.pending.get(msg.seq) : null;
  if (p) S.pending.delete(msg.seq);
  if (p?.onError) p.onError(msg); // a drag's phases (indirect.js) show their own
  else showMessage(`${msg.code}: ${msg.message}`);
  if (p?.live) { S.live.inFlight = false; flushLive(); }
  // Our optimistic copy may now be wrong: take the server's.
  if (p && p.kind !== "view" && p.kind !== "pick") scheduleRefetch(0);
}

// Frames: a 32-byte header (docs/protocol.md "Frames"), then JPEG/PNG bytes.
function onFrame(buf) {
  if (buf.byteLength < 32) return;
  const view = new DataView(buf);
  const magic = String.fromCharCode(...new Uint8Array(buf, 0, 4));
  if (magic !== "DFBF") return;
  const encoding = view.getUint16(6, true);
  if (encoding === 3) return showMessage("the server sent an EXR frame, which a browser cannot show");
  const rigVersion = Number(view.getBigUint64(16, true));
  const w = view.getUint32(24, true), h = view.getUint32(28, true);
  const blob = new Blob([new Uint8Array(buf, 32)], { type: encoding === 2 ? "image/png" : "image/jpeg" });
  const url = URL.createObjectURL(blob);
  const img = $("frame");
  const output = S.shownOutput;
  img.onload = () => {
    if (S.objectUrl) URL.revokeObjectURL(S.objectUrl);
    S.objectUrl = url;
    img.dataset.rigVersion = rigVersion;
    img.dataset.output = output;
    onLiveFrame();
  };
  img.src = url;
  if (w !== S.frameSize[0] || h !== S.frameSize[1]) { S.frameSize = [w, h]; img.width = w; img.height = h; }
  const now = performance.now();
  S.frameTimes.push(now);
  while (S.frameTimes.length && now - S.frameTimes[0] > 2000) S.frameTimes.shift();
  // Latency: from sending an edit to the first frame showing it (or a later version).
  for (const [v, t] of S.latencyByVersion) {
    if (v <= rigVersion) { S.latency = now - t; S.latencyByVersion.delete(v); }
  }
  S.frameVersion = rigVersion;
  renderStats();
}

export function renderStats() {
  const now = performance.now();
  const recent = S.frameTimes.filter((t) => now - t <= 1000).length;
  // The rate only while frames arrive: an idle session is not "0 fps".
  $("stats").textContent = `${recent > 0 ? `${recent} fps · ` : ""}latency ${S.latency === null ? "–" : `${Math.round(S.latency)} ms`}` +
    ` · rig v${S.rig?.version ?? "–"} · frame v${S.frameVersion} · ${S.frameSize[0]}×${S.frameSize[1]}`;
}

// The server's rig, read over HTTP: after changes whose effect only the server computes (a new
// chain, resampled radii, warnings) and after refused edits. Never while dragging (it would
// snap the handle back to an older position); the drag's end asks again.
export function scheduleRefetch(delay = 150) {
  clearTimeout(S.refetchTimer);
  S.refetchTimer = setTimeout(refetchRig, delay);
}
async function refetchRig() {
  // Not while our own edits are unacknowledged either: the server's copy would lack them.
  // (A drag's messages are not applied here: the server's rig is the news.)
  const unacked = [...S.pending.values()].some((p) => p.kind !== "view" && p.kind !== "pick" && p.kind !== "drag");
  if (S.drag || S.live.inFlight || S.live.queued || unacked) return scheduleRefetch(300);
  try {
    const r = await api("GET", "rig");
    if (!S.drag && r.version >= (S.rig?.version ?? 0)) setRig(r);
  } catch (e) { /* offline: the welcome will bring the rig */ }
}
export async function refreshHistory() {
  clearTimeout(refreshHistory.timer);
  refreshHistory.timer = setTimeout(async () => {
    try {
      const info = await api("GET", "");
      S.history = info.history;
      updateEditable();
      refreshHistoryList();
    } catch (e) { /* offline */ }
  }, 100);
}

// The parsed JSON of a response, or an Error carrying the server's error verbatim and the status.
async function jsonOf(res) {
  const text = await res.text();
  let j = null;
  try { j = JSON.parse(text); } catch { /* not JSON */ }
  if (!res.ok) {
    const err = new Error(j?.message ? `${j.code}: ${j.message}` : `HTTP ${res.status}: ${text.slice(0, 200)}`);
    err.status = res.status;
    throw err;
  }
  return j;
}

/** A plain HTTP endpoint of the session (docs/protocol.md "HTTP"), with the page's token. */
export async function api(method, resource, body, headers = {}) {
  const url = `/v1/sessions/${encodeURIComponent(S.sessionId)}${resource ? `/${resource}` : ""}`;
  return jsonOf(await fetch(url, {
    method, headers: { Authorization: `Bearer ${S.token}`, ...(body ? { "Content-Type": "application/json" } : {}), ...headers },
    body: body ? JSON.stringify(body) : undefined,
  }));
}

/**
 * Reads GET /v1/schema (public, the same for every session) into the rig model (rig.js
 * setSchema), where the panels' rows and the value ranges come from. True once it has; until
 * then the model knows no property (the welcome asks again).
 */
export async function loadSchema() {
  try {
    const schema = await jsonOf(await fetch("/v1/schema"));
    if (schema?.schema !== 1 || !Array.isArray(schema.light)) return false; // a version this page does not read
    setSchema(schema);
    setDragModes(schema.dragModes); // the drag-mode selector and its keys
    S.schemaLoaded = true;
    return true;
  } catch (e) {
    return false; // unreachable: the welcome asks again
  }
}
