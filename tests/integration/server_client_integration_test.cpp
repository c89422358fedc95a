// End to end over loopback: the real dfb-server on a baked shot of the default scene, driven by
// the real dfb-client. Moving the key light must move its lit region and the bunny's shadow to
// where the light's geometry puts them; malformed messages get an error and the server keeps
// serving; bad inputs give clear errors and non-zero exits.

#include "support/NetClient.h"
#include "support/Process.h"
#include "support/TestServer.h"
#include "support/RayCaster.h"

#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/Scene.h>

#include <utility> // Boost 1.74 asio needs std::exchange declared first
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>

#include <OpenImageIO/imageio.h>
#include <pwd.h>
#include <unistd.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

using namespace dfb;
using namespace std::chrono_literals;

namespace {

const std::string SHOT = DFB_TEST_DATA "/tabletop_320.exr";
const std::string SCENE = DFB_SOURCE_DIR "/scenes/tabletop.glb";

std::string vec(const glm::vec3& v) {
    char buf[128];
    std::snprintf(buf, sizeof buf, "%.6f,%.6f,%.6f", double(v.x), double(v.y), double(v.z));
    return buf;
}

struct Gray {
    int width = 0, height = 0;
    std::vector<float> lum; // linear-ish 0..1 (sRGB code values / 255, averaged)
    float at(int x, int y) const { return lum[size_t(y) * width + x]; }
};

Gray readGray(const std::string& path) {
    Gray g;
    auto in = OIIO::ImageInput::open(path);
    if (!in) return g;
    const auto& spec = in->spec();
    g.width = spec.width;
    g.height = spec.height;
    std::vector<float> px(size_t(spec.width) * spec.height * spec.nchannels);
    in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, px.data());
    g.lum.resize(size_t(g.width) * g.height);
    for (size_t i = 0; i < g.lum.size(); ++i) {
        g.lum[i] = (px[i * spec.nchannels] + px[i * spec.nchannels + 1] + px[i * spec.nchannels + 2]) / 3.f;
    }
    return g;
}

class ServerClient : public ::testing::Test {
protected:
    void SetUp() override {
        ASSERT_TRUE(std::filesystem::exists(SHOT)) << "run the bake_tabletop_fixture test first";
        auto shot = readDeepBuffer(SHOT);
        ASSERT_TRUE(shot.ok()) << shot.error().toString();
        mShot = std::move(shot.value());
        mServer = std::make_unique<test::Server>(std::vector<std::string>{SHOT});
        ASSERT_TRUE(mServer->up()) << "server did not start:\n" << mServer->process->output();
        mPort = mServer->port;
        // The editor link the server printed carries the session and its token.
        mSession = mServer->onlySession();
        mUrl = mServer->editorLink(mSession);
        mToken = mServer->tokens[mSession].editor;
        mDir = std::filesystem::temp_directory_path() / ("dfb_it_" + std::to_string(::getpid()));
        std::filesystem::create_directories(mDir);
    }
    void TearDown() override {
        mServer.reset();
        std::filesystem::remove_all(mDir);
    }

    // Runs dfb-client SUBCOMMAND ARGS... on the session; returns its exit code and output.
    std::pair<int, std::string> client(std::vector<std::string> args) {
        args.insert(args.begin(), DFB_CLIENT_EXE);
        args.insert(args.end(), {"--server", mUrl});
        return test::run(args, 60s);
    }

    Gray frameAfter(const std::vector<std::string>& sets, const std::string& name) {
        std::vector<std::string> args = {"set"};
        args.insert(args.end(), sets.begin(), sets.end());
        auto [rc, out] = client(args);
        EXPECT_EQ(rc, 0) << out;
        const std::string path = (mDir / name).string();
        std::tie(rc, out) = client({"frame", path});
        EXPECT_EQ(rc, 0) << out;
        return readGray(path);
    }

    uint32_t objectId(const std::string& name) const {
        for (size_t i = 0; i < mShot.objectNames.size(); ++i)
            if (mShot.objectNames[i] == name) return uint32_t(i + 1);
        return 0;
    }

