// glTF 2.0 (.gltf + buffers, or .glb) through tinygltf. The node hierarchy is flattened: every
// TRIANGLES primitive of every node reached from the scene's root nodes is appended with the node's
// world transform applied (normals by its inverse transpose), in depth-first order, parents before
// children, so a mesh used by two nodes appears twice (the MANIFEST's "after node instancing"
// counts). Accessor reads are bounds-checked here: a bad file gives an Error, never a read
// outside a buffer.
#include "scenes/formats.h"

#include <tiny_gltf.h>

#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

namespace raypack {
namespace {

// Images are not needed to trace triangles; skipping their decoding keeps DamagedHelmet's 4 MB of
// JPEG from costing more than its geometry.
bool skipImage(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
    return true;
}

glm::dmat4 localTransform(const tinygltf::Node& node) {
    if (node.matrix.size() == 16) return glm::make_mat4(node.matrix.data());  // column-major, as glTF
    glm::dmat4 t(1.0), r(1.0), s(1.0);
    if (node.translation.size() == 3)
        t = glm::translate(glm::dmat4(1.0), glm::dvec3(node.translation[0], node.translation[1], node.translation[2]));
    if (node.rotation.size() == 4)  // glTF stores (x, y, z, w); glm's constructor takes (w, x, y, z)
        r = glm::mat4_cast(glm::dquat(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]));
    if (node.scale.size() == 3) s = glm::scale(glm::dmat4(1.0), glm::dvec3(node.scale[0], node.scale[1], node.scale[2]));
    return t * r * s;
}

class GltfConverter {
public:
    GltfConverter(const tinygltf::Model& model, const std::filesystem::path& path) : model_(model), path_(path) {}

    Scene convert() {
        scene_.source = path_.string();
        std::vector<int> roots;
        if (!model_.scenes.empty()) {
            const int which = model_.defaultScene >= 0 ? model_.defaultScene : 0;
            if (size_t(which) >= model_.scenes.size()) fail("default scene " + std::to_string(which) + " does not exist");
            roots = model_.scenes[size_t(which)].nodes;
        } else {
            // No scene: every node that is nobody's child is a root.
            std::vector<bool> isChild(model_.nodes.size(), false);
            for (const tinygltf::Node& node : model_.nodes)
                for (int child : node.children)
                    if (child >= 0 && size_t(child) < isChild.size()) isChild[size_t(child)] = true;
            for (size_t n = 0; n < model_.nodes.size(); ++n)
                if (!isChild[n]) roots.push_back(int(n));
        }
        for (const tinygltf::Material& m : model_.materials) {
            glm::vec3 colour(1.0f);  // glTF's default baseColorFactor
            const std::vector<double>& factor = m.pbrMetallicRoughness.baseColorFactor;
            if (factor.size() >= 3) colour = glm::vec3(float(factor[0]), float(factor[1]), float(factor[2]));
            materials_.push_back(Material{m.name, colour});
        }
        for (int root : roots) visit(root, glm::dmat4(1.0), 0);
        if (scene_.triangles.empty()) fail("no TRIANGLES primitives in the scene");
        // Normals only when every primitive had them: a mesh cannot be half smooth-shaded.
        if (!allHaveNormals_) scene_.normals.clear();
        if (usesMaterials_) {
            scene_.materials = materials_;
            if (usesDefaultMaterial_) scene_.materials.push_back(Material{"default", glm::vec3(1.0f)});
            for (uint32_t& m : scene_.triangleMaterial)
                if (m == kDefaultMaterial) m = uint32_t(materials_.size());
        } else {
            scene_.triangleMaterial.clear();
        }
        return std::move(scene_);
    }

private:
    static constexpr uint32_t kDefaultMaterial = std::numeric_limits<uint32_t>::max();

    [[noreturn]] void fail(const std::string& what) const { throwFileError(path_, what); }

    void visit(int nodeIndex, const glm::dmat4& parent, int depth) {
        if (nodeIndex < 0 || size_t(nodeIndex) >= model_.nodes.size()) fail("node " + std::to_string(nodeIndex) + " does not exist");
        // A node hierarchy is a forest; a cycle would recurse forever, so depth is bounded by the
        // node count.
        if (size_t(depth) > model_.nodes.size()) fail("the node hierarchy has a cycle");
        const tinygltf::Node& node = model_.nodes[size_t(nodeIndex)];
        const glm::dmat4 world = parent * localTransform(node);
        if (node.mesh >= 0) {
            if (size_t(node.mesh) >= model_.meshes.size()) fail("node " + std::to_string(nodeIndex) + " refers to a missing mesh");
            for (const tinygltf::Primitive& primitive : model_.meshes[size_t(node.mesh)].primitives)
                if (primitive.mode == TINYGLTF_MODE_TRIANGLES || primitive.mode == -1) addPrimitive(primitive, world);
        }
        for (int child : node.children) visit(child, world, depth + 1);
    }

