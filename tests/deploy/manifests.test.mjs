// deploy/k8s and deploy/Containerfile (issue 21): every Kubernetes object is built with its
// kubernetes-models class and validated against the Kubernetes OpenAPI schema, fields the schema
// does not know included (a misspelt "livenesProbe" is otherwise silently dropped by the API
// server); then the deployment's own rules: GPU request, probes, shared volume, consistent-hash
// router, Indexed bake Job whose script is run against a stand-in dfb-bake, and an image whose
// paths and user match.
//
//   node --test tests/deploy/manifests.test.mjs
// env DFB_SERVER_EXE, DFB_BAKE_EXE: the built programs, whose --help lists the flags the manifests
// may use (CTest sets them).
import { test } from "node:test";
import assert from "node:assert/strict";
import { spawnSync } from "node:child_process";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { fileURLToPath } from "node:url";

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), "../..");
const k8sDir = path.join(root, "deploy/k8s");

let YAML, models;
try {
    YAML = await import("yaml");
    models = {
        v1: await import("kubernetes-models/v1"),
        "apps/v1": await import("kubernetes-models/apps/v1"),
        "batch/v1": await import("kubernetes-models/batch/v1"),
        "policy/v1": await import("kubernetes-models/policy/v1"),
    };
} catch (e) {
    console.error(`tests/deploy: its npm packages are missing (scripts/setup runs npm ci in tests/deploy): ${e.message}`);
    process.exit(1);
}

// Every document of every deploy/k8s/*.yaml: {file, doc}.
const documents = [];
for (const file of fs.readdirSync(k8sDir).filter((f) => f.endsWith(".yaml")).sort()) {
    for (const d of YAML.parseAllDocuments(fs.readFileSync(path.join(k8sDir, file), "utf8"))) {
        assert.equal(d.errors.length, 0, `${file}: ${d.errors.map((e) => e.message).join("; ")}`);
        const doc = d.toJS();
        if (doc !== null) documents.push({ file, doc });
    }
}
const objects = documents.filter(({ doc }) => doc.kind !== "Kustomization");
const find = (kind, name) => {
    const found = objects.filter(({ doc }) => doc.kind === kind && doc.metadata?.name === name);
    assert.equal(found.length, 1, `exactly one ${kind} ${name} in deploy/k8s (found ${found.length})`);
    return found[0].doc;
};

// Runs the class's schema validation on a proxy of the object that records which properties the
// generated validator reads; a property it never reads is one the schema does not define. (A map
// such as labels or ConfigMap data is iterated, which counts as reading all of it.)
function unknownFields(Model, data) {
    const info = new Map(); // target -> {path, read, all}
    const proxies = new WeakMap();
    const wrap = (value, where) => {
        if (value === null || typeof value !== "object") return value;
        if (proxies.has(value)) return proxies.get(value);
        const entry = { path: where, read: new Set(), all: false };
        info.set(value, entry);
        const p = new Proxy(value, {
            get(t, k, r) {
                const v = Reflect.get(t, k, r);
                if (typeof k !== "string") return v;
                entry.read.add(k);
                return wrap(v, Array.isArray(t) ? `${where}[${k}]` : `${where}.${k}`);
            },
            has(t, k) {
                if (typeof k === "string") entry.read.add(k);
                return Reflect.has(t, k);
            },
            ownKeys(t) {
                entry.all = true;
                return Reflect.ownKeys(t);
            },
        });
        proxies.set(value, p);
        return p;
    };
    Model.prototype.validate.call(wrap(structuredClone(data), ""));
    const unknown = [];
    for (const [target, entry] of info) {
        if (Array.isArray(target) || entry.all) continue;
        for (const k of Object.keys(target)) if (!entry.read.has(k)) unknown.push(`${entry.path}.${k}`.replace(/^\./, ""));
    }
    return unknown;
}

test("every object is a known kind that validates against the Kubernetes schema, with no unknown field", () => {
    assert.ok(objects.length >= 10, `deploy/k8s holds ${objects.length} objects`);
    for (const { file, doc } of objects) {
        const where = `${file}: ${doc.kind} ${doc.metadata?.name}`;
        const Model = models[doc.apiVersion]?.[doc.kind];
        assert.ok(Model, `${where}: no kubernetes-models class for ${doc.apiVersion} ${doc.kind}`);
        const object = new Model(doc);
        assert.doesNotThrow(() => object.validate(), (e) => assert.fail(`${where}: ${e.message}`));
        assert.deepEqual(unknownFields(Model, doc), [], `${where}: fields the schema does not define`);
        if (doc.kind !== "Namespace") assert.equal(doc.metadata.namespace, "dfb", `${where}: namespace`);
    }
});

