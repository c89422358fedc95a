// Protocol v1 messages: every client message parses and round-trips through its encoder; invalid
// ones are refused with the code and the field named; view settings validate; server messages
// carry the documented fields.

#include <dfb/protocol/Messages.h>

#include <gtest/gtest.h>

using namespace dfb;
using namespace dfb::protocol;
using json = nlohmann::json;

TEST(Messages, EveryClientMessageRoundTrips) {
    EditMessage e{7, {{"key.intensity", 500}, {"key.position", json::array({1, 2, 3})}}, 4, 5};
    const std::vector<std::string> texts = {
        encode(HelloMessage{1, "alice"}), encode(e), encode(UndoMessage{8}), encode(RedoMessage{9}), encode(RestoreMessage{18, 42}), encode(TimeMessage{10, 1.5}),
        encode(ViewMessage{11, {{"output", "shadow:key"}, {"encoding", "png"}}}), encode(PickMessage{12, 3, 4}),
        encode(PresenceMessage{std::string("key")}), encode(PresenceMessage{}),
        encode(DragMessage{13, DragPhase::Begin, "shadow", "key", 10, 20, {}}),
        encode(DragMessage{14, DragPhase::Begin, "localShadowMove", "bendy", 1, 2, {1, 3}}),
        encode(DragMessage{15, DragPhase::Update, "", "", 11, 21, {}}), encode(DragMessage{16, DragPhase::End, "", "", 0, 0, {}}),
        encode(DragMessage{17, DragPhase::Cancel, "", "", 0, 0, {}})};
    for (const std::string& t : texts) {
        auto m = parseClientMessage(t);
        ASSERT_TRUE(m.ok()) << t << " -> " << m.error().toString();
        EXPECT_EQ(std::visit([](auto&& x) { return encode(x); }, m.value()), t);
    }
    auto m = parseClientMessage(encode(e));
    const auto& edit = std::get<EditMessage>(m.value());
    EXPECT_EQ(edit.seq, 7u);
    EXPECT_EQ(edit.base, 4u);
    EXPECT_EQ(edit.ifVersion, 5u);
    ASSERT_EQ(edit.changes.size(), 2u);
    EXPECT_EQ(edit.changes[1].path, "key.position");
    EXPECT_EQ(edit.changes[1].value, json::array({1, 2, 3}));
    EXPECT_EQ(peekSeq(encode(e)), 7u);
    EXPECT_FALSE(peekSeq("nonsense").has_value());
}

