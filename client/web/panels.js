// The side panels: the light list, the selected light's properties (its BendyLight chain, other
// properties, light linking), the rig's settings, the view toolbar, and which controls may edit.

import { renderStats, scheduleRefetch } from "./connection.js";
import { $, div, labelEl, numberInput, showMessage, unitEl } from "./dom.js";
import { beginGesture, canEdit, edit, endGesture, sendView, sendViewThrottled, setLightProp, setPresence } from "./edits.js";
import { onViewChanged, renderFinal } from "./final.js";
import { hexToLinear, linearToHex, parseNumber } from "./format.js";
import { renderGroups } from "./groups.js";
import { renderDragModes } from "./indirect.js";
import { V } from "./linalg.js";
import { scheduleOverlay } from "./overlay.js";
import { clientColor, editorsOf } from "./presence.js";
import { NAME_RE, clone, rangeOf, schemaRows } from "./rig.js";
import { lowerFirst, propertyRows } from "./rows.js";
import { LAYERS, S, evaluated, findLight } from "./state.js";
import { renderKeyWhat, renderTimeline } from "./timeline.js";

const typeLabel = (t) => (t === "bendy" ? "BendyLight" : t === "bentArea" ? "bent area" : t);

/** Takes a whole rig from the server (welcome, undo, redo, replace, re-read). */
export function setRig(rig) {
  const selectedBefore = S.selected;
  S.rig = rig;
  // An added or duplicated light is selected when a rig that has it comes; a rig from before
  // it (a re-read still under way) leaves the wish in place rather than selecting another light.
  if (S.selectAfterPut && findLight(S.selectAfterPut)) { S.selected = S.selectAfterPut; S.selectAfterPut = null; }
  if (!findLight(S.selected)) S.selected = rig.lights.find((l) => l.name === selectedBefore)?.name ?? rig.lights[0]?.name ?? null;
  refreshUi(true);
}

let propsFor = null; // the light (name and type) whose panel is built, to rebuild only when needed
/** Shows the rig everywhere; `rebuild`: rebuild the selected light's panel even if its shape is unchanged. */
export function refreshUi(rebuild = false) {
  if (!S.rig) return;
  renderLights();
  const l = findLight(S.selected);
  const sig = l ? `${l.name}|${l.type}|${l.controlPoints?.length ?? 0}|${Object.keys(l.keys || {}).sort().join(",")}|${S.rig.lights.length}` : "";
  if (rebuild || sig !== propsFor) { propsFor = sig; buildProps(); } else updateProps();
  buildRigProps();
  renderOutputs();
  renderKeyWhat();
  renderTimeline();
  renderDragModes();
  scheduleOverlay();
  renderStats();
  renderFinal();
  renderGroups();
  updateEditable();
}

export function renderLights() {
  if (!S.rig) return;
  for (const n of [...S.also]) if (!findLight(n) || n === S.selected) S.also.delete(n); // renamed, deleted, or now the primary
  const ul = $("lights");
  ul.innerHTML = "";
  for (const l of S.rig.lights) {
    const li = document.createElement("li");
    li.dataset.light = l.name;
    li.className = `${l.name === S.selected ? "selected" : ""} ${S.also.has(l.name) ? "also" : ""} ${l.enabled ? "" : "disabled"}`;
    const en = Object.assign(document.createElement("input"), { type: "checkbox", checked: l.enabled, title: "Enabled" });
    en.dataset.edit = "";
    en.className = "enable";
    en.addEventListener("click", (e) => e.stopPropagation());
    en.addEventListener("change", () => edit([{ path: `${l.name}.enabled`, value: en.checked }]));
    const name = Object.assign(document.createElement("span"), { className: "lname", textContent: l.name });
    const type = Object.assign(document.createElement("span"), { className: "ltype", textContent: typeLabel(l.type) });
    li.append(en, name, type);
    if (l.warning) li.append(Object.assign(document.createElement("span"), { className: "warning", textContent: "⚠", title: l.warning }));
    for (const c of editorsOf(l.name)) {
      const b = Object.assign(document.createElement("span"), { className: "badge", textContent: `✎ ${c.name}`, title: `${c.name} is editing ${c.editing}` });
      b.style.background = clientColor(c.id);
      li.append(b);
    }
    const solo = Object.assign(document.createElement("button"), { className: "solo", textContent: "S",
      title: "Solo: show this light alone in your view (the rig and others are not affected)" });
    if (S.view.output === `light:${l.name}`) solo.classList.add("on");
    solo.addEventListener("click", (e) => {
      e.stopPropagation();
      sendView({ output: S.view.output === `light:${l.name}` ? "beauty" : `light:${l.name}` });
      renderLights();
    });
    li.append(solo);
    // Ctrl/Cmd/Shift+click adds the light to the selection (or takes it out): the property panel
    // shows the first one, and its edits go to every selected light that has the property.
    li.addEventListener("click", (e) => (e.ctrlKey || e.metaKey || e.shiftKey ? toggleAlso(l.name) : selectLight(l.name)));
    ul.append(li);
  }
  applyEditable(ul);
}