    DeepBuffer mShot;
    std::unique_ptr<test::Server> mServer;
    std::string mUrl, mPort, mSession, mToken;
    std::filesystem::path mDir;
};

} // namespace

TEST_F(ServerClient, ClientPrintsTheRig) {
    auto [rc, out] = client({"rig", "get"});
    ASSERT_EQ(rc, 0) << out;
    auto j = nlohmann::json::parse(out.substr(0, out.rfind('}') + 1), nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << out;
    ASSERT_TRUE(j["lights"].is_array());
    EXPECT_EQ(j["lights"][0]["name"], "key");
    EXPECT_EQ(j["lights"][0]["shadow"], true);
}

// The browser page's files: each of DFB_WEB_FILES (server/CMakeLists.txt, the list the server
// embeds) is served at /NAME as its source, with its extension's type; nothing else is.
TEST_F(ServerClient, ServesThePageFilesWithTheirTypesAndNothingElse) {
    std::vector<std::string> files;
    std::stringstream list(DFB_WEB_FILES);
    for (std::string f; std::getline(list, f, ',');) files.push_back(f);
    ASSERT_GE(files.size(), 3u) << DFB_WEB_FILES;
    const std::map<std::string, std::string> types = {{".html", "text/html; charset=utf-8"},
                                                      {".js", "text/javascript; charset=utf-8"},
                                                      {".css", "text/css; charset=utf-8"}};
    for (const std::string& f : files) {
        const auto r = test::http(mPort, "GET", "/" + f);
        EXPECT_EQ(r.status, 200) << f;
        const auto type = types.find(f.substr(f.rfind('.')));
        ASSERT_NE(type, types.end()) << f;
        EXPECT_EQ(r.headers.count("Content-Type") ? r.headers.at("Content-Type") : "", type->second) << f;
        EXPECT_EQ(r.headers.count("X-Content-Type-Options") ? r.headers.at("X-Content-Type-Options") : "", "nosniff") << f;
        std::ifstream source(DFB_SOURCE_DIR "/client/web/" + f, std::ios::binary);
        const std::string text((std::istreambuf_iterator<char>(source)), std::istreambuf_iterator<char>());
        EXPECT_FALSE(text.empty()) << f;
        EXPECT_TRUE(r.body == text) << f << ": the served file differs from its source";
    }
    const auto root = test::http(mPort, "GET", "/");
    EXPECT_EQ(root.status, 200);
    EXPECT_EQ(root.headers.count("Content-Type") ? root.headers.at("Content-Type") : "", "text/html; charset=utf-8");
    EXPECT_EQ(root.body, test::http(mPort, "GET", "/index.html").body);
    // Names of no listed file: out of the folder, files beside the listed ones, encodings and
    // near-misses of listed names, other folders.
    for (const char* path : {"/../CMakeLists.txt", "/main.js.map", "/index.html%00", "/package.json", "/web/main.js", "//main.js",
                             "/main.js/", "/MAIN.JS", "/%2e%2e/CMakeLists.txt", "/main%2ejs", "/rig.js%20", "/client/web/main.js",
                             "/./main.js", "/.."}) {
        const auto r = test::http(mPort, "GET", path);
        EXPECT_EQ(r.status, 404) << path;
        EXPECT_EQ(r.headers.count("Content-Type") ? r.headers.at("Content-Type") : "", "application/json") << path;
    }
    EXPECT_EQ(test::http(mPort, "POST", "/main.js").status, 405);
}

TEST_F(ServerClient, MovingTheKeyLightMovesTheLitRegionAndTheBunnyShadow) {
    auto scene = loadScene(SCENE);
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    const uint32_t bunnyId = objectId("bunny"), tableId = objectId("table");
    ASSERT_NE(bunnyId, 0u);
    ASSERT_NE(tableId, 0u);
    // Reference visibility: every object but the table, ray cast with Embree. `bunnyOnly` tells
    // the bunny's shadow apart from the others'.
    test::RayCaster occluders, bunnyOnly;
    Bounds bunny;
    for (const MeshPart& p : scene->parts) {
        if (p.objectId == tableId) continue;
        occluders.addMesh(p.positions, p.indices);
        if (p.objectId == bunnyId) {
            bunnyOnly.addMesh(p.positions, p.indices);
            for (const auto& v : p.positions) bunny.extend(v);
        }
    }
    occluders.commit();
    bunnyOnly.commit();
    const glm::vec3 bunnyBase(bunny.center().x, 0.f, bunny.center().z);

    // A key light above, in front and to the left of the bunny, aimed at its base; the fill is
    // off so that the image holds this light alone. Then the light moves right by 1.2 m with the
    // same direction.
    const glm::vec3 L1 = bunnyBase + glm::vec3(-1.8f, 4.2f, 2.0f);
    const glm::vec3 D = glm::normalize(bunnyBase - L1);
    const glm::vec3 L2 = L1 + glm::vec3(1.2f, 0.f, 0.f);
    const float coneDeg = 20.f, penumbraDeg = 2.f;
    const std::vector<std::string> setup = {"fill.enabled=false", "key.coneAngle=20", "key.penumbra=2",
                                            "key.direction=" + vec(D)};
    auto with = [&](std::vector<std::string> extra) {
        std::vector<std::string> all = setup;
        all.insert(all.end(), extra.begin(), extra.end());
        return all;
    };
    const Gray aOn = frameAfter(with({"key.position=" + vec(L1), "key.shadow=true"}), "a_on.png");
    const Gray aOff = frameAfter({"key.shadow=false"}, "a_off.png");
    const Gray bOn = frameAfter({"key.position=" + vec(L2), "key.shadow=true"}, "b_on.png");
    const Gray bOff = frameAfter({"key.shadow=false"}, "b_off.png");
    ASSERT_EQ(aOn.width, mShot.width);
    ASSERT_EQ(bOff.height, mShot.height);
    const int W = mShot.width, H = mShot.height;

    // Per table pixel: predicted from the G-buffer position and the light's geometry, measured
    // from the served images. Pixels within 1 degree of the cone's soft edge are not judged.
    enum { Unknown, No, Yes };
    struct Masks {
        std::vector<int> litPred, litMeas, shadowPred, shadowMeas, bunnyShadowPred;
    };
    auto masks = [&](const glm::vec3& L, const Gray& on, const Gray& off) {
        Masks m;
        const size_t n = size_t(W) * H;
        for (auto* v : {&m.litPred, &m.litMeas, &m.shadowPred, &m.shadowMeas, &m.bunnyShadowPred}) v->assign(n, Unknown);
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                const size_t i = size_t(y) * W + x;
                if (mShot.objectId[i] != tableId) continue;
                const glm::vec3 P = mShot.position(x, y);
                const float angle = glm::degrees(std::acos(glm::dot(glm::normalize(P - L), D)));
                const float edge = coneDeg - 0.5f * penumbraDeg;
                if (std::abs(angle - edge) < 1.f) continue;
                m.litPred[i] = angle < edge ? Yes : No;
                m.litMeas[i] = off.at(x, y) > 0.02f ? Yes : No;
                if (m.litPred[i] == Yes && off.at(x, y) > 0.02f) {
                    m.shadowPred[i] = occluders.occluded(P, L) ? Yes : No;
                    m.bunnyShadowPred[i] = bunnyOnly.occluded(P, L) ? Yes : No;
                    m.shadowMeas[i] = off.at(x, y) - on.at(x, y) > 0.5f * off.at(x, y) ? Yes : No;
                }
            }
        return m;
    };
    // Intersection over union of the Yes pixels, over pixels both masks judge.
    auto iou = [](const std::vector<int>& a, const std::vector<int>& b) {
        size_t inter = 0, uni = 0;
        for (size_t i = 0; i < a.size(); ++i) {
            if (a[i] == Unknown || b[i] == Unknown) continue;
            inter += a[i] == Yes && b[i] == Yes;
            uni += a[i] == Yes || b[i] == Yes;
        }
        return uni ? double(inter) / double(uni) : 0.0;
    };
    auto count = [](const std::vector<int>& a) { return std::count(a.begin(), a.end(), int(Yes)); };
    auto centroid = [&](const std::vector<int>& a) {
        glm::dvec2 c(0.0);
        size_t k = 0;
        for (size_t i = 0; i < a.size(); ++i)
            if (a[i] == Yes) { c += glm::dvec2(double(i % W), double(i / W)); ++k; }
        return k ? c / double(k) : c;
    };
    const Masks A = masks(L1, aOn, aOff), B = masks(L2, bOn, bOff);
    ASSERT_GT(count(A.litPred), 1000);
    ASSERT_GT(count(A.bunnyShadowPred), 50) << "the bunny must cast a shadow on the table";
    ASSERT_GT(count(B.bunnyShadowPred), 50);

    const double litA = iou(A.litMeas, A.litPred), litB = iou(B.litMeas, B.litPred);
    const double litStale = iou(B.litMeas, A.litPred);
    const double shA = iou(A.shadowMeas, A.shadowPred), shB = iou(B.shadowMeas, B.shadowPred);
    // The old light position's shadow, judged on the new frame's pixels.
    Masks stale = B;
    stale.shadowPred = masks(L1, bOn, bOff).shadowPred;
    const double shStale = iou(B.shadowMeas, stale.shadowPred);
    // The measured bunny shadow: shadowed pixels, less those only the other objects can shadow.
    auto bunnyShadowMeas = [&](const Masks& m) {
        std::vector<int> r = m.shadowMeas;
        for (size_t i = 0; i < r.size(); ++i)
            if (m.shadowPred[i] == Yes && m.bunnyShadowPred[i] == No) r[i] = No;
        return r;
    };
    const glm::dvec2 shMoveMeas = centroid(bunnyShadowMeas(B)) - centroid(bunnyShadowMeas(A));
    const glm::dvec2 bunnyMovePred = centroid(B.bunnyShadowPred) - centroid(A.bunnyShadowPred);
    std::printf("lit region IoU with prediction: before move %.3f, after move %.3f (vs the old position %.3f)\n", litA,
                litB, litStale);
    std::printf("shadow IoU with Embree reference: before move %.3f, after move %.3f (vs the old position %.3f)\n", shA,
                shB, shStale);
    std::printf("bunny shadow centroid moved (%.1f, %.1f) px; Embree predicts (%.1f, %.1f) px\n", shMoveMeas.x,
                shMoveMeas.y, bunnyMovePred.x, bunnyMovePred.y);

    // The lit region is where the cone says, before and after; after the move it is no longer
    // where it was.
    EXPECT_GT(litA, 0.97);
    EXPECT_GT(litB, 0.97);
    EXPECT_LT(litStale, 0.8);
    // Shadows agree with ray casting (PCF softens a pixel or two at 320x180), and they moved.
    EXPECT_GT(shA, 0.8);
    EXPECT_GT(shB, 0.8);
    EXPECT_LT(shStale, shB - 0.15);
    // Moving the light right moves the bunny's shadow left, by about the predicted amount.
    EXPECT_LT(bunnyMovePred.x, -2.0);
    EXPECT_LT(shMoveMeas.x, 0.5 * bunnyMovePred.x);
}

