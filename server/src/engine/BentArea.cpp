#include <dfb/server/AreaPattern.h>
#include <dfb/server/BendyChain.h>
#include <dfb/server/BentArea.h>

#include <algorithm>

namespace dfb {
namespace {

// The emitter's frame (always a rectangle) and the BendyLight frame of its normal.
struct Frames {
    lightmath::AreaFrame<double> area;
    glm::dvec3 uL, vL, wL;
};

Frames framesOf(const Light& l) {
    Frames f;
    f.area = lightmath::areaFrame<double>({l.position[0], l.position[1], l.position[2]},
                                          {l.direction[0], l.direction[1], l.direction[2]}, double(l.rollDeg),
                                          {l.areaSize[0], l.areaSize[1]}, false);
    lightFrame(l, f.uL, f.vL, f.wL);
    return f;
}

// A point (a, b, c) of the emitter's frame (a n + b up + c right) in the BendyLight frame's
// (a uL + b' vL + c' wL): the same normal; the roll turns the other two.
Vec3 toLightFrame(const Frames& f, const glm::dvec3& q) {
    const glm::dvec3 d = f.area.up * q.y + f.area.right * q.z;
    return {float(q.x), float(glm::dot(d, f.vL)), float(glm::dot(d, f.wL))};
}

// A BendyLight at emitter point (x, y) (right, up; scene units) with the chain `pts`, `radii`
// (emitter frame).
Light chainLight(const Light& l, const Frames& f, double x, double y, const std::vector<glm::dvec3>& pts,
                 const std::vector<float>& radii) {
    Light b = l;
    b.type = LightType::Bendy;
    b.keys.clear();
    b.cornerPoints.clear();
    b.cornerRadii.clear();
    b.warning.clear();
    b.cookie.clear();
    b.barnDoorsDeg = {90.f, 90.f, 90.f, 90.f};
    const glm::dvec3 p = f.area.centre + f.area.right * x + f.area.up * y;
    b.position = {float(p.x), float(p.y), float(p.z)};
    b.intensityCd = 1.f;
    b.color = {1.f, 1.f, 1.f};
    b.controlPoints.clear();
    for (const glm::dvec3& q : pts) b.controlPoints.push_back(toLightFrame(f, q));
    b.radii = radii;
    b.colors.assign(radii.size(), Vec3{1.f, 1.f, 1.f});
    return b;
}

glm::dvec2 cornerOffset(int c) { return {c & 1 ? 0.5 : -0.5, c & 2 ? 0.5 : -0.5}; }

} // namespace

Light bentAreaCorner(const Light& l, int corner) {
    const Frames f = framesOf(l);
    const int K = l.cornerSegments();
    std::vector<glm::dvec3> pts;
    for (int i = 0; i < 2 * K; ++i) {
        const Vec3& q = l.cornerPoints[size_t(corner * 2 * K + i)];
        pts.emplace_back(q[0], q[1], q[2]);
    }
    const std::vector<float> radii(l.cornerRadii.begin() + std::ptrdiff_t(corner * (2 * K + 1)),
                                   l.cornerRadii.begin() + std::ptrdiff_t((corner + 1) * (2 * K + 1)));
    const glm::dvec2 o = cornerOffset(corner);
    Light b = chainLight(l, f, o.x * f.area.width, o.y * f.area.height, pts, radii);
    b.name = l.name + "#corner" + std::to_string(corner);
    return b;
}

std::vector<Light> bentAreaInterior(const Light& l, glm::ivec2 grid) {
    const Frames f = framesOf(l);
    const int K = l.cornerSegments();
    std::vector<Light> out;
    if (K < 1) return out;
    out.reserve(size_t(grid.x * grid.y));
    for (int j = 0; j < grid.y; ++j) {
        for (int i = 0; i < grid.x; ++i) {
            // Paper 003 eqs. 8-10 with cell centres: weights of corners 0..3 (Rig.h's order).
            const double a = (double(i) + 0.5) / double(grid.x), b = (double(j) + 0.5) / double(grid.y);
            const double w[4] = {(1 - a) * (1 - b), a * (1 - b), (1 - a) * b, a * b};
            std::vector<glm::dvec3> pts(size_t(2 * K), glm::dvec3(0.0));
            std::vector<float> radii(size_t(2 * K + 1), 0.f);
            for (int c = 0; c < BENT_AREA_CORNERS; ++c) {
                for (int k = 0; k < 2 * K; ++k) {
                    const Vec3& q = l.cornerPoints[size_t(c * 2 * K + k)];
                    pts[size_t(k)] += w[c] * glm::dvec3(q[0], q[1], q[2]);
                }
                for (int k = 0; k <= 2 * K; ++k) radii[size_t(k)] += float(w[c]) * l.cornerRadii[size_t(c * (2 * K + 1) + k)];
            }
            Light cellLight = chainLight(l, f, (a - 0.5) * f.area.width, (b - 0.5) * f.area.height, pts, radii);
            cellLight.name = l.name + "#" + std::to_string(i) + "," + std::to_string(j);
            out.push_back(std::move(cellLight));
        }
    }
    return out;
}

float bentAreaCellArea(const Light& l, glm::ivec2 grid) {
    return l.areaSize[0] * l.areaSize[1] / float(std::max(grid.x * grid.y, 1));
}

std::string bentAreaWarning(const Light& l, double foldLimit, double apartLimit) {
    if (l.type != LightType::BentArea || l.cornerSegments() < 1) return {};
    for (int c = 0; c < BENT_AREA_CORNERS; ++c) {
        if (std::string w = chainWarning(bentAreaCorner(l, c), foldLimit, apartLimit); !w.empty())
            return "corner " + std::to_string(c) + ": " + w;
    }
    return {};
}

} // namespace dfb
