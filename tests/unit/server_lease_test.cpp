// A session's lease (server/src/session/Lease.h) on the local filesystem: exclusive, named in the
// refusal, released when its holder lets go of it and when the holding process dies, however it
// dies (the kernel drops fcntl locks: how a fleet survives a SIGKILLed node).

#include "session/Lease.h"

#include <gtest/gtest.h>

#include <csignal>
#include <filesystem>
#include <fstream>

#include <sys/wait.h>
#include <unistd.h>

namespace {

namespace fs = std::filesystem;
using dfb::ErrorCode;
using dfb::Lease;

struct LeaseDir : ::testing::Test {
    fs::path dir = fs::temp_directory_path() / ("dfb_lease_" + std::to_string(::getpid()) + "_" +
                                                ::testing::UnitTest::GetInstance()->current_test_info()->name()) / "s1";
    ~LeaseDir() override { fs::remove_all(dir.parent_path()); }
};

TEST_F(LeaseDir, OneHolderAtATimeNamedInTheRefusal) {
    auto first = Lease::take(dir, "node-a");
    ASSERT_TRUE(first) << first.error().toString();
    EXPECT_EQ(Lease::holder(dir), "node-a");
    // Another open of the same process is refused too (open-file-description locks).
    auto second = Lease::take(dir, "node-b");
    ASSERT_FALSE(second);
    EXPECT_EQ(second.error().code, ErrorCode::Moved);
    EXPECT_NE(second.error().message.find("node-a"), std::string::npos) << second.error().message;
    EXPECT_NE(second.error().message.find("'s1'"), std::string::npos) << second.error().message;
    // Looking at the holder does not release the lease (a classic POSIX lock would go with the
    // descriptor holder() closes).
    EXPECT_FALSE(Lease::take(dir, "node-b"));
    first.value().reset();
    EXPECT_EQ(Lease::holder(dir), "");
    auto third = Lease::take(dir, "node-b");
    ASSERT_TRUE(third);
    EXPECT_EQ(Lease::holder(dir), "node-b");
}

TEST_F(LeaseDir, ADeadHoldersLeaseIsFree) {
    int ready[2];
    ASSERT_EQ(::pipe(ready), 0);
    const pid_t child = ::fork();
    if (child == 0) {
        auto held = Lease::take(dir, "doomed");
        const char c = held ? 'y' : 'n';
        (void)!::write(ready[1], &c, 1);
        ::pause(); // until killed: the lease is never released by the program
        ::_exit(0);
    }
    char c = 0;
    ASSERT_EQ(::read(ready[0], &c, 1), 1);
    ASSERT_EQ(c, 'y');
    EXPECT_EQ(Lease::holder(dir), "doomed");
    auto refused = Lease::take(dir, "survivor");
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().code, ErrorCode::Moved);
    ::kill(child, SIGKILL);
    ::waitpid(child, nullptr, 0);
    auto taken = Lease::take(dir, "survivor");
    ASSERT_TRUE(taken) << taken.error().toString();
    EXPECT_EQ(Lease::holder(dir), "survivor");
    ::close(ready[0]);
    ::close(ready[1]);
}

TEST_F(LeaseDir, AnUnusableFolderIsAnIoErrorNotMoved) {
    fs::create_directories(dir.parent_path());
    std::ofstream(dir.string()) << "a file where the session's folder should be";
    auto r = Lease::take(dir, "n");
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().code, ErrorCode::IoError);
    EXPECT_NE(r.error().message.find("lease"), std::string::npos) << r.error().message;
}

} // namespace
