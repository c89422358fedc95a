// Indirect-editing drags over the protocol (issue 17 point 6; docs/protocol.md "Drags"): the real
// dfb-server on the baked default scene, driven over a loopback WebSocket, plain HTTP and the real
// dfb-client. The test finds its pixels with its own Picker on the same shot and casters, and
// solves the same drag in-process (dfb/server/Drag.h) to know what the server must have applied.

#include "support/NetClient.h"
#include "support/Process.h"
#include "support/TestServer.h"

#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/protocol/Codec.h>
#include <dfb/server/Drag.h>
#include <dfb/server/Engine.h>

#include <gtest/gtest.h>

#include <tuple>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>

using namespace dfb;
using namespace std::chrono_literals;
using nlohmann::json;

namespace {

const std::string SHOT = DFB_TEST_DATA "/tabletop_320.exr";
const std::string SCENE = DFB_SOURCE_DIR "/scenes/tabletop.glb";

// `j` with the fields of `patch` set.
json with(json j, const json& patch) {
    j.update(patch);
    return j;
}

// Fields that are not the light's geometry (compared as JSON: exact floats).
json geometry(const json& light) {
    json g = json::object();
    for (const char* f : {"position", "direction", "controlPoints", "radii", "keys"}) {
        if (light.contains(f)) g[f] = light[f];
    }
    return g;
}

class Drags : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        auto shot = readDeepBuffer(SHOT);
        ASSERT_TRUE(shot.ok()) << "run the bake_tabletop_fixture test first: " << shot.error().toString();
        sShot = new DeepBuffer(std::move(shot.value()));
        auto scene = loadScene(SCENE);
        ASSERT_TRUE(scene.ok()) << scene.error().toString();
        auto picker = Picker::create(*sShot, shadowCasters(scene.value()));
        ASSERT_TRUE(picker.ok()) << picker.error().toString();
        sPicker = picker.value().release();
    }
    static void TearDownTestSuite() {
        delete sPicker;
        delete sShot;
    }

    void SetUp() override {
        mServer = std::make_unique<test::Server>(std::vector<std::string>{SHOT});
        ASSERT_TRUE(mServer->up()) << "server did not start:\n" << mServer->process->output();
        mSession = mServer->onlySession();
        mToken = mServer->tokens[mSession].editor;
        auto rig = protocol::rigFromJson(mServer->rig(mSession));
        ASSERT_TRUE(rig.ok()) << rig.error().toString();
        mRig = rig.value();
    }

    json keyLight() {
        const json rig = mServer->rig(mSession);
        for (const json& l : rig["lights"]) {
            if (l["name"] == "key") return l;
        }
        return nullptr;
    }

    // A shadowed pixel of the key light whose occluder stands well off the receiver (near a
    // contact paper 000 eq. 11 flings the light away per pixel) and from which a drag of `dx`
    // pixels to the right solves: the grab and the in-process step.
    std::pair<DragGrab, DragStep> shadowGrab(int dx) {
        for (int y = sShot->height / 2; y < sShot->height; y += 3)
            for (int x = 0; x + dx < sShot->width; x += 3) {
                auto g = beginDrag(*sPicker, *sShot, mRig, {protocol::DragMode::Shadow, "key", x, y, {}});
                if (!g || glm::length(g->occluder->S - g->at.P) < 0.1f * glm::length(g->occluder->rayFrom - g->at.P)) continue;
                auto s = dragTo(*sPicker, *sShot, g.value(), x + dx, y);
                if (s && !s->changes.empty()) return {g.value(), s.value()};
            }
        ADD_FAILURE() << "no shadowed pixel of the key light found";
        return {};
    }

    // A pixel that shows the background, if the shot has one.
    std::optional<std::pair<int, int>> backgroundPixel() const {
        for (int y = 0; y < sShot->height; ++y)
            for (int x = 0; x < sShot->width; ++x) {
                auto p = sPicker->pick(x, y);
                if (!p && p.error().code == ErrorCode::MissingData) return std::make_pair(x, y);
            }
        return std::nullopt;
    }

    // The next answer (ack or error) on `ws`, skipping what others' activity sends.
    static json answer(test::WsClient& ws) { return ws.nextText({"presence", "welcome", "change"}); }

    static DeepBuffer* sShot;
    static Picker* sPicker;
    std::unique_ptr<test::Server> mServer;
    std::string mSession, mToken;
    Rig mRig;
};
DeepBuffer* Drags::sShot = nullptr;
Picker* Drags::sPicker = nullptr;

} // namespace

