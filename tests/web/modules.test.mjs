// The browser page's files (client/web) as a whole, read as text: the files index.html and the
// module graph from main.js need are exactly the files the server serves (DFB_WEB_FILES, passed by
// CTest from server/CMakeLists.txt), every named import is exported by its module, and the pure
// modules touch no DOM (node imports them in the other tests).

import assert from "node:assert/strict";
import { readFileSync, readdirSync } from "node:fs";
import { dirname, join } from "node:path";
import { test } from "node:test";
import { fileURLToPath, pathToFileURL } from "node:url";

const WEB = join(dirname(fileURLToPath(import.meta.url)), "../../client/web");
const read = (name) => readFileSync(join(WEB, name), "utf8");
// The modules that must run in node: no document, window, location, storage or timers of a page.
const PURE = ["linalg.js", "camera.js", "rig.js", "rows.js", "format.js", "area.js", "placement.js"];

// `import { a, b as c } from "./x.js"` and `import "./x.js"` of a module's text.
function importsOf(text) {
  const out = [];
  for (const m of text.matchAll(/^import\s+(?:\{([^}]*)\}\s+from\s+)?"([^"]+)";/gm)) {
    const names = (m[1] ?? "").split(",").map((s) => s.trim().split(/\s+as\s+/)[0]).filter(Boolean);
    out.push({ from: m[2], names });
  }
  return out;
}
function exportsOf(text) {
  return new Set([...text.matchAll(/^export\s+(?:async\s+)?(?:function|const|let|class)\s+([A-Za-z_$][\w$]*)/gm)].map((m) => m[1]));
}
// Every module reachable from main.js, with its imports.
function moduleGraph() {
  const graph = new Map();
  const visit = (name) => {
    if (graph.has(name)) return;
    const imports = importsOf(read(name));
    graph.set(name, imports);
    for (const i of imports) {
      assert.match(i.from, /^\.\/[A-Za-z0-9_-]+\.js$/, `${name} imports ${i.from}: only sibling modules, by relative name`);
      visit(i.from.slice(2));
    }
  };
  visit("main.js");
  return graph;
}

test("index.html holds markup, one stylesheet and the main module only", () => {
  const html = read("index.html");
  assert.deepEqual([...html.matchAll(/<script\b[^>]*>/g)].map((m) => m[0]), ['<script type="module" src="main.js">']);
  assert.match(html, /<script type="module" src="main.js"><\/script>/);
  assert.deepEqual([...html.matchAll(/<link\b[^>]*>/g)].map((m) => m[0]), ['<link rel="stylesheet" href="style.css">']);
  assert.doesNotMatch(html, /<style/);
  assert.doesNotMatch(html, /\son[a-z]+=/, "inline handlers cannot reach module functions");
});

test("the served files are exactly what the page loads", (t) => {
  const listed = process.env.DFB_WEB_FILES?.split(",");
  if (!listed) return t.skip("DFB_WEB_FILES is not set (CTest sets it from server/CMakeLists.txt)");
  const needed = ["index.html", "style.css", ...moduleGraph().keys()].sort();
  assert.deepEqual([...listed].sort(), needed);
  // Nothing else lies in the folder but node's module marker (not served).
  assert.deepEqual(readdirSync(WEB).filter((f) => f !== "package.json").sort(), needed);
});

test("every named import is exported by the module it names", () => {
  for (const [name, imports] of moduleGraph()) {
    for (const { from, names } of imports) {
      const exported = exportsOf(read(from.slice(2)));
      for (const n of names) assert.ok(exported.has(n), `${name} imports ${n} from ${from}, which does not export it`);
    }
  }
});

test("the pure modules import only pure modules and touch no DOM", async () => {
  const graph = moduleGraph();
  for (const name of PURE) {
    assert.ok(graph.has(name), `${name} is not part of the page`);
    for (const { from } of graph.get(name)) assert.ok(PURE.includes(from.slice(2)), `${name} imports ${from}, which is not pure`);
    // Comments may name the DOM; code may not.
    const code = read(name).replace(/\/\*[\s\S]*?\*\//g, "").replace(/\/\/.*$/gm, "");
    assert.doesNotMatch(code, /\b(document|window|location|localStorage|navigator|requestAnimationFrame|WebSocket|fetch)\b/, name);
    await import(pathToFileURL(join(WEB, name))); // and node can load it
  }
});
