// Browser test of the web client in real headless Chromium (Debian's /usr/bin/chromium, driven by
// playwright-core): the page served by a real dfb-server shows the streamed image, and changing a
// control changes the image.
//
//   node relight_page.test.mjs --server PATH/dfb-server --shot SHOT.exr --artifacts DIR
//
// Screenshots of the main states are saved in the artifacts folder.

import { spawn } from "node:child_process";
import { mkdirSync } from "node:fs";
import { join } from "node:path";
import { parseArgs } from "node:util";
import { chromium } from "playwright-core";

const { values: opts } = parseArgs({
  options: {
    server: { type: "string" },
    shot: { type: "string" },
    artifacts: { type: "string", default: "browser-artifacts" },
    chromium: { type: "string", default: "/usr/bin/chromium" },
  },
});
if (!opts.server || !opts.shot) {
  console.error("usage: node relight_page.test.mjs --server DFB_SERVER --shot SHOT.exr [--artifacts DIR]");
  process.exit(2);
}
mkdirSync(opts.artifacts, { recursive: true });

// Starts dfb-server on a free loopback port and resolves with its URL.
function startServer() {
  return new Promise((resolve, reject) => {
    const proc = spawn(opts.server, [opts.shot, "--port", "0"], { stdio: ["ignore", "pipe", "pipe"] });
    let out = "";
    const timer = setTimeout(() => reject(new Error(`server did not start:\n${out}`)), 60000);
    const onData = (d) => {
      out += d;
      const m = out.match(/listening on (http:\/\/127\.0\.0\.1:\d+\/)/);
      // The page is opened with the editor link the server prints for the session.
      const editor = out.match(/session (\S+) editor: (http:\/\/\S+token=(\w+))/);
      if (m && editor) { clearTimeout(timer); resolve({ proc, url: editor[2], base: m[1], session: editor[1], token: editor[3] }); }
    };
    proc.stdout.on("data", onData);
    proc.stderr.on("data", onData);
    proc.on("exit", (code) => reject(new Error(`server exited with ${code}:\n${out}`)));
  });
}

// Pixels of the displayed frame, read back through a canvas.
async function framePixels(page) {
  return page.evaluate(() => {
    const img = document.getElementById("frame");
    const c = document.createElement("canvas");
    c.width = img.naturalWidth;
    c.height = img.naturalHeight;
    const ctx = c.getContext("2d");
    ctx.drawImage(img, 0, 0);
    return Array.from(ctx.getImageData(0, 0, c.width, c.height).data);
  });
}

function meanAbsDiff(a, b) {
  let s = 0;
  for (let i = 0; i < a.length; i += 4) s += Math.abs(a[i] - b[i]) + Math.abs(a[i + 1] - b[i + 1]) + Math.abs(a[i + 2] - b[i + 2]);
  return s / (a.length / 4) / 3;
}

const results = [];
async function check(name, fn) {
  try {
    await fn();
    results.push([name, true]);
    console.log(`ok   ${name}`);
  } catch (e) {
    results.push([name, false]);
    console.log(`FAIL ${name}: ${e.message}`);
  }
}
function assert(cond, message) { if (!cond) throw new Error(message); }

let server, browser;
const deadline = setTimeout(() => { console.error("browser test timed out"); process.exit(1); }, 150000);
try {
  server = await startServer();
  browser = await chromium.launch({
    executablePath: opts.chromium,
    headless: true,
    args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
           "--disable-component-update", "--disable-sync"],
  });
  const page = await browser.newPage({ viewport: { width: 1000, height: 500 } });
  const consoleErrors = [];
  page.on("console", (m) => { if (m.type() === "error") consoleErrors.push(m.text()); });
  await page.goto(server.url);

  let before;
  await check("the page shows a streamed image", async () => {
    await page.waitForFunction(() => {
      const img = document.getElementById("frame");
      return img.complete && img.naturalWidth > 0 && img.dataset.rigVersion;
    }, null, { timeout: 30000 });
    const size = await page.evaluate(() => [document.getElementById("frame").naturalWidth, document.getElementById("frame").naturalHeight]);
    assert(size[0] === 320 && size[1] === 180, `unexpected frame size ${size}`);
    before = await framePixels(page);
    const lit = before.filter((v, i) => i % 4 === 0 && v > 40).length;
    assert(lit > 1000, `the image is nearly black (${lit} bright pixels)`);
    await page.screenshot({ path: join(opts.artifacts, "01-loaded.png") });
  });

  await check("the page shows the rig and connection state", async () => {
    const lights = await page.$$eval("#light option", (os) => os.map((o) => o.value));
    assert(lights.includes("key") && lights.includes("fill"), `lights listed: ${lights}`);
    const status = await page.textContent("#status");
    assert(/connected as client/.test(status), `status: ${status}`);
  });

  await check("changing a control changes the image", async () => {
    const versionBefore = Number(await page.getAttribute("#frame", "data-rig-version"));
    // Move the key light along x with its slider, as a user dragging it would.
    await page.evaluate(() => {
      const r = document.getElementById("ctl-position-0");
      r.value = String(Number(r.value) + 2.5);
      r.dispatchEvent(new Event("input", { bubbles: true }));
    });
    await page.waitForFunction((v) => Number(document.getElementById("frame").dataset.rigVersion) > v &&
                                      document.getElementById("frame").complete, versionBefore, { timeout: 30000 });
    await page.waitForTimeout(200);
    const after = await framePixels(page);
    const diff = meanAbsDiff(before, after);
    assert(diff > 2, `image barely changed (mean abs difference ${diff.toFixed(2)})`);
    await page.screenshot({ path: join(opts.artifacts, "02-key-moved.png") });
    const rig = await (await fetch(new URL(`/v1/sessions/${server.session}/rig`, server.base),
                                   { headers: { Authorization: `Bearer ${server.token}` } })).json();
    const key = rig.lights.find((l) => l.name === "key");
    assert(rig.version > versionBefore - 1, "the server's rig version did not advance");
    console.log(`     mean abs pixel difference ${diff.toFixed(2)}; key.position now ${key.position.map((v) => v.toFixed(2))}`);
  });

  await check("no errors in the page console", async () => {
    assert(consoleErrors.length === 0, consoleErrors.join("; "));
  });
} catch (e) {
  results.push(["setup", false]);
  console.log(`FAIL setup: ${e.message}`);
} finally {
  clearTimeout(deadline);
  if (browser) await browser.close();
  if (server) server.proc.kill("SIGTERM");
}
const passed = results.filter(([, ok]) => ok).length;
const failed = results.length - passed;
console.log(`${passed} passed, ${failed} failed`);
process.exit(failed === 0 ? 0 : 1);
