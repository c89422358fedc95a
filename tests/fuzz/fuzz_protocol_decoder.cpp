// libFuzzer target: the protocol v1 decoders on arbitrary bytes: a client's text message
// (parseClientMessage, then its changes applied to a rig, journaled and broadcast as the server
// does, and its view settings validated), the same as an HTTP edits body (clientMessageFromJson),
// a whole rig (rigFromJson), an HTTP frame query (viewFromQuery) and a binary frame header. Any
// input must give a value or an Error, never a crash, hang or sanitizer report; a refused edit
// must leave the rig as it was. Inputs up to 1 MiB (scripts/fuzz -max_len), seeded with deeply
// nested values (issue 14: a 100,000-deep value crashed the server) and tests/fuzz/protocol.dict.
#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Messages.h>

#include <cstdint>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace dfb;
    using json = nlohmann::json;
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    static const Rig base = defaultRig({-1, 0, -1}, {1, 1, 1});
    if (auto m = protocol::parseClientMessage(text); m.ok()) {
        if (auto* e = std::get_if<protocol::EditMessage>(&m.value())) {
            Rig rig = base;
            const auto before = protocol::toJson(rig);
            if (!protocol::applyChanges(rig, e->changes).ok() && protocol::toJson(rig) != before) std::abort();
            (void)protocol::evaluateRig(rig);
            (void)protocol::encode(*e);
            // What the server writes of an accepted edit: the journal line and the broadcast.
            (void)protocol::dump(protocol::changesToJson(e->changes));
            protocol::ChangeInfo info;
            info.changes = e->changes;
            (void)protocol::encodeChange(info);
        } else if (auto* v = std::get_if<protocol::ViewMessage>(&m.value())) {
            (void)protocol::applyViewJson(protocol::ViewSettings{}, v->settings);
        }
    }
    (void)protocol::peekSeq(text);
    if (auto j = protocol::parseJson(text, protocol::MAX_TEXT_MESSAGE_BYTES, "fuzz"); j.ok()) {
        if (auto r = protocol::rigFromJson(j.value()); r.ok()) {
            // A rig that parses must survive its own round trip.
            if (!protocol::rigFromJson(protocol::toJson(r.value())).ok()) std::abort();
        }
        if (j->is_object()) {
            // An HTTP edits body: the server adds type and seq.
            json body = j.value();
            body["type"] = "edit";
            body["seq"] = uint64_t(0);
            (void)protocol::clientMessageFromJson(body);
        }
        (void)protocol::excerpt(j.value());
    }
    (void)protocol::viewFromQuery(text);
    (void)protocol::readFrameHeader(data, size);
    return 0;
}
