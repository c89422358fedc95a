// TLS (issue 14, point 6): dfb-server with --tls-cert/--tls-key serves HTTPS and WSS on its one
// port, with a certificate this test run made (the tls_certificate fixture, openssl req). A
// client that verifies the certificate gets the health check, the rig, a WebSocket welcome, an
// acknowledged edit and a frame of it; plain HTTP on that port gets no answer and disturbs
// nobody; a bad certificate or key stops the server at start with the reason.

#include "support/Process.h"
#include "support/TestServer.h"

#include <boost/asio/ssl.hpp>
#include <boost/beast/ssl.hpp>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

using namespace dfb;
using namespace std::chrono_literals;
using json = nlohmann::json;

namespace {

namespace beast = boost::beast;
namespace asio = boost::asio;
namespace ssl = asio::ssl;
using tcp = asio::ip::tcp;

const std::string SHOT = DFB_TEST_DATA "/tabletop_320.exr";
const std::string CERT = DFB_TLS_DIR "/cert.pem", KEY = DFB_TLS_DIR "/key.pem";

// A client context that trusts exactly the test's certificate and checks the host name.
ssl::context clientContext() {
    ssl::context ctx(ssl::context::tls_client);
    ctx.load_verify_file(CERT);
    ctx.set_verify_mode(ssl::verify_peer);
    return ctx;
}

beast::ssl_stream<beast::tcp_stream> connectTls(asio::io_context& ioc, ssl::context& ctx, const std::string& port) {
    beast::ssl_stream<beast::tcp_stream> s(ioc, ctx);
    s.set_verify_callback(ssl::host_name_verification("127.0.0.1"));
    beast::get_lowest_layer(s).expires_after(30s);
    beast::get_lowest_layer(s).connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(std::stoi(port))));
    s.handshake(ssl::stream_base::client);
    return s;
}

test::HttpReply httpsGet(const std::string& port, const std::string& target, const std::string& token) {
    asio::io_context ioc;
    auto ctx = clientContext();
    auto s = connectTls(ioc, ctx, port);
    beast::http::request<beast::http::string_body> req{beast::http::verb::get, target, 11};
    req.set(beast::http::field::host, "127.0.0.1");
    if (!token.empty()) req.set(beast::http::field::authorization, "Bearer " + token);
    beast::http::write(s, req);
    beast::flat_buffer buf;
    beast::http::response_parser<beast::http::string_body> parser;
    parser.body_limit(64u << 20);
    beast::http::read(s, buf, parser);
    test::HttpReply r;
    r.status = int(parser.get().result_int());
    r.body = parser.get().body();
    for (const auto& f : parser.get()) r.headers[std::string(f.name_string())] = std::string(f.value());
    beast::error_code ec;
    s.shutdown(ec);
    return r;
}

// Reads WebSocket messages until `done` says so (text as JSON, frames as their rig version).
template <class Ws, class Done> void readUntil(Ws& ws, Done&& done) {
    for (;;) {
        beast::flat_buffer buf;
        ws.read(buf);
        if (ws.got_text()) {
            if (done(json::parse(beast::buffers_to_string(buf.data())), uint64_t(0))) return;
        } else {
            const auto* p = static_cast<const uint8_t*>(buf.data().data());
            uint64_t v = 0;
            for (int i = 7; i >= 0; --i) v = (v << 8) | p[16 + i];
            if (done(json(), v)) return;
        }
    }
}

} // namespace