export function selectLight(name) {
  S.selectAfterPut = null; // the artist chose meanwhile
  if (S.selected === name && !S.also.size) return;
  S.selected = name;
  S.also.clear();
  refreshUi(true);
}
/** Adds a light to the selection, or takes it out (the primary one stays: a plain click changes it). */
export function toggleAlso(name) {
  if (!S.selected) return selectLight(name);
  if (name === S.selected) return;
  if (S.also.has(name)) S.also.delete(name);
  else S.also.add(name);
  refreshUi(true);
}

const propWidgets = new Map(); // prop -> {update(light)}
function buildProps() {
  const box = $("props");
  box.innerHTML = "";
  propWidgets.clear();
  const l = findLight(S.selected);
  $("propsTitle").textContent = l ? `· ${l.name}${S.also.size ? ` + ${[...S.also].join(", ")}` : ""}` : "";
  if (!l) { box.innerHTML = '<div class="hint">No light selected.</div>'; return; }
  // Name: renaming is an edit of L.name, checked here first.
  {
    const row = div("row");
    const input = Object.assign(document.createElement("input"), { value: l.name, id: "lightName", title: "1-64 letters, digits, _ or -; Enter renames" });
    input.dataset.edit = "";
    input.style.flex = "1";
    const commit = () => {
      const v = input.value.trim(), cur = findLight(S.selected);
      if (!cur || v === cur.name) return;
      if (!NAME_RE.test(v)) { input.classList.add("bad"); return showMessage(`name: '${v}' is not 1-64 letters, digits, '_' or '-'`); }
      input.classList.remove("bad");
      edit([{ path: `${cur.name}.name`, value: v }]);
    };
    // Enter fires "change" as leaving the field does: one commit per typed value.
    input.addEventListener("keydown", (e) => { if (e.key === "Escape") { input.value = findLight(S.selected)?.name ?? ""; input.classList.remove("bad"); input.blur(); } });
    input.addEventListener("change", commit);
    row.append(labelEl("name"), input);
    box.append(row);
    propWidgets.set("name", { update: (x) => { if (document.activeElement !== input) input.value = x.name; } });
  }
  const e = evaluated(l);
  for (const [prop, label, unit, kind, o = {}] of propertyRows(l)) {
    if (kind === "json") {
      const update = genericRow(box, label, e[prop], `${l.name}.${prop}`, (v) => setLightProp(l.name, prop, v));
      propWidgets.set(prop, { update: (x) => update(x[prop]) });
      continue;
    }
    const row = div("row");
    const keyed = l.keys?.[prop]?.length;
    const lab = labelEl(label);
    if (keyed) lab.append(Object.assign(document.createElement("span"), { className: "keyed", textContent: " ◆", title: "keyframed: edits set a key at the current time" }));
    row.append(lab);
    let update = () => {};
    if (kind === "type") {
      const sel = document.createElement("select");
      sel.dataset.edit = ""; sel.id = "lightType";
      for (const v of o.values) sel.append(new Option(typeLabel(v), v));
      // A type this page does not know yet (a newer server) is still shown as it is.
      if (![...sel.options].some((o) => o.value === l.type)) sel.append(new Option(l.type, l.type));
      sel.value = l.type;
      sel.addEventListener("change", () => edit([{ path: `${l.name}.type`, value: sel.value }], { refetch: true }));
      row.append(sel);
      update = (x) => { sel.value = x.type; };
    } else if (kind === "bool") {
      const cb = Object.assign(document.createElement("input"), { type: "checkbox", checked: !!e[prop], id: `prop-${prop}` });
      cb.dataset.edit = "";
      cb.addEventListener("change", () => setLightProp(l.name, prop, cb.checked));
      row.append(cb);
      update = (x) => { cb.checked = !!x[prop]; };
    } else if (kind === "choice") {
      const sel = document.createElement("select");
      sel.dataset.edit = ""; sel.id = `prop-${prop}`;
      for (const v of o.values) sel.append(new Option(String(v), String(v)));
      sel.value = String(e[prop]);
      // The value goes back as the type the choices have (shadow-map sizes are numbers).
      const value = () => (typeof o.values[0] === "number" ? Number(sel.value) : sel.value);
      sel.addEventListener("change", () => setLightProp(l.name, prop, value()));
      row.append(sel, unitEl(unit));
      update = (x) => { sel.value = String(x[prop]); };
    } else if (kind === "color") {
      const pick = Object.assign(document.createElement("input"), { type: "color", value: linearToHex(e.color), title: "Color (shown in sRGB; stored linear)" });
      pick.dataset.edit = ""; pick.id = "prop-color";
      pick.addEventListener("input", () => setLightProp(l.name, "color", hexToLinear(pick.value), { live: true }));
      pick.addEventListener("change", () => setLightProp(l.name, "color", hexToLinear(pick.value)));
      const nums = [0, 1, 2].map((i) => numberInput({ label: `${label} ${"rgb"[i]}`, min: o.min ?? 0, max: o.max ?? 1e6, value: e.color[i], cls: "num",
        onCommit: (v) => { const c = evaluated(findLight(l.name)).color.slice(); c[i] = v; setLightProp(l.name, "color", c); } }));
      nums.forEach((n) => { n.style.width = "46px"; });
      row.append(pick, ...nums);
      update = (x) => { if (document.activeElement !== pick) pick.value = linearToHex(x.color); nums.forEach((n, i) => n.setValue(x.color[i])); };
    } else if (kind === "text") {
      const t = Object.assign(document.createElement("input"), { value: e[prop] ?? "", id: `prop-${prop}`, title: o.title || "" });
      t.dataset.edit = "";
      t.style.flex = "1";
      t.addEventListener("change", () => setLightProp(l.name, prop, t.value.trim()));
      row.append(t);
      update = (x) => { if (document.activeElement !== t) t.value = x[prop] ?? ""; };
    } else if (kind === "vec") {
      const nums = o.names.map((name, i) => numberInput({ label: `${label} ${name}`, min: o.min, max: o.max, value: e[prop]?.[i],
        onCommit: (v) => { const c = evaluated(findLight(l.name))[prop].slice(); c[i] = v; setLightProp(l.name, prop, c); } }));
      nums.forEach((n, i) => { n.id = `prop-${prop}-${i}`; n.style.width = nums.length > 3 ? "44px" : "62px"; });
      row.append(...nums, unitEl(unit));
      update = (x) => nums.forEach((n, i) => n.setValue(x[prop]?.[i]));
    } else if (kind === "number") {
      const num = numberInput({ label, min: o.min, max: o.max, integer: o.integer, value: e[prop], onCommit: (v) => setLightProp(l.name, prop, v) });
      num.id = `prop-${prop}`;
      row.append(num, unitEl(unit));
      update = (x) => num.setValue(x[prop]);
    } else if (kind === "slider") {
      // Sliders cover the useful range (log for intensities); the typed entry takes the full range.
      const smin = o.smin ?? (o.log ? 0 : o.min), smax = o.smax ?? o.max;
      const range = Object.assign(document.createElement("input"), { type: "range", min: 0, max: 1000, step: 1, id: `slider-${prop}` });
      range.dataset.edit = "";
      const toSlider = (v) => (o.log ? Math.round(1000 * Math.log1p(v) / Math.log1p(smax)) : Math.round(1000 * (v - smin) / (smax - smin)));
      const fromSlider = (s) => (o.log ? Math.expm1(s / 1000 * Math.log1p(smax)) : smin + (smax - smin) * s / 1000);
      range.value = toSlider(e[prop]);
      const num = numberInput({ label, min: o.min, max: o.max, integer: o.integer, value: e[prop], onCommit: (v) => { range.value = toSlider(v); setLightProp(l.name, prop, v); } });
      num.id = `prop-${prop}`;
      range.addEventListener("pointerdown", () => { beginGesture(); setPresence(`${l.name}.${prop}`); });
      range.addEventListener("input", () => {
        const s = fromSlider(Number(range.value)), v = o.integer ? Math.round(s) : Number(s.toPrecision(5));
        num.setValue(v);
        setLightProp(l.name, prop, v, { live: true });
      });
      range.addEventListener("change", () => { endGesture(); setPresence(null); scheduleRefetch(); });
      row.append(range, num, unitEl(unit));
      update = (x) => { if (document.activeElement !== range) range.value = toSlider(x[prop]); num.setValue(x[prop]); };
    }
    propWidgets.set(prop, { update });
    box.append(row);
  }
  if (l.type === "bendy" && l.controlPoints?.length) buildChain(box, l, e); // a new chain comes from the server
  buildOtherProps(box, l, e);
  if (l.warning) box.append(Object.assign(div("warning"), { textContent: `⚠ ${l.warning}`, id: "lightWarning" }));
  buildLinking(box, l);
}

