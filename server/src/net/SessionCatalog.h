#pragma once
// The sessions a server can serve and how one is opened (docs/deployment.md): the shots named on
// the command line and every *.exr of --sessions DIR (read again on each listing, so a shot baked
// later by a batch job is found), their tokens, and open(): take the session's lease, load the
// shot and scene, replay the journal and start the render thread. A server opens them all at
// start, or, in a fleet whose nodes share --sessions and --state, each on its first request
// (SharedState::acquire), on a thread of its own so that the others keep being served.

#include "net/FinalRenders.h"
#include "net/SessionHub.h"
#include "session/Metrics.h"

#include <dfb/core/Result.h>
#include <dfb/protocol/Codec.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace dfb::net {

struct SessionSpec {
    std::string name;
    std::string shotPath;
};

/// How sessions are opened: the server's flags (docs/operations.md).
struct CatalogOptions {
    std::string scenePath;      ///< --scene: shadow casters for every shot (default each shot's source)
    std::string assets;         ///< --assets
    std::string stateDir;       ///< --state (empty: nothing saved, no leases)
    std::string sessionsDir;    ///< --sessions
    std::string defaultRigKind; ///< --default-rig
    std::string node;           ///< --node: this node's name in leases and logs
    protocol::RigLimits rigLimits;
    size_t snapshotEvery = 0;
    int refineMs = 250;
    FinalRenderLimits finalLimits;
    std::map<std::string, SessionTokens> configured; ///< --tokens
};

class SessionCatalog {
public:
    /// Most sessions one server lists (shots in --sessions beyond it are left out, with a log line).
    static constexpr size_t MAX_SESSIONS = 4096;

    SessionCatalog(CatalogOptions options, std::vector<SessionSpec> named);

    /// The sessions named on the command line, then the *.exr of --sessions DIR sorted by name
    /// (read now). Any thread.
    std::vector<SessionSpec> specs() const;
    /// The session called `id`, or nothing. Any thread.
    std::optional<SessionSpec> find(const std::string& id) const;
    /// The session's tokens: from --tokens, else STATE/ID/tokens.json (made once, atomically, by
    /// whichever node asks first), else random ones kept for the server's life. Any thread.
    SessionTokens tokensFor(const std::string& id);
    /// STATE/ID, or empty without --state.
    std::filesystem::path stateDirOf(const std::string& id) const;
    const CatalogOptions& options() const { return mOptions; }

    /// What open() made of a session.
    struct Opened {
        std::shared_ptr<SessionHub> hub;
        std::vector<std::string> privateDirectories; ///< for SharedState::addPrivateDirectory
        std::string banner;                          ///< the line the server prints for it
    };
    struct Failed {
        Error error;              ///< for the log (with paths)
        std::string publicReason; ///< for clients (without paths)
        int exitCode = 2;         ///< dfb-server's exit code when no session opens at start
    };
    /// Opens session `spec` (blocking: the shot, the scene, the default rig's calibration render,
    /// the journal). With --state the session's lease is taken first: Moved when another node has
    /// it (and a handoff is asked for). The hub is not yet started (startHousekeeping, a first
    /// frame): the caller does that on the I/O thread. Any thread.
    std::variant<Opened, Failed> open(const SessionSpec& spec, asio::io_context& ioc, Metrics& metrics);

private:
    CatalogOptions mOptions;
    std::vector<SessionSpec> mNamed;
    mutable std::mutex mMutex;
    std::map<std::string, SessionTokens> mTokens; // known tokens by session
};

/// Session ids are 1-64 characters of [A-Za-z0-9_-] (docs/protocol.md).
bool validSessionName(const std::string& name);
/// A session id from a shot's file name: its stem with anything else replaced by '_'.
std::string sessionNameFromPath(const std::string& path);
/// Tokens are 16-256 URL-safe characters (they travel in query strings).
bool validToken(const std::string& token);

} // namespace dfb::net
