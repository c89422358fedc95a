#include <dfb/protocol/Messages.h>
#include <dfb/protocol/DragModes.h>

#include <dfb/protocol/Json.h>

#include <algorithm>
#include <cmath>
#include <cctype>
#include <cstdlib>

namespace dfb::protocol {
namespace {

using json = nlohmann::json;

Error protocolError(const std::string& what) { return makeError(ErrorCode::Protocol, what); }
Error invalid(const std::string& what) { return makeError(ErrorCode::InvalidValue, what); }

// Every field a message type may carry; anything else is refused so that typos are not ignored.
Status onlyFields(const json& j, const std::string& type, std::initializer_list<const char*> allowed) {
    for (auto it = j.begin(); it != j.end(); ++it) {
        bool ok = false;
        for (const char* a : allowed) ok = ok || it.key() == a;
        if (!ok) return protocolError(type + ": unknown field '" + it.key() + "'");
    }
    return okStatus();
}

Result<uint64_t> needSeq(const json& j, const std::string& type) {
    if (!j.contains("seq") || !j["seq"].is_number_unsigned()) return protocolError(type + ".seq: expected a non-negative integer");
    return j["seq"].get<uint64_t>();
}

Result<std::optional<uint64_t>> optVersion(const json& j, const std::string& type, const char* field) {
    if (!j.contains(field)) return std::optional<uint64_t>{};
    if (!j[field].is_number_unsigned()) return protocolError(type + "." + field + ": expected a non-negative integer");
    return std::optional<uint64_t>{j[field].get<uint64_t>()};
}

bool validLightName(std::string_view n) {
    if (n.empty() || n.size() > 64) return false;
    for (char c : n) {
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) return false;
    }
    return true;
}

} // namespace

std::string percentDecode(std::string_view s) {
    std::string out;
    for (size_t i = 0; i < s.size(); ++i) {
        if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
            std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
            out += char(std::strtol(std::string(s.substr(i + 1, 2)).c_str(), nullptr, 16));
            i += 2;
        } else {
            out += s[i] == '+' ? ' ' : s[i];
        }
    }
    return out;
}

std::string dump(const json& j, int indent) { return j.dump(indent, ' ', false, json::error_handler_t::replace); }

const char* toString(Role role) { return role == Role::Editor ? "editor" : "viewer"; }

const char* encodingName(Encoding e) {
    switch (e) {
    case Encoding::Jpeg: return "jpeg";
    case Encoding::Png: return "png";
    case Encoding::Exr: return "exr";
    }
    return "jpeg";
}

const char* mimeType(Encoding e) {
    switch (e) {
    case Encoding::Jpeg: return "image/jpeg";
    case Encoding::Png: return "image/png";
    case Encoding::Exr: return "image/x-exr";
    }
    return "application/octet-stream";
}

std::string ViewSettings::key() const {
    return output + "|" + encodingName(encoding) + "|" + std::to_string(quality) + "|" + dump(json(exposureStops)) +
           "|" + viewTransform + (background ? "|background" : "");
}

json toJson(const ViewSettings& v) {
    return json{{"output", v.output},
                {"encoding", encodingName(v.encoding)},
                {"quality", v.quality},
                {"exposure", v.exposureStops},
                {"viewTransform", v.viewTransform},
                {"background", v.background}};
}