function buildChain(box, l, e) {
  const K = l.controlPoints.length / 2;
  const head = div("group");
  head.textContent = `BendyLight chain · ${K} segment${K === 1 ? "" : "s"} · control points in the light's frame (a along the axis, b, c across)`;
  box.append(head);
  const row = div("row");
  const addSeg = Object.assign(document.createElement("button"), { textContent: "+ segment", disabled: K >= 8, title: "Extend the chain straight along its end tangent" });
  const delSeg = Object.assign(document.createElement("button"), { textContent: "− segment", disabled: K <= 1, title: "Remove the last segment" });
  addSeg.dataset.edit = ""; delSeg.dataset.edit = "";
  addSeg.onclick = () => {
    const cps = clone(findLight(l.name).controlPoints);
    const n = cps.length, last = cps[n - 1], prev = n >= 2 ? cps[n - 2] : [0, 0, 0];
    const t = V.sub(last, prev);
    cps.push(V.add(last, t), V.add(last, V.scale(t, 2)));
    edit([{ path: `${l.name}.controlPoints`, value: cps }], { refetch: true });
  };
  delSeg.onclick = () => edit([{ path: `${l.name}.controlPoints`, value: findLight(l.name).controlPoints.slice(0, -2) }], { refetch: true });
  row.append(addSeg, delSeg);
  box.append(row);

  const table = document.createElement("table");
  table.className = "cps";
  table.innerHTML = "<tr><th>#</th><th>a</th><th>b</th><th>c</th><th>radius</th><th>color</th></tr>";
  const cells = [];
  for (let i = 0; i <= 2 * K; i++) {
    const tr = document.createElement("tr");
    const keyedMark = ["cp", "r", "cpColor"].some((b) => l.keys?.[`${b}[${i}]`]?.length) ? " ◆" : "";
    tr.append(Object.assign(document.createElement("td"), { textContent: `p${i}${keyedMark}`, className: keyedMark ? "keyed" : "" }));
    const cpInputs = [0, 1, 2].map((c) => {
      const td = document.createElement("td");
      if (i === 0) { td.textContent = "0"; td.title = "p0 is the light's position"; tr.append(td); return null; }
      const n = numberInput({ label: `p${i}.${"abc"[c]}`, ...rangeOf(`cp[${i}]`), value: e.controlPoints[i - 1][c], digits: 3,
        onCommit: (v) => { const p = evaluated(findLight(l.name)).controlPoints[i - 1].slice(); p[c] = v; setLightProp(l.name, `cp[${i}]`, p); } });
      n.id = `cp-${i}-${c}`;
      td.append(n); tr.append(td);
      return n;
    });
    const rtd = document.createElement("td");
    const r = numberInput({ label: `radius r${i}`, ...rangeOf(`r[${i}]`), value: e.radii[i], onCommit: (v) => setLightProp(l.name, `r[${i}]`, v) });
    r.id = `r-${i}`;
    rtd.append(r);
    const ctd = document.createElement("td");
    const col = Object.assign(document.createElement("input"), { type: "color", value: linearToHex(e.colors[i]), title: `color multiplier at p${i}` });
    col.dataset.edit = "";
    col.addEventListener("change", () => setLightProp(l.name, `cpColor[${i}]`, hexToLinear(col.value)));
    ctd.append(col);
    tr.append(rtd, ctd);
    table.append(tr);
    cells.push({ cpInputs, r, col, i });
  }
  box.append(table);
  propWidgets.set("chain", {
    update: (x) => {
      for (const { cpInputs, r, col, i } of cells) {
        if (i > 0) cpInputs.forEach((n, c) => n.setValue(x.controlPoints[i - 1]?.[c]));
        r.setValue(x.radii[i]);
        if (document.activeElement !== col && x.colors[i]) col.value = linearToHex(x.colors[i]);
      }
    },
  });
}

