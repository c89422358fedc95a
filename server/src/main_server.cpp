// dfb-server: relights baked deep framebuffers (one session per shot) and serves them over
// HTTP/WebSocket (protocol v1, docs/protocol.md; operations in docs/operations.md).
//
// Exit codes: 0 clean shutdown (SIGINT/SIGTERM); 1 bad command line or token file; 2 bad input
// (shot, scene, or a damaged session journal); 3 GPU/EGL failure; 5 network (cannot bind).

#include "net/Listener.h"
#include "net/SessionCatalog.h"
#include "net/SessionHub.h"
#include "net/SharedState.h"
#include "session/RenderService.h"
#include "session/Session.h"

#include <dfb/core/Version.h>
#include <dfb/protocol/Messages.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/server/InitialRig.h>

#include <dfb/core/CommandLine.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include <unistd.h>

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using dfb::net::SessionSpec;
using dfb::net::validSessionName;
using dfb::net::validToken;

constexpr int EXIT_USAGE = 1, EXIT_INPUT = 2, EXIT_GPU = 3, EXIT_NETWORK = 5;

// A small JSON file of the operator's (tokens), read through the bounded parser.
constexpr size_t MAX_TOKEN_FILE_BYTES = 1 << 20;

dfb::Result<json> readJsonFile(const std::string& path, std::string_view what) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return dfb::makeError(dfb::ErrorCode::FileNotFound, path + ": cannot open the " + std::string(what));
    std::string text(MAX_TOKEN_FILE_BYTES + 1, '\0');
    in.read(text.data(), std::streamsize(text.size()));
    text.resize(size_t(in.gcount()));
    return dfb::protocol::parseJson(text, MAX_TOKEN_FILE_BYTES, path);
}

// Reads {"sessions": {"NAME": {"editor": "...", "viewer": "..."}}}.
dfb::Result<std::map<std::string, dfb::net::SessionTokens>> readTokenFile(const std::string& path) {
    auto parsed = readJsonFile(path, "token file");
    if (!parsed && parsed.error().code == dfb::ErrorCode::FileNotFound) return parsed.error();
    const json j = parsed ? std::move(parsed.value()) : json();
    if (!j.is_object() || !j.contains("sessions") || !j["sessions"].is_object()) {
        return dfb::makeError(dfb::ErrorCode::InvalidFile, path + ": expected {\"sessions\": {\"NAME\": {\"editor\": TOKEN, \"viewer\": TOKEN}}}");
    }
    std::map<std::string, dfb::net::SessionTokens> out;
    for (auto it = j["sessions"].begin(); it != j["sessions"].end(); ++it) {
        const json& t = it.value();
        const std::string where = path + ": sessions." + it.key();
        if (!t.is_object() || !t.contains("editor") || !t.contains("viewer") || !t["editor"].is_string() || !t["viewer"].is_string()) {
            return dfb::makeError(dfb::ErrorCode::InvalidFile, where + ": expected {\"editor\": TOKEN, \"viewer\": TOKEN}");
        }
        dfb::net::SessionTokens tk{t["editor"], t["viewer"]};
        if (!validToken(tk.editor) || !validToken(tk.viewer)) {
            return dfb::makeError(dfb::ErrorCode::InvalidValue, where + ": a token is 16-256 characters of A-Z a-z 0-9 - _ . ~");
        }
        if (tk.editor == tk.viewer) return dfb::makeError(dfb::ErrorCode::InvalidValue, where + ": the editor and viewer tokens must differ");
        out[it.key()] = tk;
    }
    return out;
}

} // namespace

