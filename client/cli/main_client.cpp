// dfb-client: command-line client of dfb-server (protocol v0, docs/protocol.md).
//
//   dfb-client URL --rig                         print the rig as JSON
//   dfb-client URL --set key.intensity=500 ...   apply an edit (all changes at once, or none)
//   dfb-client URL --frame out.jpg               save the next frame (after the edit, if any)
//
// Exit codes: 0 success; 1 bad command line; 2 cannot reach the server; 3 the server refused
// the request (its error is printed verbatim); 4 timed out or the connection broke; 5 the
// output file could not be written.

#include "Connection.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <fstream>
#include <iostream>

using namespace dfb;

namespace {

constexpr int EXIT_USAGE = 1, EXIT_UNREACHABLE = 2, EXIT_REFUSED = 3, EXIT_BROKEN = 4, EXIT_WRITE = 5;

bool endsWith(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

int writeFile(const std::string& path, const void* data, size_t size) {
    std::ofstream out(path, std::ios::binary);
    out.write(static_cast<const char*>(data), std::streamsize(size));
    out.close();
    if (!out) {
        std::cerr << "dfb-client: cannot write " << path << "\n";
        return EXIT_WRITE;
    }
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"dfb-client: talk to a dfb-server (print the rig, edit lights, save frames)"};
    app.footer("Exit codes: 0 ok, 1 bad command line, 2 server unreachable, 3 server refused (its error is "
               "printed), 4 timed out or connection lost, 5 cannot write the output file.\n"
               "Example: dfb-client http://127.0.0.1:8080 --set key.position=1,4,2 --frame out.jpg");
    std::string urlText, framePath;
    std::vector<std::string> sets;
    bool printRig = false;
    double timeoutS = 30.0;
    app.add_option("url", urlText, "server URL, e.g. http://127.0.0.1:8080")->required();
    app.add_flag("--rig", printRig, "print the rig (JSON) as the server sends it on connection");
    app.add_option("--set", sets, "PATH=VALUE, e.g. key.intensity=500 or key.position=1,2,3 (repeatable; applied together)");
    app.add_option("--frame", framePath, "save the next frame: .jpg from the stream, .png rendered losslessly");
    std::string output = "beauty";
    app.add_option("--output", output, "with --frame: beauty, light:NAME (one light alone), shadow:NAME (its shadow mask) or layer:NAME (a G-buffer layer); "
                                       "other than beauty is rendered on request (PNG, JPEG or EXR by the file name; a beauty EXR holds one layer per light)");
    app.add_option("--timeout", timeoutS, "seconds to wait for each answer")->check(CLI::Range(0.1, 3600.0));
    CLI11_PARSE(app, argc, argv);

    auto url = client::parseUrl(urlText);
    if (!url) {
        std::cerr << "dfb-client: " << url.error().message << "\n";
        return EXIT_USAGE;
    }
    protocol::EditMessage edit;
    edit.seq = 1;
    for (const std::string& s : sets) {
        auto c = protocol::parseAssignment(s);
        if (!c) {
            std::cerr << "dfb-client: --set " << c.error().message << "\n";
            return EXIT_USAGE;
        }
        edit.changes.push_back(c.value());
    }
    if (!printRig && edit.changes.empty() && framePath.empty()) {
        std::cerr << "dfb-client: nothing to do: give --rig, --set or --frame (see --help)\n";
        return EXIT_USAGE;
    }
    const auto timeout = std::chrono::milliseconds(static_cast<long>(timeoutS * 1000));

    auto conn = client::Connection::open(url.value(), timeout);
    if (!conn) {
        std::cerr << "dfb-client: " << conn.error().message << "\n";
        return EXIT_UNREACHABLE;
    }
    // The server greets every client with the session and the rig.
    std::optional<client::FrameMessage> lastFrame;
    nlohmann::json welcome;
    while (welcome.is_null()) {
        auto m = conn.value()->receive();
        if (!m) {
            std::cerr << "dfb-client: " << m.error().message << "\n";
            return EXIT_BROKEN;
        }
        if (auto* t = std::get_if<client::TextMessage>(&m.value())) {
            if (t->json.value("type", "") == "welcome") welcome = t->json;
        } else {
            lastFrame = std::get<client::FrameMessage>(std::move(m.value()));
        }
    }
    if (printRig) std::cout << welcome["rig"].dump(2) << std::endl;

    uint64_t wantVersion = welcome["rig"].value("version", uint64_t(0));
    if (!edit.changes.empty()) {
        if (auto s = conn.value()->sendText(protocol::encodeEdit(edit)); !s) {
            std::cerr << "dfb-client: " << s.error().message << "\n";
            return EXIT_BROKEN;
        }
        for (;;) {
            auto m = conn.value()->receive();
            if (!m) {
                std::cerr << "dfb-client: waiting for the server's answer: " << m.error().message << "\n";
                return EXIT_BROKEN;
            }
            if (auto* f = std::get_if<client::FrameMessage>(&m.value())) {
                lastFrame = std::move(*f);
                continue;
            }
            const auto& j = std::get<client::TextMessage>(m.value()).json;
            const std::string type = j.value("type", "");
            if (type == "error" && j.value("seq", uint64_t(0)) == edit.seq) {
                std::cerr << "dfb-client: server refused the edit: " << j.value("code", "") << ": "
                          << j.value("message", "") << "\n";
                return EXIT_REFUSED;
            }
            if (type == "ack" && j.value("seq", uint64_t(0)) == edit.seq) {
                wantVersion = j.value("rigVersion", wantVersion);
                std::cout << "applied " << edit.changes.size() << " change(s); rig version " << wantVersion << std::endl;
                break;
            }
        }
    }

    if (!framePath.empty()) {
        if (endsWith(framePath, ".png") || endsWith(framePath, ".exr") || output != "beauty") {
            const std::string resource = std::string(endsWith(framePath, ".png")   ? "/v1/frame.png"
                                                     : endsWith(framePath, ".exr") ? "/v1/frame.exr"
                                                                                   : "/v1/frame.jpg") +
                                         "?output=" + output;
            auto body = client::httpGet(url.value(), resource, timeout);
            if (!body) {
                std::cerr << "dfb-client: " << body.error().message << "\n";
                return body.error().code == ErrorCode::Network ? EXIT_BROKEN : EXIT_REFUSED;
            }
            if (int rc = writeFile(framePath, body->data(), body->size())) return rc;
        } else {
            // The next streamed frame that shows at least the rig version we know of.
            while (!lastFrame || lastFrame->header.rigVersion < wantVersion) {
                auto m = conn.value()->receive();
                if (!m) {
                    std::cerr << "dfb-client: waiting for a frame: " << m.error().message << "\n";
                    return EXIT_BROKEN;
                }
                if (auto* f = std::get_if<client::FrameMessage>(&m.value())) lastFrame = std::move(*f);
            }
            if (int rc = writeFile(framePath, lastFrame->image.data(), lastFrame->image.size())) return rc;
        }
        std::cout << "saved " << framePath << std::endl;
    }
    conn.value()->close();
    return 0;
}
