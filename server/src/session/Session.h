#pragma once
// One shot being relit: its rig (the authoritative copy), the description clients need, and the
// edit rule. Thread-safe: the network thread edits, the render thread snapshots.

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Rig.h>

#include <mutex>
#include <nlohmann/json.hpp>

namespace dfb {

class Session {
public:
    Session(const DeepBuffer& shot, std::string shotPath, Rig initialRig);

    /// Applies all changes of an edit or none. Returns the new rig version.
    Result<uint64_t> applyEdit(const std::vector<protocol::Change>& changes);

    /// Where cookie images are looked up (the engine's asset folder); default ".".
    void setAssetDirectory(std::string dir) {
        std::lock_guard lock(mMutex);
        mAssetDir = std::move(dir);
    }
    std::string assetDirectory() const {
        std::lock_guard lock(mMutex);
        return mAssetDir;
    }

    Rig rig() const;
    uint64_t rigVersion() const;
    /// Resolution, camera and source of the shot, for the welcome message and GET /v1/session.
    const nlohmann::json& description() const { return mDescription; }

private:
    mutable std::mutex mMutex;
    Rig mRig;
    std::string mAssetDir = ".";
    nlohmann::json mDescription;
};

} // namespace dfb
