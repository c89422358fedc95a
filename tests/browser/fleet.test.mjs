// The browser page through a fleet (issue 21, docs/deployment.md) in real headless Chromium
// (Debian's /usr/bin/chromium, driven by playwright-core): two dfb-server nodes share one sessions
// and state folder behind HAProxy (deploy/haproxy/, filled by scripts/fleet --config-for). The page
// is opened through the router and edits the key's and the fill's intensity in its panel; the node
// serving the session is SIGKILLed; the page must show that it is disconnected, reconnect through
// the router by itself within 10 s to the session opened on the other node (from the journal), show
// every edit the server had acknowledged, and go on editing there.
// (tests/integration/fleet_test.cpp checks the same failover with WebSocket test clients.)
//
//   DFB_SERVER_EXE=PATH/dfb-server DFB_SHOT=SHOT.exr [DFB_ARTIFACTS=DIR] node --test fleet.test.mjs
//
// Optional: DFB_HAPROXY (default /usr/sbin/haproxy), DFB_CHROMIUM (default /usr/bin/chromium).
// On a failing step the nodes' and the router's logs, the page's console and a screenshot go to
// DFB_ARTIFACTS. Every wait is for a condition; its timeout only bounds a failure.

import assert from "node:assert/strict";
import { spawn, spawnSync } from "node:child_process";
import { copyFileSync, mkdirSync, mkdtempSync, rmSync, writeFileSync } from "node:fs";
import { createServer } from "node:net";
import { tmpdir } from "node:os";
import { dirname, join, resolve } from "node:path";
import { after, before, describe, test } from "node:test";
import { fileURLToPath } from "node:url";
import { chromium } from "playwright-core";

const here = dirname(fileURLToPath(import.meta.url));
const FLEET_SCRIPT = resolve(here, "../../scripts/fleet");
const SERVER = process.env.DFB_SERVER_EXE;
const SHOT = process.env.DFB_SHOT;
const HAPROXY = process.env.DFB_HAPROXY || "/usr/sbin/haproxy";
const CHROMIUM = process.env.DFB_CHROMIUM || "/usr/bin/chromium";
const ARTIFACTS = process.env.DFB_ARTIFACTS || null;
const SESSION = "s1";
const WAIT = 20000; // bound of a wait that should take a second or two
const RECONNECT_LIMIT = 10000; // the page is back on the session within this after the kill

// Everything the test started, for the after hook and, should the runner exit without it, the
// exit handler.
const children = []; // { name, proc, log(), exited: Promise }
let dir = null;
let browser = null;

function killAllNow() {
  for (const c of children) if (c.proc.exitCode === null && c.proc.signalCode === null) c.proc.kill("SIGKILL");
  if (dir) rmSync(dir, { recursive: true, force: true });
}
process.on("exit", killAllNow);

// Starts a program, keeping its stdout and stderr together (the nodes' logs; HAProxy logs to
// stdout with -db).
function startProcess(name, file, args) {
  const proc = spawn(file, args, { stdio: ["ignore", "pipe", "pipe"] });
  let out = "";
  proc.stdout.on("data", (d) => { out += d; });
  proc.stderr.on("data", (d) => { out += d; });
  const c = { name, proc, log: () => out, exited: new Promise((r) => proc.on("exit", (code, signal) => r({ code, signal }))) };
  proc.on("error", (e) => { out += `\nspawn error: ${e.message}\n`; });
  children.push(c);
  return c;
}

