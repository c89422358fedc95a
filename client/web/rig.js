// The rig model on the client (docs/protocol.md "The rig"): property paths, the light frame, value
// ranges, keyframes (insertion, interpolation, evaluation) and the optimistic application of
// changes. Keyframe evaluation mirrors protocol::evaluateRig step for step
// (protocol/src/Keyframes.cpp), so that the panel and the handles show what the server renders;
// tests/web/parity.test.mjs checks both on cases the C++ writes
// (tests/unit/protocol_parity_cases_test.cpp).
// Pure: no DOM, so that node can import it (tests/web/).

import { V } from "./linalg.js";

export const NAME_RE = /^[A-Za-z0-9_-]{1,64}$/;
/** Most Bezier segments of a BendyLight chain (dfb::MAX_BENDY_SEGMENTS). */
export const MAX_BENDY_SEGMENTS = 8;
export const clone = (x) => JSON.parse(JSON.stringify(x));
export const lightNamed = (rig, name) => rig?.lights.find((l) => l.name === name);

// The server keeps light properties as 32-bit floats (dfb::Light): evaluated values are rounded
// the same way, so that range checks at a boundary (penumbra <= coneAngle) decide alike.
const f32 = Math.fround;

// ---- value ranges ------------------------------------------------------------------------------
// The rig schema's rows (GET /v1/schema, docs/protocol.md; protocol/src/Schema.cpp, the one list
// of properties): path, type, validation range per component, the light types a row applies to.
// The page reads the server's before it connects (connection.js loadSchema); node's tests take
// the one protocol_parity_cases writes. Until then no property is known: keyed values are not
// applied and the panel has no rows.
let lightTypeList = [];
let lightRows = new Map();
let rigRows = new Map();

/** Uses the rows of a schema ({lightTypes, light: [ROW], rig: [ROW]}, as GET /v1/schema) from now on. */
export function setSchema(schema) {
  lightRows = new Map((schema?.light ?? []).map((r) => [r.path, r]));
  rigRows = new Map((schema?.rig ?? []).map((r) => [r.path, r]));
  lightTypeList = schema?.lightTypes ?? [];
}
/** The schema in use, its rows in the schema's order. */
export const schemaRows = () => ({ lightTypes: lightTypeList, light: [...lightRows.values()], rig: [...rigRows.values()] });

/** The row of a light property ("intensity"; "cp[3]" -> the "cp[]" row), or null. */
export function lightRow(prop) {
  const [base, index] = splitIndex(prop);
  if (index === -2) return null;
  const row = lightRows.get(index >= 0 ? `${base}[]` : base);
  return row && !!row.indexOf === index >= 0 ? row : null;
}
export const rigRow = (path) => rigRows.get(path) ?? null;
/** {min, max} of a property per component, or the widest a number may be where it has none. */
export function rangeOf(prop, rig = false) {
  const row = rig ? rigRow(prop) : lightRow(prop);
  return { min: row?.min ?? -1e12, max: row?.max ?? 1e12 };
}

// ---- property paths ----------------------------------------------------------------------------

/**
 * "cp[3]" -> ["cp", 3]; no index -> [prop, -1]; a malformed index -> [base, -2], refused as
 * the server's findLightProperty (Schema.cpp) refuses it: anything but 1-3 ASCII digits between "[" and a final "]"
 * ("cp[]", "cp[x]", "cp[-1]", "cp[1.5]", "cp[1000]", "cp[1", "cp[1]x", "cp[1][2]").
 */
export function splitIndex(prop) {
  const open = prop.indexOf("[");
  if (open < 0) return [prop, -1];
  const base = prop.slice(0, open);
  if (!prop.endsWith("]") || open + 2 > prop.length - 1) return [base, -2];
  const digits = prop.slice(open + 1, -1);
  if (!/^[0-9]{1,3}$/.test(digits)) return [base, -2];
  return [base, Number(digits)];
}

