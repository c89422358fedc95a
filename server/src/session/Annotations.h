#pragma once
// A session's annotations (issue 20 point 4, docs/protocol.md "Annotations"): pins with a comment
// and freehand strokes on the frame, in shot pixels, each tied to the rig version it was made on,
// with its author and time, resolvable and reopenable. Anyone in the session may add one, viewers
// included (a review note is not an edit of the rig); deleting is the editors'. Kept per session
// in SESSION_DIR/annotations/ID.json beside the journal, one durable file per annotation (adding
// or resolving one never rewrites another; a damaged file costs only its annotation: reported,
// left on disk), or in memory for a session without --state. I/O thread only.

#include <dfb/core/Result.h>
#include <dfb/protocol/Messages.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace dfb {

class Annotations {
public:
    static constexpr size_t MAX_ANNOTATIONS = 1000; ///< per session
    /// Points of all a session's annotations together: every change sends every client the whole
    /// list, which this keeps to a few MB (1000 strokes of 2000 points would be ~40 MB).
    static constexpr size_t MAX_TOTAL_POINTS = 200000;

    struct Annotation {
        uint64_t id = 0;
        protocol::AnnotateMessage shape; ///< kind, points, text, color (its seq unused)
        uint64_t rigVersion = 0;
        std::string by;   ///< the author's name
        std::string time; ///< UTC, ISO 8601
        bool resolved = false;
        std::string resolvedBy, resolvedTime; ///< empty while open
    };

    /// The annotations kept in `dir` (created when missing; empty: in memory only). Files that
    /// cannot be read are skipped and named in `report` (one line each), left as they are.
    static Result<std::unique_ptr<Annotations>> open(const std::filesystem::path& dir, std::vector<std::string>* report = nullptr);

    /// Adds `a` (checked by protocol::annotationFromJson) made by `by` on rig version `rigVersion`
    /// of a width x height shot. InvalidValue naming the point outside the shot, LimitExceeded
    /// past MAX_ANNOTATIONS or MAX_TOTAL_POINTS, IoError when it cannot be saved (then nothing is kept). The new
    /// annotation as listed.
    Result<nlohmann::json> add(const protocol::AnnotateMessage& a, int width, int height, uint64_t rigVersion, const std::string& by);
    /// Marks annotation `id` resolved (by `by`, now) or open again; MissingData when there is
    /// none. Resolving a resolved one keeps who resolved it first. The annotation as listed.
    Result<nlohmann::json> setResolved(uint64_t id, bool resolved, const std::string& by);
    Status remove(uint64_t id);

    /// Every annotation, oldest (lowest id) first: [{id, kind, points, text, color?, rigVersion,
    /// by, time, resolved, resolvedBy?, resolvedTime?}].
    nlohmann::json list() const;
    size_t size() const { return mById.size(); }
    bool persistent() const { return !mDir.empty(); }

    static nlohmann::json toJson(const Annotation& a);

private:
    explicit Annotations(std::filesystem::path dir) : mDir(std::move(dir)) {}
    Status save(const Annotation& a) const;
    std::filesystem::path mDir;
    std::map<uint64_t, Annotation> mById;
    uint64_t mNextId = 1;
    size_t mPoints = 0; ///< of all annotations, at most MAX_TOTAL_POINTS
};

} // namespace dfb
