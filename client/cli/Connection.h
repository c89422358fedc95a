#pragma once
// A blocking client connection to dfb-server: WebSocket for the protocol, plain HTTP GETs for
// scripts. Every call has a deadline; errors are values.

#include <dfb/core/Result.h>
#include <dfb/protocol/Codec.h>

#include <chrono>
#include <memory>
#include <string>
#include <variant>
#include <vector>

namespace dfb::client {

struct Url {
    std::string host;
    std::string port;
    std::string path;    ///< without host, starting with '/'
    std::string session; ///< from a "?session=ID" query (the links dfb-server prints), else empty
    std::string token;   ///< from a "?token=T" query, else empty
    bool tls = false;    ///< https:// or wss://: TLS, the server's certificate verified
    /// PEM file of certificates to trust besides the system's (a server's self-signed one).
    std::string caFile;
};
/// Accepts http://, ws://, https://, wss:// or a bare host:port; the default port is 8080. The
/// query of the URLs the server prints (?session=ID&token=T) fills `session` and `token`.
Result<Url> parseUrl(const std::string& text);

/// A message from the server: JSON text or a binary frame.
struct TextMessage {
    nlohmann::json json;
};
struct FrameMessage {
    protocol::FrameHeader header;
    std::vector<uint8_t> image; ///< encoded bytes (JPEG or PNG, see header.encoding)
};
using ServerMessage = std::variant<TextMessage, FrameMessage>;

class Connection {
public:
    /// Connects and completes the WebSocket handshake on `target` (path and query, e.g.
    /// "/v1/sessions/ID/ws?token=T"). Fails with Network, or Unauthorized / MissingData /
    /// Protocol with the server's refusal verbatim.
    static Result<std::unique_ptr<Connection>> open(const Url& url, const std::string& target, std::chrono::milliseconds timeout);
    ~Connection();

    Status sendText(const std::string& text);
    /// Waits for the next message (at most the connection's timeout, or `timeout` when given).
    /// Fails with Network on timeout or close, Protocol on garbage.
    Result<ServerMessage> receive();
    Result<ServerMessage> receive(std::chrono::milliseconds timeout);
    /// From now on the connection pings the server when it has been quiet for half of `idle` and
    /// a receive fails (Network, "timed out") only when nothing, not even the answer to a ping,
    /// came for `idle`: an idle session is not a dead server (`watch`).
    void keepAlive(std::chrono::milliseconds idle);
    void close();
    /// Ends a receive() blocked in another thread (it fails with Network). Thread-safe.
    void shutdown();

private:
    struct Impl;
    explicit Connection(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> mImpl;
};

struct HttpResponse {
    int status = 0;
    std::string body;
    std::string etag;
    std::string rigVersion; ///< X-Rig-Version of frames
};
/// One HTTP request with an optional bearer token, body, If-Match and the user's name (header
/// X-Dfb-Name: the author of an edit in the history, docs/protocol.md). Any status is a value;
/// only failing to talk to the server is an error (Network).
Result<HttpResponse> httpRequest(const Url& url, const std::string& method, const std::string& target, const std::string& token,
                                 const std::string& body, const std::string& ifMatch, std::chrono::milliseconds timeout,
                                 const std::string& name = "");

} // namespace dfb::client