// The properties whose setters need a chain (Schema.cpp needsChain): BendyLights only.
const CHAIN = new Set(["controlPoints", "radii", "colors", "cp", "r", "cpColor"]);
const RIG_LEVEL = new Set(["exposure", "time", "viewTransform"]);

/**
 * Why the server would refuse `prop` as a property of a light whatever the value, or null:
 * a malformed index, an index on a property that takes none, an unknown property (Edits.cpp
 * setLightProperty; element indices are checked against the chain when a value is set).
 */
export function checkLightProp(prop) {
  const [base, index] = splitIndex(prop);
  if (index === -2) return `${prop}: malformed index (expected NAME[integer])`;
  if (lightRow(prop)) return null;
  if (index >= 0 && lightRows.get(base) && !lightRows.get(base).indexOf) return `${prop}: '${base}' takes no index`;
  return `${prop}: unknown light property '${prop}'`;
}

/**
 * A change's path: {rig: PROP} for a rig-level property, {light, prop} for LIGHT.PROPERTY (split
 * at the first dot, as the server does), or {error}.
 */
export function parsePath(path) {
  if (RIG_LEVEL.has(path)) return { rig: path };
  const dot = path.indexOf(".");
  if (dot <= 0 || dot + 1 === path.length) return { error: `path '${path}': expected LIGHT.PROPERTY, 'exposure', 'viewTransform' or 'time'` };
  const light = path.slice(0, dot), prop = path.slice(dot + 1);
  const error = checkLightProp(prop);
  return error ? { error: `${light}.${error}` } : { light, prop };
}

/** The value of a property path of a light (cp[0] is the source, at the frame's origin). */
export function getProp(l, prop) {
  const [base, i] = splitIndex(prop);
  if (i === -2) return undefined;
  if (base === "cp" && i >= 0) return i === 0 ? [0, 0, 0] : l.controlPoints?.[i - 1];
  if (base === "r" && i >= 0) return l.radii?.[i];
  if (base === "cpColor" && i >= 0) return l.colors?.[i];
  if (i >= 0) return undefined;
  return l[prop];
}

/**
 * Stores a value the server accepted (or will be asked to) without checking its range: the
 * optimistic copy. False when the model cannot apply it faithfully (a malformed or out-of-range
 * index): the caller then re-reads the rig.
 */
export function setProp(l, prop, v) {
  const [base, i] = splitIndex(prop);
  if (i === -2) return false;
  if (i >= 0) {
    const list = base === "cp" ? l.controlPoints : base === "r" ? l.radii : base === "cpColor" ? l.colors : null;
    const at = base === "cp" ? i - 1 : i;
    if (!list || at < 0 || at >= list.length) return false;
    list[at] = v;
    return true;
  }
  if (prop === "direction") v = V.norm(v);
  if (prop === "coneAngle") l.penumbra = Math.min(l.penumbra, v);
  l[prop] = v;
  return true;
}

// ---- the light's frame -------------------------------------------------------------------------

/**
 * The light's frame (docs/lighting.md "Conventions"), exactly as dfb::lightFrame
 * (lightmath::spotFrame, server/include/dfb/lightmath/Falloff.h): uL = direction,
 * wL = normalize(cross(uL, up)), vL = cross(wL, uL), up = +X where |uL.y| > 0.99 (within ~8
 * degrees of vertical), else +Y. At |uL.y| = 0.99 exactly, +Y (web_parity has that case).
 */
