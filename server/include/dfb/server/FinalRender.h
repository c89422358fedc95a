#pragma once
// The way from a tweaked rig to the final renderer (issue 19 point 8): the job a Cycles render of
// the shot runs from. server/blender/dfb_final.py (run by Debian's Blender, headless) reads it,
// converts the rig's lights (server/blender/README.md gives every conversion and the measured
// preview-vs-Cycles differences) and writes a linear EXR. This header writes the job: the one
// place its fields are produced.

#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/protocol/Rig.h>

#include <nlohmann/json.hpp>

#include <string>

namespace dfb {

/// The folder of dfb_final.py and dfb_inspect_gltf.py (the source tree's server/blender).
std::string blenderScriptDirectory();

/// The shot's camera as the protocol writes it (welcome's session.camera): name, yfov (radians),
/// aspect, near, far, orthographic, ymag, worldToCamera and worldToNDC (16 numbers each,
/// column-major).
nlohmann::json cameraJson(const CameraInfo& camera);

struct FinalRenderOptions {
    int samples = 64;        ///< Cycles samples per pixel, 1..65536
    bool directOnly = false; ///< light -> surface -> camera only: the preview's terms, for comparing
    int threads = 0;         ///< 0: Blender's choice
    int seed = 0;
};

/// The job file's JSON (format 1): `sceneGlb` (exportGltf of the rig), `outputExr`, the shot's
/// size and camera, `rig` evaluated at its time (protocol JSON), the asset folder the maps are
/// named in, and the options.
nlohmann::json finalRenderJob(const DeepBuffer& shot, const Rig& rig, const std::string& sceneGlb, const std::string& outputExr,
                              const std::string& assetDirectory, const FinalRenderOptions& options);

} // namespace dfb
