// The browser's area-light geometry (client/web/area.js) in node: the emitter's frame with roll
// as lightmath::areaFrame turns it (server/include/dfb/lightmath/AreaLight.h: right_r = right cos
// + up sin, up_r = up cos - right sin), outlines, handles, and what a pointer ray makes of them.

import assert from "node:assert/strict";
import { test } from "node:test";

import { DISK_SEGMENTS, angleStep, areaFrame, areaHandles, areaOutline, clampSize, planeAngleDeg, rayOnAxis, rayOnPlane,
         turnedRoll } from "../../client/web/area.js";
import { V } from "../../client/web/linalg.js";

const near = (a, b, eps, what) => a.forEach((x, i) => assert.ok(Math.abs(x - b[i]) <= eps, `${what}[${i}]: ${x} vs ${b[i]}`));

test("the frame: facing -Z, right = n x Y = +X, turned by roll about the normal as the C++ turns it", () => {
  // n = -Z: spotFrame right = normalize(cross(n, +Y)) = +X, up' = cross(right, n) = +Y.
  const l = { type: "area", position: [1, 2, 3], direction: [0, 0, -1], size: [2, 1], shape: "rect", roll: 0 };
  let a = areaFrame(l);
  near(a.right, [1, 0, 0], 1e-12, "right");
  near(a.up, [0, 1, 0], 1e-12, "up");
  near(a.normal, [0, 0, -1], 1e-12, "normal");
  assert.equal(a.width, 2);
  assert.equal(a.height, 1);
  // roll 90: right_r = up' = +Y, up_r = -right = -X.
  a = areaFrame({ ...l, roll: 90 });
  near(a.right, [0, 1, 0], 1e-12, "right at roll 90");
  near(a.up, [-1, 0, 0], 1e-12, "up at roll 90");
  // A disk: both extents are the diameter size[0].
  a = areaFrame({ ...l, shape: "disk", size: [3, 7] });
  assert.ok(a.disk && a.width === 3 && a.height === 3);
});

test("outlines: a rectangle's four corners, a disk's rim", () => {
  const a = areaFrame({ position: [0, 0, 0], direction: [0, 0, -1], size: [2, 1], shape: "rect", roll: 0 });
  const rect = areaOutline(a);
  assert.equal(rect.length, 4);
  near(rect[0], [1, 0.5, 0], 1e-12, "right-up corner");
  near(rect[2], [-1, -0.5, 0], 1e-12, "left-down corner");
  const disk = areaOutline(areaFrame({ position: [0, 0, 0], direction: [0, 0, -1], size: [2, 9], shape: "disk", roll: 30 }));
  assert.equal(disk.length, DISK_SEGMENTS);
  for (const p of disk) assert.ok(Math.abs(V.len(p) - 1) < 1e-12 && Math.abs(p[2]) < 1e-12, `rim point ${p}`);
  // Rim point 0 is on the turned right axis.
  near(disk[0], [Math.cos(Math.PI / 6), Math.sin(Math.PI / 6), 0], 1e-12, "rim at angle 0");
});

test("handles: edge midpoints, the corner, the rim and roll beyond the top (or bottom) edge", () => {
  const a = areaFrame({ position: [0, 0, 0], direction: [0, 0, -1], size: [2, 1], shape: "rect", roll: 0 });
  const h = areaHandles(a, 0.25);
  near(h.width, [1, 0, 0], 1e-12, "width");
  near(h.height, [0, 0.5, 0], 1e-12, "height");
  near(h.corner, [1, 0.5, 0], 1e-12, "corner");
  near(h.roll, [0, 0.75, 0], 1e-12, "roll");
  near(areaHandles(a, 0.25, true).roll, [0, -0.75, 0], 1e-12, "roll flipped");
  const d = areaHandles(areaFrame({ position: [0, 0, 0], direction: [0, 0, -1], size: [2, 1], shape: "disk", roll: 0 }), 0.25);
  assert.ok(!d.width && !d.height && !d.corner);
  near(d.rim, [1, 0, 0], 1e-12, "rim");
  near(d.roll, [0, 1.25, 0], 1e-12, "disk roll");
});

test("pointer rays: onto the plane, along an axis; edge-on and along-the-axis give no answer", () => {
  const a = areaFrame({ position: [0, 0, 0], direction: [0, 0, 1], size: [2, 1], shape: "rect", roll: 0 });
  const hit = rayOnPlane(a, [0.5, 0.2, 5], [0, 0, -1]);
  // n = +Z: right = cross(+Z, +Y) = -X.
  near([hit.x, hit.y], [-0.5, 0.2], 1e-12, "plane hit");
  assert.equal(rayOnPlane(a, [0, 0, 5], [0, 0, 1]), null, "behind the ray's origin");
  assert.equal(rayOnPlane(a, [0, 0, 5], [1, 0, 0.01]), null, "edge-on");
  // The axis +X through the origin, a ray down from (3, 1, 2) at x = 3: t = 3.
  assert.ok(Math.abs(rayOnAxis([0, 0, 0], [1, 0, 0], [3, 1, 2], [0, -0.3, -1]) - 3) < 1e-12);
  assert.equal(rayOnAxis([0, 0, 0], [1, 0, 0], [3, 1, 2], [1, 0, 0.01]), null, "the ray along the axis");
});

test("roll from angles: the turned up axis lies at the roll; steps wrap across 180; rolls stay in range", () => {
  for (const r of [0, 30, 90, 179, -120]) {
    const a = areaFrame({ position: [0, 0, 0], direction: [0.3, -0.8, 0.5], size: [1, 1], roll: r });
    const a0 = areaFrame({ position: [0, 0, 0], direction: [0.3, -0.8, 0.5], size: [1, 1], roll: 0 });
    const x = V.dot(a.up, a0.right), y = V.dot(a.up, a0.up);
    assert.ok(Math.abs(angleStep(planeAngleDeg(x, y), r)) < 1e-9, `roll ${r}: angle ${planeAngleDeg(x, y)}`);
  }
  assert.equal(angleStep(170, -170), 20);
  assert.equal(angleStep(-170, 170), -20);
  assert.equal(turnedRoll(350, 20), 10);
  assert.equal(turnedRoll(-350, -20), -10);
  assert.equal(turnedRoll(10, 25), 35);
});

test("sizes are clamped to the schema's range and never reach 0", () => {
  // The least size is the least 32-bit float at or above the minimum: read back as a float it
  // is still in range (Math.fround(1e-4) is below 1e-4).
  for (const v of [-3, 0, 1e-5]) {
    const s = clampSize(v, 1e-4, 1e7);
    assert.ok(Math.fround(s) >= 1e-4 && s < 1.000001e-4, `clampSize(${v}) = ${s}`);
  }
  assert.equal(clampSize(2.1234567, 1e-4, 1e7), 2.12346);
  assert.equal(clampSize(1e9, 1e-4, 1e7), 1e7);
  assert.ok(clampSize(0, 0, 10) > 0, "a schema minimum of 0 still gives a positive size");
});
