// The final render beside the preview (docs/browser-client.md "Final render"; protocol:
// docs/protocol.md "Final render"). An editor asks the server for a Cycles render of the rig of
// the moment; every client of the session hears its progress as `final` messages and, once it is
// done, can compare it with the live preview: the preview alone, the final alone, a wipe between
// them (preview left, final right of a line dragged across the image) or their difference.
//
// The final image is fetched in this page's own view (final.png?exposure=&viewTransform=, the
// same view transform as its live frames), so the two are compared as they are shown. The
// difference is the browser's per-channel |preview - final| of the displayed images (CSS
// mix-blend-mode: difference), brightened by the chosen gain; the figure beside it is the mean
// over the pixels the final covers, in linear light, relative to the final's mean.

import { api } from "./connection.js";
import { $, showMessage } from "./dom.js";
import { canEdit } from "./edits.js";
import { S } from "./state.js";

// The page's compare state (this viewer's own; nothing of it is sent to the server). B, the image
// compared with the live one, is the final render or a snapshot (library.js): `source`.
const F = {
  source: "final",  // final | snapshot
  snap: null,       // the snapshot compared (its list entry) when source is "snapshot"
  state: null,     // the newest `final` message (or GET .../final answer)
  imageKey: "",    // version|exposure|transform of the final image loaded in #finalImg
  objectUrl: null,
  mode: "live",    // live | final | wipe | difference
  wipe: 0.5,       // the wipe line, as a fraction of the image width
  gain: 4,         // difference brightening
  statsTimer: 0,
  snapshots: [],    // the session's snapshots (library.js)
};
export const finalState = () => F; // for the browser test

const busy = (st) => st === "exporting" || st === "running";

export function initFinal() {
  $("finalRender").onclick = startFinal;
  $("finalCancel").onclick = cancelFinal;
  $("compareMode").onchange = () => setCompare($("compareMode").value);
  $("compareWith").onchange = () => {
    const v = $("compareWith").value;
    if (v === "final") useFinal();
    else compareWithSnapshot(F.snapshots.find((x) => x.name === v.slice(5)), F.mode === "live" ? "wipe" : F.mode);
  };
  $("diffGain").onchange = () => { F.gain = Number($("diffGain").value); layoutCompare(); };
  const bar = $("wipeBar");
  // The wipe line is dragged by itself: its events do not reach the viewport (no pan, no pick).
  bar.addEventListener("pointerdown", (e) => {
    e.stopPropagation();
    e.preventDefault();
    bar.setPointerCapture(e.pointerId);
    const move = (ev) => {
      const r = $("frame").getBoundingClientRect();
      if (r.width > 0) F.wipe = Math.min(1, Math.max(0, (ev.clientX - r.left) / r.width));
      layoutCompare();
    };
    const up = () => { bar.removeEventListener("pointermove", move); bar.removeEventListener("pointerup", up); bar.removeEventListener("pointercancel", up); };
    bar.addEventListener("pointermove", move);
    bar.addEventListener("pointerup", up);
    bar.addEventListener("pointercancel", up);
  });
  $("finalImg").onload = () => { layoutCompare(); scheduleStats(); };
  renderFinal();
}

/** After the welcome: the session's final-render state (a render may be running or kept). */
export async function refreshFinal() {
  try { onFinal(await api("GET", "final")); } catch (e) { /* offline, or an older server */ }
}

/** A `final` message from the server (or the state read over HTTP). */
export function onFinal(msg) {
  F.state = msg;
  if (msg.state === "failed" && msg.error) showMessage(`final render: ${msg.error}`);
  if (msg.state === "done" && F.source === "final") loadFinalImage();
  renderFinal();
}

/**
 * Compares the live image with snapshot `s` (a library list entry) in `mode`: its frame as it
 * was rendered, in the rig's own view of that moment (a snapshot keeps one image).
 */
