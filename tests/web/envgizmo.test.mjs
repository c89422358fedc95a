// The environment light's gizmo (client/web/envgizmo.js) in node: the map's centre as the camera
// sees it, and a drag of its handle that makes the handle follow the pointer for cameras looking
// every way (parity.test.mjs checks envRotation against the C++ itself).

import assert from "node:assert/strict";
import { test } from "node:test";

import { centreHandle, dragSigns, draggedRotation, envDirection, envRotation, gizmoCurves, gizmoPlace } from "../../client/web/envgizmo.js";
import { V } from "../../client/web/linalg.js";

// A camera frame looking along `forward` with +Y up (as Cam has it: right, up, forward).
function camLooking(forward) {
  const f = V.norm(forward);
  const right = V.norm(V.cross(f, [0, 1, 0]));
  return { right, up: V.cross(right, f), forward: f };
}

test("unturned, the map's centre looks along -Z: the middle of the gizmo for a camera looking along -Z", () => {
  const cam = camLooking([0, 0, -1]);
  const g = gizmoPlace(0, 800);
  const h = centreHandle(g, cam, [0, 0, 0]);
  assert.ok(Math.abs(h.x - g.cx) < 1e-9 && Math.abs(h.y - g.cy) < 1e-9 && h.front);
  // Behind a camera looking along +Z: hidden (dashed), at the middle too.
  assert.equal(centreHandle(g, camLooking([0, 0, 1]), [0, 0, 0]).front, false);
  // yaw 90 turns -Z to -X: the left edge.
  const left = centreHandle(g, cam, [90, 0, 0]);
  assert.ok(Math.abs(left.x - (g.cx - g.r)) < 1e-9, `x ${left.x}`);
  // The top pole is straight up.
  const c = gizmoCurves(g, cam, [0, 0, 0]);
  assert.ok(Math.abs(c.top.y - (g.cy - g.r)) < 1e-9);
  assert.equal(c.equator.length, 49);
  // Gizmos of several environment lights do not overlap.
  const a = gizmoPlace(0, 800), b = gizmoPlace(1, 800);
  assert.ok(Math.abs(a.cx - b.cx) >= a.r + b.r);
});

test("the centre handle follows the pointer for cameras looking every way", () => {
  const g = gizmoPlace(0, 800);
  let checked = 0;
  for (const forward of [[0, 0, -1], [1, 0, 0], [0.3, -0.4, 0.8], [-0.7, 0.2, -0.2], [0, -0.9, 0.3]]) {
    const cam = camLooking(forward);
    // Turns that put the map's centre near where the camera looks (centre = (-sin yaw cos pitch,
    // sin pitch, -cos yaw cos pitch)), and a few fixed ones.
    const f = cam.forward, yaw = Math.atan2(-f[0], -f[2]) * 180 / Math.PI, pitch = Math.asin(f[1]) * 180 / Math.PI;
    for (const rot of [[0, 0, 0], [40, 10, 0], [-120, -30, 15], [170, 55, -90], [yaw + 10, pitch - 5, 20], [yaw - 15, pitch + 8, 0]]) {
      const h0 = centreHandle(g, cam, rot);
      if (!h0.front || Math.hypot(h0.x - g.cx, h0.y - g.cy) > 0.6 * g.r) continue; // near the rim a drag moves it little
      const signs = dragSigns(cam, rot);
      for (const [dx, dy] of [[3, 0], [-3, 0], [0, 3], [0, -3]]) {
        const h1 = centreHandle(g, cam, draggedRotation(rot, dx, dy, g.r, signs));
        const moved = [h1.x - h0.x, h1.y - h0.y];
        assert.ok(moved[0] * dx + moved[1] * dy > 0, `${JSON.stringify(forward)} ${JSON.stringify(rot)}: drag (${dx}, ${dy}) moved it ${moved}`);
        checked++;
      }
    }
  }
  assert.ok(checked >= 24, `${checked} drags checked`);
});

test("a drag keeps roll, wraps yaw into [-180, 180] and holds pitch within [-90, 90]", () => {
  const signs = { yaw: 1, pitch: 1 };
  const r = draggedRotation([170, 80, 33], 1000, -1000, 30, signs);
  assert.ok(r[0] >= -180 && r[0] <= 180, `yaw ${r[0]}`);
  assert.equal(r[1], 90);
  assert.equal(r[2], 33);
  // envRotation keeps lengths (a rotation) and envDirection gives unit vectors.
  const R = envRotation([33, -20, 70]);
  for (const [u, v] of [[0.1, 0.2], [0.7, 0.5], [0.5, 0.99]]) assert.ok(Math.abs(V.len(R(envDirection(u, v))) - 1) < 1e-12);
});