// A shadow drag over the WebSocket: the begin changes nothing and reports S; each update is an
// acknowledged edit; the result is exactly the in-process solve of the last pointer position; one
// undo takes the whole drag back.
TEST_F(Drags, ShadowDragIsSolvedOnTheServerAndIsOneUndoStep) {
    const auto [grab, expected] = shadowGrab(12);
    const json before = keyLight();
    test::WsClient ws(mServer->port, mSession, mToken);
    const uint64_t v0 = mServer->rig(mSession)["version"].get<uint64_t>();
    ws.send(json{{"type", "drag"}, {"seq", 1}, {"phase", "begin"}, {"mode", "shadow"}, {"light", "key"}, {"x", grab.x}, {"y", grab.y}});
    json a = answer(ws);
    ASSERT_EQ(a["type"], "ack") << a.dump();
    EXPECT_EQ(a["rigVersion"], v0) << "a begin changes nothing";
    ASSERT_TRUE(a["drag"].contains("occluder")) << a.dump();
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(a["drag"]["occluder"]["S"][k].get<float>(), grab.occluder->S[k], 1e-5f);
    uint64_t last = v0;
    for (int i = 1; i <= 3; ++i) {
        ws.send(json{{"type", "drag"}, {"seq", 1 + i}, {"phase", "update"}, {"x", grab.x + 4 * i}, {"y", grab.y}});
        a = answer(ws);
        ASSERT_EQ(a["type"], "ack") << a.dump();
        ASSERT_EQ(a["seq"], 1 + i);
        EXPECT_EQ(a["rigVersion"], last + 1) << "each update is one edit";
        last = a["rigVersion"];
        EXPECT_TRUE(a["drag"]["changed"].get<bool>());
    }
    ws.send(json{{"type", "drag"}, {"seq", 9}, {"phase", "end"}});
    a = answer(ws);
    ASSERT_EQ(a["type"], "ack") << a.dump();
    EXPECT_EQ(a["drag"]["ended"], "end");
    EXPECT_EQ(a["rigVersion"], last);

    // The server applied what the solver gives for the last pointer position (12 px right).
    const json after = keyLight();
    const auto p = expected.light.position;
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(after["position"][k].get<float>(), p[size_t(k)]) << after.dump();
    EXPECT_NE(geometry(after), geometry(before));

    // One undo takes the three updates back.
    ws.send(json{{"type", "undo"}, {"seq", 10}});
    a = answer(ws);
    ASSERT_EQ(a["type"], "ack") << a.dump();
    EXPECT_EQ(geometry(keyLight()), geometry(before));
}

