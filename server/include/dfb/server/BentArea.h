#pragma once
// A bent area light as BendyLights (paper 003 section 4.1): its four corner chains and the m x n
// interior chains blended from them (eqs. 8-10), each a BendyLight the engine shades and shadows
// like any other, their contributions summed (docs/lighting.md, "Bent area lights").

#include <dfb/protocol/Rig.h>

#include <glm/glm.hpp>

#include <string>
#include <vector>

namespace dfb {

/// Corner c of a bent area light (BENT_AREA_CORNERS in Rig.h) as a BendyLight: its source at the
/// emitter's corner, aimed along the emitter's normal, its chain converted from the emitter's
/// (rolled) frame to the BendyLight frame (Rig.h, controlPoints). Colours 1.
Light bentAreaCorner(const Light& l, int corner);

/// The m x n interior BendyLights of `l` for `grid` (its shadowGrid, or a preview's smaller one),
/// row-major (index j * m + i), named "NAME#i,j". Interior (i, j) has its source at the emitter
/// point (a - 1/2) w right + (b - 1/2) h up with a = (i + 1/2) / m, b = (j + 1/2) / n, and control
/// points and radii blended bilinearly from the corners with the same (a, b) (eqs. 8, 9; eq. 10's
/// a = s / (m - 1) replaced by cell centres, docs/lighting.md says why). Intensity 1: the engine
/// weights each by bentAreaCellArea and scales the sum by the light's radiance.
std::vector<Light> bentAreaInterior(const Light& l, glm::ivec2 grid);

/// Each interior light's share of the emitter, w h / (m n) (scene units squared): its candela per
/// unit of the emitter's radiance along the normal.
float bentAreaCellArea(const Light& l, glm::ivec2 grid);

/// Why a bent area light's corner chains are doubtful (chainWarning of each corner, named); empty
/// when fine. The limits are chainTrouble's (BendyChain.h): 1 and 1 are where a tube folds.
std::string bentAreaWarning(const Light& l, double foldLimit = 1.0, double apartLimit = 1.0);

} // namespace dfb
