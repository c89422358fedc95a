// A bounded loopback load test (issue 14, point 2) at reduced scale: 32 editing clients of one
// session of the default scene, 10 edits per second each for 10 s, through dfb-load-bench. Every
// applied edit must be acknowledged to its sender, no client disconnected, every client must get
// frames. Timings are printed, never asserted (the full 64 x 10/s x 60 s run is the benchmark,
// docs/operations.md).

#include "support/Process.h"
#include "support/TestServer.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

using namespace dfb;
using json = nlohmann::json;

TEST(Load, ThirtyTwoEditorsAtTenEditsASecondAreAllAcknowledgedAndKeptConnected) {
    test::Server server({DFB_TEST_DATA "/tabletop_320.exr"});
    ASSERT_TRUE(server.up()) << server.process->output();
    const std::string url = "http://127.0.0.1:" + server.port + "/?session=tabletop_320&token=" + server.tokens["tabletop_320"].editor;
    auto [rc, out] = test::run({DFB_LOAD_BENCH_EXE, "--server", url, "--clients", "32", "--rate", "10", "--seconds", "10",
                                "--drain-seconds", "20", "--json"});
    ASSERT_EQ(rc, 0) << out;
    const size_t start = out.find("{\"");
    ASSERT_NE(start, std::string::npos) << out;
    const json r = json::parse(out.substr(start, out.find('\n', start) - start), nullptr, false);
    ASSERT_TRUE(r.is_object()) << out;
    std::printf("load: %d sent, %d acked, ack p50 %.1f p99 %.1f ms, edit->frame p50 %.1f p99 %.1f ms, fps per client min %.1f\n",
                r["sent"].get<int>(), r["acked"].get<int>(), r["ackMs"]["p50"].get<double>(), r["ackMs"]["p99"].get<double>(),
                r["frameMs"]["p50"].get<double>(), r["frameMs"]["p99"].get<double>(), r["fpsMin"].get<double>());
    EXPECT_EQ(r["sent"], 3200);
    EXPECT_EQ(r["acked"], r["sent"]);
    EXPECT_EQ(r["unanswered"], 0);
    EXPECT_EQ(r["appliedUnacked"], 0) << "edits applied whose ack never arrived";
    EXPECT_EQ(r["disconnects"], 0) << r["disconnected"];
    EXPECT_GT(r["framesPerClient"]["min"].get<int>(), 0);
    EXPECT_EQ(r["frameMs"]["neverSeen"], 0);
    // The server served everyone and is still up.
    EXPECT_EQ(server.get("/healthz", "").status, 200);
}
