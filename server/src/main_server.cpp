// dfb-server: relights baked deep framebuffers (one session per shot) and serves them over
// HTTP/WebSocket (protocol v1, docs/protocol.md; operations in docs/operations.md).
//
// Exit codes: 0 clean shutdown (SIGINT/SIGTERM); 1 bad command line or token file; 2 bad input
// (shot, scene, or a damaged session journal); 3 GPU/EGL failure; 5 network (cannot bind).

#include "net/Listener.h"
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
#include <random>

#include <sys/stat.h>

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr int EXIT_USAGE = 1, EXIT_INPUT = 2, EXIT_GPU = 3, EXIT_NETWORK = 5;

bool validSessionName(const std::string& n) {
    if (n.empty() || n.size() > 64) return false;
    return std::all_of(n.begin(), n.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'; });
}

// Tokens are URL-safe so that they can travel in a query string.
bool validToken(const std::string& t) {
    if (t.size() < 16 || t.size() > 256) return false;
    return std::all_of(t.begin(), t.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' || c == '~';
    });
}

// 128 random bits from the kernel (std::random_device reads /dev/urandom on Linux), as hex.
std::string randomToken() {
    std::random_device rd;
    std::string t;
    for (int i = 0; i < 4; ++i) {
        char buf[9];
        std::snprintf(buf, sizeof buf, "%08x", unsigned(rd()));
        t += buf;
    }
    return t;
}

struct SessionSpec {
    std::string name;
    std::string shotPath;
};

// A session name from a file name: its stem with anything outside [A-Za-z0-9_-] replaced.
std::string nameFromPath(const std::string& path) {
    std::string n = fs::path(path).stem().string();
    for (char& c : n) {
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) c = '_';
    }
    return n.substr(0, 64);
}

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

