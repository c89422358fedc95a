// dfb-load-bench: a loopback load generator for one session (issue 14, point 2).
//
// N editor clients connect over WebSocket, then each sends edits of one property at a fixed rate
// (open loop: the schedule does not wait for acks, as real editors dragging a slider do not), while
// reading everything the server sends. At the end it reports what came back: acks, errors, ack
// latency, edit-to-frame latency as each sender sees it, frames per client, lost connections and,
// optionally, the server's resident memory. It talks to the server over the network only; it
// shares nothing with the server but the protocol library.
//
// Threading: one io_context run by a few threads; every connection lives on its own strand, so its
// handlers never run concurrently and its state needs no lock. The main thread only reads a few
// atomic counters while the run lasts and reads the per-client records after the io threads have
// been joined.

#include <dfb/core/Version.h>
#include <dfb/protocol/Messages.h>
#include <dfb/core/Stats.h>
#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Json.h>

#include <utility> // before Boost 1.74's asio, which uses std::exchange without it

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include <dfb/core/CommandLine.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr int EXIT_OK = 0;
constexpr int EXIT_USAGE = 1;
constexpr int EXIT_NO_CONNECTION = 2;

// The server's text messages (a welcome with the largest rig) stay far below this; frames of a
// 4K EXR beauty with a few light layers stay below it too.
constexpr size_t MAX_MESSAGE_BYTES = 256u << 20;
// Connecting 64 clients to a busy server on a 2-core machine takes well under a second; this only
// bounds a server that accepts but never answers.
constexpr auto CONNECT_TIMEOUT = std::chrono::seconds(15);
// A server answers a close within a frame time; a stuck one must not keep the bench running.
constexpr auto CLOSE_TIMEOUT = std::chrono::seconds(5);
constexpr auto RSS_PERIOD = std::chrono::seconds(10);

double msBetween(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
}

// ---- command line and URL -----------------------------------------------------------------------

struct Options {
    std::string server;
    int clients = 64;
    double rate = 10;
    double seconds = 60;
    std::string path = "key.intensity";
    double drainSeconds = 10;
    int serverPid = 0;
    int threads = 2;
    bool json = false;
};

struct Url {
    std::string host, port, session, token;
};

// The editor link dfb-server prints: http://HOST:PORT/?session=ID&token=T (as dfb-client's
// parseUrl reads it, without IPv6 brackets or TLS, which a loopback bench does not need).
std::optional<Url> parseUrl(const std::string& text, std::string& why) {
    std::string rest = text;
    for (const char* scheme : {"http://", "ws://"}) {
        if (rest.rfind(scheme, 0) == 0)
            rest = rest.substr(std::strlen(scheme));
    }
    Url u;
    if (const size_t q = rest.find('?'); q != std::string::npos) {
        const std::string query = rest.substr(q + 1);
        rest = rest.substr(0, q);
        size_t start = 0;
        while (start <= query.size()) {
            size_t end = query.find('&', start);
            if (end == std::string::npos)
                end = query.size();
            const std::string item = query.substr(start, end - start);
            const size_t eq = item.find('=');
            if (eq != std::string::npos && item.substr(0, eq) == "session")
                u.session = item.substr(eq + 1);
            if (eq != std::string::npos && item.substr(0, eq) == "token")
                u.token = item.substr(eq + 1);
            start = end + 1;
        }
    }
    const std::string hostPort = rest.substr(0, rest.find('/'));
    const size_t colon = hostPort.rfind(':');
    u.host = hostPort.substr(0, colon);
    u.port = colon == std::string::npos ? "8080" : hostPort.substr(colon + 1);
    if (u.host.empty())
        why = "no host";
    else if (u.port.empty() || u.port.find_first_not_of("0123456789") != std::string::npos)
        why = "bad port";
    else if (u.session.empty())
        why = "no session= in the query (give the editor link dfb-server prints)";
    else if (u.token.empty())
        why = "no token= in the query (give the editor link dfb-server prints)";
    if (!why.empty())
        return std::nullopt;
    return u;
}

// ---- one client -------------------------------------------------------------------------------

// What happened to one edit, indexed by seq - 1.
struct EditRecord {
    Clock::time_point sentAt;
    Clock::time_point ackAt;
    uint64_t version = 0; // rig version of the ack; 0 while unanswered or refused
    enum class State : uint8_t { Pending, Acked, Refused } state = State::Pending;
};

