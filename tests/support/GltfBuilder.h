#pragma once
// Test support: builds small glTF files with tinygltf (quads, materials, textures, cameras) so
// that tests can check the bake against values they know exactly.

#include <tiny_gltf.h>

#include <glm/glm.hpp>

#include <string>
#include <vector>

namespace dfb::test {

class GltfBuilder {
public:
    GltfBuilder() {
        model.asset.version = "2.0";
        model.scenes.emplace_back();
        model.defaultScene = 0;
        model.buffers.emplace_back();
    }

    /// An axis-aligned quad in the plane y = height spanning [x0,x1] x [z0,z1], facing +Y, with
    /// UV (0,0) at (x0, z0) and (1,1) at (x1, z1) in both UV sets.
    /// A mesh of one triangle primitive with `material`, in a node of the scene; the node's index.
    int addMeshNode(const std::string& name, tinygltf::Primitive prim, int material) {
        prim.material = material;
        prim.mode = TINYGLTF_MODE_TRIANGLES;
        tinygltf::Mesh mesh;
        mesh.name = name;
        mesh.primitives.push_back(prim);
        model.meshes.push_back(mesh);
        tinygltf::Node node;
        node.name = name;
        node.mesh = int(model.meshes.size()) - 1;
        model.nodes.push_back(node);
        model.scenes[0].nodes.push_back(int(model.nodes.size()) - 1);
        return int(model.nodes.size()) - 1;
    }

    int addQuad(const std::string& name, float x0, float z0, float x1, float z1, float height, int material) {
        const std::vector<float> pos = {x0, height, z0, x1, height, z0, x1, height, z1, x0, height, z1};
        const std::vector<float> nrm = {0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0};
        const std::vector<float> uv = {0, 0, 1, 0, 1, 1, 0, 1};
        const std::vector<uint16_t> idx = {0, 2, 1, 0, 3, 2}; // counter-clockwise seen from +Y
        tinygltf::Primitive prim;
        prim.attributes["POSITION"] = accessor(pos.data(), pos.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 4,
                                               {x0, height, z0}, {x1, height, z1});
        prim.attributes["NORMAL"] = accessor(nrm.data(), nrm.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 4);
        prim.attributes["TEXCOORD_0"] = accessor(uv.data(), uv.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, 4);
        prim.attributes["TEXCOORD_1"] = accessor(uv.data(), uv.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, 4);
        prim.indices = accessor(idx.data(), idx.size() * 2, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_SCALAR, 6);
        return addMeshNode(name, prim, material);
    }

