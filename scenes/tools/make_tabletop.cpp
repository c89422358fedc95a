// Generates scenes/tabletop.glb, the bundled default scene, in the spirit of the "Tabletop" scenes
// of the BendyLights paper (paper 000, section 6.1 and Table 1): a table plane, the Stanford bunny,
// two vases and a bowl (surfaces of revolution), plain PBR materials, and a perspective camera.
//
//   dfb-make-tabletop BUNNY.glb OUT.glb
//
// Units are metres; +Y is up; the table top is the plane y = 0.

#include <dfb/gbuffer/Scene.h>

#include <tiny_gltf.h>

#include <glm/gtc/constants.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <cstdio>
#include <cstring>
#include <functional>

namespace {

struct Mesh {
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals;
    std::vector<uint32_t> indices;
};

// Revolves a profile (radius, height) around +Y. The profile's normals follow from its tangent;
// `segments` around. Triangles face outwards (counter-clockwise seen from outside).
Mesh revolve(const std::vector<glm::vec2>& profile, int segments) {
    Mesh m;
    const int rows = int(profile.size());
    for (int i = 0; i < rows; ++i) {
        const glm::vec2 prev = profile[size_t(std::max(i - 1, 0))];
        const glm::vec2 next = profile[size_t(std::min(i + 1, rows - 1))];
        const glm::vec2 t = glm::normalize(next - prev);       // along the profile (dr, dy)
        const glm::vec2 n2(t.y, -t.x);                         // outward in (r, y)
        for (int s = 0; s <= segments; ++s) {
            const float a = glm::two_pi<float>() * float(s) / float(segments);
            const glm::vec3 dir(std::cos(a), 0.f, -std::sin(a));
            m.positions.push_back(dir * profile[size_t(i)].x + glm::vec3(0, profile[size_t(i)].y, 0));
            glm::vec3 n = dir * n2.x + glm::vec3(0, n2.y, 0);
            m.normals.push_back(glm::normalize(n));
        }
    }
    const uint32_t stride = uint32_t(segments + 1);
    for (uint32_t i = 0; i + 1 < uint32_t(rows); ++i) {
        for (uint32_t s = 0; s < uint32_t(segments); ++s) {
            const uint32_t a = i * stride + s, b = a + 1, c = a + stride, d = c + 1;
            m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
        }
    }
    return m;
}

// Samples f(t), t in [0,1], into a profile of `rows` points.
std::vector<glm::vec2> sampleProfile(int rows, const std::function<glm::vec2(float)>& f) {
    std::vector<glm::vec2> p;
    for (int i = 0; i < rows; ++i) p.push_back(f(float(i) / float(rows - 1)));
    return p;
}

struct Builder {
    tinygltf::Model model;
    std::vector<unsigned char> bin;

    int addView(const void* data, size_t bytes, int target) {
        while (bin.size() % 4) bin.push_back(0);
        tinygltf::BufferView v;
        v.buffer = 0;
        v.byteOffset = bin.size();
        v.byteLength = bytes;
        v.target = target;
        const auto* p = static_cast<const unsigned char*>(data);
        bin.insert(bin.end(), p, p + bytes);
        model.bufferViews.push_back(v);
        return int(model.bufferViews.size() - 1);
    }

    int addVec3(const std::vector<glm::vec3>& v, bool minmax) {
        tinygltf::Accessor a;
        a.bufferView = addView(v.data(), v.size() * sizeof(glm::vec3), TINYGLTF_TARGET_ARRAY_BUFFER);
        a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
        a.type = TINYGLTF_TYPE_VEC3;
        a.count = v.size();
        if (minmax) {
            glm::vec3 lo(1e30f), hi(-1e30f);
            for (const auto& p : v) {
                lo = glm::min(lo, p);
                hi = glm::max(hi, p);
            }
            a.minValues = {lo.x, lo.y, lo.z};
            a.maxValues = {hi.x, hi.y, hi.z};
        }
        model.accessors.push_back(a);
        return int(model.accessors.size() - 1);
    }

