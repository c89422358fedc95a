#pragma once
// The persistence of one session (DESIGN section 9): an append-only journal of JSON lines, each
// flushed to disk (fdatasync) before append() returns, so that an edit is acknowledged only once
// it would survive a crash; and the rig saved as JSON beside it for people and scripts.
//
// Directory layout (docs/operations.md):
//   DIR/journal.jsonl  one operation per line: {"op": "base"|"edit"|"time"|"undo"|"redo"|"replace", ...}
//   DIR/rig.json       the current rig, replaced atomically (write, fsync, rename) after changes
//
// Not thread-safe: the owning Session serialises calls.

#include <dfb/core/Result.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace dfb {

class Journal {
public:
    /// Reads every complete operation of DIR/journal.jsonl (creating DIR when needed) and opens
    /// the file for appending. A last line cut short by a crash (no newline, or not JSON) was
    /// never acknowledged and is dropped (the file is truncated to its last complete line); a bad
    /// line before the end means the file was damaged: InvalidFile naming the line, and the file
    /// is left untouched.
    static Result<Journal> open(const std::filesystem::path& dir, std::vector<nlohmann::json>* operations);
    Journal(Journal&&) noexcept;
    Journal& operator=(Journal&&) noexcept;
    ~Journal();

    /// Appends one operation as a line and waits until it is on disk. IoError on failure: the
    /// caller must then refuse the change it describes.
    Status append(const nlohmann::json& operation);
    /// Replaces DIR/rig.json atomically.
    Status saveRig(const nlohmann::json& rig);
    const std::filesystem::path& dir() const { return mDir; }

private:
    Journal() = default;
    std::filesystem::path mDir;
    int mFd = -1;
};

} // namespace dfb