TEST_F(ServerClient, MalformedMessagesGetAnErrorAndTheServerKeepsServing) {
    namespace beast = boost::beast;
    boost::asio::io_context ioc;
    beast::websocket::stream<boost::asio::ip::tcp::socket> ws(ioc);
    boost::asio::ip::tcp::resolver resolver(ioc);
    boost::asio::connect(ws.next_layer(), resolver.resolve("127.0.0.1", mPort));
    ws.handshake("127.0.0.1", "/v1/sessions/" + mSession + "/ws?token=" + mToken);
    auto nextText = [&]() {
        for (;;) {
            beast::flat_buffer buf;
            ws.read(buf);
            if (!ws.got_text()) continue;
            auto j = nlohmann::json::parse(beast::buffers_to_string(buf.data()));
            if (j["type"] != "presence") return j; // who is connected: not an answer
        }
    };
    EXPECT_EQ(nextText()["type"], "welcome");
    for (const std::string bad : {"{{{ not json", R"({"type":"edit"})", R"({"type":"edit","seq":5,"changes":[{"path":"key.intensity","value":"lots"}]})",
                                  R"({"type":"warp"})"}) {
        ws.text(true);
        ws.write(boost::asio::buffer(bad));
        auto reply = nextText();
        EXPECT_EQ(reply["type"], "error") << bad;
        EXPECT_FALSE(reply["message"].get<std::string>().empty());
    }
    // The third message named its sequence number: the error names it back.
    ws.write(boost::asio::buffer(std::string(R"({"type":"edit","seq":6,"changes":[{"path":"key.coneAngle","value":400}]})")));
    auto reply = nextText();
    EXPECT_EQ(reply["type"], "error");
    EXPECT_EQ(reply["seq"], 6);
    ws.write(boost::asio::buffer(std::string(R"({"type":"edit","seq":7,"changes":[{"path":"key.intensity","value":10}]})")));
    reply = nextText();
    EXPECT_EQ(reply["type"], "ack");
    EXPECT_EQ(reply["seq"], 7);
    ws.close(beast::websocket::close_code::normal);
    // Still serving plain HTTP too.
    auto [rc, out] = client({"rig", "get"});
    EXPECT_EQ(rc, 0) << out;
}

