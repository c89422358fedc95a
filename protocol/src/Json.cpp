#include <dfb/protocol/Json.h>

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <string>

#include <utility>

namespace dfb::protocol {
namespace {

using json = nlohmann::json;

// nlohmann's own DOM builder, with the depth counted on the way in: returning false from a SAX
// event stops the parser there, so a deep value is refused before it is built (the cost is
// bounded by the depth limit, not by the input).
class BoundedDomParser : public nlohmann::detail::json_sax_dom_parser<json> {
public:
    BoundedDomParser(json& result, int maxDepth) : json_sax_dom_parser(result, false), mMaxDepth(maxDepth) {}

    bool start_object(std::size_t n) { return enter() && json_sax_dom_parser::start_object(n); }
    bool end_object() {
        --mDepth;
        return json_sax_dom_parser::end_object();
    }
    bool start_array(std::size_t n) { return enter() && json_sax_dom_parser::start_array(n); }
    bool end_array() {
        --mDepth;
        return json_sax_dom_parser::end_array();
    }
    bool parse_error(std::size_t position, const std::string& token, const nlohmann::detail::exception& e) {
        mError = e.what();
        mErrorAt = position;
        return json_sax_dom_parser::parse_error(position, token, e);
    }

    bool tooDeep() const { return mTooDeep; }
    const std::string& error() const { return mError; }

private:
    bool enter() {
        if (++mDepth <= mMaxDepth) return true;
        mTooDeep = true;
        return false;
    }
    int mMaxDepth;
    int mDepth = 0;
    bool mTooDeep = false;
    std::string mError;
    std::size_t mErrorAt = 0;
};

// nlohmann's messages start with "[json.exception.parse_error.101] parse error at line 1, ...";
// the part after the bracket is the useful one.
std::string reason(const std::string& e) {
    const size_t close = e.find("] ");
    return close == std::string::npos ? e : e.substr(close + 2);
}

} // namespace

Result<json> parseJson(std::string_view text, size_t maxBytes, std::string_view what, int maxDepth) {
    if (text.size() > maxBytes) {
        return makeError(ErrorCode::LimitExceeded, std::string(what) + ": " + std::to_string(text.size()) + " bytes is over the limit of " +
                                                      std::to_string(maxBytes) + " bytes");
    }
    json root;
    BoundedDomParser sax(root, maxDepth);
    const bool ok = json::sax_parse(text.begin(), text.end(), &sax, nlohmann::detail::input_format_t::json, true);
    if (sax.tooDeep()) {
        return makeError(ErrorCode::LimitExceeded, std::string(what) + ": arrays and objects nest deeper than the limit of " +
                                                      std::to_string(maxDepth) + " levels");
    }
    if (!ok || root.is_discarded()) {
        return makeError(ErrorCode::Protocol, std::string(what) + ": not valid JSON (" + reason(sax.error()) + ")");
    }
    return root;
}

std::string excerpt(const json& v, size_t maxChars) {
    switch (v.type()) {
    case json::value_t::array: return "an array of " + std::to_string(v.size()) + (v.size() == 1 ? " value" : " values");
    case json::value_t::object: return "an object of " + std::to_string(v.size()) + (v.size() == 1 ? " member" : " members");
    case json::value_t::binary: return "binary data";
    case json::value_t::string: {
        const auto& s = v.get_ref<const std::string&>();
        if (s.size() <= maxChars) return v.dump(-1, ' ', true, json::error_handler_t::replace);
        size_t cut = maxChars;
        while (cut > 0 && (static_cast<unsigned char>(s[cut]) & 0xC0) == 0x80) --cut; // not inside a character
        return json(s.substr(0, cut)).dump(-1, ' ', true, json::error_handler_t::replace) + "...";
    }
    default: return v.dump(-1, ' ', true, json::error_handler_t::replace); // a scalar: short by nature
    }
}

namespace {
void shortestFloatsAt(json& v, int depth) {
    if (v.is_number_float()) {
        const double d = v.get<double>();
        const float f = float(d);
        if (!std::isfinite(d) || double(f) != d) return; // not a float's value: keep every digit
        char buf[32];
        auto [end, ec] = std::to_chars(buf, buf + sizeof buf, f); // shortest text that reads back as f
        if (ec != std::errc()) return;
        v = std::strtod(std::string(buf, end).c_str(), nullptr);
        return;
    }
    if (depth >= MAX_JSON_DEPTH || !(v.is_array() || v.is_object())) return;
    for (auto& e : v) shortestFloatsAt(e, depth + 1);
}
} // namespace

void shortestFloats(json& value) { shortestFloatsAt(value, 0); }

} // namespace dfb::protocol
