// The browser's rig model (client/web/rig.js) in node, with the server's schema rows
// (schema.mjs): property paths refused as the server's schema refuses them (findLightProperty, protocol/src/Schema.cpp), key insertion, interpolation values worked out by
// hand, evaluation (refused values skipped, as protocol::evaluateRig does), optimistic changes.
// The values the C++ itself gives are checked by parity.test.mjs.

import assert from "node:assert/strict";
import { describe, test } from "node:test";

import {
  applyLocal, catmullRom, checkLightProp, evaluateLight, getProp, insertKey, interpolateKeys, lightFrame,
  parsePath, rangeOf, removeKey, schemaRows, setKeyedValue, setProp, setSchema, splitIndex, uniqueName,
} from "../../client/web/rig.js";
import { serverSchema, useServerSchema } from "./schema.mjs"; // the rows: the server's schema

const spot = () => ({ name: "key", type: "spot", enabled: true, position: [0, 3, 3], direction: [0, -0.6, -0.8], color: [1, 1, 1],
                      intensity: 50, coneAngle: 35, penumbra: 8, shadow: true, shadowMapSize: 2048, shadowBias: 1.5, shadowFilter: 1,
                      barnDoors: [90, 90, 90, 90] });
const bendy = () => ({ ...spot(), type: "bendy", controlPoints: [[1, 0, 0], [2, 0, 0], [3, 0, 0], [4, 0, 0]],
                       radii: [0, 0.5, 1, 1.5, 2], colors: [[1, 1, 1], [1, 1, 1], [1, 1, 1], [1, 1, 1], [1, 1, 1]] });
const k = (t, value, interp = "linear") => ({ t, value, interp });

describe("property paths", () => {
  test("an index is 1-3 ASCII digits between [ and a final ]", () => {
    assert.deepEqual(splitIndex("intensity"), ["intensity", -1]);
    assert.deepEqual(splitIndex("cp[3]"), ["cp", 3]);
    assert.deepEqual(splitIndex("cpColor[12]"), ["cpColor", 12]);
    assert.deepEqual(splitIndex("r[999]"), ["r", 999]);
    assert.deepEqual(splitIndex("cp[01]"), ["cp", 1]); // std::stoi("01"): the server reads it as 1
  });
  test("a malformed index is refused, as the server refuses it", () => {
    for (const p of ["cp[]", "cp[x]", "cp[-1]", "cp[1.5]", "cp[1000]", "cp[1", "cp[1]x", "cp[1][2]", "cp[ 1]", "cp[1 ]", "cp[+1]",
                     "cp[１]", "cp[٣]", "cp[0x1]", "cp[1e2]", "["]) {
      assert.equal(splitIndex(p)[1], -2, p);
      assert.match(checkLightProp(p), /malformed index/, p);
    }
  });
  test("only chain elements take an index; unknown properties are refused", () => {
    assert.match(checkLightProp("intensity[0]"), /'intensity' takes no index/);
    assert.match(checkLightProp("controlPoints[1]"), /takes no index/);
    assert.match(checkLightProp("intensty"), /unknown light property/);
    assert.match(checkLightProp("foo[1]"), /unknown light property/);
    assert.match(checkLightProp("cp"), /unknown light property/); // only its elements: cp[i]
    for (const p of ["cp[0]", "cp[16]", "r[0]", "cpColor[4]", "intensity", "keys", "key", "unkey", "barnDoors"]) assert.equal(checkLightProp(p), null, p);
  });
  test("paths split at the first dot; rig-level names stand alone", () => {
    assert.deepEqual(parsePath("exposure"), { rig: "exposure" });
    assert.deepEqual(parsePath("time"), { rig: "time" });
    assert.deepEqual(parsePath("key.cp[2]"), { light: "key", prop: "cp[2]" });
    assert.match(parsePath("key.cp[2.0]").error, /^key\.cp\[2\.0\]: malformed index/);
    for (const p of [".intensity", "key.", "intensity", ""]) assert.match(parsePath(p).error, /expected LIGHT\.PROPERTY/, p);
  });
  test("getProp and setProp refuse what they cannot address", () => {
    const l = bendy();
    assert.deepEqual(getProp(l, "cp[0]"), [0, 0, 0]);
    assert.deepEqual(getProp(l, "cp[2]"), [2, 0, 0]);
    assert.equal(getProp(l, "r[4]"), 2);
    assert.equal(getProp(l, "cp[x]"), undefined);
    assert.equal(getProp(l, "intensity[0]"), undefined);
    assert.equal(setProp(l, "cp[5]", [9, 9, 9]), false);
    assert.equal(setProp(l, "cp[0]", [9, 9, 9]), false);
    assert.equal(setProp(l, "cp[]", [9, 9, 9]), false);
    assert.equal("cp[]" in l, false);
    assert.equal(setProp(l, "cp[4]", [9, 9, 9]), true);
    assert.deepEqual(l.controlPoints[3], [9, 9, 9]);
    assert.equal(setProp(l, "coneAngle", 5), true);
    assert.equal(l.penumbra, 5); // the penumbra shrinks to fit
  });
  test("value ranges are the schema's, and follow the schema set", () => {
    assert.deepEqual(rangeOf("intensity"), { min: 0, max: 1e12 });
    assert.deepEqual(rangeOf("coneAngle"), { min: 0.1, max: 85 });
    assert.deepEqual(rangeOf("cp[3]"), { min: -1e7, max: 1e7 });
    assert.deepEqual(rangeOf("exposure", true), { min: -20, max: 20 });
    try {
      setSchema({ lightTypes: ["spot"], light: [{ path: "intensity", type: "number", min: 1, max: 2 }], rig: [] });
      assert.deepEqual(rangeOf("intensity"), { min: 1, max: 2 });
      assert.match(checkLightProp("coneAngle"), /unknown light property/);
      setSchema(null); // before the page has read one: nothing is known, no key is applied
      assert.match(checkLightProp("intensity"), /unknown light property/);
      assert.equal(evaluateLight({ ...spot(), keys: { intensity: [k(0, 1), k(1, 3)] } }, 0.5).intensity, 50);
    } finally {
      useServerSchema();
    }
    assert.deepEqual(schemaRows().light, serverSchema.light);
  });
});