// A cancel puts the light back as it was at the begin; an update that moves nothing is
// acknowledged without a new version.
TEST_F(Drags, CancelRestoresTheLight) {
    const auto [grab, expected] = shadowGrab(10);
    const json before = keyLight();
    test::WsClient ws(mServer->port, mSession, mToken);
    ws.send(json{{"type", "drag"}, {"seq", 1}, {"phase", "begin"}, {"mode", "shadow"}, {"light", "key"}, {"x", grab.x}, {"y", grab.y}});
    ASSERT_EQ(answer(ws)["type"], "ack");
    ws.send(json{{"type", "drag"}, {"seq", 2}, {"phase", "update"}, {"x", grab.x}, {"y", grab.y}});
    json a = answer(ws);
    ASSERT_EQ(a["type"], "ack") << a.dump();
    EXPECT_FALSE(a["drag"]["changed"].get<bool>()) << "the pointer on the grab moves nothing";
    ws.send(json{{"type", "drag"}, {"seq", 3}, {"phase", "update"}, {"x", grab.x + 10}, {"y", grab.y}});
    ASSERT_EQ(answer(ws)["type"], "ack");
    EXPECT_NE(geometry(keyLight()), geometry(before));
    ws.send(json{{"type", "drag"}, {"seq", 4}, {"phase", "cancel"}});
    a = answer(ws);
    ASSERT_EQ(a["type"], "ack") << a.dump();
    EXPECT_EQ(a["drag"]["ended"], "cancel");
    EXPECT_EQ(geometry(keyLight()), geometry(before));
    // After the drag, an update is a protocol error.
    ws.send(json{{"type", "drag"}, {"seq", 5}, {"phase", "update"}, {"x", 1}, {"y", 1}});
    a = answer(ws);
    EXPECT_EQ(a["type"], "error");
    EXPECT_EQ(a["code"], "protocol");
}

// Where a property is keyframed the drag sets a key at the session's time (else the keys would
// override it and nothing would seem to happen).
TEST_F(Drags, KeyframedPositionGetsAKey) {
    const auto [grab, expected] = shadowGrab(10);
    const json key0 = {{"path", "position"}, {"t", 0.0}, {"value", keyLight()["position"]}};
    const json key5 = {{"path", "position"}, {"t", 5.0}, {"value", keyLight()["position"]}};
    auto r = test::http(mServer->port, "POST", "/v1/sessions/" + mSession + "/edits", mToken,
                        json{{"changes", {{{"path", "key.key"}, {"value", key0}}, {{"path", "key.key"}, {"value", key5}}}}}.dump());
    ASSERT_EQ(r.status, 200) << r.body;
    ASSERT_TRUE(protocol::rigFromJson(mServer->rig(mSession)).ok());
    mRig = protocol::rigFromJson(mServer->rig(mSession)).value();
    r = test::http(mServer->port, "POST", "/v1/sessions/" + mSession + "/drag", mToken,
                   json{{"mode", "shadow"}, {"light", "key"}, {"from", {grab.x, grab.y}}, {"to", {grab.x + 10, grab.y}}}.dump());
    ASSERT_EQ(r.status, 200) << r.body;
    const json keys = keyLight()["keys"]["position"];
    ASSERT_EQ(keys.size(), 2u) << keys.dump();
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(keys[0]["value"][k].get<float>(), expected.light.position[size_t(k)]) << keys.dump();
    EXPECT_NE(keys[0]["value"], keys[1]["value"]) << "only the key at the session's time changes";
}

// POST /drag and dfb-client drag: one request, one edit; the client's light defaults to the rig's
// first one the mode applies to.
TEST_F(Drags, HttpAndClientDrag) {
    const auto [grab, expected] = shadowGrab(8);
    const json before = keyLight();
    auto r = test::http(mServer->port, "POST", "/v1/sessions/" + mSession + "/drag", mToken,
                        json{{"mode", "shadow"}, {"light", "key"}, {"from", {grab.x, grab.y}}, {"to", {grab.x + 8, grab.y}}}.dump());
    ASSERT_EQ(r.status, 200) << r.body;
    json j = r.json();
    EXPECT_TRUE(j["drag"]["step"]["changed"].get<bool>()) << r.body;
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(keyLight()["position"][k].get<float>(), expected.light.position[size_t(k)]);
    auto undo = test::http(mServer->port, "POST", "/v1/sessions/" + mSession + "/undo", mToken);
    ASSERT_EQ(undo.status, 200) << undo.body;
    EXPECT_EQ(geometry(keyLight()), geometry(before));

    const std::string link = mServer->editorLink(mSession);
    auto [rc, out] = test::run({DFB_CLIENT_EXE, "drag", "shadow", "--from", std::to_string(grab.x) + "," + std::to_string(grab.y), "--to",
                                std::to_string(grab.x + 8) + "," + std::to_string(grab.y), "--server", link},
                               60s);
    ASSERT_EQ(rc, 0) << out;
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(keyLight()["position"][k].get<float>(), expected.light.position[size_t(k)]);
    // Bad input: a mode that does not exist is a usage error, a refused drag exit code 3.
    std::tie(rc, out) = test::run({DFB_CLIENT_EXE, "drag", "wobble", "--from", "1,1", "--to", "2,2", "--server", link}, 60s);
    EXPECT_EQ(rc, 1) << out;
    EXPECT_NE(out.find("shadow, hotspot"), std::string::npos) << out;
    std::tie(rc, out) = test::run({DFB_CLIENT_EXE, "drag", "shadow", "--from", "100000,1", "--to", "2,2", "--server", link}, 60s);
    EXPECT_NE(rc, 0) << out;
}