Result<ViewSettings> applyViewJson(ViewSettings v, const json& j) {
    if (!j.is_object()) return invalid("view: expected an object");
    for (auto it = j.begin(); it != j.end(); ++it) {
        const std::string& k = it.key();
        const json& x = it.value();
        if (k == "output") {
            if (!x.is_string()) return invalid("view.output: expected a string");
            const std::string o = x.get<std::string>();
            const size_t colon = o.find(':');
            const std::string kind = o.substr(0, colon);
            if (o == "beauty") {
            } else if (colon == std::string::npos || (kind != "light" && kind != "shadow" && kind != "layer" && kind != "reference") ||
                       !validLightName(std::string_view(o).substr(colon + 1))) {
                return invalid("view.output: '" + o + "' is not beauty, light:NAME, reference:NAME, shadow:NAME or layer:NAME");
            }
            v.output = o;
        } else if (k == "encoding") {
            if (x == "jpeg" || x == "jpg") v.encoding = Encoding::Jpeg;
            else if (x == "png") v.encoding = Encoding::Png;
            else if (x == "exr") v.encoding = Encoding::Exr;
            else return invalid("view.encoding: " + excerpt(x) + " is not \"jpeg\", \"png\" or \"exr\"");
        } else if (k == "quality") {
            if (!x.is_number_integer() || x.get<int64_t>() < 1 || x.get<int64_t>() > 100) {
                return invalid("view.quality: expected an integer in [1, 100]");
            }
            v.quality = int(x.get<int64_t>());
        } else if (k == "exposure") {
            if (!x.is_number() || !std::isfinite(x.get<double>()) || std::abs(x.get<double>()) > 20.0) {
                return invalid("view.exposure: expected a number of stops in [-20, 20]");
            }
            v.exposureStops = x.get<float>();
        } else if (k == "viewTransform") {
            if (x != "rig" && x != "srgb" && x != "filmic") {
                return invalid("view.viewTransform: " + excerpt(x) + " is not \"rig\", \"srgb\" or \"filmic\"");
            }
            v.viewTransform = x.get<std::string>();
        } else if (k == "background") {
            if (!x.is_boolean()) return invalid("view.background: expected true or false");
            v.background = x.get<bool>();
        } else {
            return invalid("view: unknown setting '" + k + "'");
        }
    }
    if (v.encoding == Encoding::Exr && v.output.rfind("layer:", 0) == 0) {
        return invalid("view: layer outputs are 8-bit views (jpeg, png); the shot's EXR file holds the float layers");
    }
    return v;
}

Result<ViewSettings> viewFromQuery(std::string_view query) {
    json j = json::object();
    while (!query.empty()) {
        const size_t amp = query.find('&');
        const std::string_view item = query.substr(0, amp);
        query = amp == std::string_view::npos ? std::string_view() : query.substr(amp + 1);
        if (item.empty()) continue;
        const size_t eq = item.find('=');
        const std::string k = percentDecode(item.substr(0, eq));
        const std::string val = eq == std::string_view::npos ? "" : percentDecode(item.substr(eq + 1));
        if (k == "output" || k == "viewTransform") {
            j[k] = val;
        } else if (k == "format" || k == "encoding") {
            j["encoding"] = val;
        } else if (k == "quality" || k == "exposure") {
            auto n = parseJson(val, 64, k);
            if (!n || !n->is_number()) return invalid(k + "=" + excerpt(json(val)) + ": expected a number");
            j[k] = n.value();
        } else if (k == "background") {
            if (val != "0" && val != "1" && val != "true" && val != "false") {
                return invalid("background=" + excerpt(json(val)) + ": expected 0, 1, true or false");
            }
            j[k] = val == "1" || val == "true";
        } else if (k == "token") {
            // The access token travels in the query for browsers; it is not a view setting.
        } else {
            return invalid("unknown query parameter '" + k + "' (output, format, quality, exposure, viewTransform, background)");
        }
    }
    return applyViewJson(ViewSettings{}, j);
}

std::optional<uint64_t> peekSeq(std::string_view text) {
    auto j = parseJson(text, MAX_TEXT_MESSAGE_BYTES, "message");
    if (j && j->is_object() && j->contains("seq") && (*j)["seq"].is_number_unsigned()) return (*j)["seq"].get<uint64_t>();
    return std::nullopt;
}

Result<ClientMessage> parseClientMessage(std::string_view text) {
    auto j = parseJson(text, MAX_TEXT_MESSAGE_BYTES, "message");
    if (!j) return j.error();
    return clientMessageFromJson(j.value());
}

