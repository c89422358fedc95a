// Edits. Discrete edits (typed values, checkboxes, the end of a drag) go out at once; live edits
// (a slider or a handle being dragged) keep one message in flight and send only the newest value
// when it is acknowledged, so the server is never flooded and frames follow the pointer.
// Whole-rig operations (add, duplicate, delete a light) are a conditional PUT of the rig.

import { Cam } from "./camera.js";
import { api, nextSeq, send } from "./connection.js";
import { $, showMessage } from "./dom.js";
import { V } from "./linalg.js";
import { refreshUi, renderView } from "./panels.js";
import { applyLocal, clone, lightRow, uniqueName } from "./rig.js";
import { S, findLight } from "./state.js";

export const canEdit = () => S.connected && S.role === "editor";

/**
 * Applies a change to the page's copy of the rig (rig.js applyLocal); an accepted rename also
 * renames the selection and a solo output of the light.
 */
export function applyChange(rig, c, authoritative = false) {
  return applyLocal(rig, c, {
    authoritative,
    onRename: (from, to) => {
      if (S.selected === from) S.selected = to;
      if (S.view.output.endsWith(`:${from}`)) S.view.output = S.view.output.replace(`:${from}`, `:${to}`);
    },
  });
}

/** Sends `changes` as one edit (applied here at once); live: the newest value of a gesture. */
export function edit(changes, { live = false, refetch = false } = {}) {
  if (!canEdit()) { showMessage(S.connected ? "viewers cannot change the rig" : "not connected: the edit was not sent"); return false; }
  let complete = true;
  for (const c of changes) complete = applyChange(S.rig, c) && complete;
  if (live) {
    // Merge with a queued live edit so that no path's newest value is lost.
    const q = S.live.queued || new Map();
    for (const c of changes) q.set(c.path, c);
    S.live.queued = q;
    S.live.gesture = S.gesture; // kept past the gesture's end for its last, still queued step
    flushLive();
  } else {
    const seq = nextSeq("edit", false);
    S.pending.get(seq).refetch = refetch || !complete;
    S.pending.get(seq).renames = changes.filter((c) => c.path.endsWith(".name"));
    send({ type: "edit", seq, base: S.rig.version, changes });
  }
  refreshUi();
  return true;
}

export const TIME_KEY = "\u0000time"; // the clock rides the live queue as a pseudo-path
/** Sends the queued live edit (or clock) unless one is still in flight. */
export function flushLive() {
  if (S.live.inFlight || !S.live.queued) return;
  const q = S.live.queued;
  if (q.has(TIME_KEY)) {
    const t = q.get(TIME_KEY).value;
    q.delete(TIME_KEY);
    if (!q.size) S.live.queued = null;
    const tseq = nextSeq("time", true);
    S.live.inFlight = true;
    if (!send({ type: "time", seq: tseq, t })) S.live.inFlight = false;
    return;
  }
  const changes = [...q.values()];
  S.live.queued = null;
  const seq = nextSeq("edit", true);
  S.live.inFlight = true;
  const msg = { type: "edit", seq, base: S.rig.version, changes };
  // The steps of one gesture after the first are merged into one undo step by the server.
  const g = S.live.gesture;
  if (g) { if (g.sent) msg.merge = true; g.sent = true; }
  if (!send(msg)) S.live.inFlight = false;
}
// A gesture is one drag of a handle or a slider: one undo step however many edits it sends.
export function beginGesture() { S.gesture = { sent: false }; }
export function endGesture() { S.gesture = null; }

// Sets a light property as the artist means it: where the property is keyframed the change is a
// key at the current time (otherwise the keys would override it and nothing would seem to happen).
export function setLightProp(name, prop, value, opts) {
  // With several lights selected (S.also), an edit of the primary one's property is made to each
  // of them that has it (its type's rows; not element rows, whose indices differ per light): one
  // edit, one undo step.
  const names = [name];
  const row = lightRow(prop);
  if (name === S.selected && row && !row.indexOf) {
    for (const n of S.also) {
      const o = findLight(n);
      if (o && n !== name && (!row.appliesTo || row.appliesTo.includes(o.type))) names.push(n);
    }
  }
  const changes = names.map((n) => {
    const l = findLight(n);
    if (l?.keys?.[prop]?.length) {
      const existing = l.keys[prop].find((k) => Math.abs(k.t - S.rig.time) < 1e-9);
      return { path: `${n}.key`, value: { path: prop, t: S.rig.time, value, interp: existing?.interp ?? $("keyInterp").value } };
    }
    return { path: `${n}.${prop}`, value };
  });
  return edit(changes, opts);
}

