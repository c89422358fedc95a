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
    std::string path; ///< without host, starting with '/'
};
/// Accepts http://, ws:// or a bare host:port; the default port is 8080.
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
    /// Connects and completes the WebSocket handshake on /v1/ws. Fails with Network.
    static Result<std::unique_ptr<Connection>> open(const Url& url, std::chrono::milliseconds timeout);
    ~Connection();

    Status sendText(const std::string& text);
    /// Waits for the next message. Fails with Network on timeout or close, Protocol on garbage.
    Result<ServerMessage> receive();
    void close();

private:
    struct Impl;
    explicit Connection(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> mImpl;
};

/// HTTP GET; returns the body on 2xx, else Protocol with the server's error body verbatim.
Result<std::string> httpGet(const Url& url, const std::string& target, std::chrono::milliseconds timeout);

} // namespace dfb::client
