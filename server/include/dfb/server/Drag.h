#pragma once
// One indirect-editing drag, from the pixel the user grabbed to the light each pointer position
// asks for (issue 17 point 6; docs/protocol.md "Drags"; the modes: dfb/protocol/DragModes.h):
// beginDrag picks what the grabbed pixel shows (and for shadow modes the occluder point S on the
// geometry the shadow map uses, Picker), dragTo picks the pointer's pixel and solves the mode's
// equation (dfb/server/IndirectEdit.h) from the light as it was at the begin, and dragChanges
// writes the solved light as the rig's property changes (keys at the session's time where a
// property is keyframed, as the browser does for handles). The server runs these for the
// WebSocket's `drag` messages and POST /v1/sessions/ID/drag; dfb-indirect-bench times them; the
// image-space tests use them directly. No GL, no protocol state: any thread (Picker is
// thread-safe).

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/protocol/Codec.h>
#include <dfb/protocol/DragModes.h>
#include <dfb/protocol/Rig.h>
#include <dfb/server/IndirectEdit.h>
#include <dfb/server/Picker.h>

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace dfb {

/// What a drag begins with (the `drag` message's begin).
struct DragStart {
    protocol::DragMode mode = protocol::DragMode::Shadow;
    std::string light;
    int x = 0, y = 0;          ///< the grabbed pixel, row 0 at the top
    indirect::Selection points; ///< BendyLight control points 1..2K; empty: the whole light
};

/// What the begin grabbed. Every update solves from `light`, so a drag never accumulates error.
struct DragGrab {
    protocol::DragMode mode = protocol::DragMode::Shadow;
    Light light;   ///< the light at the begin with its keyframes evaluated at `time` (what was on screen)
    Light stored;  ///< the rig's own light (keys included): what a cancel restores
    double time = 0.0;
    indirect::Selection points;
    int x = 0, y = 0;
    PickResult at;                          ///< the grabbed pixel's front sample (M, C, Ct of the papers)
    std::optional<OccluderResult> occluder; ///< shadow modes: the occluder point S
    /// Local shadow modes: points of the occluder's object that the light reaches at the begin
    /// (front G-buffer positions of its lit pixels inside the tube, evenly spread over them, at
    /// most indirect::LOCAL_MAX_OCCLUDER_SAMPLES; LocalShadowEdit.h keeps their tube coordinates
    /// too). Chosen once, so every update solves the same problem.
    std::vector<glm::dvec3> occluderSamples;
    glm::dvec3 eye{0.0};                    ///< the camera's position (perspective) for view directions
    bool orthographic = false;
    glm::dvec3 forward{0.0, 0.0, -1.0};     ///< the camera's view direction (orthographic views)
};

/// One update's result.
struct DragStep {
    Light light;                          ///< the solved light (evaluated values)
    std::vector<protocol::Change> changes; ///< what to apply to the rig; empty when nothing changed
    PickResult at;                        ///< the pointer's pixel's front sample
    int x = 0, y = 0;
    int iterations = 0;
    double residual = 0.0;
    double solveMs = 0.0;                 ///< pick + solve, wall time
};

/// Grabs pixel (start.x, start.y) of `shot` for `start.mode` on the rig's light `start.light`.
/// Errors (nothing is changed by any): InvalidValue for a pixel outside the image, a mode that
/// does not apply to the light's type, a selection on a light without a chain or naming control
/// points it does not have or twice, a disabled light; MissingData for an unknown light, a pixel
/// that shows the background, and (shadow modes) a pixel in no shadow of the light.
Result<DragGrab> beginDrag(const Picker& picker, const DeepBuffer& shot, const Rig& rig, const DragStart& start);

/// The light that puts the grabbed feature under pixel (x, y). Errors: InvalidValue for a pixel
/// outside the image, a solve that fails (its message says why: a point outside the tube, no
/// convergence, a degenerate configuration) or a result whose BendyLight chain folds (when the
/// begin's did not); MissingData for a pixel that shows the background.
Result<DragStep> dragTo(const Picker& picker, const DeepBuffer& shot, const DragGrab& grab, int x, int y);

/// The rig changes that make the light `solved` (evaluated values) from the grab's: one per
/// property that differs (position, direction, cp[i], r[i]), as a key at the grab's time where
/// the stored light keys that property.
std::vector<protocol::Change> dragChanges(const DragGrab& grab, const Light& solved);

/// The rig changes that put the light back as it was at the begin (a cancel): the stored
/// position, direction, chain and keys.
std::vector<protocol::Change> restoreChanges(const DragGrab& grab);

/// For acknowledgements: the grab (mode, light, pixel, the grabbed point, S and the number of
/// occluder samples) and a step
/// (pixel, point, iterations, residual, solve time).
nlohmann::json toJson(const DragGrab& grab);
nlohmann::json toJson(const DragStep& step);

} // namespace dfb