int main(int argc, char** argv) {
    dfb::keepFreedMemoryForFrames();
    CLI::App app{"dfb-server: relight deep framebuffers interactively over HTTP and WebSocket (protocol v1)"};
    app.set_version_flag("--version",
                         dfb::versionText("dfb-server") +
                             " (G-buffer format " + std::to_string(dfb::GBUFFER_FORMAT_VERSION) + ", protocol " +
                             std::to_string(dfb::protocol::PROTOCOL_VERSION) + ")");
    app.footer("Each session is one shot with its own rig, history, tokens and clients. The server prints, per session, "
               "an editor and a viewer URL carrying the token.\n"
               "Exit codes: 0 clean stop, 1 bad command line or token file, 2 bad shot/scene/journal, 3 GPU/EGL, 5 cannot bind.");
    std::string shotPath, scenePath, sessionsDir, stateDir, tokenFile, assets, bind = "127.0.0.1";
    std::vector<std::string> sessionArgs;
    int port = 8080, refineMs = 250;
    app.add_option("shot", shotPath, "deep framebuffer EXR written by dfb-bake (a session named after the file)");
    app.add_option("--session", sessionArgs, "NAME=SHOT.exr: one session (repeatable)");
    app.add_option("--sessions", sessionsDir, "a directory: every *.exr in it becomes a session named after the file");
    app.add_option("--state", stateDir, "directory of the sessions' journals, saved rigs and tokens (DIR/NAME/); "
                                        "without it nothing is saved");
    app.add_option("--tokens", tokenFile, "JSON file {\"sessions\": {NAME: {\"editor\": T, \"viewer\": T}}}; other sessions get "
                                          "random tokens");
    app.add_option("--scene", scenePath, "glTF scene for shadow casting (default: each shot's source scene)");
    app.add_option("--port", port, "TCP port; 0 picks a free one")->check(CLI::Range(0, 65535));
    app.add_option("--bind", bind, "address to listen on (default loopback only)");
    app.add_option("--assets", assets, "folder of cookie images that lights name (default: each shot's folder)");
    std::string defaultRigKind = "three-point";
    app.add_option("--default-rig", defaultRigKind,
                   "the rig of a scene without lights: three-point (key, fill, rim and a dome, calibrated so the shot's median "
                   "covered pixel is mid-grey) or key-fill (a key and fill spot on the scene's bounds alone, uncalibrated)")
        ->check(CLI::IsMember({"three-point", "key-fill"}))
        ->capture_default_str();
    app.add_option("--refine-window", refineMs,
                   "ms: an edit within this time of the previous one renders with preview shadow maps, refined when "
                   "edits stop (0 = always full quality)")
        ->check(CLI::Range(0, 10000));
    dfb::protocol::RigLimits rigLimits;
    dfb::net::ServerLimits serverLimits;
    uint64_t lightMemoryMb = rigLimits.maxLightMemoryBytes >> 20;
    app.add_option("--max-lights", rigLimits.maxLights, "most lights in one rig")->check(CLI::Range(1, 65536))->capture_default_str();
    app.add_option("--max-keys", rigLimits.maxKeysPerProperty, "most keyframes of one property of one light")
        ->check(CLI::Range(1, 1 << 20))
        ->capture_default_str();
    app.add_option("--max-light-memory-mb", lightMemoryMb,
                   "MB of GPU memory the lights of one session may use (shadow maps and cached images)")
        ->check(CLI::Range(16, 1 << 24))
        ->capture_default_str();
    app.add_option("--max-clients-per-session", serverLimits.maxClientsPerSession, "most WebSocket clients of one session")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    app.add_option("--max-connections-per-address", serverLimits.maxConnectionsPerAddress,
                   "most open connections from one IP address")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    app.add_option("--metrics-session-names", serverLimits.metricsSessionNames,
                   "label /metrics series with session names (false: sums without names)")
        ->capture_default_str();
    dfb::net::FinalRenderLimits finalLimits;
    int finalTimeout = int(finalLimits.timeLimit.count());
    app.add_option("--final-timeout", finalTimeout, "seconds a Cycles final render (POST .../final) may run before it is stopped")
        ->check(CLI::Range(1, 86400));
    app.add_option("--blender", finalLimits.blender, "the Blender executable final renders run (a name is searched in PATH)");
    size_t snapshotEvery = dfb::Session::SNAPSHOT_EVERY;
    app.add_option("--snapshot-every", snapshotEvery, "journaled changes between two snapshots of a session's state (then the "
                                                      "journal is compacted)")
        ->check(CLI::Range(size_t(1), size_t(100000000)))
        ->capture_default_str();
    std::string openMode = "auto", node;
    int idleClose = 600;
    app.add_option("--open", openMode,
                   "when sessions are opened: at-start (all, before listening), on-request (each on its first request, closed when "
                   "idle; needs --sessions and --state), or auto: on-request when --sessions and --state are both given")
        ->check(CLI::IsMember({"auto", "at-start", "on-request"}))
        ->capture_default_str();
    app.add_option("--idle-close", idleClose, "seconds without clients or requests after which a session opened on request is closed "
                                              "(GPU objects and memory freed, lease released; the journal stays); 0 = never")
        ->check(CLI::Range(0, 86400 * 365))
        ->capture_default_str();
    size_t maxOpenSessions = dfb::net::OpenPolicy{}.maxOpen;
    app.add_option("--max-open-sessions", maxOpenSessions,
                   "most sessions open at once (opened on request): one more closes the session idle longest that has no client, "
                   "or is refused when all have clients")
        ->check(CLI::Range(size_t(1), size_t(100000)))
        ->capture_default_str();
    app.add_option("--node", node, "this node's name in session leases and logs (default: the host name)");
    std::string tlsCert, tlsKey;
    auto* certOpt = app.add_option("--tls-cert", tlsCert, "PEM certificate chain: serve HTTPS and WSS (with --tls-key) instead of "
                                                          "plain HTTP on the port")
                        ->check(CLI::ExistingFile);
    auto* keyOpt = app.add_option("--tls-key", tlsKey, "PEM private key of --tls-cert")->check(CLI::ExistingFile);
    certOpt->needs(keyOpt);
    keyOpt->needs(certOpt);
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-server"); rc >= 0) return rc;
    rigLimits.maxLightMemoryBytes = lightMemoryMb << 20;
    if (node.empty()) {
        char host[256] = {};
        node = ::gethostname(host, sizeof host - 1) == 0 && host[0] ? host : "dfb-node";
    }
    if (!validSessionName(node)) {
        std::cerr << "dfb-server: --node " << node << ": a node name is 1-64 characters of [A-Za-z0-9_-]\n";
        return EXIT_USAGE;
    }

    std::vector<SessionSpec> specs;
    if (!shotPath.empty()) specs.push_back({dfb::net::sessionNameFromPath(shotPath), shotPath});
    for (const std::string& s : sessionArgs) {
        const size_t eq = s.find('=');
        if (eq == std::string::npos || !validSessionName(s.substr(0, eq)) || eq + 1 == s.size()) {
            std::cerr << "dfb-server: --session " << s << ": expected NAME=SHOT.exr with NAME 1-64 of [A-Za-z0-9_-]\n";
            return EXIT_USAGE;
        }
        specs.push_back({s.substr(0, eq), s.substr(eq + 1)});
    }
    const size_t namedCount = specs.size(); // the rest are read from --sessions again on each listing
    // A fleet's nodes open sessions on request (docs/deployment.md): by default when they share
    // --sessions and --state; the shots may not be baked yet.
    const bool onRequest = openMode == "on-request" || (openMode == "auto" && !sessionsDir.empty() && !stateDir.empty());
    if (!sessionsDir.empty()) {
        std::error_code ec;
        std::vector<std::string> found;
        for (const auto& e : fs::directory_iterator(sessionsDir, ec)) {
            if (e.is_regular_file() && e.path().extension() == ".exr") found.push_back(e.path().string());
        }
        if (ec) {
            std::cerr << "dfb-server: --sessions " << sessionsDir << ": " << ec.message() << "\n";
            return EXIT_INPUT;
        }
        std::sort(found.begin(), found.end());
        for (const auto& f : found) specs.push_back({dfb::net::sessionNameFromPath(f), f});
        if (onRequest) specs.resize(std::min(specs.size(), namedCount + dfb::net::SessionCatalog::MAX_SESSIONS));
    }
    if (onRequest && (sessionsDir.empty() || stateDir.empty())) {
        std::cerr << "dfb-server: --open on-request needs --sessions DIR and --state DIR (sessions are opened, closed and moved "
                     "between nodes through their saved state)\n";
        return EXIT_USAGE;
    }
    if (specs.empty() && !onRequest) {
        std::cerr << "dfb-server: no shot: give SHOT.exr, --session NAME=SHOT.exr or --sessions DIR (see --help)\n";
        return EXIT_USAGE;
    }
    for (size_t i = 0; i < specs.size(); ++i) {
        for (size_t k = 0; k < i; ++k) {
            if (specs[k].name == specs[i].name) {
                std::cerr << "dfb-server: two sessions are named '" << specs[i].name << "' (" << specs[k].shotPath << ", "
                          << specs[i].shotPath << "): name them with --session NAME=SHOT.exr\n";
                return EXIT_USAGE;
            }
        }
    }
    std::map<std::string, dfb::net::SessionTokens> configured;
    if (!tokenFile.empty()) {
        auto t = readTokenFile(tokenFile);
        if (!t) {
            std::cerr << "dfb-server: " << t.error().toString() << "\n";
            return EXIT_USAGE;
        }
        configured = t.value();
        for (const auto& [name, tk] : configured) {
            if (!onRequest && std::none_of(specs.begin(), specs.end(), [&](const SessionSpec& s) { return s.name == name; })) {
                std::cerr << "dfb-server: " << tokenFile << ": tokens for '" << name << "', which is not a session\n";
                return EXIT_USAGE;
            }
        }
    }

    boost::asio::io_context ioc(1);
    auto state = std::make_shared<dfb::net::SharedState>(ioc);
    state->limits() = serverLimits;
    if (!assets.empty()) state->addPrivateDirectory(assets);
    if (!stateDir.empty()) state->addPrivateDirectory(stateDir);
    if (!sessionsDir.empty()) state->addPrivateDirectory(sessionsDir);
    finalLimits.timeLimit = std::chrono::seconds(finalTimeout);
    dfb::net::CatalogOptions catalogOptions{scenePath, assets, stateDir, sessionsDir, defaultRigKind, node, rigLimits,
                                            snapshotEvery, refineMs, finalLimits, configured};
    std::vector<SessionSpec> named(specs.begin(), specs.begin() + std::ptrdiff_t(namedCount));
    auto catalog = std::make_shared<dfb::net::SessionCatalog>(std::move(catalogOptions), std::move(named));
    dfb::net::OpenPolicy policy;
    policy.onRequest = onRequest;
    policy.idleClose = std::chrono::seconds(idleClose);
    policy.maxOpen = maxOpenSessions;
    state->setCatalog(catalog, policy);
    std::vector<std::string> banner;
    if (onRequest) {
        banner.push_back("dfb-server: node " + node + ": " + std::to_string(specs.size()) + " sessions in " + sessionsDir +
                         ", each opened on its first request" +
                         (idleClose > 0 ? " and closed after " + std::to_string(idleClose) + " s idle" : std::string()) + ", state in " + stateDir);
    } else {
        // A session that cannot be opened is reported and refused on its own (503 to its
        // clients); the others are served. Only when none opens does the server stop.
        int failedExit = 0;
        for (const SessionSpec& spec : specs) {
            int exitCode = 0;
            if (auto line = state->openNow(spec, &exitCode)) {
                banner.push_back(*line);
            } else if (failedExit == 0) {
                failedExit = exitCode;
            }
        }
        if (state->sessions().empty()) {
            std::cerr << "dfb-server: no session could be opened\n";
            state->stopOpening();
            return failedExit;
        }
    }

    boost::system::error_code ec;
    const auto address = boost::asio::ip::make_address(bind, ec);
    if (ec) {
        std::cerr << "dfb-server: --bind " << bind << " is not an IP address\n";
        return EXIT_USAGE;
    }
    // TLS 1.2 and later only; the certificate and key are checked now, not at the first client.
    std::unique_ptr<boost::asio::ssl::context> tls;
    if (!tlsCert.empty()) {
        tls = std::make_unique<boost::asio::ssl::context>(boost::asio::ssl::context::tls_server);
        tls->set_options(boost::asio::ssl::context::default_workarounds | boost::asio::ssl::context::no_sslv2 |
                         boost::asio::ssl::context::no_sslv3 | boost::asio::ssl::context::no_tlsv1 |
                         boost::asio::ssl::context::no_tlsv1_1 | boost::asio::ssl::context::single_dh_use);
        boost::system::error_code tlsError;
        const char* step = "--tls-cert " ;
        tls->use_certificate_chain_file(tlsCert, tlsError);
        if (!tlsError) {
            step = "--tls-key ";
            tls->use_private_key_file(tlsKey, boost::asio::ssl::context::pem, tlsError);
        }
        if (tlsError) {
            std::cerr << "dfb-server: " << step << (step[6] == 'c' ? tlsCert : tlsKey) << ": " << tlsError.message() << "\n";
            return EXIT_USAGE;
        }
    }
    auto listener = std::make_shared<dfb::net::Listener>(ioc, state, tls.get());
    if (auto s = listener->open({address, static_cast<unsigned short>(port)}); !s) {
        std::cerr << "dfb-server: " << s.error().toString() << "\n";
        return EXIT_NETWORK;
    }
    listener->run();

    // SIGTERM / SIGINT drain the node (docs/deployment.md "Draining"): not ready, every session
    // closed (rig saved, lease released, clients told to reconnect), then exit once the clients
    // are gone or after DRAIN_GRACE. A second signal stops at once.
    constexpr std::chrono::milliseconds DRAIN_GRACE{3000};
    boost::asio::signal_set signals(ioc, SIGINT, SIGTERM);
    signals.async_wait([&](const boost::system::error_code& sigError, int) {
        if (sigError) return;
        std::printf("dfb-server: draining\n");
        std::fflush(stdout);
        signals.async_wait([&](const boost::system::error_code& again, int) {
            if (!again) ioc.stop();
        });
        // The listener stays open while clients leave: /readyz answers 503 (the router and
        // Kubernetes stop sending here) and session requests 503 moved (clients retry).
        state->drain(DRAIN_GRACE, [&] {
            listener->close();
            ioc.stop();
        });
    });
    state->startHousekeeping();

    const std::string host = address.is_v6() ? "[" + bind + "]" : bind;
    const std::string base = std::string(tls ? "https://" : "http://") + host + ":" + std::to_string(listener->port()) + "/";
    for (const auto& l : banner) std::printf("%s\n", l.c_str());
    auto links = [&](const std::string& id, const dfb::net::SessionTokens& t) {
        std::printf("dfb-server: session %s editor: %s?session=%s&token=%s\n", id.c_str(), base.c_str(), id.c_str(), t.editor.c_str());
        std::printf("dfb-server: session %s viewer: %s?session=%s&token=%s\n", id.c_str(), base.c_str(), id.c_str(), t.viewer.c_str());
    };
    for (const auto& [id, hub] : state->sessions()) links(id, hub->tokens());
    if (onRequest) {
        for (const SessionSpec& spec : catalog->specs()) links(spec.name, catalog->tokensFor(spec.name));
    }
    for (const auto& [id, f] : state->failedSessions()) {
        std::printf("dfb-server: session %s FAILED (not served): %s\n", id.c_str(), f.reason.c_str());
        links(id, f.tokens);
    }
    std::printf("dfb-server: listening on %s\n", base.c_str());
    std::fflush(stdout);
    // Handlers return errors as values; should one throw all the same (a bug), the server logs it
    // and goes on serving the other clients instead of dropping every session.
    for (;;) {
        try {
            ioc.run();
            break;
        } catch (const std::exception& e) {
            std::fprintf(stderr, "dfb-server: internal error in a network handler (continuing): %s\n", e.what());
        }
    }
    // Every session still open (a second signal cut the drain short) is closed and its lease
    // released before the process ends.
    for (const auto& [id, hub] : state->sessions()) hub->shutdown("the server stopped");
    state->stopOpening();
    std::printf("dfb-server: shutting down\n");
    return 0;
}
