#pragma once
// A session's lease: the right of one node of a fleet to serve a session whose state folder is on
// a filesystem shared by all nodes (docs/deployment.md "Leases"). It is an exclusive fcntl record
// lock on STATE/SESSION/lease, taken before the journal is replayed and held while the session is
// open, so two nodes never write the same journal.
//
// Why fcntl locks: the kernel releases them when the holder dies, however it dies (SIGKILL, OOM),
// so a crashed node never leaves a session locked; and NFSv4 and CephFS implement them across
// machines (flock() is only emulated on some NFS clients). They are open-file-description locks
// (F_OFD_SETLK, Linux >= 3.15) rather than classic per-process ones: a classic lock is dropped
// when the process closes *any* descriptor of the file, and one process cannot see its own lock
// with F_GETLK, both of which a server holding many sessions would trip over. On NFS the client
// sends them to the server as ordinary POSIX locks.

#include <dfb/core/Result.h>

#include <filesystem>
#include <memory>
#include <string>

namespace dfb {

class Lease {
public:
    /// The lease file in a session's state folder.
    static constexpr const char* FILE_NAME = "lease";
    /// Another node asks the holder to hand the session over by creating this file beside the
    /// lease (SharedState's housekeeping closes the session when it sees it).
    static constexpr const char* HANDOFF_FILE_NAME = "handoff";

    /// Takes the lease of the session whose state folder is `dir` (created if missing) for node
    /// `node`, without waiting. Moved, naming the holder, when another node (or another open of
    /// this process) holds it; IoError when the folder or file cannot be used.
    static Result<std::unique_ptr<Lease>> take(const std::filesystem::path& dir, const std::string& node);
    /// The node that holds the lease of `dir`, or "" when nobody does (a lock test; it takes
    /// nothing).
    static std::string holder(const std::filesystem::path& dir);

    /// Releases the lease (closing the descriptor releases the lock).
    ~Lease();
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;

    const std::filesystem::path& dir() const { return mDir; }

private:
    Lease(std::filesystem::path dir, int fd) : mDir(std::move(dir)), mFd(fd) {}
    std::filesystem::path mDir;
    int mFd = -1;
};

} // namespace dfb
