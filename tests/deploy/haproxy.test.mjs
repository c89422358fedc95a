// The router's config in deploy/k8s/router.yaml (its ConfigMap's haproxy.cfg) passes haproxy -c of
// Debian 12's HAProxy 2.6 (the branch of the router's image) without a warning. The resolvers are
// read from this machine's /etc/resolv.conf; nothing is resolved: the servers start without an
// address (init-addr none). scripts/fleet --check-config does the same for deploy/haproxy's
// template.
import { test } from "node:test";
import assert from "node:assert/strict";
import { spawnSync } from "node:child_process";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { fileURLToPath } from "node:url";

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), "../..");
let YAML;
try {
    YAML = await import("yaml");
} catch (e) {
    console.error(`tests/deploy: its npm packages are missing (scripts/setup runs npm ci in tests/deploy): ${e.message}`);
    process.exit(1);
}

test("haproxy -c accepts the router ConfigMap's haproxy.cfg without warnings", () => {
    const docs = YAML.parseAllDocuments(fs.readFileSync(path.join(root, "deploy/k8s/router.yaml"), "utf8")).map((d) => d.toJS());
    const cm = docs.find((d) => d?.kind === "ConfigMap" && d.metadata.name === "dfb-router");
    assert.ok(cm?.data?.["haproxy.cfg"], "router.yaml: ConfigMap dfb-router with haproxy.cfg");
    const file = path.join(fs.mkdtempSync(path.join(os.tmpdir(), "dfb-router-")), "haproxy.cfg");
    fs.writeFileSync(file, cm.data["haproxy.cfg"]);
    const r = spawnSync("haproxy", ["-c", "-f", file], { encoding: "utf8" });
    fs.rmSync(path.dirname(file), { recursive: true, force: true });
    assert.ok(!r.error, `haproxy cannot run (scripts/setup installs Debian's haproxy): ${r.error?.message}`);
    const out = r.stdout + r.stderr;
    assert.equal(r.status, 0, out);
    assert.match(out, /Configuration file is valid/);
    assert.doesNotMatch(out, /\[WARNING\]|\[ALERT\]/, out);
});
