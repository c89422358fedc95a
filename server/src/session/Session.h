#pragma once
// One shot being relit (DESIGN section 9): its rig (the authoritative copy), the description
// clients need, the undo/redo history and, when it has a directory, its journal. Every change
// goes through here, is journaled (and on disk) before it is applied and acknowledged, and gets a
// new rig version; concurrent edits are serialised, so the last writer wins deterministically.
//
// Thread-safe: the network thread changes the rig, the render thread takes snapshots.

#include "session/Journal.h"

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Messages.h>
#include <dfb/protocol/Rig.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <deque>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace dfb {

/// Who made a change: a WebSocket client (id > 0) or a plain HTTP request (id 0).
struct Author {
    uint64_t clientId = 0;
    std::string name;
};

/// What a successful change did, for the ack and the change broadcast.
struct ChangeOutcome {
    protocol::ChangeInfo info;  ///< version, author, kind, changes or the whole new rig
    /// For an edit with a `base` version older than the rig: the properties of this edit that
    /// others changed after `base` (this edit overwrote them: last writer wins), as
    /// [{"path", "version", "by"}]. Empty otherwise.
    nlohmann::json overwrote = nlohmann::json::array();
    /// Lights whose chain this edit would have folded, limited instead (limitChainEdit), as
    /// [{"light", "fraction", "warning", "message", "changes"}]: `changes` are the edit's changes of
    /// that light as applied (the client's own copy takes them). Empty otherwise.
    nlohmann::json limited = nlohmann::json::array();
};

class Session {
public:
    /// Most undo steps kept per session (older ones are forgotten, oldest first).
    static constexpr size_t MAX_UNDO = 500;
    /// Most change records kept for conflict reports and GET .../history.
    static constexpr size_t MAX_LOG = 10000;
    /// A change record keeps its whole rig every this many versions (rigAtVersion).
    static constexpr uint64_t LOG_CHECKPOINT_EVERY = 64;

    /// Changes journaled between two snapshots of the whole state (then the journal is compacted
    /// to one record). A snapshot holds up to MAX_UNDO steps of two rigs each and all MAX_LOG
    /// change records (~2 MB for the default rig), written and fsynced on the network thread,
    /// so it must be rare next to the one small record per change: every 1000 changes it cost a
    /// busy session (64 editors x 10 edits/s) a stall every 1.5 s and its ack p99 went from 18
    /// to 187 ms; 10000 changes of ~100-300 bytes keep the journal to a few MB between snapshots.
    static constexpr size_t SNAPSHOT_EVERY = 10000;
    /// rig.json (for people and scripts; a restart trusts the journal) is rewritten at most this
    /// often while changes stream in, and by flushSavedRig() after them.
    static constexpr std::chrono::milliseconds RIG_SAVE_INTERVAL{500};

    /// A session named `id` on `shot`. With a non-empty `dir` the session is persistent: the
    /// snapshot and journal there are replayed (the rig, version, undo/redo stacks and history
    /// are restored exactly; `initialRig` is then ignored), else a new journal is started from
    /// `initialRig`. A damaged last journal record is moved aside and reported by
    /// recoveryReport(). InvalidFile, naming the file, line and reason, and nothing touched, when
    /// the journal is damaged before its end, does not continue the snapshot, or is empty or
    /// missing although rig.json or a snapshot show that the session had changes: a session is
    /// never silently restarted at version 1. `snapshotEvery` (>= 1): see SNAPSHOT_EVERY.
    static Result<std::unique_ptr<Session>> open(std::string id, const DeepBuffer& shot,
                                                 std::string shotPath, Rig initialRig,
                                                 const std::filesystem::path& dir,
                                                 size_t snapshotEvery = SNAPSHOT_EVERY);

    /// Applies all changes or none. `base`: the version the client edited from (for the
    /// overwrote report); `ifVersion`: refuse with Conflict unless the rig is at that version.
    /// `merge`: fold this edit into the newest undo step when that step is `by`'s own edit and
    /// nothing else changed the rig since (a drag sends many edits; one undo takes it back).
    /// Unless `allowFold`, a BendyLight or bent area light chain that was sound and would fold
    /// is limited to the last sound configuration on the way (ChangeOutcome::limited).
    Result<ChangeOutcome> edit(const std::vector<protocol::Change>& changes, const Author& by,
                               std::optional<uint64_t> base = std::nullopt, std::optional<uint64_t> ifVersion = std::nullopt,
                               bool merge = false, bool allowFold = false);
    /// Sets the session clock (not an undo step).
    Result<ChangeOutcome> setTime(double seconds, const Author& by);
    /// Undoes / redoes the most recent edit of the session, whoever made it. MissingData when
    /// there is nothing to undo / redo. The clock is not affected.
    Result<ChangeOutcome> undo(const Author& by);
    Result<ChangeOutcome> redo(const Author& by);
    /// Replaces the lights, exposure and time (the version is the server's).
    Result<ChangeOutcome> replace(const Rig& rig, const Author& by, std::optional<uint64_t> ifVersion = std::nullopt);

