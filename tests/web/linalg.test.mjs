// The browser's linear algebra and camera (client/web/linalg.js, camera.js) in node: inverses,
// projection and its inverse on the drag plane, Bezier points.

import assert from "node:assert/strict";
import { test } from "node:test";

import { Cam } from "../../client/web/camera.js";
import { V, bezier, invert4, mulVec4 } from "../../client/web/linalg.js";

// Column-major products, independently of the module.
const mul4 = (a, b) => Array.from({ length: 16 }, (_, i) => {
  const c = Math.floor(i / 4), r = i % 4;
  return [0, 1, 2, 3].reduce((s, k) => s + a[k * 4 + r] * b[c * 4 + k], 0);
});
const near = (a, b, eps, what) => a.forEach((x, i) => assert.ok(Math.abs(x - b[i]) <= eps, `${what}[${i}]: ${x} vs ${b[i]}`));

// A camera at (1, 2, 5) looking at the origin, 60 degrees vertical, 16:9, as the welcome sends it.
function lookAt(eye, at) {
  const f = V.norm(V.sub(at, eye)), s = V.norm(V.cross(f, [0, 1, 0])), u = V.cross(s, f);
  return [s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0, -V.dot(s, eye), -V.dot(u, eye), V.dot(f, eye), 1];
}
function perspective(yfov, aspect, n, f) {
  const t = 1 / Math.tan(yfov / 2);
  return [t / aspect, 0, 0, 0, 0, t, 0, 0, 0, 0, (f + n) / (n - f), -1, 0, 0, 2 * f * n / (n - f), 0];
}
const worldToCamera = lookAt([1, 2, 5], [0, 0, 0]);
const session = { width: 320, height: 180, camera: { worldToCamera, worldToNDC: mul4(perspective(Math.PI / 3, 16 / 9, 0.05, 50), worldToCamera) } };

test("invert4 gives the inverse, and null for a singular matrix", () => {
  const m = session.camera.worldToNDC;
  near(mul4(m, invert4(m)), [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], 1e-12, "m m^-1");
  assert.equal(invert4([1, 2, 3, 4, 2, 4, 6, 8, 0, 0, 1, 0, 0, 0, 0, 1]), null);
  assert.deepEqual(mulVec4([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 5, 6, 7, 1], [1, 2, 3, 1]), [6, 8, 10, 1]);
});

test("vectors: cross is right-handed; norm divides by the length; a zero vector stays zero", () => {
  assert.deepEqual(V.cross([1, 0, 0], [0, 1, 0]), [0, 0, 1]);
  near(V.norm([3, 0, 4]), [0.6, 0, 0.8], 1e-15, "norm");
  assert.deepEqual(V.norm([0, 0, 0]), [0, 0, 0]);
});

test("the camera projects the point it looks at to the image centre, and unprojects on the drag plane", () => {
  Cam.set(session);
  near(Cam.pos, [1, 2, 5], 1e-12, "camera position");
  near(Cam.forward, V.norm([-1, -2, -5]), 1e-12, "forward");
  const c = Cam.project([0, 0, 0]);
  assert.ok(Math.abs(c.x - 160) < 1e-9 && Math.abs(c.y - 90) < 1e-9 && c.front, JSON.stringify(c));
  // Above the centre in the world is above it in the image (pixel y grows downwards).
  assert.ok(Cam.project([0, 0.5, 0]).y < 90);
  assert.equal(Cam.project([2, 4, 10]).front, false); // behind the camera
  const p = [0.3, -0.2, 0.7], q = Cam.project(p);
  near(Cam.unproject(q.x, q.y, q.z), p, 1e-9, "unproject(project(p))");
});

test("bezier: the ends and the midpoint of a quadratic segment", () => {
  assert.deepEqual(bezier([0, 0, 0], [1, 2, 0], [2, 0, 0], 0), [0, 0, 0]);
  assert.deepEqual(bezier([0, 0, 0], [1, 2, 0], [2, 0, 0], 1), [2, 0, 0]);
  assert.deepEqual(bezier([0, 0, 0], [1, 2, 0], [2, 0, 0], 0.5), [1, 1, 0]);
});
