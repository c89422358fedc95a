// dfb-client: command-line client of dfb-server (protocol v1, docs/protocol.md).
//
//   dfb-client sessions | info | rig get|put | set | apply | frame | export | final | watch | pick | drag | undo | redo |
//              bench | properties
//
// Every subcommand takes --server URL (the links dfb-server prints carry the session and the
// token), --session ID, --token T and --timeout S; DFB_SERVER, DFB_SESSION and DFB_TOKEN are the
// defaults. Exit codes: Client.h EXIT_* (listed in --help's footer and docs/operations.md).

#include "Bench.h"
#include "Client.h"
#include "Connection.h"

#include <dfb/core/Version.h>
#include <dfb/core/Stats.h>
#include <dfb/protocol/DragModes.h>
#include <dfb/protocol/Messages.h>
#include <dfb/protocol/Schema.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

using namespace dfb;
using namespace dfb::cli;
using json = nlohmann::json;

namespace {

std::string readFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) die(EXIT_FILE, "cannot read " + path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

void writeFile(const std::string& path, const void* data, size_t size) {
    std::ofstream out(path, std::ios::binary);
    out.write(static_cast<const char*>(data), std::streamsize(size));
    out.close();
    if (!out) die(EXIT_FILE, "cannot write " + path);
}

/// View settings given on the command line (frame, watch).
struct ViewArgs {
    std::string output = "beauty", format, viewTransform = "rig";
    int quality = 85;
    double exposure = 0;
    void add(CLI::App* c) {
        c->add_option("--output", output, "beauty, light:NAME (one light alone), shadow:NAME (its shadow mask) or layer:NAME "
                                          "(a G-buffer layer: P, N, albedo, ...); a beauty EXR holds one float layer per light");
        c->add_option("--format", format, "jpeg, png or exr (default: from the file name, else jpeg)")->check(CLI::IsMember({"jpeg", "png", "exr"}));
        c->add_option("--quality", quality, "JPEG quality")->check(CLI::Range(1, 100));
        c->add_option("--exposure", exposure, "stops added to the rig's exposure")->check(CLI::Range(-20.0, 20.0));
        c->add_option("--view-transform", viewTransform, "rig (the rig's), srgb or filmic")->check(CLI::IsMember({"rig", "srgb", "filmic"}));
    }
    /// The format of `path`: its extension (.jpg/.jpeg, .png, .exr) or --format; refused (exit 1)
    /// when the extension is another or disagrees with --format (`frame out.tif` wrote JPEG bytes).
    std::string formatFor(const std::string& path) const {
        const std::string ext = std::filesystem::path(path).extension().string();
        std::string byName;
        if (ext == ".jpg" || ext == ".jpeg") byName = "jpeg";
        else if (ext == ".png") byName = "png";
        else if (ext == ".exr") byName = "exr";
        else if (!ext.empty()) die(EXIT_USAGE, path + ": cannot write '" + ext + "' files: name it .jpg, .png or .exr");
        if (!format.empty() && !byName.empty() && format != byName) {
            die(EXIT_USAGE, path + ": the name says " + byName + " but --format says " + format);
        }
        return !byName.empty() ? byName : !format.empty() ? format : "jpeg";
    }
    json settings(const std::string& fmt) const {
        return json{{"output", output}, {"encoding", fmt}, {"quality", quality}, {"exposure", exposure}, {"viewTransform", viewTransform}};
    }
};

std::string urlEncode(const std::string& s) {
    std::string out;
    for (unsigned char c : s) {
        if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') out += char(c);
        else {
            char buf[4];
            std::snprintf(buf, sizeof buf, "%%%02X", c);
            out += buf;
        }
    }
    return out;
}

// ---- human-readable answers ------------------------------------------------------------------
// What the subcommands print unless --json is given (then: the server's JSON as it sent it).

// "key.intensity = 66, key.position = [1,4,2]" (the first few of many).
std::string changesText(const json& changes) {
    if (!changes.is_array()) return "";
    std::string out;
    size_t n = 0;
    for (const json& c : changes) {
        if (n == 6) {
            out += ", ... (" + std::to_string(changes.size()) + " changes)";
            break;
        }
        out += (n++ ? ", " : "") + c.value("path", std::string("?")) + " = " + (c.contains("value") ? c["value"].dump() : "?");
    }
    return out;
}

std::string str(const json& j, const char* key, const std::string& fallback = "") {
    return j.is_object() && j.contains(key) ? (j[key].is_string() ? j[key].get<std::string>() : j[key].dump()) : fallback;
}

std::string clientText(const json& c) {
    std::string t = str(c, "name", "?") + " (" + str(c, "role", "?");
    if (c.contains("editing") && c["editing"].is_string()) t += ", editing " + c["editing"].get<std::string>();
    return t + ")";
}

std::string clientsText(const json& clients) {
    std::string out;
    if (clients.is_array()) {
        for (const json& c : clients) out += (out.empty() ? "" : ", ") + clientText(c);
    }
    return out.empty() ? "none" : out;
}

std::string changeMessageText(const json& m) {
    std::string t = "rig version " + str(m, "rigVersion", "?") + " by " + str(m, "byName", "?") + " (" + str(m, "kind", "?") + ")";
    if (m.contains("changes")) t += ": " + changesText(m["changes"]);
    return t;
}

std::string finalText(const json& m) {
    std::string t = "final render: " + str(m, "state", "?");
    if (m.contains("rigVersion")) t += ", rig version " + str(m, "rigVersion");
    if (m.contains("samples") && m["samples"].is_array() && m["samples"].size() == 2) {
        t += ", " + m["samples"][0].dump() + "/" + m["samples"][1].dump() + " samples";
    }
    if (m.contains("seconds")) t += ", " + str(m, "seconds") + " s";
    if (m.contains("error")) t += ": " + str(m, "error");
    return t;
}

// One line per message of `watch` (docs/protocol.md names them).
std::string messageText(const json& m) {
    const std::string type = str(m, "type");
    if (type == "change") return "change: " + changeMessageText(m);
    if (type == "presence") return "presence: " + clientsText(m["clients"]);
    if (type == "ack") return "ack " + str(m, "seq", "?") + ": rig version " + str(m, "rigVersion", "?");
    if (type == "final") return finalText(m);
    if (type == "drag") return "drag: " + str(m, "state", "?");
    if (type == "library") {
        return "library: " + std::to_string(m.value("snapshots", json::array()).size()) + " snapshots, " +
               std::to_string(m.value("rigs", json::array()).size()) + " saved rigs";
    }
    return type + ": " + m.dump();
}

// The answer of an edit (set, apply, rig put, undo, redo, drag).
void printEditAnswer(const json& a) {
    std::cout << "rig version " << str(a, "rigVersion", "?");
    if (a.contains("kind")) std::cout << " (" << str(a, "kind") << ")";
    std::cout << "\n";
    for (const json& o : a.value("overwrote", json::array())) {
        std::cout << "overwrote " << str(o, "path", "?") << " of rig version " << str(o, "version", "?") << " (client " << str(o, "by", "?") << ")\n";
    }
    // An edit that would have folded a BendyLight's tube was limited (docs/protocol.md).
    for (const json& l : a.value("limited", json::array())) std::cout << "limited " << str(l, "message", "?") << "\n";
    if (a.contains("drag")) std::cout << "drag: " << a["drag"].dump() << "\n";
}

void printSessions(const json& j) {
    for (const json& s : j.value("sessions", json::array())) {
        if (str(s, "state") == "failed") {
            std::cout << str(s, "id") << "  " << str(s, "role") << "  failed: " << str(s, "error") << "\n";
            continue;
        }
        std::cout << str(s, "id") << "  " << str(s, "role") << "  " << str(s, "width") << "x" << str(s, "height") << "  rig version "
                  << str(s, "rigVersion") << "  " << str(s, "clients") << " client(s)  " << str(s, "shot") << "\n";
    }
}

void printInfo(const json& j) {
    const json& d = j.contains("session") ? j["session"] : json::object();
    std::cout << "session " << str(j, "id") << " (you: " << str(j, "role") << "), rig version " << str(j, "rigVersion") << ", undo "
              << str(j["history"], "undo", "0") << " / redo " << str(j["history"], "redo", "0")
              << (j.value("persistent", false) ? ", journaled" : ", not journaled") << "\n";
    std::cout << "shot " << str(d, "shot") << " (" << str(d, "width") << "x" << str(d, "height") << ", scene " << str(d, "source", "?")
              << ", camera " << str(d.contains("camera") ? d["camera"] : json(), "name", "?") << ")\n";
    std::string objects;
    for (const json& o : d.value("objects", json::array())) objects += (objects.empty() ? "" : ", ") + o.get<std::string>();
    std::cout << "objects: " << (objects.empty() ? "none" : objects) << "\n";
    std::cout << "clients: " << clientsText(j["clients"]) << "\n";
}

void printPick(const json& j) {
    std::cout << "pixel (" << str(j, "x") << ", " << str(j, "y") << "): ";
    if (!j.value("hit", false)) {
        std::cout << "background\n";
        return;
    }
    std::cout << "object " << str(j, "object", "?") << " (id " << str(j, "objectId", "?") << ") at " << str(j, "position") << ", normal "
              << str(j, "normal") << "\n";
    std::string lights;
    for (const json& l : j.value("lights", json::array())) lights += (lights.empty() ? "" : ", ") + str(l, "name") + " " + str(l, "radiance");
    std::cout << "lights: " << (lights.empty() ? "none reach it" : lights) << "\n";
}

void printHistory(const json& j) {
    const json& entries = j.value("entries", json::array());
    for (const json& e : entries) {
        std::cout << "v" << str(e, "version", "?") << "  " << str(e, "kind", "?") << " by " << str(e, "byName", "?");
        if (e.contains("changes")) std::cout << ": " << changesText(e["changes"]);
        std::cout << "\n";
    }
    std::cout << entries.size() << " change(s); rig version " << str(j, "rigVersion", "?") << "\n";
}

// Prints the answer `body`: verbatim with --json, else through `human` (verbatim too when the
// answer is not the JSON expected).
template <typename F> void printAnswer(const std::string& body, bool asJson, F human) {
    auto parsed = protocol::parseJson(body, 256u << 20, "the answer");
    if (asJson || !parsed || !parsed.value().is_object()) {
        std::cout << body << std::endl;
        return;
    }
    human(parsed.value());
    std::cout.flush();
}

// ---- properties ------------------------------------------------------------------------------
// The rig schema as a table: what `set` accepts (protocol/Schema.h is the one source).
void printProperties(bool asJson) {
    if (asJson) {
        std::cout << protocol::schemaJson().dump(2) << std::endl;
        return;
    }
    auto range = [](const protocol::Property& p) -> std::string {
        if (*p.values) return p.values;
        if (p.min == 0 && p.max == 0) return "";
        return "[" + json(p.min).dump() + ", " + json(p.max).dump() + "]";
    };
    std::printf("%-22s %-10s %-26s %-22s %s\n", "PATH", "TYPE", "RANGE", "UNIT", "A CHANGE RE-RENDERS");
    for (const auto& p : protocol::rigProperties()) {
        std::printf("%-22s %-10s %-26s %-22s %s\n", p.path, std::string(protocol::toString(p.type)).c_str(), range(p).c_str(), p.unit,
                    std::string(protocol::toString(p.invalidates)).c_str());
    }
    for (const auto& p : protocol::lightProperties()) {
        if (p.readOnly) continue;
        std::string path = std::string("LIGHT.") + p.path;
        if (*p.indexOf) path.replace(path.find("[]"), 2, "[i]");
        std::printf("%-22s %-10s %-26s %-22s %s\n", path.c_str(), std::string(protocol::toString(p.type)).c_str(), range(p).c_str(),
                    p.unit, p.type == protocol::PropType::Keys ? "" : std::string(protocol::toString(p.invalidates)).c_str());
    }
}

// ---- final -----------------------------------------------------------------------------------
// POST .../final, then the `final` messages of the session's WebSocket until the render ends
// (docs/protocol.md "Final render"). The socket is greeted before the POST so that no message of
// this render is missed; a render of the same rig version already done answers at once.
int finalRender(Client& cl, const std::string& out, int samples, bool directOnly) {
    const std::string ext = std::filesystem::path(out).extension().string();
    if (ext != ".exr" && ext != ".png") die(EXIT_USAGE, "final: " + out + ": the file must end in .exr or .png");
    json welcome;
    auto conn = cl.connect(&welcome);
    auto post = cl.request("POST", cl.base() + "/final", json{{"samples", samples}, {"directOnly", directOnly}}.dump());
    auto parsed = protocol::parseJson(post.body, protocol::MAX_TEXT_MESSAGE_BYTES, "POST final");
    json state = parsed ? std::move(parsed.value()) : json();
    if (!state.is_object()) die(EXIT_BROKEN, "POST final: unreadable answer");
    const uint64_t version = state.value("rigVersion", uint64_t(0));
    std::cerr << "final render of rig version " << version << ", " << samples << " samples" << (directOnly ? ", direct light only" : "")
              << std::endl;
    std::string lastLine;
    auto report = [&](const json& m) {
        const std::string st = m.value("state", "");
        std::string line = "final: " + st;
        if (m.contains("samples") && m["samples"].is_array() && m["samples"].size() == 2) {
            char buf[96];
            std::snprintf(buf, sizeof buf, " %d/%d samples (%.0f %%)", m["samples"][0].get<int>(), m["samples"][1].get<int>(),
                          m.value("percent", 0.0));
            line += buf;
        }
        if (line != lastLine) std::cerr << line << std::endl;
        lastLine = line;
    };
    for (const json& n : state.value("notes", json::array())) std::cerr << "note: " << n.get<std::string>() << "\n";
    bool notesShown = state.contains("notes");
    while (state.value("state", "") == "exporting" || state.value("state", "") == "running") {
        report(state);
        auto m = conn->receive(cl.timeout());
        if (!m) {
            // Quiet for a whole --timeout (a long export or a slow sample): ask for the state
            // instead of giving up; the server ends the render at its --final-timeout.
            auto s = protocol::parseJson(cl.request("GET", cl.base() + "/final").body, protocol::MAX_TEXT_MESSAGE_BYTES, "GET final");
            if (!s || !s.value().is_object()) die(EXIT_BROKEN, "GET final: unreadable answer");
            state = std::move(s.value());
            continue;
        }
        auto* t = std::get_if<client::TextMessage>(&m.value());
        if (!t || t->json.value("type", "") != "final" || t->json.value("rigVersion", uint64_t(0)) != version) continue;
        state = t->json;
        if (!notesShown && state.contains("notes")) {
            for (const json& n : state["notes"]) std::cerr << "note: " << n.get<std::string>() << "\n";
            notesShown = true;
        }
    }
    conn->close();
    const std::string st = state.value("state", "");
    if (st == "failed") die(EXIT_REFUSED, "the final render failed: " + state.value("error", std::string("(no reason given)")));
    if (st != "done") die(EXIT_REFUSED, "the final render ended as '" + st + "'" + (st == "cancelled" ? " (DELETE .../final)" : ""));
    report(state);
    auto r = cl.request("GET", cl.base() + "/final" + ext);
    if (r.etag != "\"" + std::to_string(version) + "\"") {
        die(EXIT_REFUSED, "the session's kept final render is now of another rig version (ETag " + r.etag + "): run final again");
    }
    writeFile(out, r.body.data(), r.body.size());
    std::printf("saved %s (rig version %llu, %.1f s in Cycles)\n", out.c_str(), static_cast<unsigned long long>(version),
                state.value("seconds", 0.0));
    return EXIT_OK;
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"dfb-client: talk to a dfb-server session (protocol v1): rig, edits, frames, picks, history, benchmark"};
    app.set_version_flag("--version",
                         dfb::versionText("dfb-client") +
                             " (protocol " + std::to_string(dfb::protocol::PROTOCOL_VERSION) + ")");
    app.footer("Exit codes: 0 ok, 1 bad command line, 2 server unreachable, 3 the server refused (printed as "
               "'error CODE: message'), 4 timed out or connection lost, 5 cannot read or write a local file.\n"
               "Example: dfb-client set key.position=1,4,2 --server 'http://127.0.0.1:8080/?session=shot&token=...'");
    app.require_subcommand(1);
    app.fallthrough();
    Options opt;
    if (const char* e = std::getenv("DFB_SERVER")) opt.server = e;
    if (const char* e = std::getenv("DFB_SESSION")) opt.session = e;
    if (const char* e = std::getenv("DFB_TOKEN")) opt.token = e;
    if (const char* e = std::getenv("DFB_CA_CERT")) opt.caCert = e;
    app.add_option("--server", opt.server, "server URL; the links dfb-server prints carry ?session=ID&token=T (env DFB_SERVER)");
    app.add_option("--session", opt.session, "session id (env DFB_SESSION; default: the only one the token opens)");
    app.add_option("--token", opt.token, "editor or viewer token (env DFB_TOKEN)");
    app.add_option("--ca-cert", opt.caCert, "PEM certificate(s) to trust for an https:// server besides the system's, e.g. its "
                                            "self-signed one (env DFB_CA_CERT)");
    app.add_option("--timeout", opt.timeoutS, "seconds to wait for each answer (watch: how long the server may stay silent, "
                                              "answers to pings included, before the connection counts as lost)")
        ->check(CLI::Range(0.1, 3600.0));
    app.add_option("--retry", opt.retryS, "seconds to keep retrying while a session moves to another node of a fleet (the node "
                                          "answers 503 moved, the router 502/503; watch: the connection closed): 0 = never")
        ->check(CLI::Range(0.0, 3600.0))
        ->capture_default_str();
    app.add_option("--name", opt.name, "your name: the author of your edits in the history, shown to the other clients (default: "
                                       "the login name)");
    bool asJson = false;
    app.add_flag("--json", asJson, "print the server's JSON answers (machine-readable) instead of text; watch: one JSON object per "
                                   "message and frame, its own lines on stderr");

    auto* cSessions = app.add_subcommand("sessions", "list the sessions the token opens");
    auto* cInfo = app.add_subcommand("info", "the session: shot, camera, objects, rig version, clients");
    auto* cRig = app.add_subcommand("rig", "read or replace the whole rig");
    cRig->require_subcommand(1);
    auto* cRigGet = cRig->add_subcommand("get", "print the rig (always JSON: the document rig put reads), or save it with -o");
    std::string rigOut;
    cRigGet->add_option("-o,--out", rigOut, "write the rig to this file");
    auto* cRigPut = cRig->add_subcommand("put", "replace the rig with a JSON file (editor)");
    std::string rigIn;
    uint64_t ifMatch = 0;
    cRigPut->add_option("file", rigIn, "rig JSON (as rig get prints it)")->required();
    auto* ifMatchOpt = cRigPut->add_option("--if-match", ifMatch, "refuse unless the rig is at this version");
    auto* cSet = app.add_subcommand("set", "apply PATH=VALUE changes as one edit (editor)");
    std::vector<std::string> assignments;
    cSet->add_option("changes", assignments, "PATH=VALUE, e.g. key.intensity=500, key.position=1,2,3, bendy.cp[2]=[1,0,0]")->required();
    uint64_t baseVersion = 0, ifVersion = 0;
    auto* baseOpt = cSet->add_option("--base", baseVersion, "the rig version edited from: the answer lists what this edit overwrote");
    auto* ifVersionOpt = cSet->add_option("--if-version", ifVersion, "refuse unless the rig is at this version");
    bool allowFold = false;
    cSet->add_flag("--allow-fold", allowFold,
                   "apply a BendyLight chain change as given even if the tube folds (default: stop before the fold; the "
                   "answer says where)");
    auto* cApply = app.add_subcommand("apply", "apply a JSON file of changes as one edit (editor)");
    std::string applyFile;
    cApply->add_option("file", applyFile, "{\"changes\": [{\"path\": P, \"value\": V}, ...]} or just the array")->required();
    auto* applyIfOpt = cApply->add_option("--if-version", ifVersion, "refuse unless the rig is at this version");
    auto* cFrame = app.add_subcommand("frame", "save the current frame in any output and format");
    std::string frameOut;
    ViewArgs frameView;
    cFrame->add_option("file", frameOut, "output file (.jpg, .png or .exr picks the format)")->required();
    frameView.add(cFrame);
    auto* cExport = app.add_subcommand("export", "save the session's scene with the rig's lights as glTF (GLB: KHR_lights_punctual, "
                                                 "every light exact in extras.dfb_light)");
    std::string exportOut;
    cExport->add_option("file", exportOut, "output file (.glb)")->required();
    auto* cFinal = app.add_subcommand("final", "render the shot with the current rig in Cycles on the server (Blender) and save it; "
                                               "progress on stderr (editor; --status and --cancel any role / editor)");
    std::string finalOut;
    int finalSamples = 64;
    bool finalDirect = false, finalStatus = false, finalCancel = false;
    cFinal->add_option("file", finalOut, "where to save the render: .exr (linear, the rig's exposure) or .png (the rig's view transform)");
    cFinal->add_option("--samples", finalSamples, "Cycles samples per pixel")->check(CLI::Range(1, 4096));
    cFinal->add_flag("--direct-only", finalDirect, "direct light only (no bounces), as the preview computes it");
    auto* finalStatusFlag = cFinal->add_flag("--status", finalStatus, "print the session's final-render state and exit");
    cFinal->add_flag("--cancel", finalCancel, "cancel the session's running final render")->excludes(finalStatusFlag);
    auto* cWatch = app.add_subcommand("watch", "receive streamed frames and changes; count or save them");
    int watchCount = 0;
    double watchSeconds = 0;
    std::string watchDir;
    ViewArgs watchView;
    cWatch->add_option("--count", watchCount, "stop after this many frames (default: run until --duration or forever; an idle "
                                              "rig sends none, so this waits for edits)");
    cWatch->add_option("--duration", watchSeconds, "stop after this many seconds");
    cWatch->add_option("--save", watchDir, "save each frame as DIR/frame_NNNNNN.EXT");
    watchView.add(cWatch);
    auto* cPick = app.add_subcommand("pick", "what is at a pixel: position, normal, object, lights reaching it");
    int pickX = 0, pickY = 0;
    cPick->add_option("x", pickX, "pixel column (0 = left)")->required();
    cPick->add_option("y", pickY, "pixel row (0 = top)")->required();
    auto* cDrag = app.add_subcommand("drag", "drag a shadow, hotspot or highlight in the image: the server solves for the light "
                                             "(editor; one edit, one undo step)");
    std::string dragMode, dragLight;
    std::vector<int> dragFrom, dragTo, dragPoints;
    cDrag->add_option("mode", dragMode, "one of: " + protocol::dragModeNames())->required();
    cDrag->add_option("--from", dragFrom, "the grabbed pixel X,Y (a shadowed one for shadow modes)")->required()->delimiter(',')->expected(2);
    cDrag->add_option("--to", dragTo, "where it goes: pixel X,Y")->required()->delimiter(',')->expected(2);
    cDrag->add_option("--points", dragPoints, "BendyLight control points to move, e.g. 1,2 (default: the whole light)")->delimiter(',');
    cDrag->add_option("--light", dragLight, "the light (default: the rig's first light the mode applies to)");
    auto* cUndo = app.add_subcommand("undo", "undo the session's most recent edit (editor)");
    auto* cRedo = app.add_subcommand("redo", "redo the most recently undone edit (editor)");
    auto* cHistory = app.add_subcommand("history", "the session's recorded changes: version, kind, author, what changed");
    uint64_t since = 0;
    cHistory->add_option("--since", since, "only changes after this rig version");
    auto* cBench = app.add_subcommand("bench", "edit-to-frame latency percentiles as this client sees them (editor)");
    int benchEdits = 50, benchClients = 1, benchWarmup = 3;
    std::string benchLight;
    cBench->add_option("--edits", benchEdits, "edits to time")->check(CLI::Range(1, 100000));
    cBench->add_option("--clients", benchClients, "connected clients (one edits, the others watch)")->check(CLI::Range(1, 1024));
    cBench->add_option("--light", benchLight, "light to drag (default: the first)");
    cBench->add_option("--warmup", benchWarmup, "untimed edits first")->check(CLI::Range(0, 1000));
    auto* cProperties = app.add_subcommand("properties", "the rig's property paths, their values and ranges (no server needed)");
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-client"); rc >= 0) return rc;

    if (cProperties->parsed()) {
        printProperties(asJson); // --json: the schema as the server serves it (GET /v1/schema)
        return 0;
    }
    try {
        Client cl(opt);
        if (cSessions->parsed()) {
            printAnswer(cl.request("GET", "/v1/sessions").body, asJson, printSessions);
        } else if (cInfo->parsed()) {
            printAnswer(cl.request("GET", cl.base()).body, asJson, printInfo);
        } else if (cRigGet->parsed()) {
            auto r = cl.request("GET", cl.base() + "/rig");
            if (rigOut.empty()) std::cout << r.body << std::endl;
            else writeFile(rigOut, r.body.data(), r.body.size());
        } else if (cRigPut->parsed()) {
            const std::string body = readFile(rigIn);
            auto r = cl.request("PUT", cl.base() + "/rig", body, ifMatchOpt->count() ? "\"" + std::to_string(ifMatch) + "\"" : "");
            printAnswer(r.body, asJson, printEditAnswer);
        } else if (cSet->parsed() || cApply->parsed()) {
            json body = json::object();
            if (cSet->parsed()) {
                json changes = json::array();
                for (const std::string& a : assignments) {
                    auto c = protocol::parseAssignment(a);
                    if (!c) die(EXIT_USAGE, c.error().message);
                    changes.push_back({{"path", c->path}, {"value", c->value}});
                }
                body["changes"] = changes;
                if (baseOpt->count()) body["base"] = baseVersion;
                if (ifVersionOpt->count()) body["ifVersion"] = ifVersion;
                if (allowFold) body["allowFold"] = true;
            } else {
                auto parsed = protocol::parseJson(readFile(applyFile), protocol::MAX_TEXT_MESSAGE_BYTES, applyFile);
                if (!parsed) die(EXIT_USAGE, parsed.error().message);
                const json& j = parsed.value();
                if (j.is_array()) body["changes"] = j;
                else if (j.is_object()) body = j;
                else die(EXIT_USAGE, applyFile + ": expected a JSON object {\"changes\": [...]} or an array of changes");
                if (applyIfOpt->count()) body["ifVersion"] = ifVersion;
            }
            auto r = cl.request("POST", cl.base() + "/edits", body.dump());
            printAnswer(r.body, asJson, printEditAnswer);
        } else if (cFrame->parsed()) {
            const std::string fmt = frameView.formatFor(frameOut);
            std::string q = "?output=" + urlEncode(frameView.output) + "&format=" + fmt + "&quality=" + std::to_string(frameView.quality) +
                            "&viewTransform=" + frameView.viewTransform;
            if (frameView.exposure != 0) q += "&exposure=" + json(frameView.exposure).dump();
            auto r = cl.request("GET", cl.base() + "/frame" + q);
            writeFile(frameOut, r.body.data(), r.body.size());
            std::cout << "saved " << frameOut << " (rig version " << r.rigVersion << ")" << std::endl;
        } else if (cExport->parsed()) {
            auto r = cl.request("GET", cl.base() + "/export.glb");
            if (r.body.size() < 12 || r.body.compare(0, 4, "glTF") != 0) die(EXIT_BROKEN, "GET export.glb: the answer is not a GLB file");
            writeFile(exportOut, r.body.data(), r.body.size());
            std::string version = r.etag; // "V"
            version.erase(std::remove(version.begin(), version.end(), '"'), version.end());
            std::cout << "saved " << exportOut << " (" << r.body.size() << " bytes, rig version " << version << ")" << std::endl;
        } else if (cFinal->parsed()) {
            if (finalStatus) {
                printAnswer(cl.request("GET", cl.base() + "/final").body, asJson, [](const json& j) { std::cout << finalText(j) << "\n"; });
            } else if (finalCancel) {
                printAnswer(cl.request("DELETE", cl.base() + "/final").body, asJson, [](const json& j) { std::cout << finalText(j) << "\n"; });
            } else {
                if (finalOut.empty()) die(EXIT_USAGE, "final: give the file to save the render in (.exr or .png), or --status / --cancel");
                return finalRender(cl, finalOut, finalSamples, finalDirect);
            }
        } else if (cWatch->parsed()) {
            json welcome;
            auto conn = cl.connect(&welcome);
            // An idle rig sends nothing: wait as long as the server answers pings; only silence
            // for a whole --timeout means the connection is lost.
            conn->keepAlive(cl.timeout());
            // With --json stdout carries one JSON object per line and nothing else.
            std::ostream& human = asJson ? std::cerr : std::cout;
            human << "watching session " << welcome.value("sessionId", "") << " as " << welcome.value("role", "") << ", rig version "
                  << welcome["rig"].value("version", uint64_t(0)) << std::endl;
            const std::string fmt = watchView.format.empty() ? "jpeg" : watchView.format;
            // Frames before the ack of the view settings are in the old view: not counted.
            protocol::ViewMessage v{1, watchView.settings(fmt)};
            if (auto st = conn->sendText(protocol::encode(v)); !st) cl.fail(st.error());
            bool viewSet = false;
            if (!watchDir.empty()) std::filesystem::create_directories(watchDir);
            const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(long(watchSeconds * 1000));
            int frames = 0;
            uint64_t lastVersion = 0;
            while ((watchCount == 0 || frames < watchCount) && (watchSeconds == 0 || std::chrono::steady_clock::now() < end)) {
                auto wait = std::chrono::milliseconds(std::chrono::hours(24));
                if (watchSeconds > 0) {
                    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
                    wait = std::max(std::chrono::milliseconds(1), left);
                }
                auto m = conn->receive(wait);
                if (!m) {
                    // The deadline of --duration is reached as a receive timeout (the timer may
                    // fire a little before the steady clock says the deadline passed).
                    if (watchSeconds > 0 && std::chrono::steady_clock::now() + std::chrono::milliseconds(50) >= end) break;
                    // Closed (the node went away or handed the session over: close code 1012)
                    // rather than silent: connect again, through the router, to the session's
                    // next node (docs/deployment.md "Failover").
                    if (cl.options().retryS > 0 && m.error().message.find("timed out") == std::string::npos) {
                        std::cerr << "dfb-client: watch: " << m.error().message << "; reconnecting" << std::endl;
                        conn = cl.connect(&welcome);
                        conn->keepAlive(cl.timeout());
                        human << "reconnected to session " << welcome.value("sessionId", "") << ", rig version "
                              << welcome["rig"].value("version", uint64_t(0)) << std::endl;
                        if (auto st = conn->sendText(protocol::encode(v)); !st) cl.fail(st.error());
                        viewSet = false;
                        continue;
                    }
                    die(EXIT_BROKEN, "watch: " + m.error().message + " (no answer from the server for --timeout " +
                                         json(cl.timeout().count() / 1000.0).dump() + " s, pings included)");
                }
                if (auto* t = std::get_if<client::TextMessage>(&m.value())) {
                    const std::string type = t->json.value("type", "");
                    const bool ours = t->json.value("seq", uint64_t(0)) == 1;
                    if (type == "error" && ours) die(EXIT_REFUSED, "the view settings: " + serverErrorText(t->json, t->json.dump()));
                    if (type == "ack" && ours) {
                        viewSet = true;
                        continue; // the ack of our own view settings is not news
                    }
                    if (asJson) std::cout << t->json.dump() << std::endl;
                    else if (type == "error") std::cerr << "dfb-client: " << serverErrorText(t->json, t->json.dump()) << "\n";
                    else std::cout << messageText(t->json) << std::endl;
                    continue;
                }
                if (!viewSet) continue;
                auto& f = std::get<client::FrameMessage>(m.value());
                ++frames;
                lastVersion = f.header.rigVersion;
                const std::string encoding = protocol::encodingName(f.header.encoding);
                if (asJson) {
                    std::cout << json{{"type", "frame"}, {"frameNumber", f.header.frameNumber}, {"rigVersion", f.header.rigVersion},
                                      {"width", f.header.width}, {"height", f.header.height}, {"encoding", encoding},
                                      {"bytes", f.image.size()}}
                                     .dump()
                              << std::endl;
                } else {
                    std::cout << "frame " << f.header.frameNumber << " rig version " << f.header.rigVersion << " " << f.header.width << "x"
                              << f.header.height << " " << encoding << " " << f.image.size() << " bytes" << std::endl;
                }
                if (!watchDir.empty()) {
                    char name[64];
                    std::snprintf(name, sizeof name, "frame_%06d.%s", frames, f.header.encoding == protocol::Encoding::Png ? "png"
                                                                              : f.header.encoding == protocol::Encoding::Exr ? "exr" : "jpg");
                    writeFile((std::filesystem::path(watchDir) / name).string(), f.image.data(), f.image.size());
                }
            }
            human << "received " << frames << " frame(s); last rig version " << lastVersion << std::endl;
            conn->close();
        } else if (cPick->parsed()) {
            printAnswer(cl.request("GET", cl.base() + "/pick?x=" + std::to_string(pickX) + "&y=" + std::to_string(pickY)).body, asJson, printPick);
        } else if (cDrag->parsed()) {
            auto mode = protocol::parseDragMode(dragMode);
            if (!mode) die(EXIT_USAGE, mode.error().message);
            if (dragLight.empty()) {
                const protocol::DragModeInfo& info = protocol::dragModeInfo(mode.value());
                auto rig = protocol::parseJson(cl.request("GET", cl.base() + "/rig").body, protocol::MAX_TEXT_MESSAGE_BYTES, "the rig");
                if (!rig) die(EXIT_REFUSED, rig.error().message);
                for (const json& l : rig.value().value("lights", json::array())) {
                    auto type = protocol::lightTypeFromName(l.value("type", ""));
                    if (type && (info.lights & protocol::lightBit(*type)) && l.value("enabled", true)) {
                        dragLight = l.value("name", "");
                        break;
                    }
                }
                if (dragLight.empty()) {
                    die(EXIT_REFUSED, "the rig has no enabled light that drag mode '" + dragMode + "' applies to (" +
                                          protocol::dragModeLightNames(info) + ")");
                }
            }
            json body{{"mode", dragMode}, {"light", dragLight}, {"from", dragFrom}, {"to", dragTo}};
            if (!dragPoints.empty()) body["points"] = dragPoints;
            printAnswer(cl.request("POST", cl.base() + "/drag", body.dump()).body, asJson, printEditAnswer);
        } else if (cUndo->parsed() || cRedo->parsed()) {
            printAnswer(cl.request("POST", cl.base() + (cUndo->parsed() ? "/undo" : "/redo")).body, asJson, printEditAnswer);
        } else if (cHistory->parsed()) {
            printAnswer(cl.request("GET", cl.base() + "/history?since=" + std::to_string(since)).body, asJson, printHistory);
        } else if (cBench->parsed()) {
            return bench(cl, benchEdits, benchClients, benchLight, benchWarmup);
        }
    } catch (const Exit& e) {
        return e.code;
    }
    return EXIT_OK;
}
