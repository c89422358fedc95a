#include "session/Lease.h"

#include "session/Journal.h"

#include <cerrno>
#include <cstring>
#include <string>

#include <fcntl.h>
#include <unistd.h>

namespace dfb {

namespace fs = std::filesystem;

namespace {

// The whole file, exclusively (l_pid must be 0 for open-file-description locks).
struct flock wholeFile(short type) {
    struct flock fl {};
    fl.l_type = type;
    fl.l_whence = SEEK_SET;
    fl.l_start = 0;
    fl.l_len = 0;
    return fl;
}

// The holder's record: "NODE PID UTC-TIME" on one line, written after the lock is taken (for
// people and for the `moved` error; the lock, not this text, is what counts).
std::string readHolder(int fd) {
    char buf[256];
    const ssize_t n = ::pread(fd, buf, sizeof buf - 1, 0);
    if (n <= 0) return "another node";
    std::string text(buf, size_t(n));
    const size_t end = text.find_first_of(" \n");
    text = text.substr(0, end);
    return text.empty() ? "another node" : text;
}

} // namespace

Result<std::unique_ptr<Lease>> Lease::take(const fs::path& dir, const std::string& node) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    const fs::path path = dir / FILE_NAME;
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) return makeError(ErrorCode::IoError, path.string() + ": cannot open the session's lease: " + std::strerror(errno));
    struct flock fl = wholeFile(F_WRLCK);
    if (::fcntl(fd, F_OFD_SETLK, &fl) != 0) {
        const int err = errno;
        if (err == EAGAIN || err == EACCES) {
            const std::string who = readHolder(fd);
            ::close(fd);
            return makeError(ErrorCode::Moved, "session '" + dir.filename().string() + "' is open on " + who +
                                                   " (it holds the session's lease); retry through the router");
        }
        ::close(fd);
        return makeError(ErrorCode::IoError, path.string() + ": cannot lock the session's lease: " + std::strerror(err));
    }
    const std::string record = node + " " + std::to_string(::getpid()) + " " + Journal::utcTimestamp() + "\n";
    if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, record.data(), record.size(), 0) != ssize_t(record.size())) {
        // The lock is what counts; the record is for people. Keep the lease.
    }
    return std::unique_ptr<Lease>(new Lease(dir, fd));
}

std::string Lease::holder(const fs::path& dir) {
    const fs::path path = dir / FILE_NAME;
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return "";
    struct flock fl = wholeFile(F_WRLCK);
    std::string who;
    if (::fcntl(fd, F_OFD_GETLK, &fl) == 0 && fl.l_type != F_UNLCK) who = readHolder(fd);
    ::close(fd);
    return who;
}

Lease::~Lease() {
    if (mFd >= 0) ::close(mFd);
}

} // namespace dfb