struct FrameRecord {
    uint64_t rigVersion = 0;
    Clock::time_point at;
};

// Counters the main thread polls while clients run (everything else it reads after the join).
struct Shared {
    std::atomic<int> welcomed{0};
    std::atomic<int> connectFailed{0};
    std::atomic<int> doneSending{0};
    std::atomic<int> finished{0}; // connections over: closed normally or lost
    std::atomic<uint64_t> sent{0};
    std::atomic<uint64_t> answered{0}; // acks and errors naming an edit
    std::atomic<uint64_t> lost{0};     // edits outstanding on connections that were lost
};

class LoadClient : public std::enable_shared_from_this<LoadClient> {
public:
    LoadClient(asio::io_context& ioc, int index, const Options& opt, const Url& url, Shared& shared)
        : mWs(asio::make_strand(ioc)), mTimer(mWs.get_executor()), mIndex(index), mOpt(opt),
          mUrl(url), mShared(shared) {
        mEdits.reserve(size_t(opt.rate * opt.seconds) + 16);
    }

    /// Every acknowledged edit of this client is in a frame it received (or its connection is
    /// over): the edit-to-frame figures are complete. Any thread.
    bool framesCaughtUp() const { return mNewestFrame >= mNewestAck || mFinished; }

    void start(const tcp::resolver::results_type& endpoints) {
        beast::get_lowest_layer(mWs).expires_after(CONNECT_TIMEOUT);
        beast::get_lowest_layer(mWs).async_connect(
            endpoints, [self = shared_from_this()](beast::error_code ec, const tcp::endpoint&) {
                self->onConnect(ec);
            });
    }

    /// Starts the edit schedule at `clockStart` with this client's phase in [0, 1/rate).
    void startSending(Clock::time_point clockStart, double phaseSeconds) {
        asio::post(mWs.get_executor(), [self = shared_from_this(), clockStart, phaseSeconds] {
            self->mClockStart = clockStart;
            self->mSendEnd = clockStart + std::chrono::duration_cast<Clock::duration>(
                                              std::chrono::duration<double>(self->mOpt.seconds));
            self->mPhase = std::chrono::duration_cast<Clock::duration>(
                std::chrono::duration<double>(phaseSeconds));
            self->scheduleEdit();
        });
    }

    /// Closes the WebSocket normally, once the write in flight (if any) has finished: a close is a
    /// write, and Beast allows one at a time.
    void close() {
        asio::post(mWs.get_executor(), [self = shared_from_this()] {
            if (self->mOver)
                return;
            self->mClosing = true;
            self->mTimer.cancel();
            if (!self->mWriting)
                self->doClose();
        });
    }

    // Read by the main thread after the io threads have been joined.
    int index() const { return mIndex; }
    uint64_t clientId() const { return mClientId; }
    uint64_t welcomeVersion() const { return mWelcomeVersion; }
    const std::vector<EditRecord>& edits() const { return mEdits; }
    const std::vector<FrameRecord>& frames() const { return mFrames; }
    const std::map<std::string, uint64_t>& errorsByCode() const { return mErrorsByCode; }
    uint64_t badMessages() const { return mBadMessages; }
    bool lostConnection() const { return !mLostReason.empty(); }
    const std::string& lostReason() const { return mLostReason; }
    const std::string& connectError() const { return mConnectError; }

private:
    void onConnect(beast::error_code ec) {
        if (ec)
            return connectFailed("connecting to " + mUrl.host + ":" + mUrl.port + ": " +
                                 ec.message());
        beast::error_code ignored;
        // Edits are small: send each at once, not after the server's delayed ACK (Nagle).
        beast::get_lowest_layer(mWs).socket().set_option(tcp::no_delay(true), ignored);
        // From here on the WebSocket keeps its own timeouts (handshake and close; no idle limit:
        // a session nobody edits is silent).
        beast::get_lowest_layer(mWs).expires_never();
        websocket::stream_base::timeout t =
            websocket::stream_base::timeout::suggested(beast::role_type::client);
        t.handshake_timeout = CONNECT_TIMEOUT;
        mWs.set_option(t);
        mWs.read_message_max(MAX_MESSAGE_BYTES);
        mWs.text(true);
        mWs.async_handshake(
            mHandshakeResponse, mUrl.host + ":" + mUrl.port,
            "/v1/sessions/" + mUrl.session + "/ws?token=" + mUrl.token,
            [self = shared_from_this()](beast::error_code e) { self->onHandshake(e); });
    }

