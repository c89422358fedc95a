#include "net/SessionCatalog.h"

#include "session/Lease.h"

#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/protocol/Json.h>
#include <dfb/server/InitialRig.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <random>

#include <sys/stat.h>
#include <unistd.h>

namespace dfb::net {

namespace fs = std::filesystem;
using json = nlohmann::json;

bool validSessionName(const std::string& n) {
    if (n.empty() || n.size() > 64) return false;
    return std::all_of(n.begin(), n.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'; });
}

bool validToken(const std::string& t) {
    if (t.size() < 16 || t.size() > 256) return false;
    return std::all_of(t.begin(), t.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' || c == '~';
    });
}

std::string sessionNameFromPath(const std::string& path) {
    std::string n = fs::path(path).stem().string();
    for (char& c : n) {
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) c = '_';
    }
    return n.substr(0, 64);
}

namespace {

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

std::optional<SessionTokens> readTokens(const fs::path& p) {
    auto parsed = Journal::readJsonBounded(p, 1 << 16);
    if (!parsed) return std::nullopt;
    const json& j = parsed.value();
    if (!j.is_object() || !j.contains("editor") || !j.contains("viewer") || !j["editor"].is_string() || !j["viewer"].is_string()) {
        return std::nullopt;
    }
    SessionTokens t{j["editor"], j["viewer"]};
    if (!validToken(t.editor) || !validToken(t.viewer)) return std::nullopt;
    return t;
}

// Persistent sessions keep their tokens beside the journal (readable by the owner only), so a
// restarted server, or another node of a fleet, keeps every link that was handed out. Nodes may
// ask at the same moment: the file is written whole under a unique name and link()ed into place,
// which fails if another node was first; then theirs is read.
SessionTokens persistentTokens(const fs::path& dir) {
    const fs::path p = dir / "tokens.json";
    if (auto t = readTokens(p)) return *t;
    SessionTokens t{randomToken(), randomToken()};
    std::error_code ec;
    fs::create_directories(dir, ec);
    const fs::path tmp = dir / (".tokens." + std::to_string(::getpid()) + "." + randomToken());
    {
        std::ofstream out(tmp);
        out << json{{"editor", t.editor}, {"viewer", t.viewer}}.dump(2) << "\n";
        out.close();
        if (!out) {
            fs::remove(tmp, ec);
            return t; // not saved: the links hold for this run only
        }
    }
    ::chmod(tmp.c_str(), 0600);
    const bool mine = ::link(tmp.c_str(), p.c_str()) == 0;
    fs::remove(tmp, ec);
    if (!mine) {
        if (auto theirs = readTokens(p)) return *theirs;
    }
    return t;
}

} // namespace

SessionCatalog::SessionCatalog(CatalogOptions options, std::vector<SessionSpec> named)
    : mOptions(std::move(options)), mNamed(std::move(named)) {}

std::vector<SessionSpec> SessionCatalog::specs() const {
    std::vector<SessionSpec> out = mNamed;
    if (mOptions.sessionsDir.empty()) return out;
    std::error_code ec;
    std::vector<std::string> found;
    for (const auto& e : fs::directory_iterator(mOptions.sessionsDir, ec)) {
        // Batch bakes write NAME.exr.tmp-... and rename: only whole shots end in .exr.
        if (e.is_regular_file(ec) && e.path().extension() == ".exr") found.push_back(e.path().string());
    }
    std::sort(found.begin(), found.end());
    for (const auto& f : found) {
        const std::string name = sessionNameFromPath(f);
        if (std::any_of(out.begin(), out.end(), [&](const SessionSpec& s) { return s.name == name; })) continue;
        if (out.size() >= MAX_SESSIONS) {
            std::fprintf(stderr, "dfb-server: --sessions %s: more than %zu shots; the others are not served\n",
                         mOptions.sessionsDir.c_str(), MAX_SESSIONS);
            break;
        }
        out.push_back({name, f});
    }
    return out;
}