export function compareWithSnapshot(s, mode = "wipe") {
  if (!s) return;
  F.source = "snapshot";
  F.snap = s;
  loadImage(`snap|${s.name}|${s.time}`,
            `/v1/sessions/${encodeURIComponent(S.sessionId)}/snapshots/${encodeURIComponent(s.name)}.jpg?${new URLSearchParams({ token: S.token })}`,
            "snapshot");
  F.mode = mode;
  $("compareMode").value = mode;
  renderFinal();
}
function useFinal() {
  F.source = "final";
  F.snap = null;
  dropImage();
  if (F.state?.state === "done") loadFinalImage();
  renderFinal();
}
function dropImage() {
  if (F.objectUrl) URL.revokeObjectURL(F.objectUrl);
  F.objectUrl = null;
  F.imageKey = "";
  $("finalImg").removeAttribute("src");
}
/** The snapshots there are (library.js): the compare menu's B choices; a deleted B falls back to the final. */
export function setSnapshots(list) {
  F.snapshots = list;
  if (F.source === "snapshot" && !list.some((x) => x.name === F.snap.name && x.time === F.snap.time)) useFinal();
  renderFinal();
}

/** The view (exposure, transform) changed: the final image follows it. */
export function onViewChanged() {
  if (F.source === "final" && F.state?.state === "done") loadFinalImage();
}

async function startFinal() {
  if (!canEdit()) return showMessage("viewers cannot start a final render");
  const samples = Number($("finalSamples").value);
  if (!Number.isInteger(samples) || samples < 1 || samples > 4096) return showMessage("final render: samples must be a whole number from 1 to 4096");
  try {
    onFinal(await api("POST", "final", { samples, directOnly: $("finalDirect").checked }));
  } catch (e) {
    showMessage(`final render: ${e.message}`);
  }
}
async function cancelFinal() {
  try { onFinal(await api("DELETE", "final")); } catch (e) { showMessage(`final render: ${e.message}`); }
}

function loadFinalImage() {
  const v = S.view, version = F.state.rigVersion;
  const q = new URLSearchParams({ token: S.token, exposure: String(v.exposure), viewTransform: v.viewTransform });
  loadImage(`${version}|${v.exposure}|${v.viewTransform}`, `/v1/sessions/${encodeURIComponent(S.sessionId)}/final.png?${q}`, "final render");
}

// Fetches B (once per key) into #finalImg.
function loadImage(key, url, what) {
  if (key === F.imageKey) return;
  F.imageKey = key;
  fetch(url)
    .then(async (res) => {
      if (!res.ok) throw new Error(`HTTP ${res.status}: ${(await res.text()).slice(0, 200)}`);
      if (F.imageKey !== key) return; // another B was chosen meanwhile
      const blobUrl = URL.createObjectURL(await res.blob());
      if (F.objectUrl) URL.revokeObjectURL(F.objectUrl);
      F.objectUrl = blobUrl;
      const img = $("finalImg");
      img.dataset.rigVersion = (res.headers.get("ETag") ?? res.headers.get("X-Rig-Version") ?? "").replaceAll('"', "");
      img.dataset.source = key;
      img.src = blobUrl;
      renderFinal();
    })
    .catch((e) => { F.imageKey = ""; showMessage(`${what}: cannot load the image: ${e.message}`); });
}

/** The A/B toggle (T): the live image and B alone, in turn, once B is loaded. */
export function toggleAB() {
  if (!F.objectUrl) return;
  setCompare(F.mode === "final" ? "live" : "final");
  $("compareMode").value = F.mode;
}

function setCompare(mode) {
  F.mode = mode;
  layoutCompare();
  scheduleStats();
}

/** Shows the final image as the compare mode says (called on zoom and pan too). */
export function layoutCompare() {
  const img = $("finalImg"), bar = $("wipeBar"), stage = $("stage");
  if (!img) return;
  const ready = Boolean(F.objectUrl) && img.complete && img.naturalWidth > 0;
  const mode = ready ? F.mode : "live";
  img.hidden = mode === "live";
  img.classList.toggle("pixelated", $("frame").classList.contains("pixelated"));
  img.width = $("frame").width;
  img.height = $("frame").height;
  img.style.clipPath = mode === "wipe" ? `inset(0 0 0 ${(F.wipe * 100).toFixed(3)}%)` : "";
  img.style.mixBlendMode = mode === "difference" ? "difference" : "";
  stage.style.filter = mode === "difference" ? `brightness(${F.gain})` : "";
  stage.dataset.compare = mode;
  bar.hidden = mode !== "wipe";
  if (mode === "wipe") {
    const r = $("frame").getBoundingClientRect(), vp = $("viewport").getBoundingClientRect();
    bar.style.left = `${r.left - vp.left + F.wipe * r.width}px`;
    bar.style.top = `${r.top - vp.top}px`;
    bar.style.height = `${r.height}px`;
  }
  $("diffGain").hidden = mode !== "difference";
  $("compareStats").hidden = mode !== "difference";
}

