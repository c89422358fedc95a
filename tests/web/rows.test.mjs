// The light panel's rows (client/web/rows.js) in node: built from a made-up schema in the format
// of GET /v1/schema (docs/protocol.md) that has every kind of row, and from the server's own
// (schema.mjs).

import assert from "node:assert/strict";
import { after, before, describe, test } from "node:test";

import { setSchema } from "../../client/web/rig.js";
import { propertyRows } from "../../client/web/rows.js";
import { serverSchema, useServerSchema } from "./schema.mjs";

const ALL = ["spot", "point", "bendy", "directional"];
const row = (path, type, extra = {}) => ({ path, label: path[0].toUpperCase() + path.slice(1), type, appliesTo: ALL, ...extra });
const schema = {
  schema: 1, lightTypes: ALL, rig: [],
  light: [
    row("name", "string"),
    row("type", "enum", { values: ["spot", "point", "directional", "bendy"] }),
    row("enabled", "boolean"),
    row("position", "vec3", { unit: "scene units", min: -1e7, max: 1e7, appliesTo: ["spot", "point", "bendy"] }),
    row("direction", "direction", { min: -1e7, max: 1e7, appliesTo: ["spot", "bendy", "directional"] }),
    row("color", "color", { label: "Color", unit: "linear RGB", min: 0, max: 1e6 }),
    row("intensity", "number", { unit: "cd (lux for directional)", min: 0, max: 1e12, uiMin: 0, uiMax: 1000, step: 0.1 }),
    row("coneAngle", "number", { label: "Cone angle", unit: "degrees", min: 0.1, max: 85, uiMin: 1, uiMax: 85, step: 0.5, appliesTo: ["spot", "bendy"] }),
    row("penumbra", "number", { unit: "degrees", min: 0, max: 85, uiMin: 0, uiMax: 30, step: 0.5, appliesTo: ["spot", "bendy"] }),
    row("shadowMapSize", "integer", { label: "Shadow map", unit: "texels", min: 64, max: 8192, values: [64, 128, 256, 512, 1024, 2048, 4096, 8192] }),
    row("shadowFilter", "integer", { label: "Shadow softness", min: 0, max: 4, uiMin: 0, uiMax: 4, step: 1 }),
    row("lensShift", "number", { min: -1, max: 1 }), // no slider range: typed entry only
    row("barnDoors", "numbers", { label: "Barn doors", unit: "degrees", min: 0, max: 90, uiMin: 0, uiMax: 90, step: 1, size: 4, appliesTo: ["spot"] }),
    row("cookie", "string", { appliesTo: ["spot"] }),
    row("include", "idList"),
    row("controlPoints", "points", { appliesTo: ["bendy"] }),
    row("cp[]", "vec3", { indexOf: "controlPoints", appliesTo: ["bendy"] }),
    row("radii", "numbers", { appliesTo: ["bendy"] }),
    row("colors", "colors", { appliesTo: ["bendy"] }),
    row("exactDirection", "boolean", { appliesTo: ["bendy"] }),
    row("keys", "keys"), row("key", "keys"), row("unkey", "keys"),
    row("warning", "string", { readOnly: true }),
    row("gobo", "mystery"), // a type this page does not know: edited as JSON
  ],
};
const light = (type) => ({ name: "l", type, intensity: 50, coneAngle: 20, penumbra: 5, barnDoors: [90, 90, 90, 90] });
const byPath = (rows) => Object.fromEntries(rows.map(([p, label, unit, kind, o]) => [p, { label, unit, kind, o }]));