std::optional<SessionSpec> SessionCatalog::find(const std::string& id) const {
    for (const SessionSpec& s : mNamed) {
        if (s.name == id) return s;
    }
    if (mOptions.sessionsDir.empty() || !validSessionName(id)) return std::nullopt;
    // The shot whose name gives `id`: most are NAME.exr; other stems map through
    // sessionNameFromPath, so fall back to the listing.
    const fs::path direct = fs::path(mOptions.sessionsDir) / (id + ".exr");
    std::error_code ec;
    if (fs::is_regular_file(direct, ec)) return SessionSpec{id, direct.string()};
    for (const SessionSpec& s : specs()) {
        if (s.name == id) return s;
    }
    return std::nullopt;
}

fs::path SessionCatalog::stateDirOf(const std::string& id) const {
    return mOptions.stateDir.empty() ? fs::path() : fs::path(mOptions.stateDir) / id;
}

SessionTokens SessionCatalog::tokensFor(const std::string& id) {
    std::lock_guard lock(mMutex);
    if (auto it = mTokens.find(id); it != mTokens.end()) return it->second;
    SessionTokens t;
    if (auto it = mOptions.configured.find(id); it != mOptions.configured.end()) {
        t = it->second;
    } else if (!mOptions.stateDir.empty()) {
        t = persistentTokens(stateDirOf(id));
    } else {
        t = {randomToken(), randomToken()};
    }
    mTokens[id] = t;
    return t;
}

