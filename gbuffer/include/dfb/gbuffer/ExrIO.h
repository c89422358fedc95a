#pragma once
// Reading and writing the deep framebuffer as OpenEXR (docs/gbuffer-format.md).

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>

#include <string>

namespace dfb {

/// Writes `buffer` to `path` (ZIP compression). Writes to a temporary file in the same directory
/// and renames it, so an existing file is never left half-written. Fails with IoError.
Status writeDeepBuffer(const DeepBuffer& buffer, const std::string& path);

/// Reads a deep framebuffer. Fails with FileNotFound, InvalidFile (not an EXR, truncated, tiled
/// or multi-part where not supported, data window not matching display window), MissingData
/// (a required channel or attribute is absent) or InvalidValue (absurd size, non-finite position
/// or normal on a covered pixel). Messages name the file and the offending channel or pixel.
Result<DeepBuffer> readDeepBuffer(const std::string& path);

} // namespace dfb
