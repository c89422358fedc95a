// The fixed 32-byte header before each binary frame (Codec.h FrameHeader).

#include <dfb/protocol/Codec.h>

#include <cstring>

namespace dfb::protocol {

namespace {
void put16(uint8_t* p, uint16_t v) { p[0] = uint8_t(v); p[1] = uint8_t(v >> 8); }
void put32(uint8_t* p, uint32_t v) { for (int i = 0; i < 4; ++i) p[i] = uint8_t(v >> (8 * i)); }
void put64(uint8_t* p, uint64_t v) { for (int i = 0; i < 8; ++i) p[i] = uint8_t(v >> (8 * i)); }
uint16_t get16(const uint8_t* p) { return uint16_t(p[0] | (p[1] << 8)); }
uint32_t get32(const uint8_t* p) { uint32_t v = 0; for (int i = 3; i >= 0; --i) v = (v << 8) | p[i]; return v; }
uint64_t get64(const uint8_t* p) { uint64_t v = 0; for (int i = 7; i >= 0; --i) v = (v << 8) | p[i]; return v; }
constexpr uint16_t FRAME_HEADER_VERSION = 1;
} // namespace

void writeFrameHeader(const FrameHeader& h, uint8_t* out) {
    std::memcpy(out, "DFBF", 4);
    put16(out + 4, FRAME_HEADER_VERSION);
    put16(out + 6, static_cast<uint16_t>(h.encoding));
    put64(out + 8, h.frameNumber);
    put64(out + 16, h.rigVersion);
    put32(out + 24, h.width);
    put32(out + 28, h.height);
}

Result<FrameHeader> readFrameHeader(const uint8_t* data, size_t size) {
    if (size < FRAME_HEADER_BYTES) return makeError(ErrorCode::Protocol, "frame message shorter than its header");
    if (std::memcmp(data, "DFBF", 4) != 0) return makeError(ErrorCode::Protocol, "frame message has a bad magic");
    if (get16(data + 4) != FRAME_HEADER_VERSION) {
        return makeError(ErrorCode::Protocol, "frame header version " + std::to_string(get16(data + 4)) + " is not supported");
    }
    FrameHeader h;
    const uint16_t enc = get16(data + 6);
    if (enc < 1 || enc > 3) return makeError(ErrorCode::Protocol, "frame has unknown encoding " + std::to_string(enc));
    h.encoding = static_cast<Encoding>(enc);
    h.frameNumber = get64(data + 8);
    h.rigVersion = get64(data + 16);
    h.width = get32(data + 24);
    h.height = get32(data + 28);
    return h;
}

} // namespace dfb::protocol
