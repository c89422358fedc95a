#pragma once
// Protocol codec, shared by server and clients (docs/protocol.md): the rig as JSON (RigJson.cpp),
// property-path edits (Edits.cpp), keyframes (Keyframes.cpp), limits (Limits.cpp), command-line
// paths (CliPaths.cpp) and the fixed binary header before each encoded frame. The v1 messages are in Messages.h. Every decoder validates and
// returns an Error naming the offending field instead of throwing.

#include <dfb/core/Result.h>
#include <dfb/protocol/Rig.h>

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace dfb::protocol {

// ---- rig <-> JSON ----------------------------------------------------------------------------
nlohmann::json toJson(const Light& light);
nlohmann::json toJson(const Rig& rig);
/// Parses and validates a whole rig (unknown fields are refused, ranges checked).
Result<Rig> rigFromJson(const nlohmann::json& j);

// ---- property paths ----------------------------------------------------------------------------
/// One property change: `path` is "LIGHT.PROPERTY" (e.g. "key.intensity") or a rig-level
/// property ("exposure"); `value` is the new JSON value.
struct Change {
    std::string path;
    nlohmann::json value;
};

/// Applies one change to `rig` after validating it. On error the rig is unchanged.
Status applyChange(Rig& rig, const Change& change);

/// Applies all changes or none (validated on a copy first).
Status applyChanges(Rig& rig, const std::vector<Change>& changes);

/// The rig as it is at its session time: every keyed property replaced by its interpolated value
/// (keys whose value the property refuses are skipped). Unkeyed properties are unchanged.
Rig evaluateRig(const Rig& rig);

/// The value of one property's keys at `time`: the first key's value before it, the last's after
/// it, else from the key before `time` to the next one, linearly or (interp "smooth") by
/// Catmull-Rom with tangents from the neighbours' time spacing. Null for no keys.
nlohmann::json interpolateKeys(const std::vector<Key>& keys, double time);

// ---- limits ---------------------------------------------------------------------------------------
/// What one session's rig may hold (DESIGN section 9; docs/operations.md "Limits"). Each bounds
/// memory the server would otherwise grow without end: a 10,000-light rig once allocated ~17 MB
/// per light until the GL context failed, and the journaled rig failed again on every restart.
struct RigLimits {
    /// Lights in the rig (--max-lights). Each enabled light keeps a cached image and, when it
    /// casts shadows, a shadow map; an edit of one light stays as cheap as in a rig of one.
    size_t maxLights = 256;
    /// Keyframes of one property of one light (--max-keys).
    size_t maxKeysPerProperty = 1024;
    /// Bytes of the lights' GPU caches (--max-light-memory-mb): for every enabled light its
    /// cached image (pixels x 8 bytes, RGBA16F) plus, when it casts shadows, its shadow map
    /// (side^2 x 4 bytes, DEPTH32F; six faces for a point light).
    uint64_t maxLightMemoryBytes = uint64_t(2048) << 20;
    /// Pixels of the session's shot (for the cached images); 0 leaves them out of the sum.
    uint64_t imagePixels = 0;
};

/// The GPU memory `light` costs under `limits` (RigLimits::maxLightMemoryBytes), in bytes.
uint64_t lightMemoryBytes(const Light& light, const RigLimits& limits);
/// LimitExceeded naming the limit, its value and its flag when `rig` is over one of `limits`.
/// Control points per chain are limited by the codec itself (MAX_BENDY_SEGMENTS).
Status checkRigLimits(const Rig& rig, const RigLimits& limits);

/// InvalidValue unless `path` names a settable property: a rig-level one or LIGHT.PROPERTY with a
/// property of the schema (the light itself is not checked: only the server knows the rig).
Status checkPropertyPath(std::string_view path);

/// Parses "PATH=VALUE" from a command line (the path checked by checkPropertyPath). VALUE is JSON if it parses as JSON, else a
/// comma-separated list of numbers ("1,2,3"), else a string.
Result<Change> parseAssignment(std::string_view text);

// ---- binary frames -----------------------------------------------------------------------------
/// How a frame's image bytes are encoded: 8-bit sRGB JPEG or PNG, or a float OpenEXR.
enum class Encoding : uint16_t { Jpeg = 1, Png = 2, Exr = 3 };

/// Fixed 32-byte little-endian header before the encoded image bytes of a binary frame message.
///   offset size field
///   0      4    magic "DFBF"
///   4      2    header version (1)
///   6      2    encoding (1 = JPEG, 2 = PNG, 3 = OpenEXR)
///   8      8    frame number (server-wide counter)
///   16     8    rig version the frame shows
///   24     4    width in pixels
///   28     4    height in pixels
/// followed by the encoded image (the rest of the message).
struct FrameHeader {
    Encoding encoding = Encoding::Jpeg;
    uint64_t frameNumber = 0;
    uint64_t rigVersion = 0;
    uint32_t width = 0;
    uint32_t height = 0;
};
constexpr size_t FRAME_HEADER_BYTES = 32;

void writeFrameHeader(const FrameHeader& h, uint8_t* out);
/// Validates magic, version and encoding; fails with Protocol on anything else.
Result<FrameHeader> readFrameHeader(const uint8_t* data, size_t size);

} // namespace dfb::protocol
