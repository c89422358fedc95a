// The browser's placing-lights geometry (client/web/placement.js) in node: framing the image and
// the handles, the arrows at the view's edge, a cone's footprint on the first box its axis meets
// (or the ground), and the schematic's orthographic views and their maps.

import assert from "node:assert/strict";
import { test } from "node:test";

import { AXIS_NAMES, VIEWS, coneFootprint, edgeArrow, fitMap, fitView, footprintPlane, fromView, gridStep, insideView, mapStillFits,
         outlineRuns, perpendiculars, rayBox, toView } from "../../client/web/placement.js";
import { V } from "../../client/web/linalg.js";

const near = (a, b, eps, what) => assert.ok(Math.abs(a - b) <= eps, `${what}: ${a} vs ${b}`);
const screen = (f, p) => ({ x: f.panX + p.x * f.zoom, y: f.panY + p.y * f.zoom });

test("fitView: the image and every handle inside the viewport less its margins, centred", () => {
  const m = { left: 36, top: 36, right: 36, bottom: 36 };
  // The image alone (320 x 180) in 940 x 600: the width limits, the height is centred.
  let f = fitView([{ x: 0, y: 0 }, { x: 320, y: 180 }], 940, 600, m);
  near(f.zoom, 868 / 320, 1e-12, "zoom");
  assert.equal(f.panX, 36);
  assert.equal(f.panY, Math.round(36 + (528 - 180 * f.zoom) / 2));
  // A handle far left of the image: it and the image's far corner land on the margins.
  const pts = [{ x: 0, y: 0 }, { x: 320, y: 180 }, { x: -640, y: 90 }];
  f = fitView(pts, 940, 600, m);
  near(f.zoom, 868 / 960, 1e-12, "zoom with a far handle");
  near(screen(f, pts[2]).x, 36, 0.5, "the far handle on the left margin");
  near(screen(f, pts[1]).x, 940 - 36, 0.5, "the image's corner on the right margin");
  for (const p of pts) assert.ok(insideView(screen(f, p), 940, 600, 36 - 0.5), `point ${JSON.stringify(p)} is outside`);
  // A larger top margin (the environment gizmos' band) moves everything below it.
  f = fitView(pts, 940, 600, { ...m, top: 140 });
  for (const p of pts) assert.ok(screen(f, p).y >= 140 - 0.5, `point ${JSON.stringify(p)} is under the top band`);
  // One point: the zoom is clamped to the most, and the point is centred.
  f = fitView([{ x: 10, y: 20 }], 100, 100, { left: 0, top: 0, right: 0, bottom: 0 }, { maxZoom: 4 });
  assert.equal(f.zoom, 4);
  assert.deepEqual(screen(f, { x: 10, y: 20 }), { x: 50, y: 50 });
});

test("edgeArrow: at the nearest point of the inset edge, pointing at the light; behind the camera along its direction", () => {
  let a = edgeArrow(100, 80, 10, { x: 150, y: 40 });
  assert.deepEqual([a.x, a.y, a.angle], [90, 40, 0]);
  a = edgeArrow(100, 80, 10, { x: -50, y: -50 });
  assert.deepEqual([a.x, a.y], [10, 10]);
  near(a.angle, -3 * Math.PI / 4, 1e-12, "angle to the top-left");
  // Behind: from the centre (50, 40) along the direction to the inset edge.
  a = edgeArrow(100, 80, 10, null, [0, 1]);
  assert.deepEqual([a.x, a.y], [50, 70]);
  near(a.angle, Math.PI / 2, 1e-12, "down");
  a = edgeArrow(100, 80, 10, null, [-2, 0]);
  assert.deepEqual([a.x, a.y], [10, 40]);
  a = edgeArrow(100, 80, 10, null, [1, 1]); // the bottom edge comes first (30 down vs 40 right)
  assert.deepEqual([a.x, a.y], [80, 70]);
});

