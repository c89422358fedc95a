#include "WorkerPool.h"

#include <algorithm>
#include <atomic>

namespace dfb {

WorkerPool& WorkerPool::shared() {
    static WorkerPool pool;
    return pool;
}

WorkerPool::WorkerPool() {
    const unsigned n = std::min(std::max(2u, std::thread::hardware_concurrency()), 16u) - 1;
    for (unsigned i = 0; i < n; ++i) {
        mWorkers.emplace_back([this] {
            std::unique_lock<std::mutex> lock(mMutex);
            for (;;) {
                mWork.wait(lock, [this] { return mStop || !mTasks.empty(); });
                if (mStop) return;
                auto task = std::move(mTasks.front());
                mTasks.pop_front();
                lock.unlock();
                task();
                lock.lock();
            }
        });
    }
}

WorkerPool::~WorkerPool() {
    {
        std::lock_guard<std::mutex> lock(mMutex);
        mStop = true;
    }
    mWork.notify_all();
    for (std::thread& t : mWorkers) t.join();
}

void WorkerPool::run(int n, const std::function<void(int)>& f) {
    if (n <= 0) return;
    std::atomic<int> left{n - 1};
    {
        std::lock_guard<std::mutex> lock(mMutex);
        for (int i = 1; i < n; ++i) {
            mTasks.push_back([&f, &left, i, this] {
                f(i);
                if (left.fetch_sub(1) == 1) {
                    std::lock_guard<std::mutex> done(mMutex);
                    mDone.notify_all();
                }
            });
        }
    }
    mWork.notify_all();
    f(0);
    std::unique_lock<std::mutex> lock(mMutex);
    while (left.load() > 0) {
        if (!mTasks.empty()) {
            auto task = std::move(mTasks.front());
            mTasks.pop_front();
            lock.unlock();
            task();
            lock.lock();
        } else {
            mDone.wait(lock);
        }
    }
}

} // namespace dfb
