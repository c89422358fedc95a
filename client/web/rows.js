// The rows of the selected light's property panel (panels.js builds a widget for each), from the
// rig schema's light rows (GET /v1/schema, as rig.js holds them). Each row is a descriptor
// [prop, label, unit, kind, options]; kinds: type, bool, choice (options.values), color, text,
// vec (options.names: one number per component), slider (with typed entry), number (typed
// entry), json (anything else).
// Pure: no DOM, so that node can import it (tests/web/).

import { schemaRows } from "./rig.js";

// Names of the components of fixed-size number lists (the schema gives their number only).
const COMPONENTS = { barnDoors: ["left", "right", "top", "bottom"], rotation: ["yaw", "pitch", "roll"] };
// A slider's upper end bounded by another property: the server refuses a penumbra wider than the
// cone (Schema.cpp setPenumbra), which a row's own range cannot say.
const BOUNDED_BY = { penumbra: "coneAngle" };
// Rows not listed with the others: edited in a field of their own (name), in the chain table and
// with the handles (chain lists and elements), on the timeline (keys), in the linking section, or
// set by the server alone.
const skipRow = (r) => r.readOnly || r.indexOf || r.path === "name" || ["keys", "points", "colors", "idList"].includes(r.type) ||
                       (r.type === "numbers" && !r.size); // one number per chain point
export const lowerFirst = (t) => t.charAt(0).toLowerCase() + t.slice(1);
// Units as the page shows them, short; "cd (lux for directional)" is lux for a directional light.
function shortUnit(unit = "", type) {
  const m = /^(.*) \((\S+) for (\w+)\)$/.exec(unit);
  if (m) unit = m[3] === type ? m[2] : m[1];
  return { "scene units": "u", degrees: "°", "shadow-map texels": "texels", "linear RGB": "linear" }[unit] ?? unit;
}

/**
 * The panel's rows for light `l`: the schema's light rows that apply to its type, in the schema's
 * order, with their labels, units and ranges. Sliders span a row's uiMin..uiMax (stretched to
 * show a value beyond it), on a log scale where that spans four decades of the row's step
 * (intensities); rows without a ui range get a typed entry only.
 */
export function propertyRows(l) {
  const schema = schemaRows();
  const rows = [];
  for (const r of schema.light) {
    if ((r.appliesTo && !r.appliesTo.includes(l.type)) || skipRow(r)) continue;
    const label = lowerFirst(r.label ?? r.path), unit = shortUnit(r.unit, l.type);
    const o = { min: r.min ?? -1e12, max: r.max ?? 1e12, title: r.doc ?? "", integer: r.type === "integer" };
    const ui = typeof r.uiMin === "number" && typeof r.uiMax === "number" && r.uiMax > r.uiMin;
    if (r.path === "type") rows.push([r.path, label, "", "type", { values: schema.lightTypes }]);
    else if (r.type === "boolean") rows.push([r.path, label, unit, "bool", o]);
    else if (r.values) rows.push([r.path, label, unit, "choice", { ...o, values: r.values }]);
    else if (r.type === "number" || r.type === "integer") {
      if (!ui) { rows.push([r.path, label, unit, "number", o]); continue; }
      let smax = Math.max(r.uiMax, typeof l[r.path] === "number" ? l[r.path] : -Infinity);
      const bound = BOUNDED_BY[r.path];
      if (bound && typeof l[bound] === "number") smax = Math.min(smax, l[bound]);
      const log = r.uiMin >= 0 && (r.uiMax - r.uiMin) / (r.step || 1) >= 1e4;
      rows.push([r.path, label, unit, "slider", { ...o, smin: log ? 0 : r.uiMin, smax, log }]);
    } else if (r.type === "vec3" || r.type === "direction") rows.push([r.path, label, unit, "vec", { ...o, names: ["x", "y", "z"] }]);
    else if (r.type === "color") rows.push([r.path, label, unit, "color", o]);
    else if (r.type === "numbers") rows.push([r.path, label, unit, "vec", { ...o, names: COMPONENTS[r.path] ?? [...Array(r.size).keys()].map(String) }]);
    else if (r.type === "string") rows.push([r.path, label, unit, "text", o]);
    else rows.push([r.path, label, unit, "json", o]);
  }
  return rows;
}

