#include "session/Journal.h"

#include <dfb/protocol/Messages.h>

#include <boost/crc.hpp>

#include <atomic>
#include <chrono>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>
#include <utility>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace dfb {

uint32_t crc32c(std::string_view bytes) {
    // Castagnoli's polynomial: better error detection than zlib's for short records, and what
    // ext4, iSCSI and LevelDB's log use.
    boost::crc_optimal<32, 0x1EDC6F41, 0xFFFFFFFF, 0xFFFFFFFF, true, true> crc;
    crc.process_bytes(bytes.data(), bytes.size());
    return crc.checksum();
}

namespace {
using json = nlohmann::json;

std::atomic<size_t> gWriteBudgetForTesting{Journal::NO_LIMIT};

Error ioError(const std::filesystem::path& p, const std::string& what, int err = errno) {
    return makeError(ErrorCode::IoError, p.string() + ": " + what + ": " + std::strerror(err));
}

// With a budget (tests only), writes stop part way through with ENOSPC, as on a full disk.
Status writeAll(int fd, std::string_view data, const std::filesystem::path& p,
                bool budgeted = false) {
    size_t done = 0;
    while (done < data.size()) {
        size_t want = data.size() - done;
        if (budgeted) {
            const size_t budget = gWriteBudgetForTesting.load();
            if (budget == 0)
                return ioError(p, "write", ENOSPC);
            if (budget != Journal::NO_LIMIT)
                want = std::min(want, budget);
        }
        const ssize_t n = ::write(fd, data.data() + done, want);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return ioError(p, "write");
        if (budgeted && gWriteBudgetForTesting.load() != Journal::NO_LIMIT)
            gWriteBudgetForTesting -= size_t(n);
        done += size_t(n);
    }
    return okStatus();
}

Status syncDir(const std::filesystem::path& dir) {
    const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd < 0)
        return ioError(dir, "cannot open the directory to sync it");
    const int rc = ::fsync(dfd);
    const int err = errno;
    ::close(dfd);
    if (rc != 0)
        return ioError(dir, "fsync of the directory", err);
    return okStatus();
}

// Writes `data` to `path` so that after a crash `path` holds either its old content or all of
// `data`: temp file, fsync, rename, fsync of the directory.
Status replaceDurably(const std::filesystem::path& path, std::string_view data) {
    const auto tmp = std::filesystem::path(path.string() + ".tmp");
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0)
        return ioError(tmp, "cannot create");
    Status s = writeAll(fd, data, tmp);
    if (s && ::fsync(fd) != 0)
        s = ioError(tmp, "fsync");
    ::close(fd);
    if (s && std::rename(tmp.c_str(), path.c_str()) != 0)
        s = ioError(path, "rename");
    if (!s) {
        ::unlink(tmp.c_str());
        return s;
    }
    return syncDir(path.parent_path());
}

std::string formatRecord(const json& op) {
    const std::string text = protocol::dump(op);
    char head[32];
    std::snprintf(head, sizeof head, "%zu %08x ", text.size(), unsigned(crc32c(text)));
    return head + text + "\n";
}

// The one place journal and snapshot JSON is parsed: depth-limited like every other input (a
// journal holds what clients sent; a value nested deeper than any edit could be would crash
// the replay). One record is at most a whole session snapshot: undo steps of whole rigs.
constexpr size_t MAX_RECORD_BYTES = size_t(1) << 31;

json parseRecordJson(std::string_view text) {
    auto j = protocol::parseJson(text, MAX_RECORD_BYTES, "journal record");
    return j ? std::move(j.value()) : json(json::value_t::discarded);
}

