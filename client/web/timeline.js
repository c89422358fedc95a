// Time: the session clock (typed, scrubbed on the track, stepped from key to key) and the selected
// light's keys (set, delete, shown on the track).

import { nextSeq, send } from "./connection.js";
import { $, SVGNS, showMessage, svg } from "./dom.js";
import { TIME_KEY, canEdit, edit, flushLive } from "./edits.js";
import { parseNumber } from "./format.js";
import { refreshUi } from "./panels.js";
import { getProp } from "./rig.js";
import { S, evaluated, findLight } from "./state.js";

// What Set key records for a light: its animatable properties (and its chain's elements).
function keyableProps(l) {
  const props = ["intensity", "color"];
  if (l.type !== "directional") props.push("position");
  if (l.type === "spot" || l.type === "bendy") props.push("coneAngle", "penumbra");
  if (l.type !== "point") props.push("direction");
  if (l.type === "bendy") { // the chain of a light just made a BendyLight comes from the server
    for (let i = 1; i <= (l.controlPoints?.length ?? 0); i++) props.push(`cp[${i}]`);
    for (let i = 0; i < (l.radii?.length ?? 0); i++) props.push(`r[${i}]`);
  }
  return props;
}
export function renderKeyWhat() {
  const l = findLight(S.selected);
  const sel = $("keyWhat");
  const opts = l ? ["all", ...keyableProps(l)] : [];
  const sig = opts.join("|");
  if (sel.dataset.sig === sig) return;
  const keep = sel.value;
  sel.innerHTML = "";
  for (const o of opts) sel.append(new Option(o === "all" ? "all properties" : o, o));
  sel.dataset.sig = sig;
  sel.value = opts.includes(keep) ? keep : "all";
}
function keyTimes(l) {
  const ts = new Map(); // time -> [props]
  for (const [prop, ks] of Object.entries(l?.keys || {})) for (const k of ks) {
    const t = Number(k.t.toFixed(6));
    if (!ts.has(t)) ts.set(t, []);
    ts.get(t).push(prop);
  }
  return [...ts.entries()].sort((a, b) => a[0] - b[0]);
}
export function setKey() {
  const l = findLight(S.selected);
  if (!l) return;
  const e = evaluated(l);
  const what = $("keyWhat").value;
  const props = what === "all" ? keyableProps(l) : [what];
  edit(props.map((p) => ({ path: `${l.name}.key`, value: { path: p, t: S.rig.time, value: getProp(e, p), interp: $("keyInterp").value } })));
}
export function deleteKey() {
  const l = findLight(S.selected);
  if (!l) return;
  const changes = [];
  for (const [prop, ks] of Object.entries(l.keys || {})) {
    for (const k of ks) if (Math.abs(k.t - S.rig.time) < 1e-6) changes.push({ path: `${l.name}.unkey`, value: { path: prop, t: k.t } });
  }
  if (!changes.length) return showMessage(`${l.name} has no key at t = ${S.rig.time}`, "info");
  edit(changes);
}
function setTime(t, live) {
  if (!canEdit()) return;
  t = Math.max(0, Number(t.toFixed(3)));
  S.rig.time = t;
  if (live) {
    const q = S.live.queued || new Map();
    S.live.queued = q;
    q.set(TIME_KEY, { path: TIME_KEY, value: t });
    flushLive();
  } else {
    send({ type: "time", seq: nextSeq("time"), t });
  }
  refreshUi();
}
export function renderTimeline() {
  const track = $("track");
  const W = track.clientWidth || 600, H = 34;
  track.innerHTML = "";
  if (!S.rig) return;
  const l = findLight(S.selected);
  const keys = keyTimes(l);
  const last = keys.length ? keys[keys.length - 1][0] : 0;
  const end = Math.max(S.timeEnd, last, S.rig.time);
  const x = (t) => 8 + (W - 16) * t / end;
  for (let t = 0; t <= end + 1e-9; t += end > 20 ? 5 : end > 8 ? 1 : 0.5) {
    svg("line", { x1: x(t), y1: H - 8, x2: x(t), y2: H, stroke: "#555" }, track);
    if (Math.abs(t - Math.round(t)) < 1e-9) svg("text", { x: x(t) + 2, y: H - 1, fill: "#777", "font-size": 9 }, track).textContent = `${t}s`;
  }
  for (const [t, props] of keys) {
    const k = svg("path", { d: `M${x(t)},5 l6,7 l-6,7 l-6,-7z`, fill: "#f0b34a", stroke: "#000", class: "key", "data-t": t }, track);
    k.append(Object.assign(document.createElementNS(SVGNS, "title"), { textContent: `t = ${t}s: ${props.join(", ")}` }));
  }
  const cx = x(S.rig.time);
  svg("line", { x1: cx, y1: 0, x2: cx, y2: H, stroke: "#6cf", "stroke-width": 2, id: "playhead" }, track);
  if (document.activeElement !== $("timeN")) $("timeN").value = String(S.rig.time);
  track.dataset.end = end;
}
function trackTime(e) {
  const r = $("track").getBoundingClientRect();
  const end = Number($("track").dataset.end) || S.timeEnd;
  return Math.min(end, Math.max(0, (e.clientX - r.left - 8) / (r.width - 16) * end));
}
/** Moves the clock to the selected light's next (dir > 0) or previous key. */
export function stepKey(dir) {
  const keys = keyTimes(findLight(S.selected)).map((k) => k[0]);
  const t = S.rig.time;
  const next = dir > 0 ? keys.find((k) => k > t + 1e-6) : [...keys].reverse().find((k) => k < t - 1e-6);
  if (next !== undefined) setTime(next, false);
}

/** The track, the time fields and the key buttons. */
export function initTimeline() {
  let scrubbing = false;
  $("track").addEventListener("pointerdown", (e) => {
    if (!canEdit()) return showMessage(S.connected ? "viewers cannot change the session time" : "not connected");
    scrubbing = true;
    $("track").setPointerCapture(e.pointerId);
    // Clicking a key snaps to it.
    const t = e.target.classList.contains("key") ? Number(e.target.dataset.t) : trackTime(e);
    setTime(t, true);
  });
  $("track").addEventListener("pointermove", (e) => { if (scrubbing) setTime(trackTime(e), true); });
  $("track").addEventListener("pointerup", () => { scrubbing = false; });
  $("timeN").addEventListener("change", (e) => {
    const r = parseNumber(e.target.value, "time", 0, 1e6);
    if (r.error) { e.target.classList.add("bad"); return showMessage(r.error); }
    e.target.classList.remove("bad");
    setTime(r.value, false);
  });
  $("timeEnd").addEventListener("change", (e) => {
    const r = parseNumber(e.target.value, "timeline end", 0.1, 1e6);
    if (r.error) { e.target.classList.add("bad"); return showMessage(r.error); }
    e.target.classList.remove("bad");
    S.timeEnd = r.value;
    renderTimeline();
  });
  $("setKey").onclick = setKey;
  $("delKey").onclick = deleteKey;
  $("prevKey").onclick = () => stepKey(-1);
  $("nextKey").onclick = () => stepKey(1);
  new ResizeObserver(() => renderTimeline()).observe($("track"));
}