// One node of the fleet on a free loopback port; resolves once it listens and has printed the
// session's editor link.
async function startNode(name) {
  const c = startProcess(name, SERVER, ["--sessions", join(dir, "sessions"), "--state", join(dir, "state"), "--node", name,
                                        "--port", "0", "--default-rig", "key-fill"]);
  const end = Date.now() + 60000;
  for (;;) {
    const out = c.log();
    const m = out.match(/listening on http:\/\/127\.0\.0\.1:(\d+)\//);
    const editor = out.match(new RegExp(`session ${SESSION} editor: http://\\S+token=([\\w.~-]+)`));
    if (m && editor) return { ...c, port: Number(m[1]), token: editor[1] };
    if (c.proc.exitCode !== null || c.proc.signalCode !== null) throw new Error(`${name} exited before it listened:\n${out}`);
    if (Date.now() > end) throw new Error(`${name} did not start within 60 s:\n${out}`);
    await sleep(50);
  }
}

function freePort() {
  return new Promise((res, rej) => {
    const s = createServer();
    s.on("error", rej);
    s.listen(0, "127.0.0.1", () => { const { port } = s.address(); s.close(() => res(port)); });
  });
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// Polls fn (which may be async) until it returns something truthy; fails naming `what`.
async function until(fn, what, timeout = WAIT) {
  const end = Date.now() + timeout;
  for (;;) {
    const v = await fn();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out after ${timeout / 1000} s waiting for ${what}`);
    await sleep(50);
  }
}

let router = null; // { port, proc... }
let nodes = []; // node1, node2: the fleet's server names in the order of their addresses
let token = null;
let page = null;
const pageLog = []; // console lines and page errors
const pageErrors = []; // uncaught exceptions in the page
// The page's WebSocket traffic (text messages only) and its handshakes, as Chromium saw them.
const wire = { sockets: [], sent: [], received: [] };
const handshakes = []; // { t, status, node: the X-Dfb-Node header of the answer }

// A request of the session through the router, with the editor token: the JSON and the node
// that answered.
async function viaRouter(resource, init = {}) {
  const res = await fetch(`http://127.0.0.1:${router.port}/v1/sessions/${SESSION}${resource ? `/${resource}` : ""}`,
                          { ...init, headers: { Authorization: `Bearer ${token}`, ...(init.headers || {}) } });
  const text = await res.text();
  if (!res.ok) throw new Error(`${init.method || "GET"} ${resource || "(session)"} through the router: HTTP ${res.status}: ${text.slice(0, 300)}`);
  return { json: JSON.parse(text), node: res.headers.get("x-dfb-node") };
}
const intensityOf = (rig, light) => rig.lights.find((l) => l.name === light)?.intensity;

// Edits `light`'s intensity the way an artist does (select the light in the list, type the value
// in its panel, Enter) and waits for the server's ack of that edit on the page's WebSocket.
// Returns the rig version the ack gave it.
async function editIntensity(light, value) {
  await page.click(`#lights li[data-light="${light}"] .lname`);
  await page.waitForFunction((n) => document.getElementById("lightName")?.value === n, light, { timeout: WAIT });
  const mark = wire.sent.length;
  await page.fill("#prop-intensity", String(value));
  await page.press("#prop-intensity", "Enter");
  const path = `${light}.intensity`;
  const sent = await until(() => wire.sent.slice(mark).find((m) => m.msg.type === "edit" && m.msg.changes?.some((c) => c.path === path && c.value === value)),
                           `the page to send the edit ${path} = ${value}`);
  const answer = await until(() => wire.received.find((m) => m.socket === sent.socket && m.msg.seq === sent.msg.seq && ["ack", "error"].includes(m.msg.type)),
                             `the server's ack of the edit ${path} = ${value} (seq ${sent.msg.seq})`);
  assert.equal(answer.msg.type, "ack", `the edit ${path} = ${value} was refused: ${JSON.stringify(answer.msg)}`);
  // And the page no longer has it in flight.
  await page.waitForFunction(() => ![...window.dfb.S.pending.values()].some((p) => p.kind === "edit"), null, { timeout: WAIT });
  return answer.msg.rigVersion;
}
// Waits until the page shows a decoded frame of at least rig version v.
async function frameAtLeast(v) {
  await page.waitForFunction((v) => {
    const img = document.getElementById("frame");
    return img.complete && img.naturalWidth > 0 && Number(img.dataset.rigVersion) >= v;
  }, v, { timeout: WAIT });
}
// What the page shows of a light: its intensity in the page's rig and, with it selected, in its panel.
async function shownIntensity(light) {
  await page.click(`#lights li[data-light="${light}"] .lname`);
  await page.waitForFunction((n) => document.getElementById("lightName")?.value === n, light, { timeout: WAIT });
  return page.evaluate((n) => ({ rig: window.dfb.S.rig.lights.find((l) => l.name === n)?.intensity,
                                 field: Number(document.getElementById("prop-intensity").value) }), light);
}

async function saveFailure(name) {
  if (!ARTIFACTS) return;
  try {
    mkdirSync(ARTIFACTS, { recursive: true });
    const stem = join(ARTIFACTS, `FAIL-${name.replace(/[^A-Za-z0-9]+/g, "_").slice(0, 60)}`);
    for (const c of children) writeFileSync(`${stem}-${c.name}.log`, c.log());
    writeFileSync(`${stem}-page-console.log`, pageLog.join("\n"));
    writeFileSync(`${stem}-page-wire.json`, JSON.stringify({ handshakes, ...wire }, null, 1));
    if (page && !page.isClosed()) await page.screenshot({ path: `${stem}-page.png` }).catch(() => {});
    console.log(`saved the logs and a screenshot as ${stem}-*`);
  } catch (e) {
    console.log(`could not save the failure's artifacts: ${e.message}`);
  }
}
// A step that fails saves what was seen; the steps after it are not meaningful without it.
let failed = false;
function step(name, fn) {
  test(name, { timeout: 60000 }, async (t) => {
    if (failed) return t.skip("an earlier step failed");
    try {
      await fn();
    } catch (e) {
      failed = true;
      await saveFailure(name);
      throw e;
    }
  });
}

describe("the browser page through a fleet of two nodes behind HAProxy", { timeout: 110000 }, () => {
  let victim = null, survivor = null, killedAt = 0;
  const acked = []; // { path, value, version }: every edit the server acknowledged

  before(() => setUp().catch(async (e) => { failed = true; await saveFailure("setup"); throw e; }));
  async function setUp() {
    assert.ok(SERVER && SHOT, "DFB_SERVER_EXE and DFB_SHOT must be set (tests/CMakeLists.txt sets them)");
    dir = mkdtempSync(join(tmpdir(), "dfb-browser-fleet-"));
    mkdirSync(join(dir, "sessions"));
    mkdirSync(join(dir, "state"));
    for (const s of ["s1", "s2"]) copyFileSync(SHOT, join(dir, "sessions", `${s}.exr`));
    nodes = await Promise.all(["node1", "node2"].map(startNode));
    token = nodes[0].token;
    const port = await freePort();
    const cfg = spawnSync("bash", [FLEET_SCRIPT, "--config-for", String(port), ...nodes.map((n) => `127.0.0.1:${n.port}`)], { encoding: "utf8" });
    assert.equal(cfg.status, 0, `scripts/fleet --config-for: ${cfg.stderr}`);
    writeFileSync(join(dir, "haproxy.cfg"), cfg.stdout);
    router = { port, ...startProcess("haproxy", HAPROXY, ["-db", "-f", join(dir, "haproxy.cfg")]) };
    await until(async () => {
      if (router.proc.exitCode !== null) throw new Error(`haproxy exited with ${router.proc.exitCode}:\n${router.log()}`);
      return (await fetch(`http://127.0.0.1:${port}/healthz`).catch(() => null))?.ok;
    }, "the router to answer /healthz");

    browser = await chromium.launch({
      executablePath: CHROMIUM, headless: true,
      args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
             "--disable-component-update", "--disable-sync"],
    });
    const context = await browser.newContext({ viewport: { width: 1280, height: 800 } });
    page = await context.newPage();
    page.on("console", (m) => pageLog.push(`${new Date().toISOString()} ${m.type()}: ${m.text()}`));
    page.on("pageerror", (e) => { pageLog.push(`pageerror: ${e.stack || e}`); pageErrors.push(String(e.stack || e)); });
    page.on("websocket", (ws) => {
      const socket = wire.sockets.length;
      wire.sockets.push({ url: ws.url(), opened: Date.now(), closed: null });
      ws.on("close", () => { wire.sockets[socket].closed = Date.now(); });
      const keep = (list) => (f) => {
        if (typeof f.payload !== "string") return; // frames
        try { list.push({ socket, t: Date.now(), msg: JSON.parse(f.payload) }); } catch { /* not JSON */ }
      };
      ws.on("framesent", keep(wire.sent));
      ws.on("framereceived", keep(wire.received));
    });
    // The node that answered each WebSocket handshake (the router's X-Dfb-Node on the 101).
    const cdp = await context.newCDPSession(page);
    await cdp.send("Network.enable");
    cdp.on("Network.webSocketHandshakeResponseReceived", (e) => {
      const h = Object.fromEntries(Object.entries(e.response.headers || {}).map(([k, v]) => [k.toLowerCase(), v]));
      handshakes.push({ t: Date.now(), status: e.response.status, node: h["x-dfb-node"] ?? null });
    });
  }

  after(async () => {
    if (browser) await browser.close().catch(() => {});
    // SIGTERM drains a node; whatever has not exited within 5 s is killed.
    for (const c of children) if (c.proc.exitCode === null && c.proc.signalCode === null) c.proc.kill("SIGTERM");
    let timer;
    await Promise.race([Promise.all(children.map((c) => c.exited)), new Promise((r) => { timer = setTimeout(r, 5000); })]);
    clearTimeout(timer); // not to keep the runner waiting
    killAllNow();
    dir = null;
  });

  step("the page opened through the router connects, and its edits are acknowledged", async () => {
    await page.goto(`http://127.0.0.1:${router.port}/?session=${SESSION}&token=${token}&name=alice`);
    await page.waitForFunction(() => !document.body.classList.contains("offline") &&
                                      /connected · editor/.test(document.getElementById("status").textContent), null, { timeout: WAIT });
    await frameAtLeast(1);
    // Every status the page shows from here on, with the time (the disconnected state may be short).
    await page.evaluate(() => {
      const el = document.getElementById("status");
      window.statusLog = [{ t: Date.now(), text: el.textContent, offline: document.body.classList.contains("offline") }];
      new MutationObserver(() => window.statusLog.push({ t: Date.now(), text: el.textContent, offline: document.body.classList.contains("offline") }))
        .observe(el, { childList: true, characterData: true, subtree: true });
    });
    const rig0 = (await viaRouter("rig")).json;
    for (const [light, value] of [["key", 7.25], ["fill", 1.5]]) {
      assert.notEqual(intensityOf(rig0, light), value, `${light} already has intensity ${value}`);
      acked.push({ path: `${light}.intensity`, value, version: await editIntensity(light, value) });
    }
    const { json: rig, node } = await viaRouter("rig");
    for (const a of acked) assert.equal(intensityOf(rig, a.path.split(".")[0]), a.value, `the server's rig lacks ${a.path} = ${a.value}`);
    victim = node;
    // The session's requests all go to one node: the one whose WebSocket the page has.
    assert.equal((await viaRouter("")).node, victim, "two requests of the session were routed to different nodes");
    assert.ok(["node1", "node2"].includes(victim), `X-Dfb-Node: ${victim}`);
    const hs = await until(() => handshakes.find((h) => h.status === 101), "the page's WebSocket handshake (DevTools)");
    assert.equal(hs.node, victim, `the page's WebSocket is on ${hs.node}, the session on ${victim}`);
    survivor = victim === "node1" ? "node2" : "node1";
  });

  step("after the serving node is SIGKILLed the page reconnects through the router within 10 s, with every acknowledged edit", async () => {
    const node = nodes.find((n) => n.name === victim);
    const socketsBefore = wire.sockets.length;
    killedAt = Date.now();
    node.proc.kill("SIGKILL");
    const { signal } = await node.exited;
    const exitedAt = Date.now();
    assert.equal(signal, "SIGKILL");
    // Disconnected, then connected again (as an editor) within the limit: the page's status line
    // as it changed, and as it is now.
    const statusNow = () => page.evaluate(() => ({ log: window.statusLog, offline: document.body.classList.contains("offline"),
                                                   text: document.getElementById("status").textContent }));
    const seen = (st) => {
      const down = st.log.find((s) => s.t >= killedAt && s.offline && /disconnected/.test(s.text));
      const up = down && st.log.find((s) => s.t >= down.t && !s.offline && /connected · editor/.test(s.text));
      return { down, up: up && !st.offline && /connected · editor/.test(st.text) ? up : null };
    };
    let st = null;
    try {
      await until(async () => seen(st = await statusNow()).up, "the page to show disconnected, then connected", RECONNECT_LIMIT - (Date.now() - killedAt));
    } catch {
      const { down } = seen(st);
      throw new Error(`${down ? `the page showed "disconnected" ${(down.t - killedAt) / 1000} s after the kill but was not connected again`
                              : "the page did not show that it was disconnected"} within ${RECONNECT_LIMIT / 1000} s of the kill; ` +
                      `its status line since the kill: ${JSON.stringify(st.log.filter((s) => s.t >= killedAt).map((s) => ({ ...s, t: (s.t - killedAt) / 1000 })))}; ` +
                      `now "${st.text}"${st.offline ? " (offline)" : ""}; retry text: "${await page.textContent("#retryText").catch(() => "?")}"`);
    }
    const { down, up } = seen(st);
    const closed = wire.sockets[socketsBefore - 1]?.closed;
    console.log(`# after the kill: the node had exited ${(exitedAt - killedAt) / 1000} s, the page's WebSocket closed ` +
                `${closed ? (closed - killedAt) / 1000 : "?"} s, the page showed "disconnected" ${(down.t - killedAt) / 1000} s ` +
                `and "connected" again ${(up.t - killedAt) / 1000} s`);
    assert.ok(up.t - killedAt < RECONNECT_LIMIT, `reconnected ${(up.t - killedAt) / 1000} s after the kill`);
    assert.ok(wire.sockets.length > socketsBefore, "the page opened no new WebSocket");
    const welcome = wire.received.find((m) => m.socket >= socketsBefore && m.msg.type === "welcome");
    assert.ok(welcome, "no welcome on the new WebSocket");
    // Its WebSocket is now on the other node (every handshake since the kill).
    const since = await until(() => { const h = handshakes.filter((x) => x.t >= killedAt && x.status === 101); return h.length ? h : null; },
                              "the reconnected WebSocket's handshake (DevTools)");
    assert.ok(since.every((h) => h.node === survivor), `WebSocket handshakes since the kill: ${JSON.stringify(since)}`);
    // The welcome's rig, the page's rig, its panel and its image have every acknowledged edit.
    const last = Math.max(...acked.map((a) => a.version));
    assert.ok(welcome.msg.rig.version >= last, `the welcome's rig is at version ${welcome.msg.rig.version}, the last ack was ${last}`);
    for (const a of acked) {
      const light = a.path.split(".")[0];
      assert.equal(intensityOf(welcome.msg.rig, light), a.value, `the welcome's rig: ${a.path}`);
      const shown = await shownIntensity(light);
      assert.equal(shown.rig, a.value, `the page's rig: ${a.path} is ${shown.rig}`);
      assert.equal(shown.field, a.value, `the page's panel shows ${a.path} as ${shown.field}`);
    }
    await frameAtLeast(last);
    // Through the router: answered by the other node, which has the edits in its rig and history.
    const { json: rig, node: rigNode } = await viaRouter("rig");
    assert.equal(rigNode, survivor, "GET rig after the kill");
    for (const a of acked) assert.equal(intensityOf(rig, a.path.split(".")[0]), a.value, `the other node's rig: ${a.path}`);
    const { json: history } = await viaRouter("history");
    for (const a of acked) {
      const e = history.entries.find((x) => x.version === a.version);
      assert.ok(e?.changes?.some((c) => c.path === a.path && c.value === a.value), `history at version ${a.version}: ${JSON.stringify(e)}`);
    }
  });

  step("a further edit in the page is acknowledged by the other node and reaches its rig", async () => {
    const version = await editIntensity("key", 3.5);
    acked.push({ path: "key.intensity", value: 3.5, version });
    assert.ok(version > Math.max(...acked.slice(0, -1).map((a) => a.version)), `the new edit's version ${version}`);
    const { json: rig, node } = await viaRouter("rig");
    assert.equal(node, survivor, "GET rig after the further edit");
    assert.equal(intensityOf(rig, "key"), 3.5, "the server's rig lacks the further edit");
    assert.equal(intensityOf(rig, "fill"), 1.5, "the fill's edit before the kill");
    assert.equal(rig.version, version, "the rig is at the ack's version");
    await frameAtLeast(version);
    const info = await viaRouter("");
    assert.equal(info.node, survivor);
    assert.equal(info.json.rigVersion, version);
    assert.deepEqual(pageErrors, [], "uncaught errors in the page");
  });
});