// One line without its newline: the reason it is not a good record, or empty with `*out` set.
std::string parseRecord(std::string_view line, json* out) {
    if (line.empty())
        return "empty line";
    std::string_view text;
    if (line[0] == '{') {
        text = line; // written before records had a checksum
    } else {
        size_t length = 0;
        auto [p, ec] = std::from_chars(line.data(), line.data() + line.size(), length);
        const char* end = line.data() + line.size();
        if (ec != std::errc() || p == line.data() || p >= end || *p != ' ')
            return "bad record header (expected '<length> <crc32c> <json>')";
        ++p;
        uint32_t crc = 0;
        auto [q, ec2] = std::from_chars(p, end, crc, 16);
        if (ec2 != std::errc() || q - p != 8 || q >= end || *q != ' ')
            return "bad record header (expected '<length> <crc32c> <json>')";
        text = std::string_view(q + 1, size_t(end - (q + 1)));
        if (text.size() != length) {
            return "length mismatch (the header says " + std::to_string(length) +
                   " bytes, the record has " + std::to_string(text.size()) + ")";
        }
        if (const uint32_t actual = crc32c(text); actual != crc) {
            char msg[96];
            std::snprintf(msg, sizeof msg,
                          "checksum mismatch (the header says %08x, the record's is %08x)",
                          unsigned(crc), unsigned(actual));
            return msg;
        }
    }
    json j = parseRecordJson(text);
    if (j.is_discarded())
        return "not JSON";
    if (!j.is_object() || !j.contains("op") || !j["op"].is_string())
        return "not a journal operation";
    *out = std::move(j);
    return {};
}

Result<std::string> readFile(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    if (!in)
        return makeError(ErrorCode::IoError, p.string() + ": cannot read");
    std::stringstream ss;
    ss << in.rdbuf();
    if (in.bad())
        return makeError(ErrorCode::IoError, p.string() + ": read failed");
    return ss.str();
}