    void onHandshake(beast::error_code ec) {
        if (ec == websocket::error::upgrade_declined) {
            // The server says why (wrong token, unknown session, a limit) in its JSON error body.
            return connectFailed("HTTP " + std::to_string(mHandshakeResponse.result_int()) + ": " +
                                 mHandshakeResponse.body());
        }
        if (ec)
            return connectFailed("WebSocket handshake: " + ec.message());
        mHandshakeResponse = {};
        doRead();
    }

    void connectFailed(const std::string& why) {
        mConnectError = why;
        mOver = true;
        ++mShared.connectFailed;
    }

    void doRead() {
        mWs.async_read(mBuffer, [self = shared_from_this()](beast::error_code ec, size_t) {
            self->onRead(ec);
        });
    }

    void onRead(beast::error_code ec) {
        if (ec)
            return finish(ec);
        const auto now = Clock::now();
        const auto* data = static_cast<const uint8_t*>(mBuffer.data().data());
        const size_t size = mBuffer.size();
        if (mWs.got_text())
            onText(std::string_view(reinterpret_cast<const char*>(data), size), now);
        else
            onFrame(data, size, now);
        mBuffer.consume(mBuffer.size());
        doRead();
    }

    void onFrame(const uint8_t* data, size_t size, Clock::time_point now) {
        auto h = dfb::protocol::readFrameHeader(data, size);
        if (!h) {
            ++mBadMessages;
            return;
        }
        mFrames.push_back({h.value().rigVersion, now});
        mNewestFrame = std::max<uint64_t>(mNewestFrame, h.value().rigVersion);
    }


    void onText(std::string_view text, Clock::time_point now) {
        // Changes (one per edit of every other client: most of the text traffic) need nothing
        // from their body. The server writes compact JSON, and the quotes of `"type":"change"`
        // cannot appear unescaped inside a string, so this only ever skips change messages.
        if (mWelcomed && text.find(R"("type":"change")") != std::string_view::npos)
            return;
        auto parsed = dfb::protocol::parseJson(text, MAX_MESSAGE_BYTES, "server message");
        if (!parsed || !parsed.value().is_object()) {
            ++mBadMessages;
            return;
        }
        const json& j = parsed.value();
        const std::string type = j.value("type", "");
        if (type == "ack") {
            onAnswer(j.value("seq", uint64_t(0)), EditRecord::State::Acked,
                     j.value("rigVersion", uint64_t(0)), now);
        } else if (type == "error") {
            ++mErrorsByCode[j.value("code", "?")];
            if (mErrorsByCode.size() == 1 && mErrorsByCode.begin()->second == 1) {
                // The first refusal says why every following one happened, most likely.
                std::fprintf(stderr, "dfb-load-bench: client %d: the server refused: %s\n", mIndex,
                             std::string(text.substr(0, 300)).c_str());
            }
            if (j.contains("seq") && j["seq"].is_number_unsigned())
                onAnswer(j["seq"].get<uint64_t>(), EditRecord::State::Refused, 0, now);
        } else if (type == "welcome" && !mWelcomed) {
            mWelcomed = true;
            mClientId = j.value("client", uint64_t(0));
            if (j.contains("rig") && j["rig"].is_object())
                mWelcomeVersion = j["rig"].value("version", uint64_t(0));
            ++mShared.welcomed;
        }
        // presence and anything newer: nothing to measure.
    }

    void onAnswer(uint64_t seq, EditRecord::State state, uint64_t version, Clock::time_point now) {
        if (seq == 0 || seq > mEdits.size())
            return; // not one of ours (seq 0: a view fallback)
        EditRecord& e = mEdits[seq - 1];
        if (e.state != EditRecord::State::Pending)
            return;
        e.state = state;
        e.version = version;
        e.ackAt = now;
        if (state == EditRecord::State::Acked) mNewestAck = std::max<uint64_t>(mNewestAck, version);
        ++mAnswered;
        ++mShared.answered;
    }