TEST(Messages, RefusesMalformedMessagesNamingTheProblem) {
    struct Case {
        const char* text;
        ErrorCode code;
        const char* mentions;
    };
    for (const Case& c : {Case{"not json", ErrorCode::Protocol, "JSON"}, Case{"[1,2]", ErrorCode::Protocol, "object"},
                          Case{R"({"seq":1})", ErrorCode::Protocol, "type"}, Case{R"({"type":"dance"})", ErrorCode::Protocol, "dance"},
                          Case{R"({"type":"edit","seq":-1,"changes":[]})", ErrorCode::Protocol, "seq"},
                          Case{R"({"type":"edit","seq":1,"changes":[]})", ErrorCode::Protocol, "changes"},
                          Case{R"({"type":"edit","seq":1,"changes":[{"value":1}]})", ErrorCode::Protocol, "changes[0]"},
                          Case{R"({"type":"edit","seq":1,"changes":[{"path":"a.b","value":1,"extra":2}]})", ErrorCode::Protocol, "changes[0]"},
                          Case{R"({"type":"edit","seq":1,"base":"x","changes":[{"path":"a.b","value":1}]})", ErrorCode::Protocol, "edit.base"},
                          Case{R"({"type":"edit","seq":1,"ifVersion":-2,"changes":[{"path":"a.b","value":1}]})", ErrorCode::Protocol, "ifVersion"},
                          Case{R"({"type":"edit","seq":1,"changes":[{"path":"a.b","value":1}],"x":0})", ErrorCode::Protocol, "'x'"},
                          Case{R"({"type":"hello","protocol":0})", ErrorCode::Protocol, "protocol"},
                          Case{R"({"type":"hello","name":5})", ErrorCode::Protocol, "hello.name"},
                          Case{R"({"type":"undo"})", ErrorCode::Protocol, "undo.seq"},
                          Case{R"({"type":"restore","seq":1})", ErrorCode::Protocol, "restore.version"},
                          Case{R"({"type":"restore","seq":1,"version":-3})", ErrorCode::Protocol, "restore.version"},
                          Case{R"({"type":"time","seq":1})", ErrorCode::Protocol, "time.t"},
                          Case{R"({"type":"view","seq":1,"quality":0})", ErrorCode::InvalidValue, "view.quality"},
                          Case{R"({"type":"view","seq":1,"exposure":30})", ErrorCode::InvalidValue, "view.exposure"},
                          Case{R"({"type":"view","seq":1,"output":"light:"})", ErrorCode::InvalidValue, "view.output"},
                          Case{R"({"type":"view","seq":1,"viewTransform":"linear"})", ErrorCode::InvalidValue, "viewTransform"},
                          Case{R"({"type":"view","seq":1,"output":"layer:N","encoding":"exr"})", ErrorCode::InvalidValue, "layer"},
                          Case{R"({"type":"view","seq":1,"background":1})", ErrorCode::InvalidValue, "view.background"},
                          Case{R"({"type":"pick","seq":1,"x":1.5,"y":2})", ErrorCode::Protocol, "pick.x"},
                          Case{R"({"type":"pick","seq":1,"x":1})", ErrorCode::Protocol, "pick.y"},
                          Case{R"({"type":"presence","editing":[1]})", ErrorCode::Protocol, "presence.editing"},
                          Case{R"({"type":"drag","seq":1,"x":1,"y":1})", ErrorCode::Protocol, "drag.phase"},
                          Case{R"({"type":"drag","seq":1,"phase":"begin","light":"k","x":1,"y":1})", ErrorCode::Protocol, "drag.mode"},
                          Case{R"({"type":"drag","seq":1,"phase":"begin","mode":"wobble","light":"k","x":1,"y":1})", ErrorCode::Protocol,
                               "shadow, hotspot"},
                          Case{R"({"type":"drag","seq":1,"phase":"begin","mode":"shadow","x":1,"y":1})", ErrorCode::Protocol, "drag.light"},
                          Case{R"({"type":"drag","seq":1,"phase":"begin","mode":"shadow","light":"k","x":-1,"y":1})", ErrorCode::Protocol, "drag.x"},
                          Case{R"({"type":"drag","seq":1,"phase":"update","x":1})", ErrorCode::Protocol, "drag.y"},
                          Case{R"({"type":"drag","seq":1,"phase":"update","x":1,"y":1,"mode":"shadow"})", ErrorCode::Protocol, "only a begin"},
                          Case{R"({"type":"drag","seq":1,"phase":"end","x":1})", ErrorCode::Protocol, "drag.x"},
                          Case{R"({"type":"drag","seq":1,"phase":"begin","mode":"shadow","light":"k","x":1,"y":1,"points":[0]})",
                               ErrorCode::Protocol, "cp[0]"},
                          Case{R"({"type":"drag","seq":1,"phase":"begin","mode":"shadow","light":"k","x":1,"y":1,"points":[1.5]})",
                               ErrorCode::Protocol, "drag.points"},
                          Case{R"({"type":"drag","seq":1,"phase":"begin","mode":"shadow","light":"k","x":1,"y":1,"points":[1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17]})",
                               ErrorCode::Protocol, "at most 16"},
                          Case{R"({"type":"drag","phase":"end"})", ErrorCode::Protocol, "drag.seq"}}) {
        auto m = parseClientMessage(c.text);
        ASSERT_FALSE(m.ok()) << c.text;
        EXPECT_EQ(m.error().code, c.code) << c.text << " -> " << m.error().toString();
        EXPECT_NE(m.error().message.find(c.mentions), std::string::npos) << c.text << " -> " << m.error().message;
    }
}

TEST(Messages, ViewSettingsFromJsonAndQuery) {
    auto v = applyViewJson(ViewSettings{}, {{"output", "light:key"}, {"encoding", "exr"}});
    ASSERT_TRUE(v.ok());
    EXPECT_EQ(v->output, "light:key");
    EXPECT_EQ(v->encoding, Encoding::Exr);
    EXPECT_EQ(v->quality, 85); // untouched
    EXPECT_FALSE(v->isDefaultImage());
    EXPECT_NE(v->key(), ViewSettings{}.key());
    auto q = viewFromQuery("output=shadow%3Akey&format=png&quality=40&exposure=-1.5&token=abc");
    ASSERT_TRUE(q.ok()) << q.error().toString();
    EXPECT_EQ(q->output, "shadow:key");
    EXPECT_EQ(q->encoding, Encoding::Png);
    EXPECT_EQ(q->quality, 40);
    EXPECT_FLOAT_EQ(q->exposureStops, -1.5f);
    EXPECT_TRUE(viewFromQuery("").ok());
    EXPECT_EQ(viewFromQuery("format=gif").error().code, ErrorCode::InvalidValue);
    EXPECT_EQ(viewFromQuery("quality=lots").error().code, ErrorCode::InvalidValue);
    EXPECT_NE(viewFromQuery("size=4").error().message.find("size"), std::string::npos);
    EXPECT_EQ(toJson(ViewSettings{}),
              json::parse(R"({"output":"beauty","encoding":"jpeg","quality":85,"exposure":0.0,"viewTransform":"rig","background":false})"));
    // The backdrop: its own frames (not the shared default image), a key of its own.
    auto b = viewFromQuery("background=1");
    ASSERT_TRUE(b.ok());
    EXPECT_TRUE(b->background);
    EXPECT_FALSE(b->isDefaultImage());
    EXPECT_NE(b->key(), ViewSettings{}.key());
    EXPECT_FALSE(viewFromQuery("background=false")->background);
    EXPECT_NE(viewFromQuery("background=yes").error().message.find("background"), std::string::npos);
    auto m = parseClientMessage(R"({"type":"view","seq":2,"background":true})");
    ASSERT_TRUE(m.ok()) << m.error().message;
}