std::string utcStamp() {
    const std::time_t now = std::time(nullptr);
    std::tm tm{};
    ::gmtime_r(&now, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y%m%dT%H%M%SZ", &tm);
    return buf;
}

// Copies `bytes` to a new DIR/journal.corrupt-<UTC>[-N] (never overwriting one) and syncs it.
Result<std::filesystem::path> moveAside(const std::filesystem::path& dir, std::string_view bytes) {
    const std::string stem = "journal.corrupt-" + utcStamp();
    for (int n = 0; n < 1000; ++n) {
        const auto p = dir / (n == 0 ? stem : stem + "-" + std::to_string(n));
        const int fd = ::open(p.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
        if (fd < 0 && errno == EEXIST)
            continue;
        if (fd < 0)
            return ioError(p, "cannot create");
        Status s = writeAll(fd, bytes, p);
        if (s && ::fsync(fd) != 0)
            s = ioError(p, "fsync");
        ::close(fd);
        if (!s)
            return s.error();
        if (auto d = syncDir(dir); !d)
            return d.error();
        return p;
    }
    return makeError(ErrorCode::IoError, (dir / stem).string() + ": too many files of that name");
}

} // namespace

void Journal::failWritesAfterBytesForTesting(size_t bytes) {
    gWriteBudgetForTesting = bytes;
}

Journal::Journal(Journal&& o) noexcept
    : mDir(std::move(o.mDir)), mFd(std::exchange(o.mFd, -1)), mGoodBytes(o.mGoodBytes),
      mNeedsRollBack(o.mNeedsRollBack), mRecords(o.mRecords) {}
Journal& Journal::operator=(Journal&& o) noexcept {
    if (this != &o) {
        if (mFd >= 0) ::close(mFd);
        mDir = std::move(o.mDir);
        mFd = std::exchange(o.mFd, -1);
        mGoodBytes = o.mGoodBytes;
        mNeedsRollBack = o.mNeedsRollBack;
        mRecords = o.mRecords;
    }
    return *this;
}
Journal::~Journal() {
    if (mFd >= 0) ::close(mFd);
}

Result<Journal> Journal::open(const std::filesystem::path& dir, std::vector<json>* operations,
                              std::string* recoveryReport) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) return makeError(ErrorCode::IoError, dir.string() + ": cannot create the session directory: " + ec.message());
    const auto path = dir / JOURNAL_FILE;
    operations->clear();
    recoveryReport->clear();
    size_t goodBytes = 0;
    std::string text;
    if (std::filesystem::exists(path)) {
        auto t = readFile(path);
        if (!t)
            return t.error();
        text = std::move(t.value());
    }
    size_t pos = 0, lineNo = 0;
    std::string reason;
    while (pos < text.size()) {
        ++lineNo;
        const size_t nl = text.find('\n', pos);
        json op;
        if (nl == std::string::npos)
            reason = "torn record (no newline at the end)";
        else
            reason = parseRecord(std::string_view(text).substr(pos, nl - pos), &op);
        if (!reason.empty())
            break;
        operations->push_back(std::move(op));
        pos = nl + 1;
        goodBytes = pos;
    }
    if (!reason.empty()) {
        const size_t nl = text.find('\n', pos);
        const bool last = nl == std::string::npos || nl + 1 == text.size();
        const std::string where = path.string() + ":" + std::to_string(lineNo) + ": ";
        if (!last) {
            return makeError(
                ErrorCode::InvalidFile,
                where + reason +
                    ", followed by more records: the journal is damaged, not cut short by a "
                    "crash, and was left untouched (restore it from a backup, or remove the "
                    "damaged line by hand)");
        }
        auto aside = moveAside(dir, std::string_view(text).substr(goodBytes));
        if (!aside)
            return aside.error();
        // A torn record was never acknowledged (its fdatasync had not returned); a complete one
        // failing its checksum may have been: say which, so that the operator knows what to look
        // at.
        const bool torn = nl == std::string::npos;
        *recoveryReport = where + reason + ": the last record (" +
                          std::to_string(text.size() - goodBytes) + " bytes, " +
                          (torn ? "a write cut short, never acknowledged"
                                : "complete but damaged, possibly an acknowledged change") +
                          ") was moved to " + aside->string() +
                          " and the journal truncated to its " +
                          std::to_string(operations->size()) + " good records";
    }
    Journal jr;
    jr.mDir = dir;
    jr.mFd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (jr.mFd < 0) return ioError(path, "cannot open the journal");
    if (goodBytes < text.size()) {
        if (::ftruncate(jr.mFd, off_t(goodBytes)) != 0)
            return ioError(path, "cannot truncate to the last good record");
        if (::fdatasync(jr.mFd) != 0)
            return ioError(path, "fdatasync");
    }
    jr.mGoodBytes = goodBytes;
    jr.mRecords = operations->size();
    // The directory entry of a new journal must survive a crash too.
    if (auto s = syncDir(dir); !s)
        return s.error();
    return jr;
}

Result<std::optional<json>> Journal::readSnapshot(const std::filesystem::path& dir) {
    const auto path = dir / SNAPSHOT_FILE;
    if (!std::filesystem::exists(path))
        return std::optional<json>();
    auto text = readFile(path);
    if (!text)
        return text.error();
    const std::string& t = text.value();
    json state;
    std::string reason;
    if (t.empty() || t.back() != '\n' || t.find('\n') != t.size() - 1)
        reason = "not one record";
    else
        reason = parseRecord(std::string_view(t).substr(0, t.size() - 1), &state);
    if (reason.empty() && state.value("op", "") != "state")
        reason = "not a session snapshot";
    if (!reason.empty()) {
        return makeError(
            ErrorCode::InvalidFile,
            path.string() + ":1: " + reason +
                ": the snapshot is damaged (it is written atomically, so this is not a crash); "
                "left untouched");
    }
    return std::optional<json>(std::move(state));
}

Result<std::optional<uint64_t>> Journal::savedRigVersion(const std::filesystem::path& dir) {
    const auto path = dir / RIG_FILE;
    if (!std::filesystem::exists(path))
        return std::optional<uint64_t>();
    auto text = readFile(path);
    if (!text)
        return text.error();
    const json j = parseRecordJson(text.value());
    if (!j.is_object() || !j.contains("version") || !j["version"].is_number_unsigned()) {
        return makeError(ErrorCode::InvalidFile, path.string() + ": not a rig with a version");
    }
    return std::optional<uint64_t>(j["version"].get<uint64_t>());
}