/** This page's own view settings (output, exposure, transform): the server renders each view. */
export function sendView(settings) {
  S.viewChanged = true;
  const seq = nextSeq("view");
  send({ type: "view", seq, ...settings });
  S.view = { ...S.view, ...settings };
  renderView();
}
export function sendViewThrottled(settings) {
  clearTimeout(sendViewThrottled.t);
  sendViewThrottled.t = setTimeout(() => sendView(settings), 60);
}

export function undo() { if (canEdit()) send({ type: "undo", seq: nextSeq("undo") }); }
export function redo() { if (canEdit()) send({ type: "redo", seq: nextSeq("redo") }); }

/** What this page manipulates now (a path or a light; null for nothing), shown to the others. */
export function setPresence(editing) { send({ type: "presence", editing }); }

// Whole-rig operations (add, duplicate, delete) are a PUT of the rig, conditional on its version:
// v1 has no per-light add/delete message. The server broadcasts the new rig to everyone.
// `mutate` may name the light to select afterwards in S.selectAfterPut (panels.js setRig selects
// it when a rig that has it arrives); a refused PUT forgets it.
async function replaceRig(mutate) {
  if (!canEdit()) return;
  for (let attempt = 0; attempt < 3; attempt++) {
    try {
      const rig = await api("GET", "rig");
      const next = mutate(clone(rig));
      if (!next) return;
      delete next.version;
      for (const l of next.lights) delete l.warning;
      await api("PUT", "rig", next, { "If-Match": `"${rig.version}"` });
      return;
    } catch (e) {
      if (e.status === 412) continue; // somebody edited between our read and write: read again
      S.selectAfterPut = null;
      showMessage(e.message);
      return;
    }
  }
  S.selectAfterPut = null;
  showMessage("the rig kept changing under us: try again");
}
export function addLight(type) {
  replaceRig((rig) => {
    const name = uniqueName(type === "bendy" ? "bendy" : type, rig);
    // Above and to the right of the camera, aimed at a point in front of it at the distance of
    // the existing lights (a scale the scene already uses).
    const ref = rig.lights.find((l) => l.type !== "directional");
    const d = ref ? V.len(V.sub(ref.position, Cam.pos)) : 5;
    const target = V.add(Cam.pos, V.scale(Cam.forward, d));
    const position = V.add(V.add(target, V.scale(Cam.up, 0.5 * d)), V.scale(Cam.right, 0.3 * d));
    const dir = V.norm(V.sub(target, position));
    const dist = V.len(V.sub(target, position));
    const l = { name, type, enabled: true, position, direction: dir, color: [1, 1, 1],
                intensity: type === "directional" ? 2 : 2 * dist ** 2, coneAngle: 30, penumbra: 6, shadow: true };
    if (type === "environment") {
      // A constant dome (no map) of radiance 0.1: irradiance pi x 0.1 on an open floor, a fill
      // under the other lights (docs/lighting.md "Environment light"); position and cone do not
      // apply to it.
      rig.lights.push({ name, type, enabled: true, color: [1, 1, 1], intensity: 0.1, rotation: [0, 0, 0], shadow: true });
      S.selectAfterPut = name;
      return rig;
    }
    if (type === "area" || type === "bentArea") {
      // A square panel a fifth of its distance across, as bright as the point light above would
      // be head-on (radiance x area = its candela: docs/lighting.md "Area light").
      const side = Number((0.2 * dist).toFixed(3));
      Object.assign(l, { size: [side, side], roll: 0, intensity: l.intensity / (side * side) });
      if (type === "area") l.shape = "rect";
    }
    if (type === "bentArea") {
      // Four straight corner chains of two segments reaching the target, radii following a
      // 45-degree cone: it renders as the straight panel until a chain is bent.
      Object.assign(l, { coneAngle: 45, penumbra: 10, cornerPoints: [], cornerRadii: [] });
      for (let c = 0; c < 4; c++) {
        l.cornerRadii.push(0);
        for (let i = 1; i <= 4; i++) {
          const a = Number((dist * i / 4).toFixed(4));
          l.cornerPoints.push([a, 0, 0]);
          l.cornerRadii.push(a);
        }
      }
    }
    rig.lights.push(l);
    S.selectAfterPut = name;
    return rig;
  });
}
export function duplicateLight() {
  const name = S.selected;
  replaceRig((rig) => {
    const src = rig.lights.find((l) => l.name === name);
    if (!src) return null;
    const copy = clone(src);
    copy.name = uniqueName(`${name}_copy`, rig);
    rig.lights.splice(rig.lights.indexOf(src) + 1, 0, copy);
    S.selectAfterPut = copy.name;
    return rig;
  });
}
export function deleteLight() {
  const name = S.selected;
  replaceRig((rig) => {
    const i = rig.lights.findIndex((l) => l.name === name);
    if (i < 0) return null;
    rig.lights.splice(i, 1);
    S.selected = rig.lights[Math.min(i, rig.lights.length - 1)]?.name ?? null;
    return rig;
  });
}