export function renderFinal() {
  const st = F.state?.state ?? "none";
  const box = $("finalStatus");
  let text = "No final render yet.";
  if (busy(st)) {
    const [n, m] = F.state.samples ?? [0, 0];
    text = st === "exporting" ? `Exporting the scene with rig version ${F.state.rigVersion}…`
      : `Rendering rig version ${F.state.rigVersion}: ${n} / ${m} samples`;
    $("finalProgress").value = F.state.percent ?? 0;
  } else if (st === "done") {
    const live = S.rig?.version ?? 0;
    text = `Final of rig version ${F.state.rigVersion} (${F.state.samples?.[1] ?? "?"} samples${F.state.directOnly ? ", direct only" : ""},` +
      ` ${Number(F.state.seconds ?? 0).toFixed(1)} s)` + (live !== F.state.rigVersion ? ` · the live rig is at version ${live}` : "");
  } else if (st === "failed") {
    text = `Failed: ${F.state.error ?? "no reason given"}`;
  } else if (st === "cancelled") {
    text = `Cancelled (rig version ${F.state.rigVersion}).`;
  }
  box.textContent = text;
  box.dataset.state = st;
  $("finalProgress").hidden = !busy(st);
  $("finalCancel").hidden = !busy(st);
  $("finalRender").disabled = busy(st);
  const notes = $("finalNotes");
  notes.innerHTML = "";
  for (const n of F.state?.notes ?? []) notes.append(Object.assign(document.createElement("li"), { textContent: n }));
  $("compareMode").disabled = !F.objectUrl;
  // B: the final render or a snapshot.
  const sel = $("compareWith");
  const options = [["final", F.state?.state === "done" ? `final render (v${F.state.rigVersion})` : "final render"],
                   ...(F.snapshots ?? []).map((x) => [`snap:${x.name}`, `snapshot ${x.name} (v${x.rigVersion})`])];
  if (sel.options.length !== options.length || options.some(([v, t], i) => sel.options[i].value !== v || sel.options[i].textContent !== t)) {
    sel.innerHTML = "";
    for (const [v, t] of options) sel.append(Object.assign(document.createElement("option"), { value: v, textContent: t }));
  }
  sel.value = F.source === "snapshot" ? `snap:${F.snap.name}` : "final";
  sel.disabled = options.length < 2 && !F.objectUrl;
  layoutCompare();
}

// The difference figure: both images drawn at most 320 wide, sRGB decoded, mean |a - b| of the
// luminance over pixels the final covers (its alpha), relative to the final's mean luminance.
function scheduleStats() {
  if (F.mode !== "difference") return;
  clearTimeout(F.statsTimer);
  F.statsTimer = setTimeout(computeStats, 200);
}
export function onLiveFrame() { scheduleStats(); }

const lin = (c) => { c /= 255; return c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4; };
function pixels(img, w, h) {
  const c = Object.assign(document.createElement("canvas"), { width: w, height: h });
  const ctx = c.getContext("2d");
  ctx.drawImage(img, 0, 0, w, h);
  return ctx.getImageData(0, 0, w, h).data;
}
function computeStats() {
  const a = $("frame"), b = $("finalImg");
  if (!a.complete || !a.naturalWidth || !b.complete || !b.naturalWidth) return;
  const w = Math.min(320, a.naturalWidth), h = Math.max(1, Math.round(w * a.naturalHeight / a.naturalWidth));
  const pa = pixels(a, w, h), pb = pixels(b, w, h);
  let diff = 0, ref = 0, n = 0;
  for (let i = 0; i < pa.length; i += 4) {
    if (pb[i + 3] < 128) continue;
    const la = 0.2126 * lin(pa[i]) + 0.7152 * lin(pa[i + 1]) + 0.0722 * lin(pa[i + 2]);
    const lb = 0.2126 * lin(pb[i]) + 0.7152 * lin(pb[i + 1]) + 0.0722 * lin(pb[i + 2]);
    diff += Math.abs(la - lb);
    ref += lb;
    n++;
  }
  const rel = ref > 0 ? diff / ref : 0;
  const box = $("compareStats");
  box.dataset.relative = String(rel);
  box.textContent = n ? `mean |preview − final| ${(100 * rel).toFixed(1)} % of the final (${n} pixels, as displayed)` : "the final covers no pixel";
}