Result<ClientMessage> clientMessageFromJson(const json& j) {
    if (!j.is_object()) return protocolError("message must be a JSON object");
    if (!j.contains("type") || !j["type"].is_string()) return protocolError("message needs a string field 'type'");
    const std::string type = j["type"];
    if (type == "hello") {
        if (auto s = onlyFields(j, type, {"type", "protocol", "name"}); !s) return s.error();
        HelloMessage m;
        if (j.contains("protocol")) {
            if (!j["protocol"].is_number_integer()) return protocolError("hello.protocol: expected an integer");
            // Compared as read (64-bit): a narrowing cast made 2^32 + 1 look like version 1.
            const json& p = j["protocol"];
            if (!(p.is_number_unsigned() ? p.get<uint64_t>() == uint64_t(PROTOCOL_VERSION) : p.get<int64_t>() == PROTOCOL_VERSION)) {
                return protocolError("hello.protocol: version " + excerpt(p) + " is not supported (server speaks " +
                                     std::to_string(PROTOCOL_VERSION) + ")");
            }
            m.protocol = PROTOCOL_VERSION;
        }
        if (j.contains("name")) {
            if (!j["name"].is_string()) return protocolError("hello.name: expected a string");
            m.name = clientName(j["name"].get<std::string>());
        }
        return ClientMessage{m};
    }
    if (type == "edit") {
        if (auto s = onlyFields(j, type, {"type", "seq", "changes", "base", "ifVersion", "merge", "allowFold"}); !s)
            return s.error();
        EditMessage m;
        auto seq = needSeq(j, type);
        if (!seq) return seq.error();
        m.seq = seq.value();
        auto base = optVersion(j, type, "base");
        if (!base) return base.error();
        m.base = base.value();
        auto ifv = optVersion(j, type, "ifVersion");
        if (!ifv) return ifv.error();
        m.ifVersion = ifv.value();
        if (j.contains("merge")) {
            if (!j["merge"].is_boolean()) return protocolError("edit.merge: expected true or false");
            m.merge = j["merge"].get<bool>();
        }
        if (j.contains("allowFold")) {
            if (!j["allowFold"].is_boolean()) return protocolError("edit.allowFold: expected true or false");
            m.allowFold = j["allowFold"].get<bool>();
        }
        if (!j.contains("changes") || !j["changes"].is_array() || j["changes"].empty()) {
            return protocolError("edit.changes: expected a non-empty array");
        }
        for (size_t i = 0; i < j["changes"].size(); ++i) {
            const json& c = j["changes"][i];
            const std::string where = "edit.changes[" + std::to_string(i) + "]";
            if (!c.is_object() || !c.contains("path") || !c["path"].is_string() || !c.contains("value") || c.size() != 2) {
                return protocolError(where + ": expected {\"path\": string, \"value\": ...}");
            }
            m.changes.push_back({c["path"].get<std::string>(), c["value"]});
        }
        return ClientMessage{m};
    }
    if (type == "undo" || type == "redo") {
        if (auto s = onlyFields(j, type, {"type", "seq"}); !s) return s.error();
        auto seq = needSeq(j, type);
        if (!seq) return seq.error();
        if (type == "undo") return ClientMessage{UndoMessage{seq.value()}};
        return ClientMessage{RedoMessage{seq.value()}};
    }
    if (type == "restore") {
        if (auto s = onlyFields(j, type, {"type", "seq", "version"}); !s) return s.error();
        auto seq = needSeq(j, type);
        if (!seq) return seq.error();
        if (!j.contains("version") || !j["version"].is_number_unsigned()) return protocolError("restore.version: expected a rig version");
        return ClientMessage{RestoreMessage{seq.value(), j["version"].get<uint64_t>()}};
    }
    if (type == "time") {
        if (auto s = onlyFields(j, type, {"type", "seq", "t"}); !s) return s.error();
        auto seq = needSeq(j, type);
        if (!seq) return seq.error();
        if (!j.contains("t") || !j["t"].is_number() || !std::isfinite(j["t"].get<double>())) {
            return protocolError("time.t: expected a finite number of seconds");
        }
        return ClientMessage{TimeMessage{seq.value(), j["t"].get<double>()}};
    }
    if (type == "view") {
        if (auto s = onlyFields(j, type, {"type", "seq", "output", "encoding", "quality", "exposure", "viewTransform", "background"}); !s) {
            return s.error();
        }
        auto seq = needSeq(j, type);
        if (!seq) return seq.error();
        json settings = j;
        settings.erase("type");
        settings.erase("seq");
        if (auto v = applyViewJson(ViewSettings{}, settings); !v) return v.error();
        return ClientMessage{ViewMessage{seq.value(), settings}};
    }
    if (type == "pick") {
        if (auto s = onlyFields(j, type, {"type", "seq", "x", "y"}); !s) return s.error();
        auto seq = needSeq(j, type);
        if (!seq) return seq.error();
        for (const char* f : {"x", "y"}) {
            if (!j.contains(f) || !j[f].is_number_integer() || j[f].get<int64_t>() < 0 || j[f].get<int64_t>() > (1 << 20)) {
                return protocolError(std::string("pick.") + f + ": expected a non-negative integer pixel coordinate");
            }
        }
        return ClientMessage{PickMessage{seq.value(), int(j["x"].get<int64_t>()), int(j["y"].get<int64_t>())}};
    }
    if (type == "drag") {
        if (auto s = onlyFields(j, type, {"type", "seq", "phase", "mode", "light", "x", "y", "points"}); !s) return s.error();
        auto seq = needSeq(j, type);
        if (!seq) return seq.error();
        DragMessage m;
        m.seq = seq.value();
        const std::string phase = j.contains("phase") && j["phase"].is_string() ? j["phase"].get<std::string>() : "";
        if (phase == "begin") m.phase = DragPhase::Begin;
        else if (phase == "update") m.phase = DragPhase::Update;
        else if (phase == "end") m.phase = DragPhase::End;
        else if (phase == "cancel") m.phase = DragPhase::Cancel;
        else return protocolError("drag.phase: expected \"begin\", \"update\", \"end\" or \"cancel\"");
        const bool begin = m.phase == DragPhase::Begin, moves = begin || m.phase == DragPhase::Update;
        for (const char* f : {"mode", "light", "points"}) {
            if (!begin && j.contains(f)) return protocolError(std::string("drag.") + f + ": only a begin names it");
        }
        for (const char* f : {"x", "y"}) {
            if (!moves) {
                if (j.contains(f)) return protocolError(std::string("drag.") + f + ": only begin and update carry the pointer");
                continue;
            }
            if (!j.contains(f) || !j[f].is_number_integer() || j[f].get<int64_t>() < 0 || j[f].get<int64_t>() > (1 << 20)) {
                return protocolError(std::string("drag.") + f + ": expected a non-negative integer pixel coordinate");
            }
        }
        if (moves) {
            m.x = int(j["x"].get<int64_t>());
            m.y = int(j["y"].get<int64_t>());
        }
        if (begin) {
            if (!j.contains("mode") || !j["mode"].is_string()) return protocolError("drag.mode: expected one of " + dragModeNames());
            if (auto mode = parseDragMode(j["mode"].get<std::string>()); !mode) return protocolError("drag.mode: " + mode.error().message);
            m.mode = j["mode"].get<std::string>();
            if (!j.contains("light") || !j["light"].is_string() || j["light"].get<std::string>().empty() ||
                j["light"].get<std::string>().size() > 64) {
                return protocolError("drag.light: expected a light's name");
            }
            m.light = j["light"].get<std::string>();
            if (j.contains("points")) {
                const json& pts = j["points"];
                if (!pts.is_array() || pts.size() > MAX_DRAG_POINTS) {
                    return protocolError("drag.points: expected an array of at most " + std::to_string(MAX_DRAG_POINTS) +
                                         " control-point indices");
                }
                for (const json& p : pts) {
                    if (!p.is_number_integer() || p.get<int64_t>() < 1 || p.get<int64_t>() > int64_t(MAX_DRAG_POINTS)) {
                        return protocolError("drag.points: " + excerpt(p) + " is not a control-point index 1.." +
                                             std::to_string(MAX_DRAG_POINTS) + " (cp[0], the source, moves with the light)");
                    }
                    m.points.push_back(int(p.get<int64_t>()));
                }
            }
        }
        return ClientMessage{m};
    }
    if (type == "annotate") {
        auto seq = needSeq(j, type);
        if (!seq) return seq.error();
        auto m = annotationFromJson(j, type, /*message=*/true);
        if (!m) return m.error();
        m->seq = seq.value();
        return ClientMessage{std::move(m.value())};
    }
    if (type == "presence") {
        if (auto s = onlyFields(j, type, {"type", "editing"}); !s) return s.error();
        PresenceMessage m;
        if (j.contains("editing") && !j["editing"].is_null()) {
            if (!j["editing"].is_string() || j["editing"].get<std::string>().size() > 128) {
                return protocolError("presence.editing: expected a property path (at most 128 bytes) or null");
            }
            m.editing = j["editing"].get<std::string>();
        }
        return ClientMessage{m};
    }
    return protocolError("unknown message type '" + type + "'");
}

