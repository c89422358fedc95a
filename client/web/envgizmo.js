// An environment light's gizmo (issue 19 point 1): a small sphere in the viewport's top-right
// corner showing the map's directions as the shot's camera sees them (each world direction w at
// (w . right, -w . up) times the sphere's radius; solid where the camera looks into it, w .
// forward > 0, dashed behind): the map's equator, its centre meridian and its top pole, and a
// rotation handle at the map's centre (the direction its centre column looks, -Z before the
// turn). Dragging the handle turns the map: left/right is yaw, up/down is pitch (the handle
// follows the pointer); roll stays where it is. The math is lightmath::envDirection and
// lightmath::envRotation (server/include/dfb/lightmath/Environment.h; tests/web/parity.test.mjs
// compares them). The math part is pure: node imports it.

import { V } from "./linalg.js";

const RAD = Math.PI / 180;

/** lightmath::envDirection: the world direction of map coordinates (u, v) before any turn. */
export function envDirection(u, v) {
  const phi = 2 * Math.PI * (u - 0.5), theta = Math.PI * v;
  return [Math.sin(theta) * Math.sin(phi), Math.cos(theta), -Math.sin(theta) * Math.cos(phi)];
}

/** lightmath::envRotation: world = Ry(yaw) Rx(pitch) Rz(roll) map, degrees. Returns a function. */
export function envRotation([yaw = 0, pitch = 0, roll = 0] = []) {
  const cy = Math.cos(yaw * RAD), sy = Math.sin(yaw * RAD);
  const cx = Math.cos(pitch * RAD), sx = Math.sin(pitch * RAD);
  const cz = Math.cos(roll * RAD), sz = Math.sin(roll * RAD);
  return ([x, y, z]) => {
    const x1 = cz * x - sz * y, y1 = sz * x + cz * y;            // about +Z
    const y2 = cx * y1 - sx * z, z2 = sx * y1 + cx * z;          // about +X
    return [cy * x1 + sy * z2, y2, -sy * x1 + cy * z2];          // about +Y
  };
}

/** Where the gizmo of the k-th environment light sits (screen pixels of the overlay). */
export function gizmoPlace(k, viewportWidth) {
  const r = 30;
  return { cx: viewportWidth - 44 - k * 80, cy: 92, r };
}

/** A world direction on the gizmo: screen point and whether the camera looks into it. */
export function onGizmo(g, cam, w) {
  return { x: g.cx + g.r * V.dot(w, cam.right), y: g.cy - g.r * V.dot(w, cam.up), front: V.dot(w, cam.forward) > 0 };
}

/** The map's centre direction turned by `rotation`, and the gizmo point of it. */
export function centreHandle(g, cam, rotation) {
  return onGizmo(g, cam, envRotation(rotation)(envDirection(0.5, 0.5)));
}

/** Which way yaw and pitch move the centre handle on screen at `rotation` (+1 or -1 each): the
 * sign of the screen motion of the map's centre per degree (yaw turns it about world +Y, pitch
 * about the map's +X before the yaw), so that a drag makes the handle follow the pointer. */
export function dragSigns(cam, rotation) {
  const [yaw = 0, pitch = 0, roll = 0] = rotation ?? [];
  const c = envDirection(0.5, 0.5);
  const w = envRotation([yaw, pitch, roll])(c);
  const yawSign = Math.sign(V.dot(V.cross([0, 1, 0], w), cam.right)) || 1;
  const dPitch = envRotation([yaw, 0, 0])(V.cross([1, 0, 0], envRotation([0, pitch, roll])(c)));
  const pitchSign = Math.sign(V.dot(dPitch, cam.up)) || 1;
  return { yaw: yawSign, pitch: pitchSign };
}

/** The rotation after dragging the centre handle by (dx, dy) pixels from `rotation0` (a pixel is
 * 1/r radian; `signs` from dragSigns at the press): yaw wraps into [-180, 180], pitch stays in
 * [-90, 90], roll is kept. */
export function draggedRotation(rotation0, dx, dy, r, signs) {
  const deg = 180 / (Math.PI * r);
  let yaw = (rotation0[0] ?? 0) + signs.yaw * dx * deg;
  yaw = ((yaw + 180) % 360 + 360) % 360 - 180;
  const pitch = Math.min(90, Math.max(-90, (rotation0[1] ?? 0) - signs.pitch * dy * deg));
  const round = (v) => Number(v.toFixed(2));
  return [round(yaw), round(pitch), rotation0[2] ?? 0];
}

/** The gizmo's curves: polylines of {x, y, front} (equator, centre meridian). */
export function gizmoCurves(g, cam, rotation) {
  const R = envRotation(rotation);
  const curve = (f) => Array.from({ length: 49 }, (_, i) => onGizmo(g, cam, R(f(i / 48))));
  return { equator: curve((t) => envDirection(t, 0.5)), meridian: curve((t) => envDirection(0.5, t)),
           top: onGizmo(g, cam, R([0, 1, 0])) };
}