test("rayBox: the face a ray enters first, with its outward normal; none from inside or when it misses", () => {
  const box = [-1, 0, -1, 1, 1, 1];
  assert.deepEqual(rayBox([0, 5, 0], [0, -1, 0], box), { t: 4, axis: 1, sign: 1 });
  assert.deepEqual(rayBox([-3, 0.5, 0], [1, 0, 0], box), { t: 2, axis: 0, sign: -1 });
  assert.equal(rayBox([0, 0.5, 0], [0, -1, 0], box), null, "from inside");
  assert.equal(rayBox([5, 5, 0], [0, -1, 0], box), null, "beside it");
  assert.equal(rayBox([0, 5, 0], [0, 1, 0], box), null, "behind the ray");
  // A flat box (a floor baked as one sheet): the face towards the ray, from either side.
  assert.deepEqual(rayBox([0.5, 5, 0], [0, -1, 0], [-1, 0, -1, 1, 0, 1]), { t: 5, axis: 1, sign: 1 });
  assert.deepEqual(rayBox([0.5, -2, 0], [0, 1, 0], [-1, 0, -1, 1, 0, 1]), { t: 2, axis: 1, sign: -1 });
});

test("footprintPlane: the nearest object box the axis enters, else the ground under the scene when it points down", () => {
  const far = [-1, 0, -1, 1, 1, 1], high = [-0.5, 2, -0.5, 0.5, 3, 0.5];
  let p = footprintPlane([0, 5, 0], [0, -1, 0], [far, null, high], [-5, -2, -5, 5, 3, 5]);
  assert.equal(p.object, 2);
  assert.deepEqual(p.point, [0, 3, 0]);
  assert.deepEqual(p.normal, [0, 1, 0]);
  p = footprintPlane([10, 4, 0], [0, -1, 0], [far, high], [-5, -2, -5, 5, 3, 5]);
  assert.equal(p.object, -1);
  assert.equal(p.t, 6);
  assert.deepEqual(p.point, [10, -2, 0]);
  assert.equal(footprintPlane([10, 4, 0], [0, 1, 0], [far], [-5, -2, -5, 5, 3, 5]), null, "up, past every box");
  assert.equal(footprintPlane([10, 4, 0], [0, -1, 0], [], null), null, "no boxes at all");
  // A wide cone passes over a box too narrow to hold its footprint there: from y = 5 the 1-wide
  // box's top is 2 away (radius 2 at 45 degrees), the 2-wide one's 4 (radius 4): the ground.
  p = footprintPlane([0, 5, 0], [0, -1, 0], [far, high], [-5, -2, -5, 5, 3, 5], { g: 1 });
  assert.equal(p.object, -1);
  assert.equal(p.t, 7);
  // A narrow one lands on the first box; a tube's start radius counts as well.
  assert.equal(footprintPlane([0, 5, 0], [0, -1, 0], [far, high], null, { g: 0.2 }).object, 1);
  assert.equal(footprintPlane([0, 5, 0], [0, -1, 0], [far, high], null, { r0: 1.5, g: 0.1 }).object, 0);
  // Aimed sideways past the ground with no box wide enough: the first box it meets after all.
  assert.equal(footprintPlane([-5, 0.5, 0], [1, 0, 0], [far], [-5, -2, -5, 5, 3, 5], { g: 1 }).object, 0);
});

test("coneFootprint: a spot's cone on a plane across it is a circle of radius t tan(angle); a tube's extension starts at its radius", () => {
  const o = [0, 4, 0], u = [0, -1, 0], [v, w] = perpendiculars(u);
  for (const [a, b] of [[u, v], [u, w], [v, w]]) near(V.dot(a, b), 0, 1e-12, "orthogonal");
  near(V.len(v), 1, 1e-12, "|v|");
  near(V.len(w), 1, 1e-12, "|w|");
  const ground = { point: [0, 0, 0], normal: [0, 1, 0] };
  const spot = coneFootprint(o, u, v, w, 0, Math.tan(Math.PI / 6), ground, { n: 32 });
  assert.equal(spot.length, 32);
  for (const p of spot) {
    near(p[1], 0, 1e-12, "on the plane");
    near(Math.hypot(p[0], p[2]), 4 * Math.tan(Math.PI / 6), 1e-12, "radius");
  }
  const tube = coneFootprint(o, u, v, w, 0.5, 0.1, ground, { n: 16 });
  for (const p of tube) near(Math.hypot(p[0], p[2]), 0.5 + 0.1 * 4, 1e-12, "the tube's radius grown along 4 units");
  // Tilted 45 degrees down with a 60-degree cone: the upper edge rays never reach the ground.
  const tilted = coneFootprint(o, V.norm([1, -1, 0]), ...perpendiculars(V.norm([1, -1, 0])), 0, Math.tan(Math.PI / 3), ground, { n: 32 });
  assert.ok(tilted.some((p) => p === null) && tilted.some((p) => p !== null), "part of the rim is past the horizon");
  for (const p of tilted) if (p) near(p[1], 0, 1e-9, "on the plane");
  // maxT cuts rays that meet the plane too far along.
  assert.ok(coneFootprint(o, u, v, w, 0, 0.1, ground, { n: 8, maxT: 3 }).every((p) => p === null), "cut at maxT");
});

