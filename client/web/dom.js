// Small DOM helpers shared by the page's modules: element lookup and creation, messages, and the
// checked number input.

import { parseNumber } from "./format.js";

export const $ = (id) => document.getElementById(id);
export const div = (cls) => Object.assign(document.createElement("div"), { className: cls });
export const labelEl = (t) => Object.assign(document.createElement("label"), { textContent: t });
export const unitEl = (t) => Object.assign(document.createElement("span"), { className: "unit", textContent: t });

export const SVGNS = "http://www.w3.org/2000/svg";
export function svg(tag, attrs, parent) {
  const el = document.createElementNS(SVGNS, tag);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
  if (parent) parent.append(el);
  return el;
}

/** Shows a message: errors verbatim from the server, or the page's own validation. */
export function showMessage(text, kind = "error") {
  const box = $("messages");
  const d = document.createElement("div");
  d.className = `msg ${kind}`;
  const span = document.createElement("span");
  span.textContent = text;
  const close = document.createElement("button");
  close.textContent = "×";
  close.title = "Dismiss";
  close.onclick = () => d.remove();
  d.append(span, close);
  box.prepend(d);
  while (box.children.length > 4) box.lastChild.remove();
  // Long enough to read; the newest four stay until then (× dismisses at once).
  setTimeout(() => d.remove(), kind === "error" ? 20000 : 8000);
}

/**
 * A number input that validates on Enter or leaving the field (every number typed is checked
 * before anything is sent); Escape restores the value. `input.setValue(v)` shows a new value
 * unless the artist is typing in it.
 */
export function numberInput({ label, min = -1e7, max = 1e7, integer = false, value, digits = 3, onCommit, cls = "num", title }) {
  const input = document.createElement("input");
  input.className = cls;
  input.dataset.edit = "";
  input.title = title || `${label} (${min} to ${max})`;
  input.setAttribute("aria-label", label);
  const fmt = (v) => (typeof v === "number" ? String(Number(v.toFixed(digits))) : "");
  input.value = fmt(value);
  input.dataset.committed = input.value;
  const commit = () => {
    if (input.value === input.dataset.committed) { input.classList.remove("bad"); return; }
    const r = parseNumber(input.value, label, min, max, { integer });
    if (r.error) { input.classList.add("bad"); showMessage(r.error); return; }
    input.classList.remove("bad");
    input.dataset.committed = fmt(r.value);
    onCommit(r.value);
  };
  // Enter fires "change" as leaving the field does: one commit (or one message) per typed value.
  input.addEventListener("keydown", (e) => {
    if (e.key === "Escape") { input.value = input.dataset.committed; input.classList.remove("bad"); input.blur(); }
  });
  input.addEventListener("change", commit);
  input.setValue = (v) => { if (document.activeElement !== input) { input.value = fmt(v); input.dataset.committed = input.value; input.classList.remove("bad"); } };
  return input;
}
