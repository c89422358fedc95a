// dfb-server: relights a baked deep framebuffer and serves it over HTTP/WebSocket.
//
// Exit codes: 0 clean shutdown (SIGINT/SIGTERM); 1 bad command line; 2 bad input (shot or
// scene); 3 GPU/EGL failure; 5 network (cannot bind).

#include "net/Listener.h"
#include "net/SharedState.h"
#include "session/RenderService.h"
#include "session/Session.h"

#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/server/InitialRig.h>

#include <CLI/CLI.hpp>
#include <glm/glm.hpp>

#include <algorithm>
#include <cctype>

#include <cstdio>
#include <filesystem>
#include <iostream>

int main(int argc, char** argv) {
    CLI::App app{"dfb-server: relight a deep framebuffer interactively over HTTP and WebSocket"};
    std::string shotPath, scenePath, bind = "127.0.0.1", assets;
    int refineMs = 250;
    int port = 8080, quality = 85;
    app.add_option("shot", shotPath, "deep framebuffer EXR written by dfb-bake")->required();
    app.add_option("--scene", scenePath, "glTF scene for shadow casting (default: the shot's source scene)");
    app.add_option("--port", port, "TCP port; 0 picks a free one")->check(CLI::Range(0, 65535));
    app.add_option("--bind", bind, "address to listen on (default loopback only)");
    app.add_option("--jpeg-quality", quality, "JPEG quality of streamed frames")->check(CLI::Range(1, 100));
    app.add_option("--assets", assets, "folder of cookie images that lights name (default: the shot's folder)");
    app.add_option("--refine-window", refineMs,
                   "ms: an edit within this time of the previous one renders with preview shadow maps, refined when "
                   "edits stop (0 = always full quality)")
        ->check(CLI::Range(0, 10000));
    CLI11_PARSE(app, argc, argv);

    auto shot = dfb::readDeepBuffer(shotPath);
    if (!shot) {
        std::cerr << "dfb-server: " << shot.error().toString() << "\n";
        return 2;
    }
    if (scenePath.empty()) {
        scenePath = shot->sourcePath;
        // A relative source path is relative to where the bake ran; also try beside the shot.
        if (!std::filesystem::exists(scenePath)) {
            auto beside = std::filesystem::path(shotPath).parent_path() / std::filesystem::path(scenePath).filename();
            if (std::filesystem::exists(beside)) scenePath = beside.string();
        }
    }
    auto scene = dfb::loadScene(scenePath);
    if (!scene) {
        std::cerr << "dfb-server: shadow casters: " << scene.error().toString()
                  << (scenePath == shot->sourcePath ? " (the shot's source scene; pass --scene)" : "") << "\n";
        return 2;
    }
    dfb::ShadowGeometry casters = dfb::shadowCasters(scene.value());
    bool imported = false;
    dfb::Rig rig = dfb::initialRig(scene.value(), &imported);
    if (imported) std::printf("dfb-server: initial rig from the scene's KHR_lights_punctual (%zu lights)\n", rig.lights.size());
    dfb::Session session(shot.value(), shotPath, rig);
    if (assets.empty()) assets = std::filesystem::path(shotPath).parent_path().string();
    session.setAssetDirectory(assets.empty() ? "." : assets);

    boost::asio::io_context ioc(1);
    auto state = std::make_shared<dfb::net::SharedState>(ioc, session);
    auto render = dfb::RenderService::start(
        shot.value(), std::move(casters), session,
        [state](std::shared_ptr<const dfb::EncodedFrame> f) { state->publishFrame(std::move(f)); }, quality);
    if (!render) {
        std::cerr << "dfb-server: " << render.error().toString() << "\n";
        return 3;
    }
    render.value()->setRefinement(std::chrono::milliseconds(refineMs), std::chrono::milliseconds(150));
    state->setRenderService(render->get());
    render.value()->requestFrame();

    boost::system::error_code ec;
    const auto address = boost::asio::ip::make_address(bind, ec);
    if (ec) {
        std::cerr << "dfb-server: --bind " << bind << " is not an IP address\n";
        return 1;
    }
    auto listener = std::make_shared<dfb::net::Listener>(ioc, state);
    if (auto s = listener->open({address, static_cast<unsigned short>(port)}); !s) {
        std::cerr << "dfb-server: " << s.error().toString() << "\n";
        return 5;
    }
    listener->run();

    boost::asio::signal_set signals(ioc, SIGINT, SIGTERM);
    signals.async_wait([&](const boost::system::error_code&, int) { ioc.stop(); });

    std::printf("dfb-server: %s (%dx%d), %zu shadow-casting triangles, %s\n", shotPath.c_str(), shot->width,
                shot->height, scene->triangleCount(), render.value()->deviceDescription().c_str());
    const std::string host = address.is_v6() ? "[" + bind + "]" : bind;
    std::printf("dfb-server: listening on http://%s:%u/\n", host.c_str(), unsigned(listener->port()));
    std::fflush(stdout);
    ioc.run();
    std::printf("dfb-server: shutting down\n");
    return 0;
}
