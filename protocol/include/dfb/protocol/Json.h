#pragma once
// Bounded JSON input (issue 14, DESIGN section 9): every JSON text the server or a client reads
// (WebSocket messages, HTTP bodies, rig and token files, journal records, command-line values)
// goes through parseJson, which refuses text over a size limit and stops at the first array or
// object nested deeper than MAX_JSON_DEPTH. nlohmann's DOM parser accepts any depth, but copying,
// comparing and dumping a value recurse: a 100,000-deep value (200 KB) overflowed the stack of
// the server. Error messages quote bad values through excerpt(), which never recurses.

#include <dfb/core/Result.h>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>
#include <string_view>

namespace dfb::protocol {

/// Deepest nesting of arrays and objects accepted in any JSON input. A rig is 6 levels deep
/// (rig -> lights -> light -> keys -> property -> key -> value array); 64 leaves room for any
/// extension while keeping every recursive walk of a value a few KB of stack.
constexpr int MAX_JSON_DEPTH = 64;

/// Parses `text` as one JSON value. Never throws. LimitExceeded naming `what` and the limit when
/// the text is over `maxBytes` or nests deeper than `maxDepth`; Protocol naming
/// `what` and the parser's reason when the text is not JSON.
Result<nlohmann::json> parseJson(std::string_view text, size_t maxBytes, std::string_view what,
                                 int maxDepth = MAX_JSON_DEPTH);

/// A short, printable description of a value for error messages: a number or a string of at most
/// `maxChars` characters (escaped, cut with "..."), or "an array of N values" / "an object of N
/// members". Never recurses, so it is safe on any value.
std::string excerpt(const nlohmann::json& value, size_t maxChars = 40);

/// Rewrites every number of `value` that is exactly a 32-bit float as the double nearest to its
/// shortest decimal form, so that dumping prints 0.95 rather than 0.949999988079071 (the double
/// of the float 0.95f). Reading the text back as float gives the same float: nothing changes but
/// the digits. The rig, pick results and the session's camera go through it. At most
/// MAX_JSON_DEPTH levels are visited (deeper ones are left as they are).
void shortestFloats(nlohmann::json& value);

} // namespace dfb::protocol