// Properties of a light the schema does not list are still shown and editable: numbers, booleans,
// number lists, and anything else as JSON.
function genericRow(box, label, value, path, onValue) {
  const row = div("row");
  row.append(labelEl(label));
  let update;
  if (typeof value === "boolean") {
    const cb = Object.assign(document.createElement("input"), { type: "checkbox", checked: value });
    cb.dataset.edit = "";
    cb.onchange = () => onValue(cb.checked);
    row.append(cb);
    update = (v) => { cb.checked = !!v; };
  } else if (typeof value === "number") {
    const n = numberInput({ label: path, value, min: -1e12, max: 1e12, onCommit: onValue });
    row.append(n);
    update = (v) => n.setValue(v);
  } else if (typeof value === "string") {
    const t = Object.assign(document.createElement("input"), { value, title: "Enter applies" });
    t.dataset.edit = "";
    t.style.flex = "1";
    t.onchange = () => onValue(t.value);
    row.append(t);
    update = (v) => { if (document.activeElement !== t) t.value = v ?? ""; };
  } else if (Array.isArray(value) && value.length <= 4 && value.every((x) => typeof x === "number")) {
    const nums = value.map((x, i) => numberInput({ label: `${path}[${i}]`, value: x, min: -1e12, max: 1e12,
      onCommit: (v) => { const c = nums.map((m) => Number(m.dataset.committed)); c[i] = v; onValue(c); } }));
    nums.forEach((m) => { m.style.width = "58px"; });
    row.append(...nums);
    update = (v) => nums.forEach((m, i) => m.setValue(v?.[i]));
  } else {
    // JSON text: checked as JSON here; the server validates the value itself.
    const t = Object.assign(document.createElement("input"), { value: JSON.stringify(value), title: "JSON value; Enter applies" });
    t.dataset.edit = "";
    t.style.flex = "1";
    t.onchange = () => {
      let v;
      try { v = JSON.parse(t.value); } catch { t.classList.add("bad"); return showMessage(`${path}: not valid JSON`); }
      t.classList.remove("bad");
      onValue(v);
    };
    row.append(t);
    update = (v) => { if (document.activeElement !== t) t.value = JSON.stringify(v); };
  }
  box.append(row);
  return update;
}
function buildOtherProps(box, l, e) {
  // Every property the schema lists has its place (a row, the chain, the timeline, ...).
  const known = new Set(schemaRows().light.map((r) => r.path));
  const extra = Object.keys(l).filter((k) => !known.has(k));
  if (!extra.length) return;
  box.append(Object.assign(div("group"), { textContent: "more properties" }));
  for (const k of extra) {
    const update = genericRow(box, k, e[k], `${l.name}.${k}`, (v) => setLightProp(l.name, k, v));
    propWidgets.set(`extra:${k}`, { update: (x) => update(x[k]) });
  }
}