export function lightFrame(l) {
  // The server keeps the rig's numbers as 32-bit floats and writes them in their shortest decimal
  // form (0.95, not 0.949999988...): Math.fround gives back the very floats the engine uses, so
  // that the near-vertical threshold decides alike here and there.
  const uL = V.norm(l.direction.map(Math.fround));
  const up = Math.abs(uL[1]) > 0.99 ? [1, 0, 0] : [0, 1, 0];
  const wL = V.norm(V.cross(uL, up));
  const vL = V.cross(wL, uL);
  return { uL, vL, wL };
}
/** The world point of (a, b, c) in the light's frame: position + a uL + b vL + c wL. */
export const frameToWorld = (l, f, a) => V.add(l.position, V.add(V.scale(f.uL, a[0]), V.add(V.scale(f.vL, a[1]), V.scale(f.wL, a[2]))));
export const worldToFrame = (l, f, p) => { const d = V.sub(p, l.position); return [V.dot(d, f.uL), V.dot(d, f.vL), V.dot(d, f.wL)]; };

// ---- keyframes ---------------------------------------------------------------------------------

/**
 * Adds `key` ({t, value, interp}) to the time-sorted `keys`, replacing a key at exactly the same
 * time (Keyframes.cpp insertKey: equal times only; a key 1e-12 s later is a second key).
 */
export function insertKey(keys, key) {
  const i = keys.findIndex((k) => k.t >= key.t);
  if (i >= 0 && keys[i].t === key.t) keys[i] = key;
  else if (i >= 0) keys.splice(i, 0, key);
  else keys.push(key);
}
/** Removes the keys of `prop` within 1e-9 s of t (Keyframes.cpp unkey); drops an emptied list. */
export function removeKey(l, prop, t) {
  const ks = l.keys?.[prop];
  if (!ks) return;
  l.keys[prop] = ks.filter((k) => Math.abs(k.t - t) >= 1e-9);
  if (!l.keys[prop].length) delete l.keys[prop];
}

// Catmull-Rom on scalars: p1 at s = 0, p2 at s = 1, with the neighbours p0, p3 (non-uniform in
// time: tangents from the neighbours' time spacing). Term for term as Keyframes.cpp, so that both
// round alike.
export function catmullRom(p0, p1, p2, p3, t0, t1, t2, t3, s) {
  const dt = t2 - t1;
  const m1 = t2 - t0 > 0 ? (p2 - p0) / (t2 - t0) * dt : 0;
  const m2 = t3 - t1 > 0 ? (p3 - p1) / (t3 - t1) * dt : 0;
  const s2 = s * s, s3 = s2 * s;
  return (2 * s3 - 3 * s2 + 1) * p1 + (s3 - 2 * s2 + s) * m1 + (-2 * s3 + 3 * s2) * p2 + (s3 - s2) * m2;
}

// The keys' value at `time` and whether it is a key's own value (the server's JSON keeps a key's
// integers as integers; interpolated values are floats, which integer properties refuse).
function interpolate(ks, time) {
  const n = ks.length;
  if (time <= ks[0].t) return { value: ks[0].value, fromKey: true };
  if (time >= ks[n - 1].t) return { value: ks[n - 1].value, fromKey: true };
  let i = 0;
  while (i + 1 < n && ks[i + 1].t <= time) i++;
  const a = ks[i], b = ks[i + 1];
  const s = (time - a.t) / (b.t - a.t);
  const before = i > 0 ? ks[i - 1] : a, after = i + 2 < n ? ks[i + 2] : b;
  const one = (x1, x2, x0, x3) => (a.interp === "smooth"
    ? catmullRom(x0, x1, x2, x3, before.t, a.t, b.t, after.t, s) : x1 + (x2 - x1) * s);
  if (typeof a.value === "number") {
    if (typeof b.value !== "number") return { value: a.value, fromKey: true };
    const x0 = typeof before.value === "number" ? before.value : a.value;
    const x3 = typeof after.value === "number" ? after.value : b.value;
    return { value: one(a.value, b.value, x0, x3), fromKey: false };
  }
  if (!Array.isArray(b.value) || b.value.length !== a.value.length) return { value: a.value, fromKey: true };
  const same = (k) => Array.isArray(k.value) && k.value.length === a.value.length;
  return {
    value: a.value.map((x1, c) => one(x1, b.value[c], same(before) ? before.value[c] : x1, same(after) ? after.value[c] : b.value[c])),
    fromKey: false,
  };
}