TEST_F(ServerClient, BendyLightOutputsAndSelfIntersectionWarning) {
    // Bend the key light; its shadow mask and its contribution alone are served as images.
    auto [rc, out] = client({"set", "key.type=\"bendy\"", "key.controlPoints=[[1.5,0,0],[3,0,0],[4.2,0,0.6],[4.8,0,1.9]]",
                             "key.radii=[0,0.8,1.6,1.9,2.2]"});
    ASSERT_EQ(rc, 0) << out;
    const std::string mask = (mDir / "mask.png").string(), alone = (mDir / "fill.png").string();
    std::tie(rc, out) = client({"frame", mask, "--output", "shadow:key"});
    ASSERT_EQ(rc, 0) << out;
    const Gray m = readGray(mask);
    ASSERT_EQ(m.width, mShot.width);
    size_t lit = 0, shadowed = 0;
    for (float v : m.lum) {
        lit += v > 0.9f;
        shadowed += v < 0.1f;
    }
    EXPECT_GT(lit, 500u);
    EXPECT_GT(shadowed, 500u);
    std::tie(rc, out) = client({"frame", alone, "--output", "light:fill"});
    ASSERT_EQ(rc, 0) << out;
    EXPECT_EQ(readGray(alone).width, mShot.width);
    std::tie(rc, out) = client({"frame", alone, "--output", "light:nobody"});
    EXPECT_EQ(rc, 3) << out;
    EXPECT_NE(out.find("nobody"), std::string::npos) << out;
    // A chain that loops back through itself: stopped short of the fold by default, with a line
    // saying so; with --allow-fold accepted as given, rendered, and flagged on the light.
    const std::string loop = "key.controlPoints=[[2,0,0],[2,2,0],[0,2,0],[0.5,0,0]]";
    std::tie(rc, out) = client({"set", loop, "key.radii=[0,1,1,1,1]"});
    ASSERT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("limited key: stopped"), std::string::npos) << out;
    std::tie(rc, out) = client({"rig", "get"});
    ASSERT_EQ(rc, 0) << out;
    EXPECT_EQ(out.find("\"warning\""), std::string::npos) << out;
    std::tie(rc, out) = client({"set", "--allow-fold", loop, "key.radii=[0,1,1,1,1]"});
    ASSERT_EQ(rc, 0) << out;
    EXPECT_EQ(out.find("limited"), std::string::npos) << out;
    std::tie(rc, out) = client({"rig", "get"});
    ASSERT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("\"warning\""), std::string::npos) << out;
    EXPECT_NE(out.find("\"warning\": \"the tube is wider than the bend at p"), std::string::npos) << out; // in plain words
    std::tie(rc, out) = client({"frame", mask});
    EXPECT_EQ(rc, 0) << out;
}