function buildLinking(box, l) {
  const objects = S.session?.objects || [];
  if (!objects.length) return;
  // Folded unless in use: most lights light everything.
  const details = document.createElement("details");
  details.className = "group";
  details.open = !!(l.include?.length || l.exclude?.length) || !!S.linkingOpen;
  details.addEventListener("toggle", () => { S.linkingOpen = details.open; });
  const summary = document.createElement("summary");
  summary.textContent = `light linking${l.include?.length || l.exclude?.length ? " (in use)" : ""} · shading only; every object still casts shadows`;
  details.append(summary);
  box.append(details);
  box = details;
  const rows = schemaRows().light.filter((r) => r.type === "idList" && (!r.appliesTo || r.appliesTo.includes(l.type)));
  for (const { path: prop, label } of rows) {
    const row = div("row");
    const sel = document.createElement("select");
    sel.multiple = true; sel.size = Math.min(4, objects.length); sel.style.flex = "1"; sel.dataset.edit = ""; sel.id = `prop-${prop}`;
    objects.forEach((o, i) => { const opt = new Option(o, String(i + 1)); opt.selected = (l[prop] || []).includes(i + 1); sel.append(opt); });
    sel.addEventListener("change", () => edit([{ path: `${l.name}.${prop}`, value: [...sel.selectedOptions].map((o) => Number(o.value)) }]));
    row.append(labelEl(lowerFirst(label ?? prop)), sel);
    box.append(row);
  }
  box.append(Object.assign(div("hint"), { textContent: "Ctrl-click to choose several; none chosen in 'lights only' means all objects." }));
}