// Persistent sessions keep their tokens beside the journal (readable by the owner only), so a
// restarted server keeps every link that was handed out.
dfb::net::SessionTokens persistentTokens(const fs::path& dir) {
    const fs::path p = dir / "tokens.json";
    if (auto parsed = readJsonFile(p.string(), "tokens"); parsed) {
        const json& j = parsed.value();
        if (j.is_object() && j.value("editor", "") != "" && j.value("viewer", "") != "" && validToken(j["editor"]) && validToken(j["viewer"])) {
            return {j["editor"], j["viewer"]};
        }
    }
    dfb::net::SessionTokens t{randomToken(), randomToken()};
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (std::ofstream out(p); out) {
        out << json{{"editor", t.editor}, {"viewer", t.viewer}}.dump(2) << "\n";
        out.close();
        ::chmod(p.c_str(), 0600);
    }
    return t;
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
    std::string tlsCert, tlsKey;
    auto* certOpt = app.add_option("--tls-cert", tlsCert, "PEM certificate chain: serve HTTPS and WSS (with --tls-key) instead of "
                                                          "plain HTTP on the port")
                        ->check(CLI::ExistingFile);
    auto* keyOpt = app.add_option("--tls-key", tlsKey, "PEM private key of --tls-cert")->check(CLI::ExistingFile);
    certOpt->needs(keyOpt);
    keyOpt->needs(certOpt);
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-server"); rc >= 0) return rc;
    rigLimits.maxLightMemoryBytes = lightMemoryMb << 20;

    std::vector<SessionSpec> specs;
    if (!shotPath.empty()) specs.push_back({nameFromPath(shotPath), shotPath});
    for (const std::string& s : sessionArgs) {
        const size_t eq = s.find('=');
        if (eq == std::string::npos || !validSessionName(s.substr(0, eq)) || eq + 1 == s.size()) {
            std::cerr << "dfb-server: --session " << s << ": expected NAME=SHOT.exr with NAME 1-64 of [A-Za-z0-9_-]\n";
            return EXIT_USAGE;
        }
        specs.push_back({s.substr(0, eq), s.substr(eq + 1)});
    }
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
        for (const auto& f : found) specs.push_back({nameFromPath(f), f});
    }
    if (specs.empty()) {
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
            if (std::none_of(specs.begin(), specs.end(), [&](const SessionSpec& s) { return s.name == name; })) {
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
    std::vector<std::string> banner;
    // A session that cannot be opened is reported and refused on its own (503 to its clients);
    // the others are served. Only when none opens does the server stop.
    int failedExit = 0;
    auto tokensFor = [&](const SessionSpec& spec, const fs::path& dir) {
        if (auto it = configured.find(spec.name); it != configured.end()) return it->second;
        if (!dir.empty()) return persistentTokens(dir);
        return dfb::net::SessionTokens{randomToken(), randomToken()};
    };
    auto failSession = [&](const SessionSpec& spec, const fs::path& dir, const dfb::Error& e, std::string publicReason, int exitCode) {
        std::cerr << "dfb-server: session " << spec.name << " is not served: " << e.toString() << "\n";
        state->addFailed({spec.name, tokensFor(spec, dir), std::move(publicReason)});
        if (failedExit == 0) failedExit = exitCode;
    };
    for (const SessionSpec& spec : specs) {
        const fs::path dir = stateDir.empty() ? fs::path() : fs::path(stateDir) / spec.name;
        state->addPrivateDirectory(fs::path(spec.shotPath).parent_path().string());
        auto shot = dfb::readDeepBuffer(spec.shotPath);
        if (!shot) {
            failSession(spec, dir, shot.error(), "its shot cannot be read (see the server's log)", EXIT_INPUT);
            continue;
        }
        std::string scene = scenePath;
        if (scene.empty()) {
            scene = shot->sourcePath;
            // A relative source path is relative to where the bake ran; also try beside the shot.
            if (!fs::exists(scene)) {
                auto beside = fs::path(spec.shotPath).parent_path() / fs::path(scene).filename();
                if (fs::exists(beside)) scene = beside.string();
            }
        }
        auto loaded = dfb::loadScene(scene);
        if (!loaded) {
            failSession(spec, dir,
                        dfb::makeError(loaded.error().code, "shadow casters: " + loaded.error().message +
                                                                (scene == shot->sourcePath ? " (the shot's source scene; pass --scene)" : "")),
                        "its scene cannot be read (see the server's log)", EXIT_INPUT);
            continue;
        }
        bool imported = false;
        std::vector<std::string> importWarnings;
        dfb::ShadowGeometry casters = dfb::shadowCasters(loaded.value());
        dfb::Calibration calibration;
        auto initial = defaultRigKind == "key-fill"
                           ? dfb::Result<dfb::Rig>(dfb::initialRig(loaded.value(), &imported, &importWarnings))
                           : dfb::sessionRig(loaded.value(), shot.value(), casters, &imported, &importWarnings, &calibration);
        for (const std::string& w : importWarnings) std::fprintf(stderr, "dfb-server: session %s: %s\n", spec.name.c_str(), w.c_str());
        if (!initial) {
            failSession(spec, dir, initial.error(), "its default rig cannot be rendered (see the server's log)", EXIT_INPUT);
            continue;
        }
        dfb::Rig rig = std::move(initial.value());
        auto session = dfb::Session::open(spec.name, shot.value(), spec.shotPath, rig, dir, snapshotEvery);
        if (!session) {
            // The journal's own message names the line and the reason; clients get it without
            // the server's folders.
            failSession(spec, dir, session.error(), state->redact(session.error().message), EXIT_INPUT);
            continue;
        }
        session.value()->setLimits(rigLimits);
        std::error_code absoluteError; // on failure the path as given
        const fs::path sceneAbsolute = fs::absolute(scene, absoluteError);
        session.value()->setScenePath(absoluteError ? scene : sceneAbsolute.string());
        state->addPrivateDirectory(fs::path(scene).parent_path().string()); // export errors name the scene
        if (!session.value()->recoveryReport().empty()) {
            std::fprintf(stderr, "dfb-server: session %s: journal repaired: %s\n",
                         spec.name.c_str(), session.value()->recoveryReport().c_str());
        }
        if (imported && session.value()->rigVersion() == rig.version) {
            std::printf("dfb-server: session %s: initial rig from the scene's KHR_lights_punctual (%zu lights)\n", spec.name.c_str(),
                        rig.lights.size());
        } else if (!imported && session.value()->rigVersion() == rig.version && calibration.coveredPixels > 0) {
            std::printf("dfb-server: session %s: default rig (key, fill, rim, dome) x %.4g: median covered-pixel luminance %.4g -> 0.18\n",
                        spec.name.c_str(), double(calibration.factor), double(calibration.medianBefore));
        }
        const std::string assetDir = !assets.empty() ? assets : fs::path(spec.shotPath).parent_path().string();
        session.value()->setAssetDirectory(assetDir.empty() ? "." : assetDir);
        const dfb::net::SessionTokens tokens = tokensFor(spec, dir);
        const size_t triangles = loaded->triangleCount();
        auto hub = std::make_shared<dfb::net::SessionHub>(ioc, state->metrics(), std::make_unique<dfb::DeepBuffer>(std::move(shot.value())),
                                                          std::move(session.value()), tokens);
        std::weak_ptr<dfb::net::SessionHub> weak = hub;
        auto render = dfb::RenderService::start(hub->shot(), std::move(casters), hub->session(),
                                                [weak](uint64_t, uint64_t serial) {
                                                    if (auto h = weak.lock()) h->onNewImage(serial);
                                                },
                                                &state->metrics());
        if (!render) {
            failSession(spec, dir, render.error(), "the GPU could not render it (see the server's log)", EXIT_GPU);
            continue;
        }
        char line[512];
        std::snprintf(line, sizeof line, "dfb-server: session %s: %s (%dx%d), %zu shadow-casting triangles, rig version %llu%s, %s",
                      spec.name.c_str(), spec.shotPath.c_str(), hub->shot().width, hub->shot().height, triangles,
                      static_cast<unsigned long long>(hub->session().rigVersion()),
                      hub->session().persistent() ? (", saved in " + dir.string()).c_str() : ", not saved (no --state)",
                      render.value()->deviceDescription().c_str());
        banner.push_back(line);
        render.value()->setRefinement(std::chrono::milliseconds(refineMs), std::chrono::milliseconds(150));
        hub->setRender(std::move(render.value()));
        {
            // Snapshots and saved rigs beside the journal (session/Library.h); a damaged entry is
            // named and skipped, the others kept.
            std::vector<std::string> libraryReport;
            auto library = dfb::Library::open(dir.empty() ? dir : dir / "library", &libraryReport);
            for (const std::string& skipped : libraryReport) {
                std::fprintf(stderr, "dfb-server: session %s: library: %s\n", spec.name.c_str(), skipped.c_str());
            }
            if (!library) {
                failSession(spec, dir, library.error(), "its library cannot be opened (see the server's log)", EXIT_INPUT);
                continue;
            }
            hub->setLibrary(std::move(library.value()));
        }
        {
            // Annotations the same way (session/Annotations.h): a damaged one named and skipped.
            std::vector<std::string> annotationsReport;
            auto annotations = dfb::Annotations::open(dir.empty() ? dir : dir / "annotations", &annotationsReport);
            for (const std::string& note : annotationsReport) std::fprintf(stderr, "dfb-server: session %s: annotations: %s\n", spec.name.c_str(), note.c_str());
            if (!annotations) {
                failSession(spec, dir, annotations.error(), "its annotations cannot be opened (see the server's log)", EXIT_INPUT);
                continue;
            }
            hub->setAnnotations(std::move(annotations.value()));
        }
        finalLimits.timeLimit = std::chrono::seconds(finalTimeout);
        hub->finals().setLimits(finalLimits);
        hub->render().requestFrame();
        hub->startHousekeeping();
        state->addSession(hub);
    }

    if (state->sessions().empty()) {
        std::cerr << "dfb-server: no session could be opened\n";
        return failedExit;
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

    boost::asio::signal_set signals(ioc, SIGINT, SIGTERM);
    signals.async_wait([&](const boost::system::error_code&, int) { ioc.stop(); });

    const std::string host = address.is_v6() ? "[" + bind + "]" : bind;
    const std::string base = std::string(tls ? "https://" : "http://") + host + ":" + std::to_string(listener->port()) + "/";
    for (const auto& l : banner) std::printf("%s\n", l.c_str());
    auto links = [&](const std::string& id, const dfb::net::SessionTokens& t) {
        std::printf("dfb-server: session %s editor: %s?session=%s&token=%s\n", id.c_str(), base.c_str(), id.c_str(), t.editor.c_str());
        std::printf("dfb-server: session %s viewer: %s?session=%s&token=%s\n", id.c_str(), base.c_str(), id.c_str(), t.viewer.c_str());
    };
    for (const auto& [id, hub] : state->sessions()) links(id, hub->tokens());
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
    for (const auto& [id, hub] : state->sessions()) hub->session().flushSavedRig();
    std::printf("dfb-server: shutting down\n");
    return 0;
}
