// Typed entry and colours: what the artist types is checked before anything is sent, and the
// colour picker's sRGB is converted to the rig's linear RGB. Pure: no DOM.

/** {value} or {error} for a number typed into a field labelled `label`, within [min, max]. */
export function parseNumber(text, label, min, max, { integer = false } = {}) {
  const s = String(text).trim();
  if (s === "") return { error: `${label}: enter a number` };
  const v = Number(s);
  if (!Number.isFinite(v)) return { error: `${label}: '${s}' is not a number` };
  if (integer && !Number.isInteger(v)) return { error: `${label}: '${s}' is not a whole number` };
  if (v < min || v > max) return { error: `${label}: ${v} is out of range [${min}, ${max}]` };
  return { value: v };
}

// sRGB <-> linear for the colour picker (the rig's colours are linear RGB).
export const toSrgb = (c) => (c <= 0.0031308 ? 12.92 * c : 1.055 * c ** (1 / 2.4) - 0.055);
export const toLinear = (c) => (c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4);
/** "#rrggbb" (sRGB) of a linear colour; over-bright colours show their hue. */
export function linearToHex(rgb) {
  const m = Math.max(1, ...rgb);
  return "#" + rgb.map((c) => Math.round(Math.min(1, Math.max(0, toSrgb(c / m))) * 255).toString(16).padStart(2, "0")).join("");
}
/** Linear RGB of "#rrggbb", to 4 decimals (what a picker can mean). */
export function hexToLinear(hex) {
  return [1, 3, 5].map((i) => Number(toLinear(parseInt(hex.slice(i, i + 2), 16) / 255).toFixed(4)));
}
