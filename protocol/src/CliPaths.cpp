// PATH=VALUE assignments as typed on a command line (dfb-client set).

#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Json.h>
#include <dfb/protocol/Schema.h>

#include "Validate.h"

namespace dfb::protocol {

using namespace detail;

Status checkPropertyPath(std::string_view path) {
    if (findRigProperty(path)) return okStatus();
    const size_t dot = path.find('.');
    if (dot == std::string_view::npos || dot == 0 || dot + 1 == path.size()) {
        return invalid("path '" + std::string(path) + "': expected LIGHT.PROPERTY, 'exposure', 'viewTransform' or 'time'");
    }
    int index = -1;
    const Property* p = findLightProperty(path.substr(dot + 1), &index);
    if (index == -2) return invalid("path '" + std::string(path) + "': malformed index (expected NAME[integer])");
    if (!p || p->readOnly) {
        return invalid("path '" + std::string(path) + "': no light property '" + std::string(path.substr(dot + 1)) +
                       "' ('dfb-client properties' lists them)");
    }
    return okStatus();
}

// A command-line value is at most what one WebSocket message may carry.
constexpr size_t MAX_TEXT_MESSAGE_VALUE_BYTES = 1 << 20;

Result<Change> parseAssignment(std::string_view text) {
    const size_t eq = text.find('=');
    if (eq == std::string_view::npos || eq == 0) return invalid("'" + std::string(text) + "': expected PATH=VALUE");
    Change c;
    c.path = std::string(text.substr(0, eq));
    if (auto s = checkPropertyPath(c.path); !s) return s.error();
    const std::string rhs(text.substr(eq + 1));
    auto v = parseJson(rhs, MAX_TEXT_MESSAGE_VALUE_BYTES, c.path);
    if (v) {
        c.value = std::move(v.value());
        return c;
    }
    if (v.error().code == ErrorCode::LimitExceeded) return v.error();
    if (rhs.find(',') != std::string::npos) {
        json arr = json::array();
        size_t start = 0;
        while (start <= rhs.size()) {
            size_t end = rhs.find(',', start);
            if (end == std::string::npos) end = rhs.size();
            auto n = parseJson(std::string_view(rhs).substr(start, end - start), 64, c.path);
            if (!n || !n->is_number()) {
                return invalid("'" + std::string(text) + "': list items must be numbers");
            }
            arr.push_back(n.value());
            start = end + 1;
        }
        c.value = arr;
        return c;
    }
    c.value = rhs;
    return c;
}

} // namespace dfb::protocol