    // Edits follow an absolute schedule (start + phase + k / rate), so timer lateness does not
    // accumulate into a lower rate.
    void scheduleEdit() {
        const auto period = std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double>(1.0 / mOpt.rate));
        const auto due = mClockStart + mPhase + period * int64_t(mEdits.size());
        if (due >= mSendEnd || mClosing || mOver) {
            ++mShared.doneSending;
            return;
        }
        mTimer.expires_at(due);
        mTimer.async_wait([self = shared_from_this()](beast::error_code ec) {
            if (ec || self->mClosing || self->mOver) {
                ++self->mShared.doneSending;
                return;
            }
            self->sendEdit();
            self->scheduleEdit();
        });
    }

    void sendEdit() {
        const uint64_t seq = mEdits.size() + 1;
        // Intensity must stay >= 0; any value changes the rig version and forces a new frame.
        const json edit{
            {"type", "edit"},
            {"seq", seq},
            {"changes", json::array({{{"path", mOpt.path}, {"value", 50 + int(seq % 100)}}})}};
        // The send time is taken when the edit is queued: a write still in flight delays it, and
        // that delay is part of what the user would see.
        mEdits.push_back({Clock::now(), {}, 0, EditRecord::State::Pending});
        ++mShared.sent;
        mQueue.push_back(edit.dump());
        if (!mWriting)
            doWrite();
    }

    void doWrite() {
        mWriting = true;
        mWs.async_write(
            asio::buffer(mQueue.front()),
            [self = shared_from_this()](beast::error_code ec, size_t) { self->onWrite(ec); });
    }

    void onWrite(beast::error_code ec) {
        mWriting = false;
        if (ec)
            return finish(ec);
        mQueue.pop_front();
        if (!mQueue.empty())
            return doWrite();
        if (mClosing)
            doClose();
    }

    void doClose() {
        if (mCloseSent || mOver)
            return;
        mCloseSent = true;
        mWs.async_close(websocket::close_code::normal,
                        [self = shared_from_this()](beast::error_code ec) {
                            // The read loop sees the server's close frame and ends the connection;
                            // a failed close (server gone meanwhile) ends it here.
                            if (ec)
                                self->finish(ec);
                        });
    }

    // The one end of every connection: a read or write failed, or the close handshake completed
    // (the pending read then fails with `closed`). Only a failure before our close counts as lost.
    void finish(beast::error_code ec) {
        if (mOver)
            return;
        mOver = true;
        mTimer.cancel();
        if (!mClosing) {
            if (ec == websocket::error::closed) {
                const auto& r = mWs.reason();
                mLostReason = "closed by the server, code " + std::to_string(unsigned(r.code));
                if (!r.reason.empty())
                    mLostReason += ": " + std::string(r.reason.data(), r.reason.size());
            } else {
                mLostReason = ec.message();
            }
            if (!mWelcomed) {
                // Refused after the upgrade (e.g. a client limit): still a failure to connect.
                mConnectError = "connection ended before the welcome: " + mLostReason;
                ++mShared.connectFailed;
            } else {
                std::fprintf(stderr, "dfb-load-bench: client %d lost its connection: %s\n", mIndex,
                             mLostReason.c_str());
            }
            mShared.lost += mEdits.size() - mAnswered;
            beast::error_code ignored;
            beast::get_lowest_layer(mWs).socket().close(ignored);
        }
        mFinished = true;
        ++mShared.finished;
    }

    websocket::stream<beast::tcp_stream> mWs;
    asio::steady_timer mTimer;
    beast::flat_buffer mBuffer;
    websocket::response_type mHandshakeResponse;
    std::atomic<uint64_t> mNewestAck{0}, mNewestFrame{0};
    std::atomic<bool> mFinished{false};
    std::deque<std::string> mQueue; // front: the write in flight
    const int mIndex;
    const Options& mOpt;
    const Url& mUrl;
    Shared& mShared;

    Clock::time_point mClockStart, mSendEnd;
    Clock::duration mPhase{};
    bool mWelcomed = false, mWriting = false, mClosing = false, mCloseSent = false, mOver = false;
    uint64_t mClientId = 0, mWelcomeVersion = 0, mAnswered = 0, mBadMessages = 0;
    std::vector<EditRecord> mEdits;
    std::vector<FrameRecord> mFrames; // in arrival order; versions never go backwards per client
    std::map<std::string, uint64_t> mErrorsByCode;
    std::string mLostReason, mConnectError;
};

// ---- the rig version at the end, the server's memory
// ----------------------------------------------

