// libFuzzer target: the protocol v1 decoders on arbitrary bytes: a client's text message
// (parseClientMessage, then its changes applied to a rig and its view settings validated), a
// whole rig (rigFromJson), an HTTP frame query (viewFromQuery) and a binary frame header. Any input
// must give a value or an Error, never a crash, hang or sanitizer report; a refused edit must leave
// the rig as it was.
#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Messages.h>

#include <cstdint>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace dfb;
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    static const Rig base = defaultRig({-1, 0, -1}, {1, 1, 1});
    if (auto m = protocol::parseClientMessage(text); m.ok()) {
        if (auto* e = std::get_if<protocol::EditMessage>(&m.value())) {
            Rig rig = base;
            const auto before = protocol::toJson(rig);
            if (!protocol::applyChanges(rig, e->changes).ok() && protocol::toJson(rig) != before) std::abort();
            (void)protocol::evaluateRig(rig);
            (void)protocol::encode(*e);
        } else if (auto* v = std::get_if<protocol::ViewMessage>(&m.value())) {
            (void)protocol::applyViewJson(protocol::ViewSettings{}, v->settings);
        }
    }
    (void)protocol::peekSeq(text);
    auto j = nlohmann::json::parse(text, nullptr, false);
    if (!j.is_discarded()) {
        if (auto r = protocol::rigFromJson(j); r.ok()) {
            // A rig that parses must survive its own round trip.
            if (!protocol::rigFromJson(protocol::toJson(r.value())).ok()) std::abort();
        }
    }
    (void)protocol::viewFromQuery(text);
    (void)protocol::readFrameHeader(data, size);
    return 0;
}
