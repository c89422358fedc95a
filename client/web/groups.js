// Light groups (docs/browser-client.md "Lights panel"; the rig's `groups`, docs/protocol.md "Property paths"):
// named sets of lights kept in the rig, so shared, undoable and saved with it. A group is made from
// the selected lights (Ctrl/Shift+click in the list); Mute, Solo and the intensity scales change
// every member in one edit, one undo step.

import { $, showMessage } from "./dom.js";
import { canEdit, edit } from "./edits.js";
import { refreshUi } from "./panels.js";
import { NAME_RE } from "./rig.js";
import { S, findLight } from "./state.js";

const groupsOf = () => S.rig?.groups ?? [];

export function initGroups() {
  $("groupMake").onclick = makeGroup;
  $("groupName").onkeydown = (e) => { if (e.key === "Enter") makeGroup(); };
}

function makeGroup() {
  if (!canEdit()) return showMessage("viewers cannot change the rig");
  const members = [S.selected, ...S.also].filter((n) => n && findLight(n));
  if (!members.length) return showMessage("group: select its lights first (Ctrl/Shift+click adds to the selection)");
  let name = $("groupName").value.trim();
  if (!name) { let n = groupsOf().length + 1; while (groupsOf().some((g) => g.name === `group${n}`)) n++; name = `group${n}`; }
  if (!NAME_RE.test(name)) return showMessage(`group: '${name}' is not 1-64 letters, digits, '_' or '-'`);
  // A name in use is replaced: making a group again from a new selection updates it.
  const groups = groupsOf().filter((g) => g.name !== name).concat([{ name, lights: members }]);
  edit([{ path: "groups", value: groups }]);
  $("groupName").value = "";
}

// One edit of every member (or, for solo, of every light).
function intensityChange(l, factor) {
  if (l.keys?.intensity?.length) {
    // Keyed: every key scaled, so the whole animation is brighter or darker.
    return { path: `${l.name}.keys`, value: { ...l.keys, intensity: l.keys.intensity.map((k) => ({ ...k, value: k.value * factor })) } };
  }
  return { path: `${l.name}.intensity`, value: l.intensity * factor };
}
function act(g, what) {
  if (!canEdit()) return showMessage("viewers cannot change the rig");
  const members = g.lights.map(findLight).filter(Boolean);
  let changes = [];
  if (what === "mute") {
    const on = members.some((l) => l.enabled);
    changes = members.map((l) => ({ path: `${l.name}.enabled`, value: !on }));
  } else if (what === "solo") {
    const inGroup = new Set(g.lights);
    changes = S.rig.lights.filter((l) => l.enabled !== inGroup.has(l.name)).map((l) => ({ path: `${l.name}.enabled`, value: inGroup.has(l.name) }));
  } else if (what === "select") {
    S.selected = members[0]?.name ?? S.selected;
    S.also = new Set(members.slice(1).map((l) => l.name));
    return refreshUi(true);
  } else if (what === "delete") {
    changes = [{ path: "groups", value: groupsOf().filter((x) => x.name !== g.name) }];
  } else {
    changes = members.map((l) => intensityChange(l, what));
  }
  if (changes.length) edit(changes, { refetch: what !== "mute" && what !== "solo" && what !== "delete" });
}

export function renderGroups() {
  const ul = $("groups");
  if (!ul || !S.rig) return;
  ul.innerHTML = "";
  for (const g of groupsOf()) {
    const li = document.createElement("li");
    li.dataset.group = g.name;
    const members = g.lights.map(findLight).filter(Boolean);
    const muted = members.length > 0 && members.every((l) => !l.enabled);
    li.classList.toggle("muted", muted);
    li.append(Object.assign(document.createElement("span"), { className: "gname", textContent: g.name, title: g.lights.join(", ") }),
              Object.assign(document.createElement("span"), { className: "hint", textContent: `${members.length}` }));
    const button = (text, title, what) => {
      const b = Object.assign(document.createElement("button"), { textContent: text, title, onclick: () => act(g, what) });
      b.dataset.action = String(what);
      if (what !== "select") b.dataset.edit = "";
      b.disabled = what !== "select" && !canEdit();
      return b;
    };
    li.append(button(muted ? "Unmute" : "Mute", "Disable (or enable again) every light of the group: one edit", "mute"),
              button("Solo", "Enable the group's lights and disable every other light: one edit", "solo"),
              button("×½", "Halve the intensity of every light of the group (keyed ones: every key)", 0.5),
              button("×2", "Double the intensity of every light of the group (keyed ones: every key)", 2),
              button("Select", "Select the group's lights (edits in the light panel go to all of them)", "select"),
              button("×", "Delete the group (its lights stay)", "delete"));
    ul.append(li);
  }
}