Result<AnnotateMessage> annotationFromJson(const json& j, const std::string& what, bool message) {
    if (!j.is_object()) return protocolError(what + ": expected an object {\"kind\", \"points\", \"text\", \"color\"}");
    auto s = message ? onlyFields(j, what, {"type", "seq", "kind", "points", "text", "color"})
                     : onlyFields(j, what, {"kind", "points", "text", "color"});
    if (!s) return s.error();
    AnnotateMessage m;
    const std::string kind = j.contains("kind") && j["kind"].is_string() ? j["kind"].get<std::string>() : "";
    if (kind != "pin" && kind != "stroke") return protocolError(what + ".kind: expected \"pin\" or \"stroke\"");
    m.kind = kind;
    const bool pin = kind == "pin";
    const std::string count = pin ? "exactly 1 point" : "2.." + std::to_string(MAX_ANNOTATION_POINTS) + " points";
    if (!j.contains("points") || !j["points"].is_array()) return protocolError(what + ".points: expected an array of [x, y] (" + kind + ": " + count + ")");
    const json& pts = j["points"];
    if (pin ? pts.size() != 1 : (pts.size() < 2 || pts.size() > MAX_ANNOTATION_POINTS)) {
        return invalid(what + ".points: a " + kind + " has " + count + ", not " + std::to_string(pts.size()));
    }
    for (size_t i = 0; i < pts.size(); ++i) {
        const json& p = pts[i];
        if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number() || !std::isfinite(p[0].get<double>()) ||
            !std::isfinite(p[1].get<double>())) {
            return protocolError(what + ".points[" + std::to_string(i) + "]: " + excerpt(p) + " is not a pixel [x, y] of finite numbers");
        }
        m.points.push_back({p[0].get<double>(), p[1].get<double>()});
    }
    if (j.contains("text")) {
        if (!j["text"].is_string()) return protocolError(what + ".text: expected a string");
        m.text = j["text"].get<std::string>();
    }
    // Characters, not bytes: a comment in any script has the same room. The JSON parser has
    // checked the UTF-8, so counting the bytes that start a character is enough.
    const size_t chars = size_t(std::count_if(m.text.begin(), m.text.end(), [](char c) { return (static_cast<unsigned char>(c) & 0xC0) != 0x80; }));
    if (pin && chars == 0) return invalid(what + ".text: a pin needs a comment (1.." + std::to_string(MAX_ANNOTATION_TEXT) + " characters)");
    if (chars > MAX_ANNOTATION_TEXT) {
        return invalid(what + ".text: " + std::to_string(chars) + " characters, more than the " + std::to_string(MAX_ANNOTATION_TEXT) + " allowed");
    }
    for (char c : m.text) {
        if ((static_cast<unsigned char>(c) < 0x20 && c != '\n' && c != '\t') || c == 0x7f) {
            return invalid(what + ".text: control characters other than newline and tab are not allowed");
        }
    }
    if (j.contains("color") && !j["color"].is_null()) {
        const std::string c = j["color"].is_string() ? j["color"].get<std::string>() : "";
        const bool hex = c.size() == 7 && c[0] == '#' &&
                         std::all_of(c.begin() + 1, c.end(), [](char x) { return std::isxdigit(static_cast<unsigned char>(x)) != 0; });
        if (!hex) return invalid(what + ".color: " + excerpt(j["color"]) + " is not a color \"#rrggbb\"");
        m.color = c;
        std::transform(m.color.begin(), m.color.end(), m.color.begin(), [](char x) { return char(std::tolower(static_cast<unsigned char>(x))); });
    }
    return m;
}