// Every refusal names what was wrong, changes nothing, and the server keeps serving.
TEST_F(Drags, BadDragsAreRefusedAndChangeNothing) {
    const auto [grab, expected] = shadowGrab(8);
    ASSERT_TRUE(backgroundPixel()) << "the tabletop shot shows the background somewhere";
    test::WsClient ws(mServer->port, mSession, mToken);
    auto expectError = [&](json msg, const std::string& code, const std::string& words) {
        ws.send(msg);
        const json a = answer(ws);
        EXPECT_EQ(a["type"], "error") << msg.dump() << " -> " << a.dump();
        EXPECT_EQ(a["code"], code) << msg.dump() << " -> " << a.dump();
        EXPECT_NE(a.value("message", "").find(words), std::string::npos) << msg.dump() << " -> " << a.dump();
    };
    const json begin{{"type", "drag"}, {"seq", 1}, {"phase", "begin"}, {"mode", "shadow"}, {"light", "key"}, {"x", grab.x}, {"y", grab.y}};
    expectError(json{{"type", "drag"}, {"seq", 1}, {"phase", "update"}, {"x", 3}, {"y", 3}}, "protocol", "no drag");
    expectError(with(begin, {{"x", 5000}}), "invalid_value", "outside");
    expectError(with(begin, {{"light", "nobody"}}), "missing_data", "nobody");
    expectError(with(begin, {{"mode", "wobble"}}), "protocol", "drag.mode");
    expectError(with(begin, {{"points", {1}}}), "invalid_value", "BendyLight");
    expectError(with(begin, {{"points", {0}}}), "protocol", "cp[0]");
    expectError(with(begin, {{"phase", "sideways"}}), "protocol", "drag.phase");
    expectError(json{{"type", "drag"}, {"seq", 1}, {"phase", "end"}, {"x", 3}}, "protocol", "drag.x");
    if (auto bg = backgroundPixel()) expectError(with(begin, {{"x", bg->first}, {"y", bg->second}}), "missing_data", "background");
    // A lit pixel for a shadow mode: the centre of the key's beam on the table is lit.
    bool done = false;
    for (int y = 0; y < sShot->height; y += 5) {
        for (int x = 0; x < sShot->width && !done; x += 5) {
            auto p = sPicker->pick(x, y);
            if (!p) continue;
            auto o = sPicker->occluder(mRig.lights[0], p->P, p->Ng);
            if (o && !o->found) {
                expectError(with(begin, {{"x", x}, {"y", y}}), "missing_data", "not in a shadow");
                done = true;
            }
        }
        if (done) break;
    }
    EXPECT_TRUE(done) << "no pixel lit by the key light found";
    // A mode that does not apply to the light's type: no hotspot on a point light.
    auto r = test::http(mServer->port, "POST", "/v1/sessions/" + mSession + "/edits", mToken,
                        json{{"changes", {{{"path", "fill.type"}, {"value", "point"}}}}}.dump());
    ASSERT_EQ(r.status, 200) << r.body;
    const json rigPoint = mServer->rig(mSession);
    expectError(with(begin, {{"mode", "hotspot"}, {"light", "fill"}}), "invalid_value", "does not apply");
    // A begin that was refused refuses its updates too.
    expectError(json{{"type", "drag"}, {"seq", 2}, {"phase", "update"}, {"x", 3}, {"y", 3}}, "protocol", "begin was refused");
    // An update over the background is refused, and the drag goes on.
    ws.send(begin);
    ASSERT_EQ(answer(ws)["type"], "ack");
    if (auto bg = backgroundPixel()) {
        expectError(json{{"type", "drag"}, {"seq", 3}, {"phase", "update"}, {"x", bg->first}, {"y", bg->second}}, "missing_data", "background");
    }
    EXPECT_EQ(mServer->rig(mSession), rigPoint) << "refused drags change nothing";
    ws.send(json{{"type", "drag"}, {"seq", 4}, {"phase", "update"}, {"x", grab.x + 8}, {"y", grab.y}});
    EXPECT_EQ(answer(ws)["type"], "ack") << "the drag goes on after a refused update";
    // Viewers cannot drag.
    test::WsClient viewer(mServer->port, mSession, mServer->tokens[mSession].viewer);
    viewer.send(begin);
    const json v = answer(viewer);
    EXPECT_EQ(v["type"], "error") << v.dump();
    EXPECT_EQ(v["code"], "forbidden") << v.dump();
    auto hv = test::http(mServer->port, "POST", "/v1/sessions/" + mSession + "/drag", mServer->tokens[mSession].viewer,
                         json{{"mode", "shadow"}, {"light", "key"}, {"from", {grab.x, grab.y}}, {"to", {grab.x + 8, grab.y}}}.dump());
    EXPECT_EQ(hv.status, 403) << hv.body;
    auto bad = test::http(mServer->port, "POST", "/v1/sessions/" + mSession + "/drag", mToken, R"({"mode": "shadow", "light": "key", "from": [1]})");
    EXPECT_EQ(bad.status, 400) << bad.body;
    // Still serving.
    EXPECT_EQ(test::http(mServer->port, "GET", "/healthz").status, 200);
}