test("the unknown-field check finds a misspelt field (it would otherwise prove nothing)", () => {
    const d = structuredClone(find("Deployment", "dfb-node"));
    const c = d.spec.template.spec.containers[0];
    c.livenesProbe = c.livenessProbe;
    assert.doesNotThrow(() => new models["apps/v1"].Deployment(d).validate());
    assert.deepEqual(unknownFields(models["apps/v1"].Deployment, d), ["spec.template.spec.containers[0].livenesProbe"]);
});

test("kustomization.yaml lists every manifest but the bake Job, and files that exist", () => {
    const k = documents.find(({ doc }) => doc.kind === "Kustomization")?.doc;
    assert.ok(k, "deploy/k8s/kustomization.yaml");
    const expected = [...new Set(objects.map(({ file }) => file))].filter((f) => f !== "bake-job.yaml").sort();
    assert.deepEqual([...k.resources].sort(), expected);
});

const container = (deployment) => deployment.spec.template.spec.containers[0];
const envOf = (c) => Object.fromEntries((c.env ?? []).map((e) => [e.name, e.value ?? e.valueFrom]));
const portOf = (c, name) => c.ports.find((p) => p.name === name)?.containerPort;

test("GPU nodes: one NVIDIA GPU each, EGL device platform, the driver's graphics libraries", () => {
    const c = container(find("Deployment", "dfb-node"));
    assert.equal(Number(c.resources.limits["nvidia.com/gpu"]), 1);
    assert.equal(envOf(c).DFB_EGL_PLATFORM, "device");
    assert.match(envOf(c).NVIDIA_DRIVER_CAPABILITIES, /(^|,)graphics(,|$)/);
});

test("nodes: liveness on /healthz, readiness on /readyz, time to drain, the shared volume and tokens", () => {
    for (const name of ["dfb-node", "dfb-node-cpu"]) {
        const d = find("Deployment", name);
        const pod = d.spec.template.spec;
        const c = container(d);
        const http = portOf(c, "http");
        assert.equal(http, 8080, `${name}: container port http`);
        const probePort = (probe) => (probe.httpGet.port === "http" ? http : probe.httpGet.port);
        assert.equal(c.livenessProbe.httpGet.path, "/healthz", `${name}: liveness`);
        assert.equal(c.readinessProbe.httpGet.path, "/readyz", `${name}: readiness`);
        assert.equal(c.startupProbe.httpGet.path, "/healthz", `${name}: startup`);
        for (const p of [c.livenessProbe, c.readinessProbe, c.startupProbe]) assert.equal(probePort(p), http, `${name}: probe port`);
        assert.ok(pod.terminationGracePeriodSeconds >= 60, `${name}: terminationGracePeriodSeconds ${pod.terminationGracePeriodSeconds}`);
        const args = Object.fromEntries(c.args.map((a) => a.replace(/^--/, "").split(/=(.*)/s).slice(0, 2)));
        assert.equal(args.port, String(http), `${name}: --port`);
        assert.equal(args.bind, "0.0.0.0", `${name}: --bind`);
        assert.equal(args.node, "$(POD_NAME)", `${name}: --node`);
        assert.deepEqual(envOf(c).POD_NAME, { fieldRef: { fieldPath: "metadata.name" } }, `${name}: POD_NAME`);
        // The shared volume: the claim, mounted where --sessions and --state point.
        const shared = pod.volumes.find((v) => v.persistentVolumeClaim);
        assert.equal(shared.persistentVolumeClaim.claimName, "dfb-shared", `${name}: claim`);
        const mount = c.volumeMounts.find((m) => m.name === shared.name).mountPath;
        assert.equal(args.sessions, `${mount}/sessions`, `${name}: --sessions`);
        assert.equal(args.state, `${mount}/state`, `${name}: --state`);
        assert.ok(pod.initContainers[0].command.join(" ").includes(args.sessions), `${name}: the init container makes ${args.sessions}`);
        // The tokens file: the Secret's key, mounted where --tokens points.
        const tokens = pod.volumes.find((v) => v.secret);
        assert.equal(tokens.secret.secretName, "dfb-tokens", `${name}: tokens secret`);
        const tokensMount = c.volumeMounts.find((m) => m.name === tokens.name).mountPath;
        assert.ok(Object.hasOwn(find("Secret", "dfb-tokens").stringData, path.basename(args.tokens)), `${name}: --tokens key`);
        assert.equal(path.dirname(args.tokens), tokensMount, `${name}: --tokens mount`);
        // Readable by the server's user through fsGroup.
        assert.equal(tokens.secret.defaultMode & 0o040, 0o040, `${name}: the tokens file is readable by the group`);
        assert.equal(pod.securityContext.fsGroup, pod.securityContext.runAsGroup, `${name}: fsGroup`);
    }
});