nlohmann::json changesToJson(const std::vector<Change>& changes) {
    json arr = json::array();
    for (const Change& c : changes) arr.push_back({{"path", c.path}, {"value", c.value}});
    return arr;
}

std::string encode(const HelloMessage& m) { return dump(json{{"type", "hello"}, {"protocol", m.protocol}, {"name", m.name}}); }
std::string encode(const EditMessage& m) {
    json j{{"type", "edit"}, {"seq", m.seq}, {"changes", changesToJson(m.changes)}};
    if (m.base) j["base"] = *m.base;
    if (m.ifVersion) j["ifVersion"] = *m.ifVersion;
    if (m.merge) j["merge"] = true;
    if (m.allowFold) j["allowFold"] = true;
    return dump(j);
}
std::string encode(const UndoMessage& m) { return dump(json{{"type", "undo"}, {"seq", m.seq}}); }
std::string encode(const RedoMessage& m) { return dump(json{{"type", "redo"}, {"seq", m.seq}}); }
std::string encode(const RestoreMessage& m) { return dump(json{{"type", "restore"}, {"seq", m.seq}, {"version", m.version}}); }
std::string encode(const TimeMessage& m) { return dump(json{{"type", "time"}, {"seq", m.seq}, {"t", m.seconds}}); }
std::string encode(const ViewMessage& m) {
    json j = m.settings.is_object() ? m.settings : json::object();
    j["type"] = "view";
    j["seq"] = m.seq;
    return dump(j);
}
const char* toString(DragPhase phase) {
    switch (phase) {
    case DragPhase::Begin: return "begin";
    case DragPhase::Update: return "update";
    case DragPhase::End: return "end";
    case DragPhase::Cancel: return "cancel";
    }
    return "begin";
}