/**
 * The value of one property's keys (sorted by t) at `time`: the first key's value before it, the
 * last's after it, else from the key before `time` towards the next, linearly or (the earlier
 * key's interp "smooth") by Catmull-Rom. Keys of numbers and of equal-length number arrays.
 */
export const interpolateKeys = (ks, time) => interpolate(ks, time).value;

const isNum = (v, lo, hi) => typeof v === "number" && Number.isFinite(v) && v >= lo && v <= hi;
const isVec = (v, n, lo, hi) => Array.isArray(v) && v.length === n && v.every((x) => isNum(x, lo, hi));

/**
 * Stores a key's value (a number or an array of numbers) in light `l` as the server's
 * setLightProperty does, rounded to 32-bit floats; or returns why the server refuses it (then `l`
 * is unchanged). `fromKey`: the value is a key's own, not interpolated (see interpolate).
 */
export function setKeyedValue(l, prop, v, fromKey = false) {
  const err = checkLightProp(prop);
  if (err) return err;
  const [base, index] = splitIndex(prop);
  const row = lightRow(prop);
  const lo = row.min ?? -Infinity, hi = row.max ?? Infinity;
  const refuse = (why) => `${prop}: ${why}`;
  if (CHAIN.has(base)) {
    if (l.type !== "bendy") return refuse(`'${base}' applies to BendyLights only`);
    const K = Math.floor((l.controlPoints?.length ?? 0) / 2);
    if (base === "cp") {
      if (index < 1 || index > 2 * K) return refuse(`index out of range 1..${2 * K}`);
      if (!isVec(v, 3, lo, hi)) return refuse("expected [a, b, c] in range");
      l.controlPoints[index - 1] = v.map(f32);
    } else if (base === "r" || base === "cpColor") {
      if (index < 0 || index > 2 * K) return refuse(`index out of range 0..${2 * K}`);
      if (base === "r" ? !isNum(v, lo, hi) : !isVec(v, 3, lo, hi)) return refuse("out of range");
      if (base === "r") l.radii[index] = f32(v); else l.colors[index] = v.map(f32);
    } else if (base === "radii") {
      if (!isVec(v, 2 * K + 1, lo, hi)) return refuse(`expected ${2 * K + 1} radii in range`);
      l.radii = v.map(f32);
    } else {
      // controlPoints, colors: lists of [x, y, z], never a key's value (keys hold numbers or
      // flat arrays of numbers: Keyframes.cpp keyFromJson), so the server refuses what a key holds.
      return refuse("expected a list of [x, y, z]");
    }
    return null;
  }
  switch (row.type) {
  case "number":
    if (!isNum(v, lo, hi)) return refuse("expected a number in range");
    if (prop === "penumbra" && f32(v) > l.coneAngle) return refuse("penumbra must not exceed coneAngle");
    l[prop] = f32(v);
    if (prop === "coneAngle") l.penumbra = Math.min(l.penumbra, l.coneAngle); // the penumbra shrinks to fit
    return null;
  case "integer":
    // Integers: only a key's own value (an interpolated one is a float to the server).
    if (!fromKey || !Number.isInteger(v) || v < lo || v > hi) return refuse("expected an integer in range");
    if (prop === "shadowMapSize" && (v & (v - 1)) !== 0) return refuse("must be a power of two");
    l[prop] = v;
    return null;
  case "vec3": case "color":
    if (!isVec(v, 3, lo, hi)) return refuse("expected [x, y, z] in range");
    l[prop] = v.map(f32);
    return null;
  case "direction": {
    if (!isVec(v, 3, lo, hi)) return refuse("expected [x, y, z] in range");
    // In floats, as Schema.cpp setDirection: already-unit directions are kept bit for bit.
    const a = v.map(f32);
    const len = f32(Math.sqrt(f32(f32(f32(a[0] * a[0]) + f32(a[1] * a[1])) + f32(a[2] * a[2]))));
    if (!(len > f32(1e-12)) || !Number.isFinite(len)) return refuse("direction must not be zero");
    l[prop] = Math.abs(f32(len - 1)) < f32(1e-6) ? a : a.map((x) => f32(x / len));
    return null;
  }
  case "numbers": {
    const n = row.size ?? v?.length;
    if (!isVec(v, n, lo, hi)) return refuse(`expected ${n} numbers in range`);
    l[prop] = v.map(f32);
    return null;
  }
  case "idList":
    if (!fromKey || !Array.isArray(v) || v.length > 4096 || !v.every((x) => Number.isInteger(x) && x >= 1 && x <= 2 ** 24)) {
      return refuse("expected an array of object ids");
    }
    l[prop] = v.slice();
    return null;
  default: // strings, booleans, enums, keys: a key's number is not one of them
    return refuse(`a ${row.type} property cannot take a key's value`);
  }
}

