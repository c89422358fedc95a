#pragma once
// Test support: runs a real program (server, client, bake) as a child process, reads its output,
// and always stops it when the test ends (no orphaned servers on loopback).

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include <fcntl.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

namespace dfb::test {

class Process {
public:
    /// Starts argv[0] with arguments; stdout and stderr are captured together.
    explicit Process(std::vector<std::string> argv) {
        int fds[2];
        if (::pipe(fds) != 0) return;
        mPid = ::fork();
        if (mPid == 0) {
            ::dup2(fds[1], 1);
            ::dup2(fds[1], 2);
            ::close(fds[0]);
            ::close(fds[1]);
            std::vector<char*> args;
            for (auto& a : argv) args.push_back(a.data());
            args.push_back(nullptr);
            ::execv(args[0], args.data());
            std::perror("execv");
            ::_exit(127);
        }
        ::close(fds[1]);
        mOut = fds[0];
    }
    ~Process() { stop(); }
    Process(const Process&) = delete;
    Process& operator=(const Process&) = delete;

    bool started() const { return mPid > 0; }
    pid_t pid() const { return mPid; }

    /// Reads output until `pattern` matches a line or the timeout passes; returns the match.
    std::optional<std::smatch> waitForLine(const std::regex& pattern, std::chrono::milliseconds timeout) {
        const auto deadline = std::chrono::steady_clock::now() + timeout;
        size_t scanned = 0;
        for (;;) {
            size_t nl;
            while ((nl = mOutput.find('\n', scanned)) != std::string::npos) {
                mLine = mOutput.substr(scanned, nl - scanned);
                scanned = nl + 1;
                std::smatch m;
                if (std::regex_search(mLine, m, pattern)) return m;
            }
            const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
            if (left.count() <= 0 || !readSome(int(left.count()))) return std::nullopt;
        }
    }

    /// Waits for exit (killing it after the timeout); returns the exit code, or -1 if killed.
    int wait(std::chrono::milliseconds timeout) {
        const auto deadline = std::chrono::steady_clock::now() + timeout;
        while (std::chrono::steady_clock::now() < deadline) {
            int status = 0;
            readSome(20);
            if (::waitpid(mPid, &status, WNOHANG) == mPid) {
                while (readSome(0)) {}
                mPid = -1;
                return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
            }
        }
        stop();
        return -1;
    }

    void stop() {
        if (mPid > 0) {
            ::kill(mPid, SIGTERM);
            for (int i = 0; i < 100; ++i) {
                if (::waitpid(mPid, nullptr, WNOHANG) == mPid) { mPid = -1; break; }
                ::usleep(20000);
            }
            if (mPid > 0) {
                ::kill(mPid, SIGKILL);
                ::waitpid(mPid, nullptr, 0);
                mPid = -1;
            }
        }
        if (mOut >= 0) { ::close(mOut); mOut = -1; }
    }

    const std::string& output() const { return mOutput; }

    /// Sends `sig` (e.g. SIGKILL) and reaps the process without reading more output.
    void kill(int sig) {
        if (mPid <= 0) return;
        ::kill(mPid, sig);
        ::waitpid(mPid, nullptr, 0);
        mPid = -1;
    }

private:
    bool readSome(int timeoutMs) {
        if (mOut < 0) return false;
        pollfd p{mOut, POLLIN, 0};
        if (::poll(&p, 1, timeoutMs) <= 0) return false;
        char buf[4096];
        const ssize_t n = ::read(mOut, buf, sizeof buf);
        if (n <= 0) return false;
        mOutput.append(buf, size_t(n));
        return true;
    }

    pid_t mPid = -1;
    int mOut = -1;
    std::string mOutput;
    std::string mLine;
};

/// Runs a program to completion and returns {exit code, output}.
inline std::pair<int, std::string> run(std::vector<std::string> argv, std::chrono::milliseconds timeout = std::chrono::seconds(120)) {
    Process p(std::move(argv));
    const int rc = p.wait(timeout);
    return {rc, p.output()};
}

} // namespace dfb::test