std::string encode(const DragMessage& m) {
    json j{{"type", "drag"}, {"seq", m.seq}, {"phase", toString(m.phase)}};
    if (m.phase == DragPhase::Begin) {
        j["mode"] = m.mode;
        j["light"] = m.light;
        if (!m.points.empty()) j["points"] = m.points;
    }
    if (m.phase == DragPhase::Begin || m.phase == DragPhase::Update) {
        j["x"] = m.x;
        j["y"] = m.y;
    }
    return dump(j);
}

std::string encode(const AnnotateMessage& m) {
    json pts = json::array();
    for (const auto& p : m.points) pts.push_back({p[0], p[1]});
    json j{{"type", "annotate"}, {"seq", m.seq}, {"kind", m.kind}, {"points", pts}};
    if (!m.text.empty()) j["text"] = m.text;
    if (!m.color.empty()) j["color"] = m.color;
    return dump(j);
}

std::string encode(const PickMessage& m) { return dump(json{{"type", "pick"}, {"seq", m.seq}, {"x", m.x}, {"y", m.y}}); }
std::string encode(const PresenceMessage& m) {
    return dump(json{{"type", "presence"}, {"editing", m.editing ? json(*m.editing) : json(nullptr)}});
}

std::string clientName(std::string name) {
    name.erase(std::remove_if(name.begin(), name.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; }),
               name.end());
    if (name.size() > MAX_CLIENT_NAME_BYTES) {
        size_t cut = MAX_CLIENT_NAME_BYTES;
        while (cut > 0 && (static_cast<unsigned char>(name[cut]) & 0xC0) == 0x80) --cut; // not inside a character
        name.resize(cut);
    }
    return name;
}

