#pragma once
// Test support: reference visibility by ray casting with Embree on the CPU, to check what the
// GPU shadow maps say. The server's own hierarchy (dfb/bvh/TriangleBvh.h, what the Picker
// casts against), under the name the tests know.

#include <dfb/bvh/TriangleBvh.h>

namespace dfb::test {

/// addMesh(positions, indices) for each mesh, commit(), then occluded(from, to, eps): true when
/// something lies on the open segment from `from` to `to` (ends excluded by `eps`, a fraction of
/// the segment's length).
using RayCaster = TriangleBvh;

} // namespace dfb::test
