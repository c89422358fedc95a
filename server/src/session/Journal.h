#pragma once
// The persistence of one session (DESIGN section 9): an append-only journal of records, each
// flushed to disk (fdatasync) before append() returns, so that an edit is acknowledged only once
// it would survive a crash; a snapshot of the whole session state every so many records, after
// which the journal is compacted so that it does not grow without bound; and the rig saved as
// JSON beside them for people and scripts.
//
// Directory layout (docs/operations.md, "Persistence"):
//   DIR/journal.jsonl             one record per line (format below): first {"op": "base", "rig"}
//                                 or {"op": "snapshot", "v"}, then one operation per change
//   DIR/snapshot.jsonl            one record in the same format: the session state at a version
//   DIR/rig.json                  the current rig, replaced atomically after changes
//   DIR/journal.corrupt-<UTC>     a damaged last record moved aside at open (never deleted)
//
// Record format, one line each, readable with `cut -d' ' -f3-`:
//   <length> <crc32c> <json>\n
// <length>: decimal byte length of <json>; <crc32c>: CRC32C (Castagnoli, as iSCSI and ext4 use
// it) of the <json> bytes as 8 lowercase hex digits. The length and the checksum let a torn or
// bit-flipped record be told from a good one: JSON alone accepts a changed digit. Lines that start
// with '{' are records of journals written before the checksum (accepted without one); new
// records are always written with it.
//
// Not thread-safe: the owning Session serialises calls.

#include <dfb/core/Result.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace dfb {

/// CRC32C of `bytes` (reflected, initial and final value 0xFFFFFFFF; check value of "123456789"
/// is 0xE3069283).
uint32_t crc32c(std::string_view bytes);

class Journal {
public:
    /// File names inside the session directory.
    static constexpr const char* JOURNAL_FILE = "journal.jsonl";
    static constexpr const char* SNAPSHOT_FILE = "snapshot.jsonl";
    static constexpr const char* RIG_FILE = "rig.json";

    /// Reads every record of DIR/journal.jsonl (creating DIR when needed) into `operations` and
    /// opens the file for appending.
    ///
    /// A damaged last record (torn by a crash or a full disk: no newline, a wrong length, not
    /// JSON; or a checksum that fails) is moved aside, not dropped: its bytes are copied to
    /// DIR/journal.corrupt-<UTC time> (fsynced) and the journal is truncated to its last good
    /// record; `recoveryReport` then says so (file, line, reason, the aside file), else it is
    /// left empty. Damage before the last record cannot be a crash: InvalidFile naming the file,
    /// line and reason, and the file is left untouched.
    static Result<Journal> open(const std::filesystem::path& dir,
                                std::vector<nlohmann::json>* operations,
                                std::string* recoveryReport);
    /// DIR/snapshot.jsonl's state, or nullopt when there is none. InvalidFile when it exists but
    /// is damaged (it is written atomically, so that is not a crash).
    static Result<std::optional<nlohmann::json>> readSnapshot(const std::filesystem::path& dir);

    /// The version DIR/rig.json records; nullopt when there is no rig.json. InvalidFile when it
    /// cannot be read as a rig with a version (a crash can leave it empty: it is not fsynced).
    static Result<std::optional<uint64_t>> savedRigVersion(const std::filesystem::path& dir);

    Journal(Journal&&) noexcept;
    Journal& operator=(Journal&&) noexcept;
    ~Journal();

    /// Appends one operation as a record and waits until it is on disk. IoError on failure:
    /// the caller must then refuse the change it describes. A failed or short write (or a failed
    /// fdatasync) is rolled back to the end of the last good record, so that the file never
    /// holds a fragment followed by good records; if even that fails, every later append is
    /// refused until a rollback succeeds.
    Status append(const nlohmann::json& operation);
    /// Replaces DIR/snapshot.jsonl atomically and durably (temp file, fsync, rename, fsync of
    /// DIR) by one record holding `state`.
    Status writeSnapshot(const nlohmann::json& state);
    /// Replaces the journal atomically and durably by one holding `operations` (the first one a
    /// {"op": "snapshot", "v"} that a snapshot on disk continues), and appends to it from then
    /// on. If the new file cannot be written the old journal stays in use; if it was written but
    /// cannot be reopened, appends are refused (IoError) until the session is reopened. Nothing
    /// acknowledged is lost either way.
    Status compact(const std::vector<nlohmann::json>& operations);
    /// Writes `data` to `path` so that after a crash `path` holds either its old content or all
    /// of `data` (temp file, fsync, rename, fsync of the folder); the session library's files.
    static Status writeFileDurably(const std::filesystem::path& path, std::string_view data);
    /// Reads a whole file of at most `maxBytes` (the session's own records and images: a larger
    /// one is not one the server wrote, refused with LimitExceeded instead of read into memory).
    /// Error messages do not repeat the path: callers name the file.
    static Result<std::string> readFileBounded(const std::filesystem::path& path, uintmax_t maxBytes);
    /// readFileBounded, parsed as JSON ("not JSON" when it is not): the library's, the
    /// annotations' and the tokens' records.
    static Result<nlohmann::json> readJsonBounded(const std::filesystem::path& path, uintmax_t maxBytes);
    /// Now, UTC, ISO 8601 to the second ("2026-12-05T19:47:41Z"): the time of library entries and
    /// annotations.
    static std::string utcTimestamp();
    /// Replaces DIR/rig.json atomically (not durably: a restart trusts the journal, not it).
    Status saveRig(const nlohmann::json& rig);

    const std::filesystem::path& dir() const { return mDir; }
    /// Records in the journal file (the first one, base or snapshot, included).
    size_t records() const { return mRecords; }

    /// Tests only: after `bytes` more bytes of journal appends, write() fails with ENOSPC (a
    /// record crossing the limit is written in part first, as a full disk does). NO_LIMIT turns
    /// it off. Process-wide; not for concurrent tests.
    static constexpr size_t NO_LIMIT = SIZE_MAX;
    static void failWritesAfterBytesForTesting(size_t bytes);

private:
    Journal() = default;
    // Truncates back to mGoodBytes after a failed append; false if the fragment remains.
    bool rollBack();

    std::filesystem::path mDir;
    int mFd = -1;
    uint64_t mGoodBytes = 0;     ///< size of the file up to the end of its last good record
    bool mNeedsRollBack = false; ///< a failed append's fragment could not be cut off yet
    size_t mRecords = 0;
};

} // namespace dfb