    // A bounds-checked view of an accessor's elements.
    struct AccessorView {
        const unsigned char* data = nullptr;
        size_t stride = 0;
        size_t count = 0;
        int componentType = 0;
    };

    AccessorView view(int accessorIndex, int wantType, const char* what) const {
        if (accessorIndex < 0 || size_t(accessorIndex) >= model_.accessors.size())
            fail(std::string(what) + " accessor " + std::to_string(accessorIndex) + " does not exist");
        const tinygltf::Accessor& accessor = model_.accessors[size_t(accessorIndex)];
        const std::string name = std::string(what) + " accessor " + std::to_string(accessorIndex);
        if (accessor.sparse.isSparse) fail(name + " is sparse, which raypack does not support");
        if (accessor.type != wantType) fail(name + " has the wrong element type");
        if (accessor.bufferView < 0 || size_t(accessor.bufferView) >= model_.bufferViews.size())
            fail(name + " has no buffer view");
        const tinygltf::BufferView& bufferView = model_.bufferViews[size_t(accessor.bufferView)];
        if (bufferView.buffer < 0 || size_t(bufferView.buffer) >= model_.buffers.size())
            fail(name + ": its buffer view refers to a missing buffer");
        const std::vector<unsigned char>& buffer = model_.buffers[size_t(bufferView.buffer)].data;
        const int stride = accessor.ByteStride(bufferView);
        const int components = tinygltf::GetNumComponentsInType(uint32_t(accessor.type));
        const int componentSize = tinygltf::GetComponentSizeInBytes(uint32_t(accessor.componentType));
        if (stride <= 0 || components <= 0 || componentSize <= 0) fail(name + " has an invalid type or stride");
        const size_t elementSize = size_t(components) * size_t(componentSize);
        // Everything the accessor reads must lie inside its buffer view, and the view inside the buffer.
        if (bufferView.byteOffset > buffer.size() || bufferView.byteLength > buffer.size() - bufferView.byteOffset)
            fail(name + ": buffer view " + std::to_string(accessor.bufferView) + " lies outside its buffer (truncated file?)");
        if (accessor.count > 0) {
            const uint64_t last = uint64_t(accessor.byteOffset) + uint64_t(stride) * (accessor.count - 1) + elementSize;
            if (accessor.count > bufferView.byteLength || last > bufferView.byteLength)
                fail(name + " reads " + std::to_string(accessor.count) + " elements, more than its buffer view holds");
        }
        AccessorView result;
        result.data = buffer.data() + bufferView.byteOffset + accessor.byteOffset;
        result.stride = size_t(stride);
        result.count = accessor.count;
        result.componentType = accessor.componentType;
        return result;
    }

    glm::vec3 readVec3(const AccessorView& v, size_t i, const char* what) const {
        if (v.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT) fail(std::string(what) + " is not float");
        float xyz[3];
        std::memcpy(xyz, v.data + i * v.stride, sizeof xyz);
        return glm::vec3(xyz[0], xyz[1], xyz[2]);
    }