    int addIndices(const std::vector<uint32_t>& idx, size_t vertexCount) {
        tinygltf::Accessor a;
        if (vertexCount < 65536) {
            std::vector<uint16_t> s(idx.begin(), idx.end());
            a.bufferView = addView(s.data(), s.size() * 2, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
            a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
        } else {
            a.bufferView = addView(idx.data(), idx.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
            a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
        }
        a.type = TINYGLTF_TYPE_SCALAR;
        a.count = idx.size();
        model.accessors.push_back(a);
        return int(model.accessors.size() - 1);
    }

    int addMaterial(const std::string& name, glm::vec3 color, float metallic, float roughness, bool doubleSided) {
        tinygltf::Material m;
        m.name = name;
        m.pbrMetallicRoughness.baseColorFactor = {color.r, color.g, color.b, 1.0};
        m.pbrMetallicRoughness.metallicFactor = metallic;
        m.pbrMetallicRoughness.roughnessFactor = roughness;
        m.doubleSided = doubleSided;
        model.materials.push_back(m);
        return int(model.materials.size() - 1);
    }

    void addObject(const std::string& name, const Mesh& mesh, int material, glm::vec3 translation) {
        tinygltf::Primitive prim;
        prim.attributes["POSITION"] = addVec3(mesh.positions, true);
        prim.attributes["NORMAL"] = addVec3(mesh.normals, false);
        prim.indices = addIndices(mesh.indices, mesh.positions.size());
        prim.material = material;
        prim.mode = TINYGLTF_MODE_TRIANGLES;
        tinygltf::Mesh gm;
        gm.name = name;
        gm.primitives.push_back(prim);
        model.meshes.push_back(gm);
        tinygltf::Node node;
        node.name = name;
        node.mesh = int(model.meshes.size() - 1);
        node.translation = {translation.x, translation.y, translation.z};
        model.nodes.push_back(node);
        model.scenes[0].nodes.push_back(int(model.nodes.size() - 1));
    }
};

} // namespace

int main(int argc, char** argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: dfb-make-tabletop BUNNY.glb OUT.glb\n");
        return 1;
    }
    auto bunnyScene = dfb::loadScene(argv[1]);
    if (!bunnyScene) {
        std::fprintf(stderr, "dfb-make-tabletop: %s\n", bunnyScene.error().toString().c_str());
        return 2;
    }

    Builder b;
    b.model.asset.version = "2.0";
    b.model.asset.generator = "dfb-make-tabletop";
    b.model.scenes.emplace_back();
    b.model.scenes[0].name = "Tabletop";
    b.model.defaultScene = 0;

    const int wood = b.addMaterial("table_wood", {0.42f, 0.27f, 0.16f}, 0.f, 0.55f, false);
    const int clay = b.addMaterial("bunny_clay", {0.82f, 0.78f, 0.72f}, 0.f, 0.5f, false);
    const int blue = b.addMaterial("vase_blue_glaze", {0.08f, 0.22f, 0.65f}, 0.f, 0.25f, true);
    const int orange = b.addMaterial("vase_orange_glaze", {0.85f, 0.38f, 0.08f}, 0.f, 0.3f, true);
    const int copper = b.addMaterial("bowl_copper", {0.95f, 0.64f, 0.54f}, 1.f, 0.3f, true);