std::variant<SessionCatalog::Opened, SessionCatalog::Failed> SessionCatalog::open(const SessionSpec& spec, asio::io_context& ioc,
                                                                                  Metrics& metrics) {
    const fs::path dir = stateDirOf(spec.name);
    Opened opened;
    auto failed = [](Error e, std::string publicReason, int exitCode = 2) { return Failed{std::move(e), std::move(publicReason), exitCode}; };
    // The lease first: a session open on another node is not loaded here at all.
    std::unique_ptr<Lease> lease;
    if (!dir.empty()) {
        auto taken = Lease::take(dir, mOptions.node);
        if (!taken) {
            if (taken.error().code == ErrorCode::Moved) {
                // Ask the holder to hand the session over (SharedState's housekeeping): the
                // router sends this session's requests here now.
                std::ofstream(dir / Lease::HANDOFF_FILE_NAME) << mOptions.node << "\n";
            }
            return failed(taken.error(), taken.error().message);
        }
        lease = std::move(taken.value());
        std::error_code ec;
        fs::remove(dir / Lease::HANDOFF_FILE_NAME, ec); // asked of a previous owner
    }
    opened.privateDirectories.push_back(fs::path(spec.shotPath).parent_path().string());
    auto shot = readDeepBuffer(spec.shotPath);
    if (!shot) return failed(shot.error(), "its shot cannot be read (see the server's log)");
    std::string scene = mOptions.scenePath;
    if (scene.empty()) {
        scene = shot->sourcePath;
        // A relative source path is relative to where the bake ran; also try beside the shot.
        if (!fs::exists(scene)) {
            auto beside = fs::path(spec.shotPath).parent_path() / fs::path(scene).filename();
            if (fs::exists(beside)) scene = beside.string();
        }
    }
    auto loaded = loadScene(scene);
    if (!loaded) {
        return failed(makeError(loaded.error().code, "shadow casters: " + loaded.error().message +
                                                         (scene == shot->sourcePath ? " (the shot's source scene; pass --scene)" : "")),
                      "its scene cannot be read (see the server's log)");
    }
    bool imported = false;
    std::vector<std::string> importWarnings;
    ShadowGeometry casters = shadowCasters(loaded.value());
    Calibration calibration;
    auto initial = mOptions.defaultRigKind == "key-fill"
                       ? Result<Rig>(initialRig(loaded.value(), &imported, &importWarnings))
                       : sessionRig(loaded.value(), shot.value(), casters, &imported, &importWarnings, &calibration);
    for (const std::string& w : importWarnings) std::fprintf(stderr, "dfb-server: session %s: %s\n", spec.name.c_str(), w.c_str());
    if (!initial) return failed(initial.error(), "its default rig cannot be rendered (see the server's log)");
    Rig rig = std::move(initial.value());
    auto session = Session::open(spec.name, shot.value(), spec.shotPath, rig, dir, mOptions.snapshotEvery);
    // The journal's own message names the line and the reason; clients get it without the
    // server's folders (the caller redacts).
    if (!session) return failed(session.error(), session.error().message);
    session.value()->setLimits(mOptions.rigLimits);
    std::error_code absoluteError; // on failure the path as given
    const fs::path sceneAbsolute = fs::absolute(scene, absoluteError);
    session.value()->setScenePath(absoluteError ? scene : sceneAbsolute.string());
    opened.privateDirectories.push_back(fs::path(scene).parent_path().string()); // export errors name the scene
    if (!session.value()->recoveryReport().empty()) {
        std::fprintf(stderr, "dfb-server: session %s: journal repaired: %s\n", spec.name.c_str(), session.value()->recoveryReport().c_str());
    }
    if (imported && session.value()->rigVersion() == rig.version) {
        std::printf("dfb-server: session %s: initial rig from the scene's KHR_lights_punctual (%zu lights)\n", spec.name.c_str(),
                    rig.lights.size());
    } else if (!imported && session.value()->rigVersion() == rig.version && calibration.coveredPixels > 0) {
        std::printf("dfb-server: session %s: default rig (key, fill, rim, dome) x %.4g: median covered-pixel luminance %.4g -> 0.18\n",
                    spec.name.c_str(), double(calibration.factor), double(calibration.medianBefore));
    }
    const std::string assetDir = !mOptions.assets.empty() ? mOptions.assets : fs::path(spec.shotPath).parent_path().string();
    session.value()->setAssetDirectory(assetDir.empty() ? "." : assetDir);
    const SessionTokens tokens = tokensFor(spec.name);
    const size_t triangles = loaded->triangleCount();
    auto hub = std::make_shared<SessionHub>(ioc, metrics, std::make_unique<DeepBuffer>(std::move(shot.value())), std::move(session.value()),
                                            tokens);
    std::weak_ptr<SessionHub> weak = hub;
    auto render = RenderService::start(hub->shot(), std::move(casters), hub->session(),
                                       [weak](uint64_t, uint64_t serial) {
                                           if (auto h = weak.lock()) h->onNewImage(serial);
                                       },
                                       &metrics);
    if (!render) return failed(render.error(), "the GPU could not render it (see the server's log)", 3);
    char line[512];
    std::snprintf(line, sizeof line, "dfb-server: session %s: %s (%dx%d), %zu shadow-casting triangles, rig version %llu%s, %s",
                  spec.name.c_str(), spec.shotPath.c_str(), hub->shot().width, hub->shot().height, triangles,
                  static_cast<unsigned long long>(hub->session().rigVersion()),
                  hub->session().persistent() ? (", saved in " + dir.string()).c_str() : ", not saved (no --state)",
                  render.value()->deviceDescription().c_str());
    opened.banner = line;
    render.value()->setRefinement(std::chrono::milliseconds(mOptions.refineMs), std::chrono::milliseconds(150));
    hub->setRender(std::move(render.value()));
    // Snapshots and saved rigs (session/Library.h) and annotations (session/Annotations.h) beside
    // the journal; a damaged entry is named and skipped, the others kept.
    auto openStore = [&](auto openFolder, const char* folder) {
        std::vector<std::string> report;
        auto store = openFolder(dir.empty() ? dir : dir / folder, &report);
        for (const std::string& entry : report) std::fprintf(stderr, "dfb-server: session %s: %s: %s\n", spec.name.c_str(), folder, entry.c_str());
        return store;
    };
    auto library = openStore(&Library::open, "library");
    if (!library) return failed(library.error(), "its library cannot be opened (see the server's log)");
    hub->setLibrary(std::move(library.value()));
    auto annotations = openStore(&Annotations::open, "annotations");
    if (!annotations) return failed(annotations.error(), "its annotations cannot be opened (see the server's log)");
    hub->setAnnotations(std::move(annotations.value()));
    hub->finals().setLimits(mOptions.finalLimits);
    hub->setLease(std::move(lease));
    opened.hub = std::move(hub);
    return opened;
}

} // namespace dfb::net