TEST(Tls, HttpsAndWssOnTheServersPort) {
    test::Server server({SHOT, "--tls-cert", CERT, "--tls-key", KEY});
    ASSERT_TRUE(server.up()) << server.process->output();
    ASSERT_NE(server.process->output().find("listening on https://"), std::string::npos);
    const std::string port = server.port, id = "tabletop_320", token = server.tokens[id].editor;

    EXPECT_EQ(httpsGet(port, "/healthz", "").body, "ok\n");
    auto rig = httpsGet(port, "/v1/sessions/" + id + "/rig", token);
    ASSERT_EQ(rig.status, 200) << rig.body;
    const uint64_t v0 = json::parse(rig.body)["version"];

    // Plain HTTP on the TLS port: no answer (the handshake fails), and the server goes on.
    {
        asio::io_context ioc;
        tcp::socket plain(ioc);
        plain.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(std::stoi(port))));
        test::setReceiveTimeout(plain, 10s);
        const std::string req = "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
        asio::write(plain, asio::buffer(req));
        char buf[256];
        beast::error_code ec;
        const size_t n = plain.read_some(asio::buffer(buf), ec);
        EXPECT_EQ(std::string(buf, n).find("200 OK"), std::string::npos);
    }

    // WSS: welcome, an edit acknowledged, a frame of it.
    asio::io_context ioc;
    auto ctx = clientContext();
    beast::websocket::stream<beast::ssl_stream<beast::tcp_stream>> ws(connectTls(ioc, ctx, port));
    beast::get_lowest_layer(ws).expires_never();
    ws.read_message_max(64u << 20);
    ws.handshake("127.0.0.1", "/v1/sessions/" + id + "/ws?token=" + token);
    readUntil(ws, [](const json& j, uint64_t) { return j.is_object() && j["type"] == "welcome"; });
    ws.text(true);
    ws.write(asio::buffer(json{{"type", "edit"}, {"seq", 1}, {"changes", {{{"path", "key.intensity"}, {"value", 77}}}}}.dump()));
    uint64_t acked = 0;
    readUntil(ws, [&](const json& j, uint64_t) {
        if (j.is_object() && j["type"] == "ack") acked = j["rigVersion"];
        return acked != 0;
    });
    EXPECT_EQ(acked, v0 + 1);
    uint64_t frameVersion = 0;
    readUntil(ws, [&](const json&, uint64_t v) {
        frameVersion = std::max(frameVersion, v);
        return frameVersion >= acked;
    });
    EXPECT_EQ(frameVersion, acked);
    ws.close(beast::websocket::close_code::normal);
    EXPECT_EQ(httpsGet(port, "/healthz", "").status, 200);
}

TEST(Tls, TheCommandLineClientSpeaksHttpsAndWss) {
    test::Server server({SHOT, "--tls-cert", CERT, "--tls-key", KEY});
    ASSERT_TRUE(server.up()) << server.process->output();
    const std::string link = "https://127.0.0.1:" + server.port + "/?session=tabletop_320&token=" + server.tokens["tabletop_320"].editor;
    auto client = [&](std::vector<std::string> args, bool trust = true) {
        args.insert(args.begin(), {DFB_CLIENT_EXE, "--server", link});
        if (trust) args.insert(args.end(), {"--ca-cert", CERT});
        return test::run(args);
    };
    auto [rc, out] = client({"rig", "get"});
    ASSERT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("\"lights\""), std::string::npos) << out;
    std::tie(rc, out) = client({"set", "key.intensity=66"}); // HTTP POST
    ASSERT_EQ(rc, 0) << out;
    const std::string png = DFB_TLS_DIR "/frame.png";
    std::tie(rc, out) = client({"frame", png}); // over WSS
    ASSERT_EQ(rc, 0) << out;
    EXPECT_GT(std::filesystem::file_size(png), 1000u);
    std::tie(rc, out) = client({"watch", "--count", "1"});
    EXPECT_EQ(rc, 0) << out;
    // Without trusting the self-signed certificate: refused, and the message says what to do.
    std::tie(rc, out) = client({"rig", "get"}, false);
    EXPECT_EQ(rc, 2) << out;
    EXPECT_NE(out.find("--ca-cert"), std::string::npos) << out;
}

TEST(Tls, ABadCertificateOrKeyStopsTheServerWithTheReason) {
    const std::string bogus = DFB_TLS_DIR "/not-a-certificate.pem";
    std::ofstream(bogus) << "not a certificate\n";
    auto [rc, out] = test::run({DFB_SERVER_EXE, SHOT, "--port", "0", "--tls-cert", bogus, "--tls-key", KEY});
    EXPECT_EQ(rc, 1) << out;
    EXPECT_NE(out.find("--tls-cert"), std::string::npos) << out;
    std::tie(rc, out) = test::run({DFB_SERVER_EXE, SHOT, "--port", "0", "--tls-cert", CERT, "--tls-key", bogus});
    EXPECT_EQ(rc, 1) << out;
    EXPECT_NE(out.find("--tls-key"), std::string::npos) << out;
    std::tie(rc, out) = test::run({DFB_SERVER_EXE, SHOT, "--port", "0", "--tls-cert", CERT});
    EXPECT_NE(rc, 0) << out; // a certificate needs its key
}