    // Table: a 7 m x 5 m plane subdivided so that bent shadows on it stay smooth (paper 000, sec. 4:
    // deformed geometry needs tessellation), facing +Y.
    {
        Mesh m;
        const int n = 48;
        const float sx = 7.f, sz = 5.f;
        for (int j = 0; j <= n; ++j)
            for (int i = 0; i <= n; ++i) {
                m.positions.push_back({(float(i) / n - 0.5f) * sx, 0.f, (float(j) / n - 0.5f) * sz});
                m.normals.push_back({0, 1, 0});
            }
        for (uint32_t j = 0; j < uint32_t(n); ++j)
            for (uint32_t i = 0; i < uint32_t(n); ++i) {
                const uint32_t a = j * (n + 1) + i, bb = a + 1, c = a + (n + 1), d = c + 1;
                m.indices.insert(m.indices.end(), {a, c, d, a, d, bb});
            }
        b.addObject("table", m, wood, {0, 0, 0});
    }
    // Bunny: rescaled to 1 m tall, standing on the table.
    {
        Mesh m;
        const dfb::Bounds& bb = bunnyScene->bounds;
        const float scale = 1.f / (bb.max.y - bb.min.y);
        for (const dfb::MeshPart& p : bunnyScene->parts) {
            const uint32_t base = uint32_t(m.positions.size());
            for (size_t i = 0; i < p.positions.size(); ++i) {
                glm::vec3 q = p.positions[i] - glm::vec3(bb.center().x, bb.min.y, bb.center().z);
                m.positions.push_back(q * scale);
                m.normals.push_back(p.normals[i]);
            }
            for (uint32_t i : p.indices) m.indices.push_back(base + i);
        }
        b.addObject("bunny", m, clay, {-0.1f, 0.f, 0.2f});
    }
    // Vases: bellied profiles with a neck and a flared lip, closed at the bottom.
    auto vase = [](float height, float belly, float neck, float lip) {
        return sampleProfile(96, [=](float t) {
            if (t < 0.04f) return glm::vec2(belly * 0.6f * (t / 0.04f), 0.f); // bottom disc
            const float s = (t - 0.04f) / 0.96f;
            const float body = belly * (0.6f + 0.4f * std::sin(glm::pi<float>() * std::min(s / 0.7f, 1.f)));
            const float narrowing = glm::smoothstep(0.45f, 0.8f, s);
            float r = glm::mix(body, neck, narrowing);
            r += (lip - neck) * glm::smoothstep(0.88f, 1.f, s);
            return glm::vec2(r, s * height);
        });
    };
    b.addObject("vase_tall", revolve(vase(1.5f, 0.32f, 0.12f, 0.18f), 64), blue, {-1.5f, 0.f, -0.7f});
    b.addObject("vase_short", revolve(vase(1.0f, 0.28f, 0.14f, 0.2f), 64), orange, {1.6f, 0.f, -1.0f});
    // Bowl: a thin spherical shell, open at the top, on a small foot.
    b.addObject("bowl", revolve(sampleProfile(48, [](float t) {
                                    if (t < 0.06f) return glm::vec2(0.16f * t / 0.06f, 0.f);
                                    const float s = (t - 0.06f) / 0.94f;
                                    const float a = glm::mix(0.35f, 1.45f, s);
                                    return glm::vec2(0.5f * std::sin(a), 0.5f - 0.5f * std::cos(a) - 0.03f + 0.03f);
                                }),
                                64),
                copper, {1.0f, 0.f, 1.0f});

    // Camera: a three-quarter view from the front, a little above the table.
    {
        tinygltf::Camera cam;
        cam.type = "perspective";
        cam.name = "shot_cam";
        cam.perspective.yfov = glm::radians(38.0);
        cam.perspective.aspectRatio = 16.0 / 9.0;
        cam.perspective.znear = 0.05;
        cam.perspective.zfar = 50.0;
        b.model.cameras.push_back(cam);
        const glm::vec3 eye(0.4f, 2.1f, 5.4f), target(0.f, 0.45f, 0.f);
        const glm::mat4 view = glm::lookAt(eye, target, glm::vec3(0, 1, 0));
        const glm::quat q = glm::quat_cast(glm::inverse(glm::mat3(view)));
        tinygltf::Node node;
        node.name = "shot_cam";
        node.camera = 0;
        node.translation = {eye.x, eye.y, eye.z};
        node.rotation = {q.x, q.y, q.z, q.w};
        b.model.nodes.push_back(node);
        b.model.scenes[0].nodes.push_back(int(b.model.nodes.size() - 1));
    }

    tinygltf::Buffer buf;
    buf.data = b.bin;
    b.model.buffers.push_back(buf);
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToFile(&b.model, argv[2], true, true, false, true)) {
        std::fprintf(stderr, "dfb-make-tabletop: could not write %s\n", argv[2]);
        return 4;
    }
    std::printf("wrote %s\n", argv[2]);
    return 0;
}