// The editor's HTTP bodies (PUT rig, POST edits, POST drag) are read by one helper: an unreadable
// If-Match, a body that is not JSON and (edits, drag) one that is not an object are refused alike,
// naming the request, and change nothing.
TEST_F(Drags, EditorBodiesAreCheckedAlike) {
    const std::string base = "/v1/sessions/" + mSession;
    const std::string rigBefore = mServer->rig(mSession).dump();
    const std::string validEdit = json{{"changes", json::array()}}.dump();
    for (const auto& [method, path, label] : {std::tuple{"PUT", "/rig", "PUT rig"}, std::tuple{"POST", "/edits", "POST edits"},
                                              std::tuple{"POST", "/drag", "POST drag"}}) {
        SCOPED_TRACE(label);
        auto r = test::http(mServer->port, method, base + path, mToken, validEdit, {{"If-Match", "\"twelve\""}});
        EXPECT_EQ(r.status, 400) << r.body;
        EXPECT_NE(r.body.find("If-Match: expected the rig version"), std::string::npos) << r.body;
        r = test::http(mServer->port, method, base + path, mToken, "{not json");
        EXPECT_EQ(r.status, 400) << r.body;
        EXPECT_NE(r.body.find(std::string(label) + ": the body"), std::string::npos) << r.body;
        if (std::string(method) == "POST") {
            r = test::http(mServer->port, method, base + path, mToken, "[1, 2]");
            EXPECT_EQ(r.status, 400) << r.body;
            EXPECT_NE(r.body.find(std::string(label) + ": the body must be a JSON object {"), std::string::npos) << r.body;
        }
    }
    EXPECT_EQ(mServer->rig(mSession).dump(), rigBefore);
}