function updateProps() {
  const l = findLight(S.selected);
  if (!l) return;
  const e = evaluated(l);
  for (const w of propWidgets.values()) w.update(e);
}

function buildRigProps() {
  const box = $("rigProps");
  if (!box.firstChild) {
    const row = div("row");
    const range = Object.assign(document.createElement("input"), { type: "range", min: -6, max: 6, step: 0.1, id: "rigExposure" });
    range.dataset.edit = "";
    const num = numberInput({ label: "rig exposure", ...rangeOf("exposure", true), value: 0, onCommit: (v) => { range.value = v; edit([{ path: "exposure", value: v }]); } });
    num.id = "rigExposureN";
    range.addEventListener("pointerdown", beginGesture);
    range.addEventListener("change", endGesture);
    range.addEventListener("input", () => { num.setValue(Number(range.value)); edit([{ path: "exposure", value: Number(range.value) }], { live: true }); });
    row.append(labelEl("exposure"), range, num, unitEl("stops"));
    box.append(row, Object.assign(div("hint"), { textContent: "The rig's exposure is shared by everyone; the toolbar's is yours alone." }));
    const vtRow = div("row");
    const vt = document.createElement("select");
    vt.id = "rigViewTransform"; vt.dataset.edit = "";
    vt.title = "The view transform everyone sees unless they choose their own in the toolbar";
    for (const [v, t] of [["srgb", "sRGB"], ["filmic", "filmic (ACES fit)"]]) vt.append(new Option(t, v));
    vt.addEventListener("change", () => edit([{ path: "viewTransform", value: vt.value }]));
    vtRow.append(labelEl("view transform"), vt);
    const more = div("");
    box.append(vtRow, more);
    box.update = () => {
      if (document.activeElement !== range) range.value = S.rig.exposure;
      num.setValue(S.rig.exposure);
      vtRow.style.display = "viewTransform" in S.rig ? "" : "none"; // servers before the filmic curve
      if ("viewTransform" in S.rig && document.activeElement !== vt) vt.value = S.rig.viewTransform;
      // Rig-level settings of a newer server (e.g. a view transform for everyone), shown generically.
      const extra = Object.keys(S.rig).filter((k) => !["version", "exposure", "time", "lights", "viewTransform", "groups"].includes(k));
      if (more.dataset.sig !== extra.join("|")) {
        more.dataset.sig = extra.join("|");
        more.innerHTML = "";
        more.updates = extra.map((k) => [k, genericRow(more, k, S.rig[k], k, (v) => edit([{ path: k, value: v }]))]);
      }
      for (const [k, u] of more.updates || []) u(S.rig[k]);
    };
  }
  box.update();
}