TEST(Messages, ServerMessagesCarryTheDocumentedFields) {
    WelcomeInfo w;
    w.clientId = 3;
    w.role = Role::Viewer;
    w.sessionId = "shot";
    w.session = {{"width", 4}};
    w.rig = defaultRig({-1, 0, -1}, {1, 1, 1});
    w.clients = {{3, "bob", Role::Viewer, ""}};
    const json welcome = json::parse(encodeWelcome(w));
    EXPECT_EQ(welcome["type"], "welcome");
    EXPECT_EQ(welcome["protocol"], PROTOCOL_VERSION);
    EXPECT_EQ(welcome["role"], "viewer");
    EXPECT_EQ(welcome["sessionId"], "shot");
    EXPECT_EQ(welcome["rig"]["lights"][0]["name"], "key");
    EXPECT_EQ(welcome["clients"][0]["editing"], nullptr);
    EXPECT_EQ(welcome["view"]["encoding"], "jpeg");
    // The viewer token goes to editors only.
    w.viewerToken = "viewer-token-0123456789";
    EXPECT_FALSE(json::parse(encodeWelcome(w)).contains("viewerToken"));
    w.role = Role::Editor;
    EXPECT_EQ(json::parse(encodeWelcome(w))["viewerToken"], "viewer-token-0123456789");

    const json ack = json::parse(encodeAck(7, 12, {{"overwrote", json::array({{{"path", "key.intensity"}}})}}));
    EXPECT_EQ(ack["seq"], 7);
    EXPECT_EQ(ack["rigVersion"], 12);
    EXPECT_EQ(ack["overwrote"][0]["path"], "key.intensity");

    ChangeInfo c;
    c.rigVersion = 12;
    c.byClient = 3;
    c.byName = "alice";
    c.changes = {{"key.intensity", 80}};
    json change = json::parse(encodeChange(c));
    EXPECT_EQ(change["kind"], "edit");
    EXPECT_EQ(change["changes"][0]["value"], 80);
    EXPECT_FALSE(change.contains("rig"));
    c.kind = "undo";
    c.rig = w.rig;
    change = json::parse(encodeChange(c));
    EXPECT_EQ(change["rig"]["lights"].size(), w.rig.lights.size());
    EXPECT_FALSE(change.contains("changes"));

    const json err = json::parse(encodeError(ErrorCode::Forbidden, "viewers cannot edit", 9));
    EXPECT_EQ(err["code"], "forbidden");
    EXPECT_EQ(err["seq"], 9);
    EXPECT_FALSE(json::parse(encodeError(ErrorCode::Conflict, "x", std::nullopt)).contains("seq"));
    EXPECT_EQ(json::parse(encodeError(ErrorCode::Conflict, "x", std::nullopt))["code"], "conflict");
    EXPECT_EQ(json::parse(encodePresence(w.clients))["clients"][0]["role"], "viewer");
    EXPECT_EQ(json::parse(encodePickResult(4, {{"hit", false}}))["seq"], 4);
}

TEST(Messages, BytesThatAreNotUtf8NeverThrow) {
    // Found by fuzzing: a URL query or a file name is not always UTF-8, and nlohmann::json throws
    // when it writes such a string; every message the server writes must survive it.
    const std::string bad = "format=mn\xfa\x67&output=light:\xff";
    auto v = viewFromQuery(bad);
    ASSERT_FALSE(v.ok());
    const json err = json::parse(encodeError(v.error().code, v.error().message, std::nullopt));
    EXPECT_EQ(err["code"], "invalid_value");
    // The bad value is quoted escaped (excerpt): U+FFFD as \ufffd.
    EXPECT_NE(err["message"].get<std::string>().find("\\ufffd"), std::string::npos) << err["message"];
    EXPECT_NO_THROW(json::parse(dump(json{{"shot", "/shots/\xc3(.exr"}}, 2)));
    // A long name is cut at a character boundary, not inside one.
    auto hello = parseClientMessage(R"({"type":"hello","name":")" + std::string(63, 'a') + "\xc3\xa9" + R"("})");
    ASSERT_TRUE(hello.ok());
    EXPECT_EQ(std::get<HelloMessage>(hello.value()).name, std::string(63, 'a'));
}