    /// An axis-aligned box from `lo` to `hi`: six faces with outward flat normals, counter-clockwise
    /// seen from outside (a single-sided material culls the faces seen from inside), UV (0,0) to
    /// (1,1) on each face.
    int addBox(const std::string& name, const glm::vec3& lo, const glm::vec3& hi, int material) {
        const glm::vec3 c = 0.5f * (lo + hi), h = 0.5f * (hi - lo);
        // Per face: its normal n and axes u, v with cross(u, v) = n, so that the corners
        // -u-v, +u-v, +u+v, -u+v go counter-clockwise seen from n's side.
        const glm::vec3 faces[6][3] = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}},  {{-1, 0, 0}, {0, 0, 1}, {0, 1, 0}},
                                       {{0, 1, 0}, {0, 0, 1}, {1, 0, 0}},  {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}},
                                       {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}},  {{0, 0, -1}, {0, 1, 0}, {1, 0, 0}}};
        std::vector<float> pos, nrm, uv;
        std::vector<uint16_t> idx;
        for (const auto& f : faces) {
            const auto base = uint16_t(pos.size() / 3);
            const float corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
            for (const auto& k : corners) {
                const glm::vec3 p = c + h * (f[0] + k[0] * f[1] + k[1] * f[2]);
                pos.insert(pos.end(), {p.x, p.y, p.z});
                nrm.insert(nrm.end(), {f[0].x, f[0].y, f[0].z});
                uv.insert(uv.end(), {0.5f + 0.5f * k[0], 0.5f + 0.5f * k[1]});
            }
            for (uint16_t i : {0, 1, 2, 0, 2, 3}) idx.push_back(uint16_t(base + i));
        }
        tinygltf::Primitive prim;
        prim.attributes["POSITION"] = accessor(pos.data(), pos.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 24,
                                               {lo.x, lo.y, lo.z}, {hi.x, hi.y, hi.z});
        prim.attributes["NORMAL"] = accessor(nrm.data(), nrm.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 24);
        prim.attributes["TEXCOORD_0"] = accessor(uv.data(), uv.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, 24);
        prim.indices = accessor(idx.data(), idx.size() * 2, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_SCALAR, 36);
        return addMeshNode(name, prim, material);
    }

    int addMaterial(const tinygltf::Material& m) {
        model.materials.push_back(m);
        return int(model.materials.size()) - 1;
    }

    /// An RGBA8 texture from raw pixels (row 0 at the top), stored as PNG inside the file.
    int addTexture(int w, int h, const std::vector<uint8_t>& rgba, int wrap = TINYGLTF_TEXTURE_WRAP_REPEAT,
                   int magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR) {
        tinygltf::Image img;
        img.width = w;
        img.height = h;
        img.component = 4;
        img.bits = 8;
        img.pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
        img.image = rgba;
        img.mimeType = "image/png";
        model.images.push_back(img);
        tinygltf::Sampler s;
        s.wrapS = s.wrapT = wrap;
        s.magFilter = magFilter;
        s.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR;
        model.samplers.push_back(s);
        tinygltf::Texture t;
        t.source = int(model.images.size()) - 1;
        t.sampler = int(model.samplers.size()) - 1;
        model.textures.push_back(t);
        return int(model.textures.size()) - 1;
    }

    /// An orthographic camera looking straight down (-Y) from above (cx, height, cz).
    void addTopCamera(const std::string& name, float cx, float cz, float height, float xmag, float ymag) {
        tinygltf::Camera cam;
        cam.type = "orthographic";
        cam.name = name;
        cam.orthographic.xmag = xmag;
        cam.orthographic.ymag = ymag;
        cam.orthographic.znear = 0.01;
        cam.orthographic.zfar = 100;
        model.cameras.push_back(cam);
        tinygltf::Node node;
        node.name = name;
        node.camera = int(model.cameras.size()) - 1;
        node.translation = {cx, height, cz};
        // Rotate -90 degrees about X: the camera's -Z (view) becomes -Y, its +Y (up) becomes -Z.
        node.rotation = {-0.7071067811865476, 0, 0, 0.7071067811865476};
        model.nodes.push_back(node);
        model.scenes[0].nodes.push_back(int(model.nodes.size()) - 1);
    }

    bool write(const std::string& path) {
        model.buffers[0].data = bin;
        tinygltf::TinyGLTF w;
        return w.WriteGltfSceneToFile(&model, path, true, true, false, true);
    }

    tinygltf::Model model;

private:
    int accessor(const void* data, size_t bytes, int componentType, int type, size_t count,
                 std::vector<double> mn = {}, std::vector<double> mx = {}) {
        while (bin.size() % 4) bin.push_back(0);
        tinygltf::BufferView v;
        v.buffer = 0;
        v.byteOffset = bin.size();
        v.byteLength = bytes;
        const auto* p = static_cast<const uint8_t*>(data);
        bin.insert(bin.end(), p, p + bytes);
        model.bufferViews.push_back(v);
        tinygltf::Accessor a;
        a.bufferView = int(model.bufferViews.size()) - 1;
        a.componentType = componentType;
        a.type = type;
        a.count = count;
        a.minValues = mn;
        a.maxValues = mx;
        model.accessors.push_back(a);
        return int(model.accessors.size()) - 1;
    }
    std::vector<uint8_t> bin;
};

} // namespace dfb::test