// GET /v1/sessions/ID/rig -> its "version"; nullopt when the server does not answer in time.
std::optional<uint64_t> fetchRigVersion(const Url& url, std::string& why) {
    asio::io_context ioc;
    beast::tcp_stream stream(ioc);
    http::request<http::empty_body> req{http::verb::get, "/v1/sessions/" + url.session + "/rig",
                                        11};
    req.set(http::field::host, url.host + ":" + url.port);
    req.set(http::field::authorization, "Bearer " + url.token);
    beast::flat_buffer buffer;
    http::response_parser<http::string_body> parser;
    parser.body_limit(MAX_MESSAGE_BYTES);
    beast::error_code result = asio::error::would_block;
    tcp::resolver resolver(ioc);
    beast::error_code ec;
    const auto endpoints = resolver.resolve(url.host, url.port, ec);
    if (ec) {
        why = "resolving " + url.host + ": " + ec.message();
        return std::nullopt;
    }
    // tcp_stream's deadline covers each step; 10 s leaves room for a server still busy rendering.
    stream.expires_after(std::chrono::seconds(10));
    stream.async_connect(endpoints, [&](beast::error_code e1, const tcp::endpoint&) {
        if (e1) {
            result = e1;
            return;
        }
        http::async_write(stream, req, [&](beast::error_code e2, size_t) {
            if (e2) {
                result = e2;
                return;
            }
            http::async_read(stream, buffer, parser,
                             [&](beast::error_code e3, size_t) { result = e3; });
        });
    });
    ioc.run();
    if (result) {
        why = "GET rig: " + result.message();
        return std::nullopt;
    }
    const auto& res = parser.get();
    auto j = dfb::protocol::parseJson(res.body(), MAX_MESSAGE_BYTES, "rig");
    if (res.result_int() != 200 || !j || !j.value().is_object() || !j.value().contains("version")) {
        why =
            "GET rig: HTTP " + std::to_string(res.result_int()) + ": " + res.body().substr(0, 200);
        return std::nullopt;
    }
    return j.value().value("version", uint64_t(0));
}

// VmRSS of a process in MB (MiB / 1.048576 is not worth it: kB / 1024); nullopt when unreadable.
std::optional<double> readRssMb(int pid) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/status");
    std::string line;
    while (std::getline(in, line)) {
        if (line.rfind("VmRSS:", 0) == 0)
            return std::strtod(line.c_str() + 6, nullptr) / 1024.0;
    }
    return std::nullopt;
}

// ---- statistics
// ----------------------------------------------------------------------------------

// percentile: dfb/core/Stats.h (linear between closest ranks, NaN for no samples).

json numberOrNull(double v) {
    return std::isfinite(v) ? json(std::round(v * 100) / 100) : json(nullptr);
}

struct Summary {
    double p50 = NAN, p95 = NAN, p99 = NAN, max = NAN;
    size_t count = 0;
};

Summary summarize(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return {dfb::percentile(v, 50), dfb::percentile(v, 95), dfb::percentile(v, 99), v.empty() ? NAN : v.back(),
            v.size()};
}

json toJson(const Summary& s) {
    return {{"p50", numberOrNull(s.p50)},
            {"p95", numberOrNull(s.p95)},
            {"p99", numberOrNull(s.p99)},
            {"max", numberOrNull(s.max)},
            {"count", s.count}};
}

std::string toText(const Summary& s) {
    char line[160];
    std::snprintf(line, sizeof line, "p50 %.1f  p95 %.1f  p99 %.1f  max %.1f ms (%zu)", s.p50,
                  s.p95, s.p99, s.max, s.count);
    return line;
}

} // namespace

