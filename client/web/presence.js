// Review: who is here and what they edit (the Review panel and the header), your name, and the
// links to share (yours, and for editors the session's viewer link).

import { send } from "./connection.js";
import { $, showMessage } from "./dom.js";
import { S } from "./state.js";

/** Each client's colour, stable across pages (by client id). */
export const clientColor = (id) => `hsl(${(id * 67) % 360} 70% 62%)`;
/** The other clients editing light `name` or one of its properties. */
export const editorsOf = (name) => S.clients.filter((c) => c.id !== S.clientId && c.editing &&
                                                        (c.editing === name || c.editing.startsWith(`${name}.`)));

export function renderClients() {
  const ul = $("clients");
  ul.innerHTML = "";
  for (const c of S.clients) {
    const li = document.createElement("li");
    li.dataset.client = c.id;
    const dot = Object.assign(document.createElement("span"), { className: "dot" });
    dot.style.background = clientColor(c.id);
    const who = Object.assign(document.createElement("span"), { className: "cname", textContent: c.name + (c.id === S.clientId ? " (you)" : "") });
    const role = Object.assign(document.createElement("span"), { className: "hint", textContent: c.role });
    li.append(dot, who, role);
    if (c.editing) li.append(Object.assign(document.createElement("span"), { className: "hint", textContent: `✎ ${c.editing}` }));
    ul.append(li);
  }
  const people = $("people");
  people.innerHTML = "";
  for (const c of S.clients) {
    const sp = document.createElement("span");
    sp.title = `${c.name} · ${c.role}${c.editing ? ` · editing ${c.editing}` : ""}`;
    const dot = Object.assign(document.createElement("span"), { className: "dot" });
    dot.style.background = clientColor(c.id);
    if (c.role !== "editor") dot.style.opacity = 0.5;
    sp.append(dot, `${c.name}${c.id === S.clientId ? " (you)" : ""}${c.role === "editor" ? "" : " (viewer)"}`);
    people.append(sp);
  }
}
export function renderShare() {
  const u = new URL(location.href);
  u.search = `?session=${encodeURIComponent(S.sessionId)}&token=${encodeURIComponent(S.token)}`;
  $("shareLink").value = u.toString();
  $("shareRole").textContent = S.role;
  $("viewerShare").style.display = S.viewerToken ? "" : "none";
  if (S.viewerToken) {
    u.search = `?session=${encodeURIComponent(S.sessionId)}&token=${encodeURIComponent(S.viewerToken)}`;
    $("viewerLink").value = u.toString();
  }
}
async function copyFrom(input, note) {
  // The clipboard API needs a secure context (https or localhost); else the old way.
  try { await navigator.clipboard.writeText(input.value); } catch { input.select(); document.execCommand("copy"); }
  note.textContent = "copied";
}

/** The copy buttons and the name field. */
export function initPresence() {
  $("copyLink").onclick = () => copyFrom($("shareLink"), $("copied"));
  $("copyViewerLink").onclick = () => copyFrom($("viewerLink"), $("copiedViewer"));
  $("myName").value = S.name;
  $("myName").addEventListener("change", () => {
    const v = $("myName").value.trim().slice(0, 64);
    if (!v) { $("myName").value = S.name; return showMessage("name: enter a name others will see"); }
    S.name = v;
    localStorage.setItem("dfb.name", v);
    send({ type: "hello", protocol: 1, name: v }); // the server updates presence for everyone
  });
}
