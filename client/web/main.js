// dfb browser client, entry point (docs/browser-client.md; the modules: docs/architecture.md).
// Wires the buttons and keyboard shortcuts, reads the rig schema and connects. Modules only define
// functions when they load; everything that touches the page starts here, after the whole
// document is parsed (module scripts are deferred).

import { initAnnotations, setTool, annotationTool } from "./annotations.js";
import { connect, loadSchema, renderStats, send } from "./connection.js";
import { $, showMessage } from "./dom.js";
import { addLight, canEdit, deleteLight, duplicateLight, redo, undo } from "./edits.js";
import { initFinal, toggleAB } from "./final.js";
import { initGroups } from "./groups.js";
import { initLibrary } from "./library.js";
import { cancelIndirect, dragModeKey, setDragMode } from "./indirect.js";
import { scheduleOverlay } from "./overlay.js";
import { initPanels } from "./panels.js";
import { initPresence } from "./presence.js";
import { initSchematic } from "./schematic.js";
import { S } from "./state.js";
import { deleteKey, initTimeline, setKey, stepKey } from "./timeline.js";
import { frameLights, initViewport, vpCenter, zoomAt, zoomFit, zoomNative } from "./viewport.js";

initPanels();
initViewport();
initTimeline();
initPresence();
initFinal();
initLibrary();
initGroups();
initAnnotations();
initSchematic();
setInterval(renderStats, 500);

$("keysHelp").onclick = () => showMessage($("keysHelp").title, "info");
$("undo").onclick = undo;
$("redo").onclick = redo;
$("addLight").onclick = () => addLight($("addType").value);
$("dupLight").onclick = duplicateLight;
$("delLight").onclick = deleteLight;
$("dragMode").onchange = () => setDragMode($("dragMode").value);
document.addEventListener("keydown", (e) => {
  const t = e.target;
  const typing = t instanceof HTMLInputElement && !["checkbox", "range", "color"].includes(t.type) || t instanceof HTMLSelectElement || t instanceof HTMLTextAreaElement;
  const mod = e.ctrlKey || e.metaKey;
  // Escape during an indirect drag cancels it (the server puts the light back), wherever the focus is.
  if (e.key === "Escape" && cancelIndirect()) { e.preventDefault(); return; }
  if (mod && !typing && e.key.toLowerCase() === "z") { e.preventDefault(); return e.shiftKey ? redo() : undo(); }
  if (mod && !typing && e.key.toLowerCase() === "y") { e.preventDefault(); return redo(); }
  if (mod && !typing && e.key.toLowerCase() === "d") { e.preventDefault(); return canEdit() && duplicateLight(); }
  if (typing || mod || e.altKey) return;
  switch (e.key) {
  case "f": case "F": return zoomFit();
  case "l": case "L": return frameLights();
  case "1": return zoomNative();
  case "+": case "=": return zoomAt(S.zoom * 1.25, ...vpCenter());
  case "-": return zoomAt(S.zoom / 1.25, ...vpCenter());
  case "h": case "H": return $("handlesToggle").click();
  case "b": case "B": return $("backdropToggle").click();
  case "t": case "T": return toggleAB();
  case "k": return canEdit() && setKey();
  case "K": return canEdit() && deleteKey();
  case ",": return stepKey(-1);
  case ".": return stepKey(1);
  case "Delete": return canEdit() && deleteLight();
  case "n": return setTool(annotationTool() === "pin" ? null : "pin");
  case "N": return setTool(annotationTool() === "stroke" ? null : "stroke");
  case "Escape": if (annotationTool()) setTool(null); S.pickResult = null; return scheduleOverlay();
  // "d" (direct handles) and the drag modes' keys, from the server's schema (indirect.js).
  default: if (dragModeKey(e.key)) e.preventDefault(); return;
  }
});
window.addEventListener("resize", scheduleOverlay);
// A drop-down keeps the keyboard after a choice (its letters jump between options); give it back
// to the shortcuts.
document.addEventListener("change", (e) => { if (e.target instanceof HTMLSelectElement && !e.target.multiple) e.target.blur(); });

// For the console and the browser test (tests/browser): the state and the raw send, which a
// module keeps out of the page's global scope.
window.dfb = { S, send };

// The rig schema first (public, one small GET): the light's property rows and ranges come from it.
loadSchema().then(connect);