describe("keys", () => {
  test("insertion keeps time order and replaces a key at exactly the same time", () => {
    const ks = [];
    insertKey(ks, k(1, 10));
    insertKey(ks, k(0, 5));
    insertKey(ks, k(3, 30));
    insertKey(ks, k(2, 20));
    assert.deepEqual(ks.map((x) => x.t), [0, 1, 2, 3]);
    insertKey(ks, k(2, 99, "smooth"));
    assert.deepEqual(ks.map((x) => [x.t, x.value, x.interp]), [[0, 5, "linear"], [1, 10, "linear"], [2, 99, "smooth"], [3, 30, "linear"]]);
    // Equal means equal (Keyframes.cpp insertKey): a key 1e-12 s later is another key, after it.
    insertKey(ks, k(2 + 1e-12, 7));
    assert.deepEqual(ks.map((x) => x.value), [5, 10, 99, 7, 30]);
  });
  test("removal takes the keys within 1e-9 s and drops an emptied property", () => {
    const l = { keys: { intensity: [k(0, 1), k(1, 2)] } };
    removeKey(l, "intensity", 1 + 1e-10);
    assert.deepEqual(l.keys.intensity, [k(0, 1)]);
    removeKey(l, "intensity", 0.5);
    assert.equal(l.keys.intensity.length, 1);
    removeKey(l, "intensity", 0);
    assert.equal("intensity" in l.keys, false);
  });
  test("linear: ends hold, between is a straight line from the earlier key", () => {
    const ks = [k(0, 10), k(2, 30), k(3, 0)];
    assert.equal(interpolateKeys(ks, -5), 10);
    assert.equal(interpolateKeys(ks, 0), 10);
    assert.equal(interpolateKeys(ks, 0.5), 15);
    assert.equal(interpolateKeys(ks, 2), 30);
    assert.equal(interpolateKeys(ks, 2.5), 15);
    assert.equal(interpolateKeys(ks, 99), 0);
    assert.deepEqual(interpolateKeys([k(0, [0, 2, 4]), k(1, [1, 4, 0])], 0.25), [0.25, 2.5, 3]);
  });
  test("smooth: Catmull-Rom reproduces a parabola on even spacing, and follows the time spacing", () => {
    const sq = [0, 1, 2, 3].map((t) => k(t, t * t, "smooth"));
    assert.equal(interpolateKeys(sq, 1.5), 2.25);
    assert.equal(interpolateKeys(sq, 0.5), 0.375); // the first segment's missing neighbour is the key itself
    // Uneven: tangents (p2 - p0) / (t2 - t0) scaled to the segment: 1 + 0.75, 9 - 1.25 at the middle.
    const uneven = [k(0, 0, "smooth"), k(1, 1, "smooth"), k(3, 9, "smooth"), k(4, 16, "smooth")];
    assert.equal(interpolateKeys(uneven, 2), 4.5);
    assert.equal(catmullRom(0, 1, 9, 16, 0, 1, 3, 4, 0), 1);
    assert.equal(catmullRom(0, 1, 9, 16, 0, 1, 3, 4, 1), 9);
  });
  test("the earlier key's interp decides a segment", () => {
    const ks = [k(0, 0, "smooth"), k(1, 1), k(2, 4, "smooth"), k(3, 9)];
    assert.equal(interpolateKeys(ks, 1.5), 2.5); // linear from the key at 1
    // Smooth from the key at 2, the last segment: its missing neighbour is its own end key, so the
    // tangents are 4 and 5 (not the parabola's 6.25).
    assert.equal(interpolateKeys(ks, 2.5), 6.375);
  });
  test("mismatched values hold the earlier key's value", () => {
    assert.equal(interpolateKeys([k(0, 3), k(1, [1, 2, 3])], 0.5), 3);
    assert.deepEqual(interpolateKeys([k(0, [1, 2]), k(1, [1, 2, 3])], 0.5), [1, 2]);
    // A neighbour of another length is replaced by the segment's own key, as in Keyframes.cpp.
    const ks = [k(0, [0, 0, 0, 0], "smooth"), k(1, [0, 0, 0], "smooth"), k(2, [2, 4, 6], "smooth"), k(3, [9, 9, 9, 9], "smooth")];
    assert.deepEqual(interpolateKeys(ks, 1.5), [1, 2, 3]);
  });
});