    /// Where cookie images and area lights' patterns are looked up (the engine's asset folder);
    /// default ".". Refits the area lights' alphaBeta with the patterns found there.
    void setAssetDirectory(std::string dir) {
        std::lock_guard lock(mMutex);
        mAssetDir = std::move(dir);
        updateFits(mRig);
    }
    std::string assetDirectory() const {
        std::lock_guard lock(mMutex);
        return mAssetDir;
    }
    /// The glTF scene the session's shadow casters came from (the shot's source or --scene),
    /// which GET .../export.glb writes the rig into (dfb/server/GltfExport.h); empty: none.
    void setScenePath(std::string path) {
        std::lock_guard lock(mMutex);
        mScenePath = std::move(path);
    }
    std::string scenePath() const {
        std::lock_guard lock(mMutex);
        return mScenePath;
    }
    /// The limits every new edit and rig is checked against (LimitExceeded, nothing applied or
    /// journaled). A replayed journal is not: it was accepted under the limits of its time.
    /// `imagePixels` is the shot's and is kept.
    void setLimits(protocol::RigLimits limits) {
        std::lock_guard lock(mMutex);
        limits.imagePixels = mLimits.imagePixels;
        mLimits = limits;
    }

    /// Writes rig.json now if changes since the last write left it behind (the server calls it
    /// every RIG_SAVE_INTERVAL and at shutdown).
    void flushSavedRig();
    /// Writes a rig.json left behind (flushSavedRig).
    ~Session();
    /// Ends the session on this node before its lease is released (another node may open it
    /// next): rig.json is brought up to date and every later change is refused with Moved, so
    /// nothing is written to the journal without the lease. Reading goes on working.
    void close();
    bool closed() const;

    Rig rig() const;
    uint64_t rigVersion() const;
    size_t undoDepth() const;
    size_t redoDepth() const;
    /// The change records with a version > `since` (oldest first), as the history endpoint
    /// shows them: [{"version", "kind", "by", "byName", "changes" | "rig"}].
    nlohmann::json history(uint64_t since) const;
    /// The rig as it was at `version` (a version in the history, or the current one), rebuilt
    /// from the log's nearest whole rig and the changes after it; MissingData naming the range
    /// the history covers otherwise. "Go to this version" is replace(rigAtVersion(v)).
    Result<Rig> rigAtVersion(uint64_t version) const;

    /// What open() repaired in the journal (file, line, reason, where the damaged bytes were
    /// moved), for the operator; empty when nothing needed repair.
    const std::string& recoveryReport() const { return mRecoveryReport; }

    const std::string& id() const { return mId; }
    bool persistent() const { return mJournal.has_value(); }
    /// Resolution, camera and source of the shot, its objects' names and boxes and the scene's box
    /// (docs/protocol.md "Connection"), for the welcome message and GET /v1/sessions/ID.
    const nlohmann::json& description() const { return mDescription; }

private:
    struct Step {
        Rig before, after;
    };
    Session(std::string id, const DeepBuffer& shot, std::string shotPath, Rig rig);
    void saveRigNow(); // with mMutex held
    Result<Rig> rigAtVersionLocked(uint64_t version) const;
    // Applies one journal operation (replay) or a new one (journal != null: written first).
    Result<ChangeOutcome> apply(const nlohmann::json& op, bool record);
    // A cookie or area-light pattern new in `next` must be an image the engine can read, or the
    // change is refused now rather than every frame failing later.
    Status checkImages(const Rig& next) const;
    /// Writes every area light's Light::alphaBeta: the fit of its shape and pattern
    /// (fitAreaAlphaBeta; cached, so only a new pattern, shape or aspect costs a fit). A pattern
    /// that cannot be read keeps the defaults (the render reports it).
    void updateFits(Rig& rig) const;
    // The whole state a restart needs (what replaying the journal so far would rebuild), and back.
    nlohmann::json stateJson() const;
    Status restoreState(const nlohmann::json& state);
    // After enough journaled changes: snapshot the state and compact the journal. A failure is
    // logged only: the journal still holds every change, and the next change tries again.
    void snapshotIfDue();

    const std::string mId;
    mutable std::mutex mMutex;
    Rig mRig;
    std::deque<Step> mUndo;
    std::vector<Step> mRedo;
    std::deque<nlohmann::json> mLog;
    std::optional<Journal> mJournal;
    /// The client whose edit is the newest undo step and may take merged edits; 0: none.
    uint64_t mMergeableBy = 0;
    std::string mAssetDir = ".";
    std::string mScenePath;
    protocol::RigLimits mLimits;
    size_t mSnapshotEvery = SNAPSHOT_EVERY;
    bool mRigSaveDue = false;
    bool mClosed = false; // close(): changes refused (the lease is about to go)
    std::chrono::steady_clock::time_point mLastRigSave{};
    std::string mRecoveryReport;
    nlohmann::json mDescription;
};

} // namespace dfb
