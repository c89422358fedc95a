#include "session/Journal.h"

#include <dfb/protocol/Messages.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <utility>

#include <fcntl.h>
#include <unistd.h>

namespace dfb {
namespace {

Error ioError(const std::filesystem::path& p, const std::string& what) {
    return makeError(ErrorCode::IoError, p.string() + ": " + what + ": " + std::strerror(errno));
}

Status writeAll(int fd, const std::string& data, const std::filesystem::path& p) {
    size_t done = 0;
    while (done < data.size()) {
        const ssize_t n = ::write(fd, data.data() + done, data.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return ioError(p, "write");
        done += size_t(n);
    }
    return okStatus();
}

} // namespace

Journal::Journal(Journal&& o) noexcept : mDir(std::move(o.mDir)), mFd(std::exchange(o.mFd, -1)) {}
Journal& Journal::operator=(Journal&& o) noexcept {
    if (this != &o) {
        if (mFd >= 0) ::close(mFd);
        mDir = std::move(o.mDir);
        mFd = std::exchange(o.mFd, -1);
    }
    return *this;
}
Journal::~Journal() {
    if (mFd >= 0) ::close(mFd);
}

Result<Journal> Journal::open(const std::filesystem::path& dir, std::vector<nlohmann::json>* operations) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) return makeError(ErrorCode::IoError, dir.string() + ": cannot create the session directory: " + ec.message());
    const auto path = dir / "journal.jsonl";
    operations->clear();
    size_t goodBytes = 0;
    bool truncate = false;
    if (std::filesystem::exists(path)) {
        std::ifstream in(path, std::ios::binary);
        std::stringstream ss;
        ss << in.rdbuf();
        const std::string text = ss.str();
        size_t pos = 0, lineNo = 0;
        while (pos < text.size()) {
            ++lineNo;
            const size_t nl = text.find('\n', pos);
            const bool last = nl == std::string::npos || text.find_first_not_of(" \r\n\t", nl + 1) == std::string::npos;
            auto j = nlohmann::json::parse(text.substr(pos, nl == std::string::npos ? std::string::npos : nl - pos), nullptr, false);
            const bool ok = nl != std::string::npos && !j.is_discarded() && j.is_object() && j.contains("op");
            if (!ok) {
                if (!last) {
                    return makeError(ErrorCode::InvalidFile, path.string() + ":" + std::to_string(lineNo) +
                                                                 ": not a journal operation; the journal is damaged (left untouched)");
                }
                truncate = true; // a write cut short by a crash: never acknowledged
                break;
            }
            operations->push_back(std::move(j));
            pos = nl + 1;
            goodBytes = pos;
        }
        if (!truncate && goodBytes < text.size()) truncate = true; // trailing blank space
    }
    Journal jr;
    jr.mDir = dir;
    jr.mFd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (jr.mFd < 0) return ioError(path, "cannot open the journal");
    if (truncate && ::ftruncate(jr.mFd, off_t(goodBytes)) != 0) return ioError(path, "cannot drop the incomplete last line");
    // The directory entry of a new journal must survive a crash too.
    if (int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); dfd >= 0) {
        ::fsync(dfd);
        ::close(dfd);
    }
    return jr;
}

Status Journal::append(const nlohmann::json& operation) {
    const auto path = mDir / "journal.jsonl";
    // One write() of the whole line: with O_APPEND a crash leaves at most one incomplete last line.
    if (auto s = writeAll(mFd, protocol::dump(operation) + "\n", path); !s) return s;
    if (::fdatasync(mFd) != 0) return ioError(path, "fdatasync");
    return okStatus();
}

Status Journal::saveRig(const nlohmann::json& rig) {
    const auto path = mDir / "rig.json", tmp = mDir / "rig.json.tmp";
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return ioError(tmp, "cannot create");
    Status s = writeAll(fd, protocol::dump(rig, 2) + "\n", tmp);
    // No fsync here: the journal, not rig.json, is what a restart trusts.
    ::close(fd);
    if (!s) return s;
    if (std::rename(tmp.c_str(), path.c_str()) != 0) return ioError(path, "rename");
    return okStatus();
}

} // namespace dfb
