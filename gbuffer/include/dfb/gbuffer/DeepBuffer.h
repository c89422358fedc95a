#pragma once
// The deep framebuffer in memory: one shot from one fixed camera, with every material input the
// relight loop needs evaluated per pixel at bake time (paper 004 section 4.1). The file format is
// specified in docs/gbuffer-format.md; ExrIO.h reads and writes it.

#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace dfb {

/// Version of the file format written by this build (header attribute `dfb.formatVersion`).
/// Readers accept files with the same major version; see docs/gbuffer-format.md.
constexpr int GBUFFER_FORMAT_VERSION = 1;

/// The camera the shot was baked from.
/// Conventions (glTF / OpenGL): camera space is right-handed with the camera looking down -Z and
/// +Y up; NDC is the OpenGL cube [-1,1]^3 after the perspective divide, +X right, +Y up.
/// Pixel (x, y), with y = 0 the top row, has its centre at
///   ndc.x = (x + 0.5) / width * 2 - 1,   ndc.y = 1 - (y + 0.5) / height * 2.
struct CameraInfo {
    std::string name;             ///< glTF camera or node name, or "auto" when framed automatically
    glm::mat4 worldToCamera{1.f}; ///< view matrix (column-vector convention: c = M * w)
    glm::mat4 worldToNDC{1.f};    ///< projection * view; divide by w to get NDC
    float yfovRadians = 0.8f;     ///< vertical field of view, radians, in (0, pi)
    float aspect = 1.f;           ///< width / height
    float znear = 0.1f;           ///< near plane distance, scene units, > 0
    float zfar = 1000.f;          ///< far plane distance, scene units, > znear

    /// World-space position of the camera (inverse of worldToCamera applied to the origin).
    glm::vec3 position() const { return glm::vec3(glm::inverse(worldToCamera)[3]); }
};

/// Per-pixel surface data, one sample per pixel (format v1 stores flat images).
/// Memory layout: every layer is a planar array of `components` floats per pixel, row-major,
/// row 0 at the top: element (x, y, c) is at index `(y * width + x) * components + c`.
/// Pixels with no surface have A = 0 and every other layer 0.
struct DeepBuffer {
    int width = 0;
    int height = 0;

    std::vector<float> P;        ///< 3: world-space position, scene units
    std::vector<float> N;        ///< 3: shading normal, world space, unit length
    std::vector<float> Ng;       ///< 3: geometric normal, world space, unit length (shadow bias)
    std::vector<float> Z;        ///< 1: camera depth (distance along the view axis), scene units
    std::vector<float> albedo;   ///< 3: linear base colour, [0,1]
    std::vector<float> brdf;     ///< 4: metallic, roughness, specular, occlusion, each in [0,1]
    std::vector<float> emission; ///< 3: emitted radiance, linear, >= 0
    std::vector<float> A;        ///< 1: coverage in [0,1]
    std::vector<uint32_t> objectId;   ///< 1: object id (1-based index into objectNames; 0 = none)
    std::vector<uint32_t> materialId; ///< 1: material id (1-based index into materialNames; 0 = none)

    CameraInfo camera;
    std::string sourcePath;               ///< the glTF scene the shot was baked from
    std::vector<std::string> objectNames;   ///< objectNames[id - 1] is the glTF node name
    std::vector<std::string> materialNames; ///< materialNames[id - 1] is the glTF material name

    size_t pixelCount() const { return static_cast<size_t>(width) * static_cast<size_t>(height); }
    /// Allocates every layer for width x height pixels, zero-filled.
    void allocate(int w, int h);

    glm::vec3 position(int x, int y) const;
    glm::vec3 normal(int x, int y) const;
    float coverage(int x, int y) const { return A[static_cast<size_t>(y) * width + x]; }
};

} // namespace dfb