// Editing controls ([data-edit]) under `root` are disabled for viewers and while disconnected,
// with the reason as a tooltip. Every renderer that creates such controls calls it on what it made
// (a light list rebuilt by a presence message must not hand a viewer enabled checkboxes).
function applyEditable(root) {
  const ok = canEdit();
  const why = !S.connected ? "not connected" : S.role !== "editor" ? "viewer link: editing is not allowed" : "";
  for (const el of root.querySelectorAll("[data-edit]")) {
    el.disabled = !ok;
    if (!ok) el.dataset.why = why;
  }
  return { ok, why };
}

export function updateEditable() {
  const { ok, why } = applyEditable(document);
  if (ok) {
    $("undo").disabled = !S.history.undo;
    $("redo").disabled = !S.history.redo;
    $("delLight").disabled = $("dupLight").disabled = !S.selected;
  }
  $("undo").title = `Undo the session's last edit (Ctrl+Z) · ${S.history.undo} step(s)${why ? ` · ${why}` : ""}`;
  $("redo").title = `Redo (Ctrl+Shift+Z or Ctrl+Y) · ${S.history.redo} step(s)${why ? ` · ${why}` : ""}`;
  $("overlay").classList.toggle("readonly", !ok);
  $("track").classList.toggle("readonly", !ok);
}

// ---- view settings: output, exposure, transform (per client: the server renders each view) ----

function renderOutputs() {
  const sel = $("output");
  const opts = [["beauty", "beauty"]];
  for (const l of S.rig.lights) opts.push([`light:${l.name}`, `light: ${l.name}`]);
  // An area light's stratified reference beside its one-shot image: the approximation's error.
  for (const l of S.rig.lights) if (l.type === "area" || l.type === "environment") opts.push([`reference:${l.name}`, `reference: ${l.name}`]);
  for (const l of S.rig.lights) opts.push([`shadow:${l.name}`, `shadow: ${l.name}`]);
  for (const n of LAYERS) opts.push([`layer:${n}`, `layer: ${n}`]);
  const sig = opts.map((o) => o[0]).join("|");
  if (sel.dataset.sig !== sig) {
    sel.innerHTML = "";
    for (const [v, t] of opts) sel.append(new Option(t, v));
    sel.dataset.sig = sig;
  }
  sel.value = S.view.output;
}
export function renderView() {
  if (S.rig) renderOutputs();
  $("viewExposure").value = S.view.exposure;
  if (document.activeElement !== $("viewExposureN")) $("viewExposureN").value = S.view.exposure;
  $("viewTransform").value = S.view.viewTransform;
  $("backdropToggle").classList.toggle("on", !!S.view.background);
  renderLights();
  onViewChanged();
}

/** The view toolbar's controls. */
export function initPanels() {
  $("output").addEventListener("change", (e) => sendView({ output: e.target.value }));
  $("viewTransform").addEventListener("change", (e) => sendView({ viewTransform: e.target.value }));
  $("backdropToggle").addEventListener("click", () => sendView({ background: !S.view.background }));
  $("viewExposure").addEventListener("input", (e) => { $("viewExposureN").value = e.target.value; sendViewThrottled({ exposure: Number(e.target.value) }); });
  $("viewExposureN").addEventListener("change", (e) => {
    const r = parseNumber(e.target.value, "view exposure", -20, 20);
    if (r.error) { e.target.classList.add("bad"); return showMessage(r.error); }
    e.target.classList.remove("bad");
    sendView({ exposure: r.value });
  });
}