bool Journal::rollBack() {
    if (mFd < 0)
        return false;
    if (::ftruncate(mFd, off_t(mGoodBytes)) != 0 || ::fdatasync(mFd) != 0) {
        mNeedsRollBack = true;
        return false;
    }
    mNeedsRollBack = false;
    return true;
}

Status Journal::append(const json& operation) {
    const auto path = mDir / JOURNAL_FILE;
    if (mFd < 0)
        return makeError(ErrorCode::IoError,
                         path.string() +
                             ": the journal is not open (an earlier compaction failed)");
    if (mNeedsRollBack && !rollBack()) {
        return ioError(
            path, "a failed write's fragment still cannot be cut off; refusing to append after it");
    }
    const std::string record = formatRecord(operation);
    // One write() of the whole record: with O_APPEND a crash leaves at most one incomplete last
    // record, which open() moves aside. A failure here is undone at once, because later records
    // appended after a fragment would make the journal unreadable.
    Status s = writeAll(mFd, record, path, true);
    if (s && ::fdatasync(mFd) != 0)
        s = ioError(path, "fdatasync");
    if (!s) {
        if (!rollBack()) {
            return makeError(ErrorCode::IoError,
                             s.error().message + "; and the partial record could not be cut off (" +
                                 std::strerror(errno) +
                                 "): later changes are refused until it can");
        }
        return s;
    }
    mGoodBytes += record.size();
    ++mRecords;
    return okStatus();
}

Status Journal::writeSnapshot(const json& state) {
    return replaceDurably(mDir / SNAPSHOT_FILE, formatRecord(state));
}

Status Journal::compact(const std::vector<json>& operations) {
    std::string text;
    for (const json& op : operations)
        text += formatRecord(op);
    const auto path = mDir / JOURNAL_FILE;
    if (auto s = replaceDurably(path, text); !s)
        return s;
    // The old descriptor still names the replaced file: appends must go to the new one.
    if (mFd >= 0)
        ::close(mFd);
    mFd = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
    if (mFd < 0)
        return ioError(path, "cannot reopen the compacted journal");
    mGoodBytes = text.size();
    mNeedsRollBack = false;
    mRecords = operations.size();
    return okStatus();
}

Status Journal::saveRig(const json& rig) {
    const auto path = mDir / RIG_FILE, tmp = mDir / (std::string(RIG_FILE) + ".tmp");
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return ioError(tmp, "cannot create");
    Status s = writeAll(fd, protocol::dump(rig, 2) + "\n", tmp);
    // No fsync here: the journal, not rig.json, is what a restart trusts.
    ::close(fd);
    if (!s) return s;
    if (std::rename(tmp.c_str(), path.c_str()) != 0) return ioError(path, "rename");
    return okStatus();
}

Status Journal::writeFileDurably(const std::filesystem::path& path, std::string_view data) {
    return replaceDurably(path, data);
}

Result<std::string> Journal::readFileBounded(const std::filesystem::path& path, uintmax_t maxBytes) {
    std::error_code ec;
    const uintmax_t size = std::filesystem::file_size(path, ec);
    if (ec) return makeError(ErrorCode::FileNotFound, ec.message());
    if (size > maxBytes) {
        return makeError(ErrorCode::LimitExceeded, "larger than " + std::to_string(maxBytes >> 20) + " MiB");
    }
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    if (!in.good() && !in.eof()) return makeError(ErrorCode::IoError, "cannot read");
    return text.str();
}

Result<nlohmann::json> Journal::readJsonBounded(const std::filesystem::path& path, uintmax_t maxBytes) {
    auto text = readFileBounded(path, maxBytes);
    if (!text) return text.error();
    nlohmann::json j = nlohmann::json::parse(text.value(), nullptr, false);
    if (j.is_discarded()) return makeError(ErrorCode::InvalidFile, "not JSON");
    return j;
}

std::string Journal::utcTimestamp() {
    const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

} // namespace dfb