describe("evaluation at the session time", () => {
  test("a light without keys is returned as it is", () => {
    const l = spot();
    assert.equal(evaluateLight(l, 3), l);
  });
  test("keyed values replace the property; the keys stay", () => {
    const l = { ...spot(), keys: { intensity: [k(0, 10), k(2, 30)], position: [k(0, [0, 0, 0]), k(1, [2, 4, 6])] } };
    const e = evaluateLight(l, 0.5);
    assert.equal(e.intensity, 15);
    assert.deepEqual(e.position, [1, 2, 3]);
    assert.equal(l.intensity, 50); // the rig is not touched
    assert.deepEqual(e.keys, l.keys);
  });
  test("a value the property refuses is skipped: the unkeyed value stays", () => {
    // Catmull-Rom dips below 0 between the first two keys: intensity >= 0 refuses it.
    const l = { ...spot(), keys: { intensity: [k(0, 0, "smooth"), k(1, 0, "smooth"), k(1.1, 100, "smooth")] } };
    assert.equal(evaluateLight(l, 0.5).intensity, 50);
    assert.equal(evaluateLight(l, 1.05).intensity > 0, true);
  });
  test("the cone is applied before the penumbra and clamps it", () => {
    const l = { ...spot(), keys: { penumbra: [k(0, 5), k(2, 20)], coneAngle: [k(0, 40), k(2, 10)] } };
    const at1 = evaluateLight(l, 1);
    assert.deepEqual([at1.coneAngle, at1.penumbra], [25, 12.5]);
    const at18 = evaluateLight(l, 1.8); // penumbra 18.5 > cone 13: refused; the unkeyed 8 stays
    assert.deepEqual([at18.coneAngle, at18.penumbra], [Math.fround(13), 8]);
    const after = evaluateLight({ ...l, penumbra: 12 }, 5); // cone 10 clamps the unkeyed 12
    assert.deepEqual([after.coneAngle, after.penumbra], [10, 10]);
  });
  test("integers take a key's own value only (an interpolated one is a float to the server)", () => {
    const l = { ...spot(), keys: { shadowFilter: [k(0, 2), k(2, 4)], shadowMapSize: [k(0, 512), k(1, 1024)] } };
    assert.equal(evaluateLight(l, -1).shadowFilter, 2);
    assert.equal(evaluateLight(l, 1).shadowFilter, 1);
    assert.equal(evaluateLight(l, 3).shadowFilter, 4);
    assert.equal(evaluateLight(l, 0.5).shadowMapSize, 2048);
    assert.equal(evaluateLight(l, 1).shadowMapSize, 1024);
  });
  test("chain keys apply to BendyLights only, within the chain", () => {
    const keys = { "cp[2]": [k(0, [2, 0, 0]), k(1, [2, 2, 0])], "r[9]": [k(0, 1), k(1, 2)], intensity: [k(0, 1), k(1, 3)] };
    const b = evaluateLight({ ...bendy(), keys }, 0.5);
    assert.deepEqual(b.controlPoints[1], [2, 1, 0]);
    assert.equal(b.intensity, 2);
    const s = evaluateLight({ ...bendy(), type: "spot", keys }, 0.5);
    assert.deepEqual(s.controlPoints[1], [2, 0, 0]);
    assert.equal(s.intensity, 2);
  });
  test("interpolated directions are normalised in floats; unit ones kept as they are", () => {
    const l = { ...spot(), keys: { direction: [k(0, [1, 0, 0]), k(1, [0, 0, 1])] } };
    const e = evaluateLight(l, 0.5);
    assert.deepEqual(e.direction, [Math.fround(Math.SQRT1_2), 0, Math.fround(Math.SQRT1_2)]);
    assert.deepEqual(evaluateLight(l, 0).direction, [1, 0, 0]);
    assert.match(setKeyedValue(spot(), "direction", [0, 0, 0]), /must not be zero/);
  });
  test("evaluated values are 32-bit floats, as the server stores them", () => {
    const e = evaluateLight({ ...spot(), keys: { intensity: [k(0, 0), k(3, 1)] } }, 1);
    assert.equal(e.intensity, Math.fround(1 / 3));
  });
});