describe("rows from the schema", () => {
  before(() => setSchema(schema));
  after(useServerSchema);
  test("rows that apply to the light's type, in the schema's order; the rest are edited elsewhere", () => {
    assert.deepEqual(propertyRows(light("spot")).map((r) => r[0]),
                     ["type", "enabled", "position", "direction", "color", "intensity", "coneAngle", "penumbra", "shadowMapSize",
                      "shadowFilter", "lensShift", "barnDoors", "cookie", "gobo"]);
    assert.deepEqual(propertyRows(light("point")).map((r) => r[0]),
                     ["type", "enabled", "position", "color", "intensity", "shadowMapSize", "shadowFilter", "lensShift", "gobo"]);
    assert.deepEqual(propertyRows(light("bendy")).map((r) => r[0]),
                     ["type", "enabled", "position", "direction", "color", "intensity", "coneAngle", "penumbra", "shadowMapSize",
                      "shadowFilter", "lensShift", "exactDirection", "gobo"]);
  });
  test("widgets, labels and units follow the row's type", () => {
    const r = byPath(propertyRows(light("spot")));
    assert.deepEqual(r.type.o.values, ALL); // the schema's order of light types
    assert.equal(r.enabled.kind, "bool");
    assert.deepEqual([r.position.kind, r.position.o.names, r.position.unit, r.position.o.min], ["vec", ["x", "y", "z"], "u", -1e7]);
    assert.deepEqual([r.color.kind, r.color.label], ["color", "color"]);
    assert.deepEqual([r.coneAngle.label, r.coneAngle.unit], ["cone angle", "°"]);
    assert.deepEqual([r.shadowMapSize.kind, r.shadowMapSize.o.values.length], ["choice", 8]);
    assert.deepEqual([r.barnDoors.kind, r.barnDoors.o.names, r.barnDoors.o.max], ["vec", ["left", "right", "top", "bottom"], 90]);
    assert.deepEqual([r.lensShift.kind, r.lensShift.o.min, r.lensShift.o.max], ["number", -1, 1]);
    assert.equal(r.cookie.kind, "text");
    assert.equal(r.gobo.kind, "json");
  });
  test("intensity: lux for a directional light, cd for the others", () => {
    assert.equal(byPath(propertyRows(light("spot"))).intensity.unit, "cd");
    assert.equal(byPath(propertyRows(light("directional"))).intensity.unit, "lux");
  });
  test("sliders: the row's ui range, log where it spans four decades of its step, integers stepped", () => {
    const r = byPath(propertyRows(light("spot")));
    assert.deepEqual([r.intensity.kind, r.intensity.o.log, r.intensity.o.smin, r.intensity.o.smax, r.intensity.o.max], ["slider", true, 0, 1000, 1e12]);
    assert.deepEqual([r.coneAngle.o.log, r.coneAngle.o.smin, r.coneAngle.o.smax, r.coneAngle.o.min], [false, 1, 85, 0.1]);
    assert.deepEqual([r.shadowFilter.kind, r.shadowFilter.o.integer, r.shadowFilter.o.smax], ["slider", true, 4]);
    // The penumbra's slider ends at the cone (the server refuses a wider one).
    assert.equal(r.penumbra.o.smax, 20);
    // A value beyond the ui range stretches the slider rather than pinning its knob.
    assert.equal(byPath(propertyRows({ ...light("spot"), intensity: 5000 })).intensity.o.smax, 5000);
  });
});

test("with the server's schema: its rows by type, under its labels", () => {
  useServerSchema();
  const spot = propertyRows(light("spot"));
  assert.deepEqual(spot.map((r) => r[0]), ["type", "enabled", "position", "direction", "color", "intensity", "coneAngle", "penumbra",
                                           "shadow", "shadowMapSize", "shadowBias", "shadowFilter", "barnDoors", "cookie"]);
  const label = (path) => serverSchema.light.find((r) => r.path === path).label;
  for (const [path, shown] of spot) assert.equal(shown, label(path).charAt(0).toLowerCase() + label(path).slice(1), path);
  const point = propertyRows(light("point")).map((r) => r[0]);
  assert.ok(!point.includes("direction") && !point.includes("coneAngle") && !point.includes("barnDoors"), point.join());
  assert.ok(propertyRows(light("bendy")).some((r) => r[0] === "exactDirection"));
  assert.ok(!propertyRows(light("spot")).some((r) => r[0] === "exactDirection"));
});