test("the CPU nodes are the GPU nodes' pod but for resources, EGL platform and GPU tolerations", () => {
    const strip = (d) => {
        const t = structuredClone(d.spec.template);
        delete t.metadata.labels["app.kubernetes.io/component"];
        delete t.spec.tolerations;
        const c = t.spec.containers[0];
        delete c.resources;
        c.env = c.env.filter((e) => !["DFB_EGL_PLATFORM", "NVIDIA_DRIVER_CAPABILITIES"].includes(e.name));
        return t;
    };
    const gpu = find("Deployment", "dfb-node"), cpu = find("Deployment", "dfb-node-cpu");
    assert.deepEqual(strip(cpu), strip(gpu));
    assert.equal(container(cpu).resources.limits?.["nvidia.com/gpu"], undefined);
    assert.equal(envOf(container(cpu)).DFB_EGL_PLATFORM, "surfaceless");
});

test("the headless Service lists the pods of both node deployments, as the router's SRV name says", () => {
    const s = find("Service", "dfb-node");
    assert.equal(s.spec.clusterIP, "None");
    for (const name of ["dfb-node", "dfb-node-cpu"]) {
        const labels = find("Deployment", name).spec.template.metadata.labels;
        for (const [k, v] of Object.entries(s.spec.selector)) assert.equal(labels[k], v, `${name}: selector ${k}`);
    }
    const port = s.spec.ports.find((p) => p.name === "http");
    assert.equal(port.protocol, "TCP");
    assert.equal(port.targetPort, "http");
    const cfg = find("ConfigMap", "dfb-router").data["haproxy.cfg"];
    const srv = `_${port.name}._tcp.${s.metadata.name}.${s.metadata.namespace}.svc.cluster.local`;
    assert.match(cfg, new RegExp(`^\\s*server-template \\S+ \\d+ ${srv.replace(/\./g, "\\.")} resolvers (\\S+)`, "m"));
    const pdb = find("PodDisruptionBudget", "dfb-node");
    assert.deepEqual(pdb.spec.selector.matchLabels, s.spec.selector);
});

test("the shared volume is ReadWriteMany, and every claim used exists", () => {
    assert.deepEqual(find("PersistentVolumeClaim", "dfb-shared").spec.accessModes, ["ReadWriteMany"]);
    for (const { doc } of objects) {
        const pod = doc.spec?.template?.spec;
        for (const v of pod?.volumes ?? []) {
            if (v.persistentVolumeClaim) find("PersistentVolumeClaim", v.persistentVolumeClaim.claimName);
            if (v.configMap) find("ConfigMap", v.configMap.name);
            if (v.secret) find("Secret", v.secret.secretName);
        }
    }
});

test("the tokens Secret is a token file dfb-server accepts", () => {
    const t = JSON.parse(find("Secret", "dfb-tokens").stringData["tokens.json"]);
    assert.equal(typeof t.sessions, "object");
    for (const [name, tk] of Object.entries(t.sessions)) {
        assert.match(name, /^[A-Za-z0-9_-]{1,64}$/);
        for (const role of ["editor", "viewer"]) assert.match(tk[role], /^[A-Za-z0-9._~-]{16,256}$/, `${name}.${role}`);
        assert.notEqual(tk.editor, tk.viewer);
    }
});

// The lines between "routing: begin" and "routing: end", without indentation.
const routing = (text, where) => {
    const lines = text.split("\n").map((l) => l.trim());
    const b = lines.indexOf("# routing: begin"), e = lines.indexOf("# routing: end");
    assert.ok(b >= 0 && e > b, `${where}: routing: begin / end markers`);
    return lines.slice(b, e + 1);
};

