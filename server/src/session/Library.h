#pragma once
// A session's library (issue 20 point 3, docs/protocol.md "Snapshots and saved rigs"): snapshots
// (a named frame with the rig it shows, its version, author and time, and a thumbnail) and saved
// rigs (a named rig), kept per session in SESSION_DIR/library/ beside the journal so that they
// survive restarts, or in memory for a session without --state. Each entry is written durably in
// files of its own (a JSON record, and for a snapshot its JPEG frame and thumbnail): saving one
// never rewrites another, and a damaged file costs only its entry (reported, left on disk).
// Loading a saved rig is the caller's: Session::replace, one undoable edit. I/O thread only.

#include <dfb/core/Result.h>
#include <dfb/protocol/Rig.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace dfb {

class Library {
public:
    static constexpr size_t MAX_SNAPSHOTS = 100; ///< per session
    static constexpr size_t MAX_RIGS = 100;      ///< per session
    static constexpr int THUMBNAIL_WIDTH = 240;  ///< at most, in pixels

    struct Entry {
        std::string name;
        uint64_t rigVersion = 0;
        std::string by;   ///< the author's name
        std::string time; ///< UTC, ISO 8601 (2026-12-05T19:47:41Z)
        nlohmann::json rig; ///< the rig as protocol::toJson writes it
    };
    struct Snapshot : Entry {
        int width = 0, height = 0; ///< of the frame
        std::shared_ptr<const std::string> image;     ///< JPEG of the frame
        std::shared_ptr<const std::string> thumbnail; ///< JPEG, at most THUMBNAIL_WIDTH wide
    };

    /// The library kept in `dir` (created when missing; empty: in memory only). Files that cannot
    /// be read are skipped and named in `report` (one line each), left as they are.
    static Result<std::unique_ptr<Library>> open(const std::filesystem::path& dir, std::vector<std::string>* report = nullptr);

    /// Adds a snapshot of `frameJpeg` (width x height) showing `rig`. InvalidValue for a bad name, Conflict for a
    /// name in use, LimitExceeded past MAX_SNAPSHOTS, IoError when it cannot be saved (then
    /// nothing is kept). The new entry's summary.
    Result<nlohmann::json> addSnapshot(const std::string& name, const Rig& rig, const std::string& by, std::string frameJpeg,
                                       int width, int height);
    Status removeSnapshot(const std::string& name);
    /// MissingData naming the snapshot when there is none of that name.
    Result<std::shared_ptr<const Snapshot>> snapshot(const std::string& name) const;

    /// Saves `rig` under `name`, replacing a saved rig of that name (a saved rig is a named
    /// state: saving again updates it). InvalidValue, LimitExceeded, IoError as above.
    Result<nlohmann::json> saveRig(const std::string& name, const Rig& rig, const std::string& by);
    Status removeRig(const std::string& name);
    Result<Entry> savedRig(const std::string& name) const;

    /// {"snapshots": [summary...], "rigs": [summary...]}, each sorted by time then name; a summary
    /// is the entry without its rig and images ({name, rigVersion, by, time, lights[, width,
    /// height]}).
    nlohmann::json list() const;
    bool persistent() const { return !mDir.empty(); }

private:
    explicit Library(std::filesystem::path dir) : mDir(std::move(dir)) {}
    static nlohmann::json summary(const Entry& e);
    std::filesystem::path mDir;
    std::map<std::string, std::shared_ptr<const Snapshot>> mSnapshots;
    std::map<std::string, Entry> mRigs;
};

} // namespace dfb
