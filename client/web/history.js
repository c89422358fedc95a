// The session's history (docs/browser-client.md "History"; GET .../history, POST
// .../history/V/restore): who changed what, newest first, the last HISTORY_SHOWN changes; "Go to"
// (editors) puts the rig back as it was at that version, as one edit that undo takes back.

import { api } from "./connection.js";
import { $, showMessage } from "./dom.js";
import { canEdit } from "./edits.js";
import { S } from "./state.js";

const HISTORY_SHOWN = 40;

// What a change record did, in a few words: the paths it changed, or its kind.
function summary(e) {
  if (e.changes?.length) {
    const paths = e.changes.map((c) => c.path);
    const shown = paths.slice(0, 3).join(", ");
    return paths.length > 3 ? `${shown} +${paths.length - 3}` : shown;
  }
  return { undo: "undo", redo: "redo", replace: "the whole rig (load, go to, PUT)" }[e.kind] ?? e.kind;
}

/** Reads the newest entries (after each change; connection.js refreshHistory) and lists them. */
export async function refreshHistoryList() {
  const v = S.rig?.version ?? 0;
  let answer;
  try { answer = await api("GET", `history?since=${Math.max(0, v - HISTORY_SHOWN)}`); } catch (e) { return; }
  const list = $("historyList");
  list.innerHTML = "";
  for (const e of [...answer.entries].reverse()) {
    const li = document.createElement("li");
    li.dataset.version = String(e.version);
    const text = Object.assign(document.createElement("div"), { className: "entry" });
    text.append(Object.assign(document.createElement("span"), { className: "hver", textContent: `v${e.version}` }),
                Object.assign(document.createElement("span"), { className: "hwho", textContent: ` ${e.byName || "?"}` }),
                Object.assign(document.createElement("div"), { className: "hint", textContent: summary(e) }));
    li.append(text);
    if (e.version === answer.rigVersion) {
      li.classList.add("current");
    } else {
      const b = Object.assign(document.createElement("button"), {
        textContent: "Go to", title: `Put the rig back as it was at version ${e.version} (one edit: undo takes it back)`,
      });
      b.dataset.edit = "";
      b.disabled = !canEdit();
      b.onclick = () => goTo(e.version);
      li.append(b);
    }
    list.append(li);
  }
}

async function goTo(version) {
  if (!canEdit()) return showMessage("viewers cannot change the rig");
  try {
    await api("POST", `history/${version}/restore`, undefined, { "X-Dfb-Name": S.name ?? "" });
    showMessage(`went back to version ${version} (undo takes it back)`, "info");
  } catch (e) {
    showMessage(`go to version ${version}: ${e.message}`);
  }
}