json toJson(const ClientInfo& c) {
    return json{{"id", c.id}, {"name", c.name}, {"role", toString(c.role)},
                {"editing", c.editing.empty() ? json(nullptr) : json(c.editing)}};
}

std::string encodeWelcome(const WelcomeInfo& w) {
    json clients = json::array();
    for (const ClientInfo& c : w.clients) clients.push_back(toJson(c));
    json j{{"type", "welcome"},  {"protocol", PROTOCOL_VERSION}, {"client", w.clientId},
           {"role", toString(w.role)}, {"sessionId", w.sessionId}, {"session", w.session},
           {"rig", toJson(w.rig)}, {"view", toJson(w.view)},     {"clients", clients},
           {"history", {{"undo", w.undoDepth}, {"redo", w.redoDepth}}}};
    if (w.viewerToken && w.role == Role::Editor) j["viewerToken"] = *w.viewerToken;
    return dump(j);
}

std::string encodeAck(uint64_t seq, uint64_t rigVersion, const json& extra) {
    json j{{"type", "ack"}, {"seq", seq}, {"rigVersion", rigVersion}};
    if (extra.is_object()) j.update(extra);
    return dump(j);
}

std::string encodeChange(const ChangeInfo& c) {
    json j{{"type", "change"}, {"rigVersion", c.rigVersion}, {"by", c.byClient}, {"byName", c.byName}, {"kind", c.kind}};
    if (c.rig) j["rig"] = toJson(*c.rig);
    else j["changes"] = changesToJson(c.changes);
    return dump(j);
}

std::string encodeChanges(const std::vector<const ChangeInfo*>& cs) {
    if (cs.size() == 1) return encodeChange(*cs.front());
    const ChangeInfo& newest = *cs.back();
    json all = json::array(), versions = json::array(), authors = json::array();
    bool allTime = true;
    for (const ChangeInfo* c : cs) {
        allTime = allTime && c->kind == "time";
        for (const Change& ch : c->changes) {
            all.push_back({{"path", ch.path}, {"value", ch.value}});
            versions.push_back(c->rigVersion);
        }
        if (!authors.empty() && authors.back()["by"] == c->byClient && authors.back()["byName"] == c->byName) {
            authors.back()["to"] = c->rigVersion;
        } else {
            authors.push_back({{"by", c->byClient}, {"byName", c->byName}, {"from", c->rigVersion}, {"to", c->rigVersion}});
        }
    }
    return dump(json{{"type", "change"},      {"rigVersion", newest.rigVersion}, {"by", newest.byClient},
                     {"byName", newest.byName}, {"kind", allTime ? "time" : "edit"},  {"changes", all},
                     {"versions", versions},    {"coalesced", cs.size()},         {"authors", authors}});
}

std::string encodeError(ErrorCode code, std::string_view message, std::optional<uint64_t> seq) {
    json j{{"type", "error"}, {"code", toString(code)}, {"message", message}};
    if (seq) j["seq"] = *seq;
    return dump(j);
}

std::string encodePresence(const std::vector<ClientInfo>& clients) {
    json arr = json::array();
    for (const ClientInfo& c : clients) arr.push_back(toJson(c));
    return dump(json{{"type", "presence"}, {"clients", arr}});
}

std::string encodePickResult(uint64_t seq, const json& pick) {
    json j = pick;
    j["type"] = "pick";
    j["seq"] = seq;
    return dump(j);
}

} // namespace dfb::protocol
