// Snapshots and saved rigs (docs/browser-client.md "Snapshots and saved rigs"; protocol:
// docs/protocol.md "Snapshots and saved rigs"). The session keeps them on the server, shared by
// everyone in it: a snapshot is a named frame with the rig it shows (listed with its thumbnail,
// compared with the live image through the compare controls: A/B toggle, wipe, difference), a
// saved rig a named rig to go back to. Loading either replaces the rig as one edit, which undo
// takes back. Viewers see the lists and compare; editors take, save, load and delete.

import { api } from "./connection.js";
import { $, showMessage } from "./dom.js";
import { canEdit } from "./edits.js";
import { compareWithSnapshot, setSnapshots } from "./final.js";
import { S } from "./state.js";

const L = { snapshots: [], rigs: [] };
export const libraryState = () => L; // for the browser test

export function initLibrary() {
  $("snapTake").onclick = () => take();
  $("snapName").onkeydown = (e) => { if (e.key === "Enter") take(); };
  $("rigSave").onclick = () => saveRig();
  $("rigName").onkeydown = (e) => { if (e.key === "Enter") saveRig(); };
}

/** After the welcome: the session's lists (a `library` message keeps them current after that). */
export async function refreshLibrary() {
  try { onLibrary(await api("GET", "library")); } catch (e) { /* offline, or an older server */ }
}

/** A `library` message (or the GET answer): the session's snapshots and saved rigs. */
export function onLibrary(msg) {
  L.snapshots = msg.snapshots ?? [];
  L.rigs = msg.rigs ?? [];
  setSnapshots(L.snapshots); // the compare menu's choices; a deleted B falls back to the final
  render();
}

// A default name: the first "snapN" / "rigN" not in use.
function freeName(prefix, list) {
  const used = new Set(list.map((e) => e.name));
  let n = list.length + 1;
  while (used.has(`${prefix}${n}`)) n++;
  return `${prefix}${n}`;
}

async function take() {
  if (!canEdit()) return showMessage("viewers cannot take snapshots");
  const name = $("snapName").value.trim() || freeName("snap", L.snapshots);
  $("snapTake").disabled = true;
  try {
    await api("POST", "snapshots", { name }, { "X-Dfb-Name": S.name ?? "" });
    $("snapName").value = "";
  } catch (e) {
    showMessage(`snapshot: ${e.message}`);
  } finally {
    $("snapTake").disabled = false;
  }
}

async function saveRig() {
  if (!canEdit()) return showMessage("viewers cannot save rigs");
  const name = $("rigName").value.trim() || freeName("rig", L.rigs);
  try {
    await api("POST", "rigs", { name }, { "X-Dfb-Name": S.name ?? "" });
    $("rigName").value = "";
  } catch (e) {
    showMessage(`save rig: ${e.message}`);
  }
}

async function load(kind, name) {
  if (!canEdit()) return showMessage("viewers cannot load rigs");
  try {
    await api("POST", `${kind}/${encodeURIComponent(name)}/load`, undefined, { "X-Dfb-Name": S.name ?? "" });
    showMessage(`loaded ${kind === "rigs" ? "rig" : "the rig of snapshot"} ${name} (undo takes it back)`, "info");
  } catch (e) {
    showMessage(`load ${name}: ${e.message}`);
  }
}

async function remove(kind, name) {
  try { await api("DELETE", `${kind}/${encodeURIComponent(name)}`); } catch (e) { showMessage(`delete ${name}: ${e.message}`); }
}

const when = (iso) => {
  const d = new Date(iso);
  return Number.isNaN(d.getTime()) ? iso : d.toLocaleString([], { month: "short", day: "numeric", hour: "2-digit", minute: "2-digit" });
};
function button(text, title, onclick, edit = true) {
  const b = Object.assign(document.createElement("button"), { textContent: text, title, onclick });
  if (edit) b.dataset.edit = "";
  b.disabled = edit && !canEdit();
  return b;
}
function meta(e) {
  return Object.assign(document.createElement("div"), {
    className: "hint",
    textContent: `v${e.rigVersion} · ${e.lights} light${e.lights === 1 ? "" : "s"} · ${e.by} · ${when(e.time)}`,
  });
}

function render() {
  const snaps = $("snapshots");
  snaps.innerHTML = "";
  for (const s of L.snapshots) {
    const li = document.createElement("li");
    li.dataset.snapshot = s.name;
    const q = new URLSearchParams({ token: S.token, t: s.time });
    const img = Object.assign(document.createElement("img"), {
      className: "thumb", alt: `snapshot ${s.name}`, title: "Compare the live image with this snapshot (wipe)",
      src: `/v1/sessions/${encodeURIComponent(S.sessionId)}/snapshots/${encodeURIComponent(s.name)}.thumb.jpg?${q}`,
    });
    img.onclick = () => compareWithSnapshot(s, "wipe");
    const text = document.createElement("div");
    text.className = "entry";
    text.append(Object.assign(document.createElement("div"), { className: "ename", textContent: s.name }), meta(s));
    const actions = document.createElement("div");
    actions.className = "actions";
    actions.append(button("A/B", "Compare the live image with this snapshot (toggle, wipe or difference in the compare menu)",
                          () => compareWithSnapshot(s, "wipe"), false),
                   button("Load", "Replace the rig with the one this snapshot shows (one edit: undo takes it back)", () => load("snapshots", s.name)),
                   button("×", "Delete this snapshot", () => remove("snapshots", s.name)));
    li.append(img, text, actions);
    snaps.append(li);
  }
  $("snapEmpty").hidden = L.snapshots.length > 0;
  const rigs = $("savedRigs");
  rigs.innerHTML = "";
  for (const r of L.rigs) {
    const li = document.createElement("li");
    li.dataset.rig = r.name;
    const text = document.createElement("div");
    text.className = "entry";
    text.append(Object.assign(document.createElement("div"), { className: "ename", textContent: r.name }), meta(r));
    const actions = document.createElement("div");
    actions.className = "actions";
    actions.append(button("Load", "Replace the rig with this one (one edit: undo takes it back)", () => load("rigs", r.name)),
                   button("×", "Delete this saved rig", () => remove("rigs", r.name)));
    li.append(text, actions);
    rigs.append(li);
  }
  $("rigEmpty").hidden = L.rigs.length > 0;
}