// The user's login name, as the default --name of dfb-client should be.
std::string loginName() {
    const passwd* pw = ::getpwuid(::geteuid());
    return pw && pw->pw_name ? pw->pw_name : "";
}

// dfb-client behaves like the tools TDs use (issue 20 point 6; docs/operations.md "dfb-client").
TEST_F(ServerClient, CommandLineConventions) {
    // Usage errors exit 1 and say what was wrong; an unknown subcommand is named with the ones
    // there are.
    auto [rc, out] = client({"nosuch"});
    EXPECT_EQ(rc, 1) << out;
    EXPECT_NE(out.find("unknown subcommand 'nosuch'"), std::string::npos) << out;
    EXPECT_NE(out.find("sessions, info, rig"), std::string::npos) << out;
    std::tie(rc, out) = client({"rig", "fetch"});
    EXPECT_EQ(rc, 1) << out;
    EXPECT_NE(out.find("unknown subcommand 'fetch' (dfb-client rig has: get, put)"), std::string::npos) << out;
    std::tie(rc, out) = client({"pick", "x", "1"});
    EXPECT_EQ(rc, 1) << out;
    // The file's extension is the format; one it cannot write is refused before asking.
    const std::string tif = (mDir / "out.tif").string();
    std::tie(rc, out) = client({"frame", tif});
    EXPECT_EQ(rc, 1) << out;
    EXPECT_NE(out.find("cannot write '.tif'"), std::string::npos) << out;
    EXPECT_FALSE(std::filesystem::exists(tif));
    std::tie(rc, out) = client({"frame", (mDir / "out.jpg").string(), "--format", "png"});
    EXPECT_EQ(rc, 1) << out;
    EXPECT_NE(out.find("--format says png"), std::string::npos) << out;
    const std::string png = (mDir / "out.png").string();
    std::tie(rc, out) = client({"frame", png});
    ASSERT_EQ(rc, 0) << out;
    std::ifstream pngIn(png, std::ios::binary);
    char magic[4] = {};
    pngIn.read(magic, 4);
    EXPECT_EQ(std::string(magic + 1, 3), "PNG");

    // Edits carry the user's name: --name, else the login name.
    std::tie(rc, out) = client({"set", "fill.color=0.95,0.9,0.8", "--name", "alice"});
    ASSERT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("rig version "), std::string::npos) << out; // text, not JSON
    EXPECT_EQ(out.find('{'), std::string::npos) << out;
    std::tie(rc, out) = client({"set", "key.intensity=66"});
    ASSERT_EQ(rc, 0) << out;
    std::tie(rc, out) = client({"history"});
    ASSERT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("edit by alice: fill.color = [0.95,0.9,0.8]"), std::string::npos) << out;
    EXPECT_NE(out.find("edit by " + loginName() + ": key.intensity = 66"), std::string::npos) << out;
    auto h = test::http(mPort, "GET", "/v1/sessions/" + mSession + "/history", mToken);
    EXPECT_NE(h.body.find("\"byName\": \"alice\""), std::string::npos) << h.body;
    // Floats in their shortest form: 0.95, not 0.949999988079071.
    std::tie(rc, out) = client({"rig", "get"});
    ASSERT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("0.95,"), std::string::npos) << out;
    EXPECT_EQ(out.find("0.9499999"), std::string::npos) << out;
    // Human text by default, the server's JSON with --json.
    std::tie(rc, out) = client({"pick", "160", "150"});
    ASSERT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("pixel (160, 150): object table"), std::string::npos) << out;
    std::tie(rc, out) = client({"--json", "pick", "160", "150"});
    ASSERT_EQ(rc, 0) << out;
    EXPECT_EQ(nlohmann::json::parse(out, nullptr, false).value("object", ""), "table") << out;
    // Server refusals read "error CODE: message".
    std::tie(rc, out) = client({"set", "key.coneAngle=400"});
    EXPECT_EQ(rc, 3) << out;
    EXPECT_NE(out.find("dfb-client: error invalid_value: key.coneAngle"), std::string::npos) << out;

    // watch on an idle rig: no time-out while the server answers pings (--timeout 1 here, idle
    // for 4 s), then the frame of an edit; with --json stdout is JSON lines only.
    const std::string cmd = std::string(DFB_CLIENT_EXE) + " --server '" + mUrl + "' --json --timeout 1 watch --duration 8 2>/dev/null";
    test::Process watcher({"/bin/sh", "-c", cmd});
    std::this_thread::sleep_for(4s);
    std::tie(rc, out) = client({"--json", "set", "key.intensity=67"});
    ASSERT_EQ(rc, 0) << out;
    const uint64_t edited = nlohmann::json::parse(out, nullptr, false).value("rigVersion", uint64_t(0));
    ASSERT_GT(edited, 0u) << out;
    EXPECT_EQ(watcher.wait(60s), 0) << "watch timed out on an idle rig? " << watcher.output();
    std::istringstream lines(watcher.output());
    std::string line;
    bool sawFrame = false, sawChange = false;
    while (std::getline(lines, line)) {
        auto j = nlohmann::json::parse(line, nullptr, false);
        EXPECT_TRUE(j.is_object()) << "not a JSON line: " << line;
        if (!j.is_object()) continue;
        sawFrame |= j.value("type", "") == "frame" && j.value("rigVersion", uint64_t(0)) == edited;
        sawChange |= j.value("type", "") == "change" && j.value("byName", "") == loginName();
    }
    EXPECT_TRUE(sawFrame) << watcher.output();
    EXPECT_TRUE(sawChange) << watcher.output();
}