    uint32_t readIndex(const AccessorView& v, size_t i) const {
        const unsigned char* p = v.data + i * v.stride;
        switch (v.componentType) {
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return *p;
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
                uint16_t value;
                std::memcpy(&value, p, 2);
                return value;
            }
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
                uint32_t value;
                std::memcpy(&value, p, 4);
                return value;
            }
            default: fail("index accessor is not 8, 16 or 32-bit unsigned");
        }
    }

    void addPrimitive(const tinygltf::Primitive& primitive, const glm::dmat4& world) {
        const auto position = primitive.attributes.find("POSITION");
        if (position == primitive.attributes.end()) fail("a TRIANGLES primitive has no POSITION attribute");
        const AccessorView positions = view(position->second, TINYGLTF_TYPE_VEC3, "POSITION");
        const auto normal = primitive.attributes.find("NORMAL");
        AccessorView normals;
        const bool hasNormals = normal != primitive.attributes.end();
        if (hasNormals) {
            normals = view(normal->second, TINYGLTF_TYPE_VEC3, "NORMAL");
            if (normals.count != positions.count) fail("NORMAL and POSITION accessors differ in length");
        } else {
            allHaveNormals_ = false;
        }
        if (scene_.positions.size() + positions.count > std::numeric_limits<uint32_t>::max())
            fail("more vertices than 32-bit indices can address");

        const glm::mat4 toWorld(world);
        const glm::mat3 normalToWorld(glm::inverseTranspose(glm::dmat3(world)));
        const uint32_t base = uint32_t(scene_.positions.size());
        for (size_t i = 0; i < positions.count; ++i) {
            const glm::vec3 p = glm::vec3(toWorld * glm::vec4(readVec3(positions, i, "POSITION"), 1.0f));
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
                fail("vertex " + std::to_string(i) + " of POSITION accessor " + std::to_string(position->second) +
                     " is not finite");
            scene_.positions.push_back(p);
            if (hasNormals) {
                const glm::vec3 n = normalToWorld * readVec3(normals, i, "NORMAL");
                const float length = glm::length(n);
                scene_.normals.push_back(length > 0.0f && std::isfinite(length) ? n / length : glm::vec3(0.0f));
            } else {
                scene_.normals.push_back(glm::vec3(0.0f));  // dropped at the end unless all have normals
            }
        }

        uint32_t material = kDefaultMaterial;
        if (primitive.material >= 0) {
            if (size_t(primitive.material) >= materials_.size()) fail("a primitive refers to a missing material");
            material = uint32_t(primitive.material);
        }
        if (!materials_.empty()) usesMaterials_ = true;
        if (material == kDefaultMaterial) usesDefaultMaterial_ = true;

        auto addTriangle = [&](uint32_t a, uint32_t b, uint32_t c) {
            if (a >= positions.count || b >= positions.count || c >= positions.count)
                fail("a triangle index is outside the primitive's " + std::to_string(positions.count) + " vertices");
            scene_.triangles.emplace_back(base + a, base + b, base + c);
            scene_.triangleMaterial.push_back(material);
        };
        if (primitive.indices >= 0) {
            const AccessorView indices = view(primitive.indices, TINYGLTF_TYPE_SCALAR, "index");
            if (indices.count % 3 != 0) fail("a TRIANGLES primitive's index count is not a multiple of 3");
            for (size_t i = 0; i + 2 < indices.count; i += 3)
                addTriangle(readIndex(indices, i), readIndex(indices, i + 1), readIndex(indices, i + 2));
        } else {
            // Non-indexed: consecutive vertex triples.
            if (positions.count % 3 != 0) fail("a non-indexed TRIANGLES primitive's vertex count is not a multiple of 3");
            for (size_t i = 0; i + 2 < positions.count; i += 3)
                addTriangle(uint32_t(i), uint32_t(i + 1), uint32_t(i + 2));
        }
        if (scene_.triangles.size() > std::numeric_limits<uint32_t>::max())
            fail("more triangles than 32-bit triangle indices can address");
    }

    const tinygltf::Model& model_;
    const std::filesystem::path& path_;
    std::vector<Material> materials_;
    Scene scene_;
    bool allHaveNormals_ = true;
    bool usesMaterials_ = false;
    bool usesDefaultMaterial_ = false;
};

}  // namespace

Scene loadGltf(const std::filesystem::path& path, LoadProgress* progress) {
    const FileBytes file = readWholeFile(path, progress);
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(skipImage, nullptr);
    tinygltf::Model model;
    std::string errors, warnings;
    const std::string baseDir = path.has_parent_path() ? path.parent_path().string() : std::string(".");
    const bool binary = file.size >= 4 && std::memcmp(file.begin(), "glTF", 4) == 0;
    if (file.size > std::numeric_limits<unsigned int>::max()) throwFileError(path, "file larger than 4 GiB");
    const bool ok = binary ? loader.LoadBinaryFromMemory(&model, &errors, &warnings,
                                                         reinterpret_cast<const unsigned char*>(file.begin()),
                                                         unsigned(file.size), baseDir)
                           : loader.LoadASCIIFromString(&model, &errors, &warnings, file.begin(), unsigned(file.size), baseDir);
    if (progress && progress->cancel) throw LoadCancelled(path.string() + ": loading cancelled");
    if (!ok) {
        while (!errors.empty() && errors.back() == '\n') errors.pop_back();
        throwFileError(path, errors.empty() ? "tinygltf could not parse the file" : errors);
    }
    if (!warnings.empty()) {
        while (warnings.back() == '\n') warnings.pop_back();
        std::fprintf(stderr, "raypack: warning: %s: %s\n", path.string().c_str(), warnings.c_str());
    }
    Scene scene = GltfConverter(model, path).convert();
    reportParsed(progress, path, file.size, file.size);
    return scene;
}

}  // namespace raypack
