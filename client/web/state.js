// The page's state. `S.rig` is the server's rig plus this client's not-yet-acknowledged edits
// (optimistic); the server's acks, changes and an occasional re-read of GET .../rig keep it
// converged (connection.js). One object, shared by every module of the page.

import { evaluateLight, lightNamed } from "./rig.js";

const params = new URLSearchParams(location.search);
export const S = {
  sessionId: params.get("session"), token: params.get("token"),
  name: params.get("name") || localStorage.getItem("dfb.name") || `artist-${Math.floor(Math.random() * 9000 + 1000)}`,
  ws: null, connected: false, attempts: 0, clientId: 0, role: "viewer",
  session: null, rig: null, selected: null, clients: [], history: { undo: 0, redo: 0 },
  also: new Set(), // lights selected with the primary one (Ctrl/Shift+click): its property edits apply to them too
  view: { output: "beauty", exposure: 0, viewTransform: "rig", background: false }, // what this page asked for
  viewChanged: false, // this page chose its own view: restored after a reconnect
  shownOutput: "beauty", // the output of the frames arriving now: the last one the server acknowledged
  seq: 0, pending: new Map(),        // seq -> {t, kind, live}
  latencyByVersion: new Map(),      // acknowledged rig version -> time the edit was sent
  frameTimes: [], latency: null, frameVersion: 0, frameSize: [0, 0], objectUrl: null,
  live: { inFlight: false, queued: null }, // one live (drag/slider) edit in flight, the newest queued
  drag: null, gesture: null, zoom: 1, panX: 0, panY: 0, fitted: false, showHandles: true,
  selectAfterPut: null, // the light an Add or Duplicate selects once a rig from the server has it (edits.js)
  pickResult: null, timeEnd: 4, refetchTimer: null,
  dragMode: "direct", // "direct" (handles, drag.js) or a schema drag mode (indirect.js)
  indirect: null, lastIndirect: null, // the indirect drag going on; a summary of the last one
  cpSelection: { light: null, count: 0, points: [] }, // BendyLight control points a drag moves (indirect.js)
  schematicView: "top", // the Schematic panel's view: "top", "side" or "front" (schematic.js)
  schemaLoaded: false, // GET /v1/schema read into rig.js (connection.js loadSchema)
};

// The G-buffer layers the server shows as images (gbuffer/src/LayerImage.cpp, dfb-bake --layer).
export const LAYERS = ["P", "N", "Ng", "T", "Z", "albedo", "brdf", "occlusion", "sheen", "coat", "emission", "A", "id", "material"];

export const findLight = (name) => lightNamed(S.rig, name);
/** The light as rendered at the session time. */
export const evaluated = (l) => (l ? evaluateLight(l, S.rig.time) : l);
