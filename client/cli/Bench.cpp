#include "Bench.h"

#include <dfb/core/Stats.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <thread>
#include <vector>

namespace dfb::cli {

// ---- bench ----------------------------------------------------------------------------------
// One editing client sends edits one after another; each waits for the first frame showing its
// version (edit-to-frame latency as this client sees it). The other clients only watch; for each
// edit, the time until every client had a frame showing it is reported too.
int bench(Client& cl, int edits, int clients, const std::string& lightName, int warmup) {
    using Clock = std::chrono::steady_clock;
    json welcome;
    auto editor = cl.connect(&welcome);
    const json rig = welcome["rig"];
    json light;
    for (const auto& l : rig["lights"]) {
        if (l.value("name", "") == lightName || (lightName.empty() && light.is_null())) light = l;
    }
    if (light.is_null()) die(EXIT_USAGE, "no light '" + lightName + "' in the rig");
    const std::string name = light["name"];
    const std::vector<double> p0 = light["position"].get<std::vector<double>>();

    struct Watcher {
        std::thread thread;
        std::unique_ptr<client::Connection> conn;
        std::mutex mutex;
        std::vector<std::pair<uint64_t, Clock::time_point>> frames; // (rig version, arrival)
        std::atomic<bool> stopping{false}, dead{false};
        std::string error;
        uint64_t newest() {
            std::lock_guard lock(mutex);
            return frames.empty() ? 0 : frames.back().first;
        }
    };
    std::vector<std::unique_ptr<Watcher>> watchers;
    std::atomic<int> ready{0};
    for (int i = 1; i < clients; ++i) {
        auto w = std::make_unique<Watcher>();
        json wel;
        w->conn = cl.connect(&wel);
        w->thread = std::thread([w = w.get(), &ready] {
            bool first = true;
            for (;;) {
                auto m = w->conn->receive();
                if (!m) {
                    if (!w->stopping) w->error = m.error().message; // read by main after join()
                    w->dead = true;
                    return;
                }
                if (auto* f = std::get_if<client::FrameMessage>(&m.value())) {
                    const auto now = Clock::now();
                    std::lock_guard lock(w->mutex);
                    w->frames.emplace_back(f->header.rigVersion, now);
                    if (first) {
                        first = false;
                        ++ready;
                    }
                }
            }
        });
        watchers.push_back(std::move(w));
    }
    // Everyone has its first frame before the clock starts.
    const auto readyBy = Clock::now() + cl.timeout();
    while (ready.load() < clients - 1 && Clock::now() < readyBy) std::this_thread::sleep_for(std::chrono::milliseconds(5));

    std::vector<double> mine, all;
    std::vector<std::pair<uint64_t, Clock::time_point>> sent;
    uint64_t seq = 0;
    for (int i = 0; i < warmup + edits; ++i) {
        // A small drag of the light: its shadow map is re-rendered every time, as in real use.
        const double dx = (i % 2 == 0 ? 0.05 : -0.05) * double(1 + i % 7);
        protocol::EditMessage e;
        e.seq = ++seq;
        e.changes.push_back({name + ".position", json::array({p0[0] + dx, p0[1], p0[2]})});
        const auto t0 = Clock::now();
        if (auto s = editor->sendText(protocol::encode(e)); !s) cl.fail(s.error());
        uint64_t version = ~0ull;
        for (;;) {
            auto m = editor->receive();
            if (!m) cl.fail(m.error());
            if (auto* t = std::get_if<client::TextMessage>(&m.value())) {
                const std::string type = t->json.value("type", "");
                if (type == "error") die(EXIT_REFUSED, "server refused the edit: " + t->json.dump());
                if (type == "ack" && t->json.value("seq", uint64_t(0)) == e.seq) version = t->json.value("rigVersion", uint64_t(0));
            } else if (auto* f = std::get_if<client::FrameMessage>(&m.value()); f && f->header.rigVersion >= version) {
                if (i >= warmup) {
                    mine.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
                    sent.emplace_back(version, t0);
                }
                break;
            }
        }
    }
    // Wait until every watcher has the last version (or the timeout), then stop them.
    const uint64_t finalVersion = sent.empty() ? 0 : sent.back().first;
    const auto doneBy = Clock::now() + cl.timeout();
    for (auto& w : watchers) {
        while (w->newest() < finalVersion && !w->dead && Clock::now() < doneBy) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    int failed = 0;
    for (auto& w : watchers) {
        w->stopping = true;
        w->conn->shutdown();
        w->thread.join();
        if (!w->error.empty()) {
            ++failed;
            std::cerr << "dfb-client: bench: a watching client: " << w->error << "\n";
        }
    }
    if (failed) die(EXIT_BROKEN, std::to_string(failed) + " watching client(s) lost their connection");
    for (const auto& [version, t0] : sent) {
        Clock::time_point last = t0;
        bool everyone = true;
        for (auto& w : watchers) {
            auto it = std::find_if(w->frames.begin(), w->frames.end(), [&](const auto& f) { return f.first >= version; });
            if (it == w->frames.end()) everyone = false;
            else last = std::max(last, it->second);
        }
        if (everyone) all.push_back(std::chrono::duration<double, std::milli>(last - t0).count());
    }
    // Mine is the editor's; "all" adds the watchers (equal to mine with one client).
    if (clients == 1) all = mine;
    std::printf("clients %d, edits %zu (after %d warm-up): edit-to-frame latency, ms\n", clients, mine.size(), warmup);
    std::printf("  %-22s p50 %8.1f  p95 %8.1f  p99 %8.1f  max %8.1f\n", "editing client", percentile(mine, 50), percentile(mine, 95),
                percentile(mine, 99), percentile(mine, 100));
    std::printf("  %-22s p50 %8.1f  p95 %8.1f  p99 %8.1f  max %8.1f\n", "all clients have it", percentile(all, 50), percentile(all, 95),
                percentile(all, 99), percentile(all, 100));
    return EXIT_OK;
}

} // namespace dfb::cli
