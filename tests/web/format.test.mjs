// Typed entry and colour conversion of the browser page (client/web/format.js) in node.

import assert from "node:assert/strict";
import { test } from "node:test";

import { hexToLinear, linearToHex, parseNumber, toLinear, toSrgb } from "../../client/web/format.js";

test("typed numbers: empty, not a number, not whole, out of range, accepted", () => {
  assert.deepEqual(parseNumber(" ", "intensity", 0, 1e12), { error: "intensity: enter a number" });
  assert.deepEqual(parseNumber("abc", "intensity", 0, 1e12), { error: "intensity: 'abc' is not a number" });
  assert.deepEqual(parseNumber("NaN", "position x", -1e7, 1e7), { error: "position x: 'NaN' is not a number" });
  assert.deepEqual(parseNumber("Infinity", "x", -1, 1), { error: "x: 'Infinity' is not a number" });
  assert.deepEqual(parseNumber("1e13", "intensity", 0, 1e12), { error: "intensity: 10000000000000 is out of range [0, 1000000000000]" });
  assert.deepEqual(parseNumber("2.5", "filter", 0, 4, { integer: true }), { error: "filter: '2.5' is not a whole number" });
  assert.deepEqual(parseNumber(" 7.25 ", "intensity", 0, 1e12), { value: 7.25 });
  assert.deepEqual(parseNumber("-20", "exposure", -20, 20), { value: -20 });
});

test("colours: sRGB and linear are inverse; hex shows over-bright colours by their hue", () => {
  for (const c of [0, 0.001, 0.0031308, 0.2, 0.5, 1]) assert.ok(Math.abs(toLinear(toSrgb(c)) - c) < 1e-12, String(c));
  assert.equal(linearToHex([1, 1, 1]), "#ffffff");
  assert.equal(linearToHex([0, 0, 0]), "#000000");
  assert.equal(linearToHex([4, 2, 0]), linearToHex([1, 0.5, 0]));
  assert.equal(linearToHex([0.2140, 0, 1]), "#7f00ff");
  assert.deepEqual(hexToLinear("#7f00ff"), [0.2122, 0, 1]);
});