TEST(BadInput, ProgramsExitWithClearMessages) {
    const auto dir = std::filesystem::temp_directory_path() / ("dfb_bad_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string notGltf = (dir / "scene.glb").string();
    std::ofstream(notGltf) << "hello";
    {
        auto [rc, out] = test::run({DFB_BAKE_EXE, "/no/such.glb", "-o", (dir / "x.exr").string()});
        EXPECT_EQ(rc, 2);
        EXPECT_NE(out.find("no such file"), std::string::npos) << out;
    }
    {
        auto [rc, out] = test::run({DFB_BAKE_EXE, notGltf, "-o", (dir / "x.exr").string()});
        EXPECT_EQ(rc, 2);
        EXPECT_NE(out.find("not a glTF"), std::string::npos) << out;
    }
    {
        auto [rc, out] = test::run({DFB_SERVER_EXE, "/no/such.exr", "--port", "0"});
        EXPECT_EQ(rc, 2);
        EXPECT_NE(out.find("/no/such.exr"), std::string::npos) << out;
    }
    {
        auto [rc, out] = test::run({DFB_SERVER_EXE, notGltf, "--port", "0"});
        EXPECT_EQ(rc, 2);
        EXPECT_NE(out.find("not an OpenEXR file"), std::string::npos) << out;
    }
    {
        auto [rc, out] = test::run({DFB_SERVER_EXE, SHOT, "--scene", notGltf, "--port", "0"});
        EXPECT_EQ(rc, 2);
        EXPECT_NE(out.find("not a glTF"), std::string::npos) << out;
    }
    {
        auto [rc, out] = test::run({DFB_CLIENT_EXE, "rig", "get", "--server", "http://127.0.0.1:1/?session=s&token=t", "--timeout", "2"});
        EXPECT_EQ(rc, 2) << out;
    }
    {
        auto [rc, out] = test::run({DFB_CLIENT_EXE, "set", "broken", "--server", "http://127.0.0.1:1/?session=s&token=t"});
        EXPECT_EQ(rc, 1) << out;
    }
    std::filesystem::remove_all(dir);
}

// A server on a scene without lights starts with the three-point rig and dome (issue 19 point 6;
// docs/lighting.md "Default rig"), calibrated on the shot at start: the log names the factor and
// the served rig has key, fill, rim and the environment light "dome".
TEST(DefaultRig, TheServerStartsThreePointWithADomeCalibratedToMidGrey) {
    test::Server server({SHOT, "--default-rig", "three-point"});
    ASSERT_TRUE(server.up()) << server.process->output();
    const std::string out = server.process->output();
    EXPECT_NE(out.find("default rig (key, fill, rim, dome) x "), std::string::npos) << out;
    EXPECT_NE(out.find("-> 0.18"), std::string::npos) << out;
    const nlohmann::json rig = server.rig(server.onlySession());
    std::vector<std::string> names;
    for (const auto& l : rig["lights"]) names.push_back(l["name"].get<std::string>() + ":" + l["type"].get<std::string>());
    EXPECT_EQ(names, (std::vector<std::string>{"key:spot", "fill:spot", "rim:spot", "dome:environment"})) << rig.dump();
}
