// The shot's camera (docs/gbuffer-format.md "NDC": OpenGL cube, +Y up; the centre of pixel
// (x, y) is at ndc = ((x + 0.5) / W * 2 - 1, 1 - (y + 0.5) / H * 2)). One per page: the session's
// camera is fixed (a deep framebuffer is baked from one view). Pure: no DOM.

import { V, invert4, mulVec4 } from "./linalg.js";

export const Cam = {
  /** Takes the camera of a welcome's `session` (width, height, camera.worldToNDC/worldToCamera). */
  set(session) {
    this.W = session.width; this.H = session.height;
    this.toNDC = session.camera.worldToNDC;
    this.fromNDC = invert4(this.toNDC);
    const c2w = invert4(session.camera.worldToCamera);
    this.pos = mulVec4(c2w, [0, 0, 0, 1]).slice(0, 3);
    this.right = V.norm(mulVec4(c2w, [1, 0, 0, 0]).slice(0, 3));
    this.up = V.norm(mulVec4(c2w, [0, 1, 0, 0]).slice(0, 3));
    this.forward = V.norm(mulVec4(c2w, [0, 0, -1, 0]).slice(0, 3));
  },
  // World point -> continuous image pixel coordinates {x, y} (0..W, 0..H), its NDC depth, and
  // whether it is in front of the camera.
  project(p) {
    const c = mulVec4(this.toNDC, [p[0], p[1], p[2], 1]);
    const w = c[3];
    return { x: (c[0] / w + 1) * 0.5 * this.W, y: (1 - c[1] / w) * 0.5 * this.H, z: c[2] / w, front: w > 1e-6 };
  },
  // Image pixel coordinates at NDC depth z -> world point. A constant NDC depth is a plane
  // parallel to the image (perspective and orthographic alike): that is the drag plane.
  unproject(x, y, z) {
    const h = mulVec4(this.fromNDC, [x / this.W * 2 - 1, 1 - y / this.H * 2, z, 1]);
    return [h[0] / h[3], h[1] / h[3], h[2] / h[3]];
  },
};
