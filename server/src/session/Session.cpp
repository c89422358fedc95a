#include "session/Session.h"

#include <dfb/server/BendyChain.h>
#include <dfb/server/ImageCodec.h>

#include <filesystem>

namespace dfb {

namespace {
// The server, not clients, says what is doubtful about a BendyLight's chain (paper section 7).
void updateWarnings(Rig& rig) {
    for (Light& l : rig.lights) l.warning = chainWarning(l);
}
} // namespace

Session::Session(const DeepBuffer& shot, std::string shotPath, Rig initialRig) : mRig(std::move(initialRig)) {
    updateWarnings(mRig);
    auto mat = [](const glm::mat4& m) {
        nlohmann::json a = nlohmann::json::array();
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) a.push_back(m[c][r]);
        return a; // column-major, as glm and WebGL store matrices
    };
    mDescription = {{"shot", shotPath},
                    {"source", shot.sourcePath},
                    {"width", shot.width},
                    {"height", shot.height},
                    {"camera",
                     {{"name", shot.camera.name},
                      {"yfov", shot.camera.yfovRadians},
                      {"aspect", shot.camera.aspect},
                      {"near", shot.camera.znear},
                      {"far", shot.camera.zfar},
                      {"worldToCamera", mat(shot.camera.worldToCamera)},
                      {"worldToNDC", mat(shot.camera.worldToNDC)}}},
                    {"objects", shot.objectNames}};
}

Result<uint64_t> Session::applyEdit(const std::vector<protocol::Change>& changes) {
    std::lock_guard lock(mMutex);
    Rig next = mRig;
    if (auto s = protocol::applyChanges(next, changes); !s) return s.error();
    // A new cookie must be an image the engine can read (from the asset folder), or the edit is
    // refused now rather than every frame failing later.
    for (const Light& l : next.lights) {
        const Light* before = mRig.find(l.name);
        if (l.cookie.empty() || (before && before->cookie == l.cookie)) continue;
        auto img = readLinearImage((std::filesystem::path(mAssetDir) / l.cookie).string());
        if (!img) {
            return makeError(ErrorCode::InvalidValue, l.name + ".cookie: '" + l.cookie + "' is not a readable image in the asset folder " +
                                                          mAssetDir + " (" + img.error().message + ")");
        }
    }
    mRig = std::move(next);
    updateWarnings(mRig);
    return ++mRig.version;
}

Rig Session::rig() const {
    std::lock_guard lock(mMutex);
    return mRig;
}

uint64_t Session::rigVersion() const {
    std::lock_guard lock(mMutex);
    return mRig.version;
}

} // namespace dfb
