// glTF export over the wire (issue 19 point 7): GET /v1/sessions/ID/export.glb on a real
// dfb-server over loopback (any role, model/gltf-binary, the file loads back to the session's rig)
// and `dfb-client export OUT.glb`; refusals: a rig with no lights (409, nothing written by the
// client), a scene that went missing (500, its folder not shown), wrong method, no token.

#include "support/EveryLightRig.h"
#include "support/Process.h"
#include "support/TestServer.h"

#include <dfb/gbuffer/Scene.h>
#include <dfb/protocol/Codec.h>
#include <dfb/server/InitialRig.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

using namespace std::chrono_literals;
using json = nlohmann::json;

namespace {

const std::string SHOT = DFB_TEST_DATA "/tabletop_320.exr";

std::string readAll(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// The rig a GLB's lights import to (loadScene + initialRig, as a new session would start).
dfb::Result<dfb::Rig> importRig(const std::string& path) {
    auto scene = dfb::loadScene(path);
    if (!scene) return scene.error();
    return dfb::initialRig(scene.value());
}

class ServerExport : public ::testing::Test {
protected:
    void SetUp() override {
        ASSERT_TRUE(std::filesystem::exists(SHOT)) << "run the bake_tabletop_fixture test first";
        mDir = std::filesystem::temp_directory_path() / ("dfb_export_" + std::to_string(::getpid()));
        std::filesystem::create_directories(mDir);
    }
    void TearDown() override { std::filesystem::remove_all(mDir); }
    std::pair<int, std::string> client(const std::string& link, std::vector<std::string> args) {
        args.insert(args.begin(), DFB_CLIENT_EXE);
        args.insert(args.end(), {"--server", link});
        return dfb::test::run(args, 120s);
    }
    std::filesystem::path mDir;
};

} // namespace

TEST_F(ServerExport, EndpointAndClientWriteTheRigIntoTheScene) {
    dfb::test::Server server({SHOT});
    ASSERT_TRUE(server.up()) << server.process->output();
    const std::string id = server.onlySession();
    const auto& tokens = server.tokens[id];
    // Every light type, put by an editor.
    const dfb::Rig rig = dfb::test::everyLightRig();
    auto put = dfb::test::http(server.port, "PUT", "/v1/sessions/" + id + "/rig", tokens.editor, dfb::protocol::toJson(rig).dump());
    ASSERT_EQ(put.status, 200) << put.body;
    const json want = server.rig(id); // as the session holds it (fitted alphaBeta included)

    // A viewer may read it, like the rig.
    auto r = dfb::test::http(server.port, "GET", "/v1/sessions/" + id + "/export.glb", tokens.viewer);
    ASSERT_EQ(r.status, 200) << r.body;
    EXPECT_EQ(r.headers["Content-Type"], "model/gltf-binary");
    EXPECT_EQ(r.headers["ETag"], "\"" + std::to_string(want["version"].get<uint64_t>()) + "\"");
    ASSERT_TRUE(dfb::test::glbJson(r.body).has_value()) << "not a GLB";
    const std::string viaHttp = (mDir / "http.glb").string();
    std::ofstream(viaHttp, std::ios::binary) << r.body;
    auto back = importRig(viaHttp);
    ASSERT_TRUE(back.ok()) << back.error().toString();
    ASSERT_EQ(back->lights.size(), want["lights"].size());
    // What the server derives (area lights' fitted alphaBeta, a chain's warning) is written but
    // not read back: a session derives it again from the rest.
    auto authored = [](json l) {
        l.erase("alphaBeta");
        l.erase("warning");
        return l;
    };
    for (size_t i = 0; i < back->lights.size(); ++i) {
        EXPECT_EQ(authored(dfb::protocol::toJson(back->lights[i])), authored(want["lights"][i]));
    }
    EXPECT_EQ(back->exposureStops, want["exposure"].get<float>());

    // dfb-client export: a file that loads, with the same lights.
    const std::string viaClient = (mDir / "client.glb").string();
    auto [rc, out] = client(server.editorLink(id), {"export", viaClient});
    ASSERT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("saved " + viaClient), std::string::npos) << out;
    EXPECT_EQ(readAll(viaClient), r.body) << "the same rig exports the same bytes";
    auto back2 = importRig(viaClient);
    ASSERT_TRUE(back2.ok()) << back2.error().toString();
    EXPECT_EQ(back2->lights.size(), rig.lights.size());

    // Only GET (and HEAD); a token is needed.
    auto post = dfb::test::http(server.port, "POST", "/v1/sessions/" + id + "/export.glb", tokens.editor);
    EXPECT_EQ(post.status, 405);
    auto anonymous = dfb::test::http(server.port, "GET", "/v1/sessions/" + id + "/export.glb");
    EXPECT_EQ(anonymous.status, 401);

    // No lights: 409 with the project's error JSON naming why; the client writes nothing, exits 3.
    auto empty = dfb::test::http(server.port, "PUT", "/v1/sessions/" + id + "/rig", tokens.editor, R"({"lights": []})");
    ASSERT_EQ(empty.status, 200) << empty.body;
    auto refused = dfb::test::http(server.port, "GET", "/v1/sessions/" + id + "/export.glb", tokens.viewer);
    EXPECT_EQ(refused.status, 409);
    const json err = refused.json();
    EXPECT_EQ(err.value("type", ""), "error");
    EXPECT_EQ(err.value("code", ""), "missing_data");
    EXPECT_NE(err.value("message", "").find("no lights"), std::string::npos) << refused.body;
    const std::string none = (mDir / "none.glb").string();
    auto [rc2, out2] = client(server.editorLink(id), {"export", none});
    EXPECT_EQ(rc2, 3) << out2;
    EXPECT_NE(out2.find("no lights"), std::string::npos) << out2;
    EXPECT_FALSE(std::filesystem::exists(none));
    // Nothing changed: the rig is as the empty PUT left it.
    EXPECT_EQ(server.rig(id)["lights"].size(), 0u);
}

TEST_F(ServerExport, ASceneThatCannotBeReadIsAClearError) {
    // The session's scene is a copy that goes away after the server has loaded its casters.
    const std::filesystem::path scene = mDir / "copy.glb";
    std::filesystem::copy_file(DFB_SOURCE_DIR "/scenes/tabletop.glb", scene);
    dfb::test::Server server({SHOT, "--scene", scene.string()});
    ASSERT_TRUE(server.up()) << server.process->output();
    const std::string id = server.onlySession();
    std::filesystem::remove(scene);
    auto r = dfb::test::http(server.port, "GET", "/v1/sessions/" + id + "/export.glb", server.tokens[id].viewer);
    EXPECT_EQ(r.status, 500);
    const json err = r.json();
    EXPECT_EQ(err.value("type", ""), "error");
    EXPECT_EQ(err.value("code", ""), "file_not_found");
    EXPECT_NE(err.value("message", "").find("cannot export the scene"), std::string::npos) << r.body;
    EXPECT_EQ(r.body.find(mDir.string()), std::string::npos) << "the server's folders stay private: " << r.body;
    // The session goes on serving.
    EXPECT_EQ(dfb::test::http(server.port, "GET", "/v1/sessions/" + id + "/rig", server.tokens[id].viewer).status, 200);
    // A scene that is not glTF any more.
    std::ofstream(scene, std::ios::binary) << "not a scene";
    auto bad = dfb::test::http(server.port, "GET", "/v1/sessions/" + id + "/export.glb", server.tokens[id].viewer);
    EXPECT_EQ(bad.status, 500);
    EXPECT_EQ(bad.json().value("code", ""), "invalid_file") << bad.body;
}
