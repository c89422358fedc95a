// Keyframe evaluation, the light frame and an area light's emitter frame exist once each in the
// page (client/web/rig.js, area.js) and once in the server (protocol::evaluateRig,
// dfb::lightFrame, lightmath::areaFrame): this checks that both give the
// same values on the cases tests/unit/protocol_parity_cases_test.cpp writes (CTest runs that
// first: fixture protocol_parity_cases; the file's path comes in DFB_PARITY_CASES), with the
// server's schema rows (schema.mjs).
//
// Tolerance: 1e-6 relative. The server stores light properties as 32-bit floats and so does the
// page's evaluation (Math.fround), so most values agree exactly; components of a vector are
// compared relative to the vector's length (a component near 0 after a cancellation carries the
// rounding of the whole vector).

import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { test } from "node:test";

import { areaFrame, cornerChains } from "../../client/web/area.js";
import { envDirection, envRotation } from "../../client/web/envgizmo.js";
import { evaluateLight, lightFrame } from "../../client/web/rig.js";
import { propertyRows } from "../../client/web/rows.js";
import { serverSchema } from "./schema.mjs";

const file = process.env.DFB_PARITY_CASES;
const cases = file ? JSON.parse(readFileSync(file, "utf8")) : null;
const REL = 1e-6;

const isNumeric = (v) => typeof v === "number" || (Array.isArray(v) && v.every(isNumeric));
const norm = (v) => Math.hypot(...v.flat(Infinity));
// Compares a JavaScript value with the C++ one: numbers within REL of the larger magnitude,
// arrays component by component relative to the C++ array's length; anything else equal.
function same(js, cpp, where, scale = 0) {
  if (typeof cpp === "number") {
    const tol = REL * Math.max(Math.abs(cpp), Math.abs(js ?? 0), scale, 1e-30);
    assert.ok(typeof js === "number" && Math.abs(js - cpp) <= tol, `${where}: JavaScript ${js}, C++ ${cpp}`);
  } else if (Array.isArray(cpp) && isNumeric(cpp)) {
    assert.ok(Array.isArray(js) && js.length === cpp.length, `${where}: JavaScript ${JSON.stringify(js)}, C++ ${JSON.stringify(cpp)}`);
    const s = Math.max(scale, norm(cpp));
    cpp.forEach((c, i) => same(js[i], c, `${where}[${i}]`, Array.isArray(c) ? 0 : s));
  } else {
    assert.deepEqual(js, cpp, where);
  }
}

test("the cases file is there and holds cases", { skip: !file && "DFB_PARITY_CASES is not set (CTest sets it)" }, () => {
  assert.ok(cases.keyframes.length >= 10, `${cases.keyframes.length} keyframe cases`);
  assert.ok(cases.lightFrames.length >= 25, `${cases.lightFrames.length} light frames`);
});

test("keyframed lights evaluate as protocol::evaluateRig evaluates them", { skip: !file && "DFB_PARITY_CASES is not set" }, () => {
  let values = 0;
  for (const c of cases.keyframes) {
    for (const { time, light: expected } of c.evaluations) {
      const got = evaluateLight(c.light, time);
      for (const [prop, v] of Object.entries(expected)) {
        same(got[prop], v, `${c.name}, t = ${time}: ${prop}`);
        if (isNumeric(v)) values++;
      }
      for (const prop of Object.keys(got)) assert.ok(prop in expected, `${c.name}, t = ${time}: ${prop} is not in the server's light`);
    }
  }
  assert.ok(values > 1000, `only ${values} values compared`);
});

test("the schema the node tests use is the one written with the cases", { skip: !file && "DFB_PARITY_CASES is not set" }, () => {
  assert.deepEqual(serverSchema, cases.schema);
});

test("every row of the server's schema has a widget the panel knows, or its place elsewhere", () => {
  for (const type of serverSchema.lightTypes) {
    const rows = propertyRows({ name: "l", type, intensity: 50, coneAngle: 30, penumbra: 5 });
    assert.ok(rows.length >= 8, `${type}: ${rows.length} rows`);
    for (const [path, , , kind] of rows) assert.notEqual(kind, "json", `${path} (${type}) has no widget of its own`);
  }
});

test("an area light's frame is lightmath::areaFrame's, roll included", { skip: !file && "DFB_PARITY_CASES is not set" }, () => {
  assert.ok(cases.areaFrames.length >= 100, `${cases.areaFrames.length} area frames`);
  for (const { direction, roll, normal, right, up } of cases.areaFrames) {
    const a = areaFrame({ position: [1, 2, 3], direction, roll, size: [2, 1], shape: "rect" });
    const where = `${JSON.stringify(direction)} roll ${roll}`;
    same(a.normal, normal, `normal of ${where}`);
    same(a.right, right, `right of ${where}`);
    same(a.up, up, `up of ${where}`);
  }
});

test("a bent area light's corner chains are dfb::bentAreaCorner's, roll included", { skip: !file && "DFB_PARITY_CASES is not set" }, () => {
  assert.ok(cases.bentCorners.length >= 100, `${cases.bentCorners.length} bent area lights`);
  for (const { light, corners } of cases.bentCorners) {
    const chains = cornerChains(light, areaFrame(light));
    assert.equal(chains.length, 4);
    chains.forEach((ch, c) => ch.points.forEach((p, i) => same(p, corners[c][i], `corner ${c} p${i} of ${JSON.stringify(light.direction)} roll ${light.roll}`)));
  }
});

test("the light frame is dfb::lightFrame's, near vertical included", { skip: !file && "DFB_PARITY_CASES is not set" }, () => {
  for (const { direction, uL, vL, wL } of cases.lightFrames) {
    const f = lightFrame({ direction });
    same(f.uL, uL, `uL of ${JSON.stringify(direction)}`);
    same(f.vL, vL, `vL of ${JSON.stringify(direction)}`);
    same(f.wL, wL, `wL of ${JSON.stringify(direction)}`);
  }
});

test("an environment map's turn is lightmath::envRotation of lightmath::envDirection", { skip: !file && "DFB_PARITY_CASES is not set" }, () => {
  assert.ok(cases.envRotations.length >= 7, `${cases.envRotations.length} rotations`);
  for (const { rotation, directions } of cases.envRotations) {
    const R = envRotation(rotation);
    for (const { u, v, world } of directions) same(R(envDirection(u, v)), world, `(${u}, ${v}) turned by ${JSON.stringify(rotation)}`);
  }
});