test("the router hashes consistently on the session id, as deploy/haproxy's template does", () => {
    const cfg = find("ConfigMap", "dfb-router").data["haproxy.cfg"];
    assert.match(cfg, /^\s*hash-type consistent\b/m);
    assert.match(cfg, /^\s*balance hash var\(txn\.sid\)/m);
    assert.match(cfg, /^\s*option httpchk GET \/readyz$/m);
    assert.match(cfg, /^\s*timeout tunnel \d+[hm]\b/m);
    const resolvers = cfg.match(/^\s*server-template .* resolvers (\S+)/m)[1];
    assert.match(cfg, new RegExp(`^resolvers ${resolvers}$`, "m"), "the resolvers section the servers use");
    const template = fs.readFileSync(path.join(root, "deploy/haproxy/haproxy.cfg.tmpl"), "utf8");
    assert.deepEqual(routing(cfg, "router.yaml"), routing(template, "haproxy.cfg.tmpl"));
});

test("one router, reading the ConfigMap where the image looks, behind a Service on its port", () => {
    const d = find("Deployment", "dfb-router");
    // Two routers could place the nodes in different server slots, so hash sessions differently.
    assert.equal(d.spec.replicas, 1);
    const pod = d.spec.template.spec, c = container(d);
    const config = pod.volumes.find((v) => v.configMap?.name === "dfb-router");
    assert.equal(c.volumeMounts.find((m) => m.name === config.name).mountPath, "/usr/local/etc/haproxy");
    assert.match(c.image, /^haproxy:2\.6(\.|$)/);
    const cfg = find("ConfigMap", "dfb-router").data["haproxy.cfg"];
    const bind = Number(cfg.match(/^frontend dfb\n(?:.*\n)*?\s*bind :(\d+)/m)[1]);
    assert.equal(portOf(c, "http"), bind);
    const s = find("Service", "dfb-router");
    assert.equal(s.spec.ports.find((p) => p.name === "http").targetPort, "http");
    for (const [k, v] of Object.entries(s.spec.selector)) assert.equal(d.spec.template.metadata.labels[k], v, `selector ${k}`);
    const probe = Number(cfg.match(/^frontend stats\n\s*bind :(\d+)/m)[1]);
    assert.equal(portOf(c, "stats"), probe);
    assert.equal(c.livenessProbe.httpGet.path, cfg.match(/monitor-uri (\S+)/)[1]);
});

// The non-comment, non-blank lines of the bake list.
const shots = () => find("ConfigMap", "dfb-bake-shots").data.shots.split("\n").filter((l) => l.trim() && !l.trim().startsWith("#"));

test("the bake Job is Indexed, one index per listed shot, retried per shot", () => {
    const j = find("Job", "dfb-bake");
    assert.equal(j.spec.completionMode, "Indexed");
    assert.equal(j.spec.completions, shots().length, "completions = shots listed");
    assert.ok(j.spec.backoffLimitPerIndex >= 1 || j.spec.backoffLimit >= 1, "failed shots are retried");
    const pod = j.spec.template.spec;
    assert.equal(pod.restartPolicy, "Never");
    const c = pod.containers[0];
    for (const r of j.spec.podFailurePolicy?.rules ?? []) if (r.onExitCodes) assert.equal(r.onExitCodes.containerName, c.name);
    // The command is the ConfigMap's script where the ConfigMap is mounted.
    const list = pod.volumes.find((v) => v.configMap?.name === "dfb-bake-shots");
    const at = c.volumeMounts.find((m) => m.name === list.name).mountPath;
    assert.deepEqual(c.command, ["/bin/bash", `${at}/bake-shot`]);
    const shared = pod.volumes.find((v) => v.persistentVolumeClaim?.claimName === "dfb-shared");
    assert.equal(c.volumeMounts.find((m) => m.name === shared.name).mountPath, "/shared");
    assert.equal(Number(c.resources.limits["nvidia.com/gpu"]), 1);
});

// Runs the Job's script with a stand-in dfb-bake that records its arguments.
function runBakeShot(index) {
    const dir = fs.mkdtempSync(path.join(os.tmpdir(), "dfb-bake-shot-"));
    const data = find("ConfigMap", "dfb-bake-shots").data;
    fs.writeFileSync(path.join(dir, "shots"), data.shots);
    fs.writeFileSync(path.join(dir, "bake-shot"), data["bake-shot"]);
    fs.writeFileSync(path.join(dir, "fake-bake"), `#!/bin/sh\nprintf '%s\\n' "$@" > "${dir}/args"\n`, { mode: 0o755 });
    const r = spawnSync("bash", [path.join(dir, "bake-shot")], {
        encoding: "utf8",
        env: { ...process.env, JOB_COMPLETION_INDEX: String(index), DFB_SHOTS: path.join(dir, "shots"),
               DFB_SESSIONS: path.join(dir, "sessions"), DFB_BAKE: path.join(dir, "fake-bake") },
    });
    const args = fs.existsSync(path.join(dir, "args")) ? fs.readFileSync(path.join(dir, "args"), "utf8").trimEnd().split("\n") : null;
    fs.rmSync(dir, { recursive: true, force: true });
    return { status: r.status, stderr: r.stderr, args, dir };
}