/**
 * The light as the server renders it at `time` (protocol::evaluateRig): every keyed property,
 * in the server's order (std::map: by path), replaced by its interpolated value; a value the
 * property refuses (a Catmull-Rom overshoot below 0, a penumbra over the cone) is skipped.
 * Returns `l` itself when it has no keys.
 */
export function evaluateLight(l, time) {
  const props = l?.keys ? Object.keys(l.keys).sort() : [];
  if (!props.length) return l;
  const e = clone(l);
  for (const prop of props) {
    const ks = l.keys[prop];
    if (!ks?.length) continue;
    const { value, fromKey } = interpolate(ks, time);
    setKeyedValue(e, prop, value, fromKey);
  }
  return e;
}

// ---- changes -----------------------------------------------------------------------------------

/**
 * Applies one change to the optimistic copy `rig`. Returns false for changes whose full effect only
 * the server knows (a new chain, resampled lists, a rename not yet accepted, a path the model
 * cannot apply): the caller then re-reads the rig. `authoritative`: the server accepted it (an
 * ack or another client's change); `onRename(old, new)` runs before an accepted rename.
 */
export function applyLocal(rig, c, { authoritative = false, onRename = null } = {}) {
  if (c.path === "exposure") { rig.exposure = c.value; return true; }
  if (c.path === "time") { rig.time = c.value; return true; }
  const dot = c.path.indexOf(".");
  if (dot < 0) { rig[c.path] = c.value; return true; } // another rig-level setting
  const l = lightNamed(rig, c.path.slice(0, dot));
  if (!l) return false;
  const prop = c.path.slice(dot + 1);
  if (prop === "key") {
    const { path, ...k } = c.value;
    l.keys = l.keys || {};
    insertKey(l.keys[path] = l.keys[path] || [], { interp: "linear", ...k });
    return true;
  }
  if (prop === "unkey") { removeKey(l, c.value.path, c.value.t); return true; }
  if (prop === "name") {
    // Our own rename waits for the server: a refused one (a name taken) must not leave two
    // lights of one name here.
    if (!authoritative) return false;
    onRename?.(l.name, c.value);
    for (const g of rig.groups ?? []) g.lights = g.lights.map((n) => (n === l.name ? c.value : n)); // as the server does
    l.name = c.value;
    return true;
  }
  if (prop === "type" || prop === "controlPoints" || prop === "radii" || prop === "colors" || prop === "keys") {
    l[prop] = c.value;
    return false;
  }
  return setProp(l, prop, c.value);
}

/** `base` made a valid light name not yet used in `rig` (base, base2, base3, ...). */
export function uniqueName(base, rig) {
  const names = new Set(rig.lights.map((l) => l.name));
  base = base.replace(/[^A-Za-z0-9_-]/g, "_").slice(0, 56) || "light";
  if (!names.has(base)) return base;
  for (let i = 2; ; i++) if (!names.has(`${base}${i}`)) return `${base}${i}`;
}