test("outlineRuns: a whole outline is one closed run; nulls split it into open runs (single points dropped)", () => {
  const [a, b, c, d] = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]];
  assert.deepEqual(outlineRuns([a, b, c]), [{ points: [a, b, c, a], closed: true }]);
  // The run that wraps past the end is one run: c, d, a.
  assert.deepEqual(outlineRuns([a, null, c, d]), [{ points: [c, d, a], closed: false }]);
  assert.deepEqual(outlineRuns([a, null, c, null]), []);
  assert.deepEqual(outlineRuns([null, null]), []);
});

test("the schematic's views: which axes each shows, none mirrored, and a drag keeps the third component", () => {
  const p = [1, 2, 3];
  assert.deepEqual(toView(VIEWS.top, p), [1, 3]);
  assert.deepEqual(toView(VIEWS.side, p), [-3, -2]);
  assert.deepEqual(toView(VIEWS.front, p), [1, -2]);
  for (const [name, view] of Object.entries(VIEWS)) {
    // Screen right and screen up as world vectors; right x up must point at the viewer (the
    // view's depth axis, towards which it looks from): a drawing, not a mirror image.
    const right = [0, 0, 0], up = [0, 0, 0];
    right[view.axes[0]] = view.signs[0];
    up[view.axes[1]] = -view.signs[1];
    const toViewer = V.cross(right, up);
    assert.equal(Math.abs(toViewer[view.depth]), 1, `${name}: the depth axis is the third one`);
    assert.ok(toViewer[view.depth] > 0, `${name} is mirrored`);
    // fromView sets exactly the view's two components and keeps the depth one.
    const q = fromView(view, [7, 8], p);
    assert.deepEqual(toView(view, q), [7, 8]);
    assert.equal(q[view.depth], p[view.depth], `${name} changed ${AXIS_NAMES[view.depth]}`);
  }
  assert.deepEqual(fromView(VIEWS.top, [5, 6], p), [5, 2, 6]);
  assert.deepEqual(fromView(VIEWS.side, [-7, -8], p), [1, 8, 7]);
});

test("fitMap and mapStillFits: the points whole, centred, one scale; a map is kept while they still fill it", () => {
  const pts = [[0, 0], [10, 5]];
  const m = fitMap(pts, 200, 100, 10);
  assert.equal(m.scale, 16); // the height limits: 80 px for 5 units
  const at = ([a, b]) => [m.ox + a * m.scale, m.oy + b * m.scale];
  assert.deepEqual(pts.map(at), [[20, 10], [180, 90]]);
  assert.ok(mapStillFits(m, pts, 200, 100, 10));
  assert.ok(mapStillFits(m, [[1, 1], [9, 4]], 200, 100, 10), "a little smaller still fits");
  assert.ok(!mapStillFits(m, [[0, 0], [20, 5]], 200, 100, 10), "a point out of the canvas");
  assert.ok(!mapStillFits(m, [[4, 2], [5, 2.5]], 200, 100, 10), "a small cluster in a corner of it");
  assert.ok(!mapStillFits(null, pts, 200, 100, 10));
  // One point (or none) still gets a finite map.
  for (const one of [[[3, 4]], []]) {
    const f = fitMap(one, 200, 100, 10);
    assert.ok(Number.isFinite(f.scale) && f.scale > 0 && Number.isFinite(f.ox) && Number.isFinite(f.oy), JSON.stringify(f));
  }
});

test("gridStep: 1, 2 or 5 times a power of ten", () => {
  assert.equal(gridStep(10, 10), 1);
  assert.equal(gridStep(25, 10), 2);
  assert.equal(gridStep(37, 10), 5);
  assert.equal(gridStep(80, 10), 10);
  near(gridStep(0.13, 10), 0.01, 1e-15, "small");
});
