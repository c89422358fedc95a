#include <dfb/server/FinalRender.h>

#include <dfb/protocol/Codec.h>

namespace dfb {

std::string blenderScriptDirectory() { return DFB_BLENDER_SCRIPT_DIR; }

nlohmann::json cameraJson(const CameraInfo& camera) {
    auto mat = [](const glm::mat4& m) {
        nlohmann::json a = nlohmann::json::array();
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) a.push_back(m[c][r]);
        return a; // column-major, as glm and WebGL store matrices
    };
    return {{"name", camera.name},
            {"yfov", camera.yfovRadians},
            {"aspect", camera.aspect},
            {"near", camera.znear},
            {"far", camera.zfar},
            {"orthographic", camera.orthographic},
            {"ymag", camera.ymag},
            {"worldToCamera", mat(camera.worldToCamera)},
            {"worldToNDC", mat(camera.worldToNDC)}};
}

nlohmann::json finalRenderJob(const DeepBuffer& shot, const Rig& rig, const std::string& sceneGlb, const std::string& outputExr,
                              const std::string& assetDirectory, const FinalRenderOptions& options) {
    return {{"format", 1},
            {"scene", sceneGlb},
            {"output", outputExr},
            {"width", shot.width},
            {"height", shot.height},
            {"camera", cameraJson(shot.camera)},
            {"samples", options.samples},
            {"directOnly", options.directOnly},
            {"threads", options.threads},
            {"seed", options.seed},
            {"assetDirectory", assetDirectory},
            // The script converts the lights as they are now: keys are not its business.
            {"rig", protocol::toJson(protocol::evaluateRig(rig))}};
}

} // namespace dfb
