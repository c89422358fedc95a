#pragma once
// A fixed set of worker threads for short data-parallel jobs on the frame path (JPEG strips, the
// read-back copy): starting a thread per piece per frame cost as much as the piece.

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace dfb {

class WorkerPool {
public:
    /// The process's pool: one worker per hardware thread but one (at most 15), started on first use.
    static WorkerPool& shared();
    /// Runs f(i) for every i in [0, n) on the workers and the calling thread; returns when all have
    /// run. May be called from several threads at once: a caller runs queued pieces itself while it
    /// waits, so every call progresses even when all workers are busy.
    void run(int n, const std::function<void(int)>& f);

    WorkerPool(const WorkerPool&) = delete;
    WorkerPool& operator=(const WorkerPool&) = delete;

private:
    WorkerPool();
    ~WorkerPool();
    std::mutex mMutex;
    std::condition_variable mWork, mDone;
    std::deque<std::function<void()>> mTasks;
    std::vector<std::thread> mWorkers;
    bool mStop = false;
};

} // namespace dfb