describe("optimistic changes", () => {
  test("a rename waits for the server; an accepted one renames through onRename", () => {
    const rig = { exposure: 0, time: 0, lights: [spot()] };
    assert.equal(applyLocal(rig, { path: "key.name", value: "rim" }), false);
    assert.equal(rig.lights[0].name, "key");
    const renamed = [];
    assert.equal(applyLocal(rig, { path: "key.name", value: "rim" }, { authoritative: true, onRename: (a, b) => renamed.push([a, b]) }), true);
    assert.deepEqual(renamed, [["key", "rim"]]);
    assert.equal(rig.lights[0].name, "rim");
  });
  test("keys are added and removed; the server's effects are left to it", () => {
    const rig = { exposure: 0, time: 0, lights: [bendy()] };
    assert.equal(applyLocal(rig, { path: "key.key", value: { path: "intensity", t: 1, value: 5 } }), true);
    assert.deepEqual(rig.lights[0].keys.intensity, [{ interp: "linear", t: 1, value: 5 }]);
    assert.equal(applyLocal(rig, { path: "key.unkey", value: { path: "intensity", t: 1 } }), true);
    assert.equal("intensity" in rig.lights[0].keys, false);
    assert.equal(applyLocal(rig, { path: "key.type", value: "spot" }), false);
    assert.equal(applyLocal(rig, { path: "nobody.intensity", value: 1 }), false);
    assert.equal(applyLocal(rig, { path: "key.cp[9]", value: [0, 0, 0] }), false);
    assert.equal(applyLocal(rig, { path: "exposure", value: 2 }), true);
    assert.equal(rig.exposure, 2);
  });
  test("unique names", () => {
    const rig = { lights: [{ name: "spot" }, { name: "spot2" }] };
    assert.equal(uniqueName("spot", rig), "spot3");
    assert.equal(uniqueName("a b!", rig), "a_b_");
    assert.equal(uniqueName("", rig), "light");
  });
});

test("the light frame is right-handed and orthonormal; near vertical, up is +X", () => {
  for (const direction of [[0, -0.6, -0.8], [1, 2, 3], [0, 1, 0], [0.1, -0.995, 0]]) {
    const { uL, vL, wL } = lightFrame({ direction });
    const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    for (const [a, b] of [[uL, vL], [uL, wL], [vL, wL]]) assert.ok(Math.abs(dot(a, b)) < 1e-12);
    for (const a of [uL, vL, wL]) assert.ok(Math.abs(dot(a, a) - 1) < 1e-12);
  }
  // |uL.y| > 0.99: wL = normalize(cross(uL, +X)) lies in the y-z plane.
  assert.equal(lightFrame({ direction: [0, 1, 0] }).wL[0], 0);
  assert.deepEqual(lightFrame({ direction: [1, 0, 0] }).wL, [0, 0, 1]);
});