int main(int argc, char** argv) {
    Options opt;
    CLI::App app{"dfb-load-bench: N editor clients of one session send edits at a fixed rate over "
                 "WebSocket and read "
                 "everything; reports acks, errors, ack and edit-to-frame latency, frames per "
                 "client, lost connections "
                 "and the server's memory"};
    app.set_version_flag("--version",
                         dfb::versionText("dfb-load-bench") +
                             " (protocol " + std::to_string(dfb::protocol::PROTOCOL_VERSION) + ")");
    app.footer("The session must have no other editor during the run: 'applied but unacknowledged' "
               "is the rig version "
               "at the end (GET .../rig) minus the version in the first welcome, minus the acks "
               "received.\n"
               "Exit codes: 0 it ran (whatever the numbers), 1 bad command line, 2 could not "
               "connect every client.\n"
               "Example: dfb-load-bench --server 'http://127.0.0.1:8080/?session=shot&token=...' "
               "--clients 8 --seconds 10");
    app.add_option("--server", opt.server,
                   "the editor link dfb-server prints: http://HOST:PORT/?session=ID&token=T")
        ->required();
    app.add_option("--clients", opt.clients, "WebSocket clients, all editing")
        ->check(CLI::Range(1, 4096))
        ->capture_default_str();
    app.add_option("--rate", opt.rate, "edits per second per client")
        ->check(CLI::Range(0.01, 1000.0))
        ->capture_default_str();
    app.add_option("--seconds", opt.seconds, "sending period, seconds")
        ->check(CLI::Range(0.1, 86400.0))
        ->capture_default_str();
    app.add_option("--path", opt.path, "property edited (a number >= 0; values 50-149 are sent)")
        ->capture_default_str();
    app.add_option("--drain-seconds", opt.drainSeconds,
                   "longest wait for outstanding acks after sending stops")
        ->check(CLI::Range(0.0, 3600.0))
        ->capture_default_str();
    app.add_option("--server-pid", opt.serverPid,
                   "the server's process id: report its VmRSS every 10 s and at the end")
        ->check(CLI::PositiveNumber);
    app.add_option("--threads", opt.threads, "io threads of the bench")
        ->check(CLI::Range(1, 64))
        ->capture_default_str();
    app.add_flag("--json", opt.json,
                 "one JSON object on stdout (the human-readable lines go to stderr)");
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-load-bench"); rc >= 0) return rc;
    std::string why;
    const auto parsedUrl = parseUrl(opt.server, why);
    if (!parsedUrl) {
        std::fprintf(stderr, "dfb-load-bench: --server '%s': %s\n", opt.server.c_str(),
                     why.c_str());
        return EXIT_USAGE;
    }
    const Url url = *parsedUrl;
    std::FILE* human = opt.json ? stderr : stdout;

    asio::io_context ioc;
    auto work = asio::make_work_guard(ioc);
    std::vector<std::thread> threads;
    for (int i = 0; i < opt.threads; ++i)
        threads.emplace_back([&ioc] { ioc.run(); });
    auto stopThreads = [&] {
        work.reset();
        ioc.stop();
        for (auto& t : threads)
            t.join();
        threads.clear();
    };

    Shared shared;
    std::vector<std::shared_ptr<LoadClient>> clients;
    {
        beast::error_code ec;
        tcp::resolver resolver(ioc);
        const auto endpoints = resolver.resolve(url.host, url.port, ec);
        if (ec) {
            std::fprintf(stderr, "dfb-load-bench: resolving %s: %s\n", url.host.c_str(),
                         ec.message().c_str());
            stopThreads();
            return EXIT_NO_CONNECTION;
        }
        for (int i = 0; i < opt.clients; ++i) {
            clients.push_back(std::make_shared<LoadClient>(ioc, i, opt, url, shared));
            clients.back()->start(endpoints);
        }
    }

    // Everyone is in (welcome read) before the clock starts.
    const auto connectBy = Clock::now() + CONNECT_TIMEOUT + std::chrono::seconds(1);
    while (shared.welcomed + shared.connectFailed < opt.clients && Clock::now() < connectBy)
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    if (shared.welcomed < opt.clients) {
        for (auto& c : clients)
            c->close();
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
        stopThreads();
        int shown = 0;
        for (const auto& c : clients) {
            if (!c->connectError().empty() && shown++ < 3)
                std::fprintf(stderr, "dfb-load-bench: client %d: %s\n", c->index(),
                             c->connectError().c_str());
        }
        std::fprintf(
            stderr, "dfb-load-bench: %d of %d clients connected (welcome received) within %lld s\n",
            shared.welcomed.load(), opt.clients,
            (long long)std::chrono::duration_cast<std::chrono::seconds>(CONNECT_TIMEOUT).count());
        return EXIT_NO_CONNECTION;
    }
    // Safe to read: that welcome is in (the atomic count says so) and nothing is sent yet.
    const uint64_t startVersion = clients.front()->welcomeVersion();

    std::vector<double> rssSeconds, rssMb;
    auto sampleRss = [&](double t) {
        if (opt.serverPid <= 0)
            return;
        if (const auto mb = readRssMb(opt.serverPid)) {
            rssSeconds.push_back(std::round(t * 10) / 10);
            rssMb.push_back(std::round(*mb * 10) / 10);
            std::fprintf(stderr, "rss %7.1f s  %8.1f MB\n", t, *mb);
        } else {
            std::fprintf(stderr, "rss %7.1f s  (cannot read /proc/%d/status)\n", t, opt.serverPid);
        }
    };

    // Clients' phases spread their edits over each period, as independent users would.
    const auto clockStart = Clock::now() + std::chrono::milliseconds(20);
    {
        std::mt19937 rng(std::random_device{}());
        std::uniform_real_distribution<double> phase(0.0, 1.0 / opt.rate);
        for (auto& c : clients)
            c->startSending(clockStart, phase(rng));
    }
    const auto sendEnd = clockStart + std::chrono::duration_cast<Clock::duration>(
                                          std::chrono::duration<double>(opt.seconds));
    std::fprintf(human,
                 "dfb-load-bench: %d clients, %g edits/s each, %g s, editing %s of session %s (rig "
                 "version %llu)\n",
                 opt.clients, opt.rate, opt.seconds, opt.path.c_str(), url.session.c_str(),
                 (unsigned long long)startVersion);
    std::fflush(human);
    sampleRss(0);
    auto nextRss = clockStart + RSS_PERIOD;
    auto sleepUntil = [&](Clock::time_point until, auto done) {
        while (Clock::now() < until && !done()) {
            if (opt.serverPid > 0 && Clock::now() >= nextRss) {
                sampleRss(std::chrono::duration<double>(nextRss - clockStart).count());
                nextRss += RSS_PERIOD;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
    };
    // All clients stopping early means all connections were lost: nothing left to measure.
    sleepUntil(sendEnd, [&] { return shared.finished >= opt.clients; });
    sleepUntil(sendEnd + std::chrono::seconds(2),
               [&] { return shared.doneSending >= opt.clients; });
    const auto drainStart = Clock::now();
    const auto drainBy = drainStart + std::chrono::duration_cast<Clock::duration>(
                                          std::chrono::duration<double>(opt.drainSeconds));
    sleepUntil(drainBy, [&] { return shared.answered + shared.lost >= shared.sent; });
    // Then the frames of the last acknowledged edits (they follow the acks by a render).
    sleepUntil(drainBy, [&] {
        return std::all_of(clients.begin(), clients.end(), [](const auto& c) { return c->framesCaughtUp(); });
    });
    const auto drainEnd = Clock::now();

    for (auto& c : clients)
        c->close();
    const auto closeBy = Clock::now() + CLOSE_TIMEOUT;
    while (shared.finished < opt.clients && Clock::now() < closeBy)
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    const int unclosed = opt.clients - shared.finished;
    stopThreads();

    std::string rigWhy;
    const auto endVersion = fetchRigVersion(url, rigWhy);
    if (!endVersion)
        std::fprintf(stderr, "dfb-load-bench: the rig version at the end is unknown: %s\n",
                     rigWhy.c_str());
    sampleRss(std::chrono::duration<double>(Clock::now() - clockStart).count());

    // ---- results ----
    uint64_t sent = 0, acked = 0, refused = 0, unanswered = 0, neverFramed = 0, badMessages = 0;
    std::map<std::string, uint64_t> errorsByCode;
    std::vector<double> ackMs, frameMs, frameCounts;
    json disconnected = json::array();
    for (const auto& c : clients) {
        for (const auto& [code, n] : c->errorsByCode())
            errorsByCode[code] += n;
        badMessages += c->badMessages();
        const auto& frames = c->frames();
        for (const auto& e : c->edits()) {
            ++sent;
            if (e.state == EditRecord::State::Refused)
                ++refused;
            if (e.state == EditRecord::State::Pending)
                ++unanswered;
            if (e.state != EditRecord::State::Acked)
                continue;
            ++acked;
            ackMs.push_back(msBetween(e.sentAt, e.ackAt));
            // Versions are monotonic per client, so the first frame showing the edit is a search.
            const auto it =
                std::lower_bound(frames.begin(), frames.end(), e.version,
                                 [](const FrameRecord& f, uint64_t v) { return f.rigVersion < v; });
            if (it == frames.end())
                ++neverFramed;
            else
                frameMs.push_back(std::max(0.0, msBetween(e.sentAt, it->at)));
        }
        frameCounts.push_back(
            double(std::count_if(frames.begin(), frames.end(), [&](const FrameRecord& f) {
                return f.at >= clockStart && f.at < sendEnd;
            })));
        if (c->lostConnection())
            disconnected.push_back(
                {{"client", c->index()}, {"id", c->clientId()}, {"reason", c->lostReason()}});
    }
    std::sort(frameCounts.begin(), frameCounts.end());
    const Summary ackSummary = summarize(ackMs), frameSummary = summarize(frameMs);
    const double framesMin = frameCounts.front(), framesMax = frameCounts.back(),
                 framesMedian = dfb::percentile(frameCounts, 50);
    std::optional<int64_t> appliedUnacked;
    if (endVersion)
        appliedUnacked = int64_t(*endVersion) - int64_t(startVersion) - int64_t(acked);

    std::fprintf(
        human, "edits        sent %llu, acked %llu, refused %llu, unanswered %llu (drain %.1f s)\n",
        (unsigned long long)sent, (unsigned long long)acked, (unsigned long long)refused,
        (unsigned long long)unanswered,
        std::chrono::duration<double>(drainEnd - drainStart).count());
    std::string codes;
    for (const auto& [code, n] : errorsByCode)
        codes += " " + code + " " + std::to_string(n);
    std::fprintf(human, "errors       %s\n", codes.empty() ? " none" : codes.c_str());
    if (appliedUnacked) {
        std::fprintf(human, "applied but unacknowledged %lld (rig version %llu -> %llu)\n",
                     (long long)*appliedUnacked, (unsigned long long)startVersion,
                     (unsigned long long)*endVersion);
    } else {
        std::fprintf(human, "applied but unacknowledged: unknown\n");
    }
    std::fprintf(human, "ack          %s\n", toText(ackSummary).c_str());
    std::fprintf(human, "edit->frame  %s, never in a frame %llu\n", toText(frameSummary).c_str(),
                 (unsigned long long)neverFramed);
    std::fprintf(
        human,
        "frames/client min %.0f  median %.0f  max %.0f  (fps min %.1f  median %.1f  max %.1f)\n",
        framesMin, framesMedian, framesMax, framesMin / opt.seconds, framesMedian / opt.seconds,
        framesMax / opt.seconds);
    std::fprintf(human, "disconnects  %zu%s\n", disconnected.size(),
                 unclosed > 0 ? (", " + std::to_string(unclosed) + " not closed in time").c_str()
                              : "");
    for (const auto& d : disconnected)
        std::fprintf(human, "  client %d (id %llu): %s\n", d["client"].get<int>(),
                     (unsigned long long)d["id"].get<uint64_t>(),
                     d["reason"].get<std::string>().c_str());
    if (badMessages)
        std::fprintf(human, "unreadable messages %llu\n", (unsigned long long)badMessages);
    if (!rssMb.empty())
        std::fprintf(human, "server rss   start %.1f MB, end %.1f MB\n", rssMb.front(),
                     rssMb.back());

    if (opt.json) {
        json errors = json::object();
        for (const auto& [code, n] : errorsByCode)
            errors[code] = n;
        json frameJson = toJson(frameSummary);
        frameJson["neverSeen"] = neverFramed;
        const json out{
            {"clients", opt.clients},
            {"rate", opt.rate},
            {"seconds", opt.seconds},
            {"path", opt.path},
            {"sent", sent},
            {"acked", acked},
            {"refused", refused},
            {"errors", errors},
            {"unanswered", unanswered},
            {"rigVersionStart", startVersion},
            {"rigVersionEnd", endVersion ? json(*endVersion) : json(nullptr)},
            {"appliedUnacked", appliedUnacked ? json(*appliedUnacked) : json(nullptr)},
            {"ackMs", toJson(ackSummary)},
            {"frameMs", frameJson},
            {"framesPerClient",
             {{"min", uint64_t(framesMin)},
              {"median", numberOrNull(framesMedian)},
              {"max", uint64_t(framesMax)}}},
            {"fpsMin", numberOrNull(framesMin / opt.seconds)},
            {"fpsMedian", numberOrNull(framesMedian / opt.seconds)},
            {"fpsMax", numberOrNull(framesMax / opt.seconds)},
            {"disconnects", disconnected.size()},
            {"disconnected", disconnected},
            {"notClosed", unclosed},
            {"badMessages", badMessages},
            {"rssSeconds", rssSeconds},
            {"rssMb", rssMb},
        };
        std::printf("%s\n", out.dump().c_str());
    }
    return EXIT_OK;
}