test("the bake script bakes its index's shot with dfb-bake flags that exist, and refuses a missing one", () => {
    const list = shots();
    for (let i = 0; i < list.length; ++i) {
        const [name, scene, width, height, samples, camera] = list[i].trim().split(/\s+/);
        const r = runBakeShot(i);
        assert.equal(r.status, 0, `shot ${i}: ${r.stderr}`);
        const expected = [`/shared/scenes/${scene}`, "-o", `${r.dir}/sessions/${name}.exr`, "--width", width, "--height", height,
                          "--samples", samples, ...(camera ? ["--camera", camera] : [])];
        assert.deepEqual(r.args, expected, `shot ${i}`);
    }
    assert.ok(list.some((l) => l.trim().split(/\s+/).length === 6), "one listed shot names a camera (so --camera is checked)");
    const missing = runBakeShot(list.length);
    assert.notEqual(missing.status, 0);
    assert.equal(missing.args, null);
    assert.match(missing.stderr, new RegExp(`has no shot ${list.length}`));
    // Every flag the script passes is one dfb-bake takes.
    const bake = process.env.DFB_BAKE_EXE;
    assert.ok(bake && fs.existsSync(bake), `DFB_BAKE_EXE (the built dfb-bake) is set and exists: ${bake}`);
    const help = spawnSync(bake, ["--help"], { encoding: "utf8" }).stdout;
    for (const flag of ["-o", "--width", "--height", "--samples", "--camera"]) assert.match(help, new RegExp(`(^|[ ,])${flag}[ ,]`, "m"), flag);
});

test("the bake script passes shellcheck", () => {
    const file = path.join(os.tmpdir(), `dfb-bake-shot-${process.pid}.sh`);
    fs.writeFileSync(file, find("ConfigMap", "dfb-bake-shots").data["bake-shot"]);
    const r = spawnSync("shellcheck", [file], { encoding: "utf8" });
    fs.rmSync(file);
    assert.ok(!r.error, `shellcheck cannot run (scripts/setup installs it): ${r.error?.message}`);
    assert.equal(r.status, 0, r.stdout);
});

test("the nodes' flags are dfb-server's", () => {
    const server = process.env.DFB_SERVER_EXE;
    assert.ok(server && fs.existsSync(server), `DFB_SERVER_EXE (the built dfb-server) is set and exists: ${server}`);
    const help = spawnSync(server, ["--help"], { encoding: "utf8" }).stdout;
    for (const a of container(find("Deployment", "dfb-node")).args) {
        const flag = a.split("=")[0];
        assert.match(help, new RegExp(`(^|[ ,])${flag}[ =]`, "m"), flag);
    }
});

test("deploy/Containerfile: its sources exist, its user and port are the manifests'", () => {
    const text = fs.readFileSync(path.join(root, "deploy/Containerfile"), "utf8").replace(/\\\n/g, " ");
    const copies = text.split("\n").filter((l) => /^COPY /.test(l) && !/--from=/.test(l));
    assert.ok(copies.length >= 5);
    for (const l of copies) {
        for (const src of l.trim().split(/\s+/).slice(1, -1)) assert.ok(fs.existsSync(path.join(root, src)), `COPY ${src}: not in the repository`);
    }
    const uid = Number(text.match(/useradd [^\n]*--uid (\d+)/)[1]);
    assert.match(text, new RegExp(`^USER ${uid}$`, "m"));
    for (const { doc } of objects) {
        const sc = doc.spec?.template?.spec?.securityContext;
        if (doc.spec?.template?.spec?.containers?.[0]?.image?.startsWith("dfb:")) assert.equal(sc.runAsUser, uid, `${doc.kind} ${doc.metadata.name}: runAsUser`);
    }
    assert.match(text, /^EXPOSE 8080$/m);
    assert.match(text, /^ENTRYPOINT \["dfb-server"\]$/m);
    // The programs the manifests run are in the image.
    for (const p of ["dfb-server", "dfb-bake"]) assert.match(text, new RegExp(`cp [^\\n]*/${p} `), p);
    // The build stage takes its packages from scripts/setup, not from a list of its own.
    assert.match(text, /scripts\/setup --build/);
    assert.match(text, /scripts\/setup --runtime/);
    assert.doesNotMatch(text, /apt-get install/);
});
