// glTF 2.0 (.gltf + buffers, or .glb) through tinygltf. The node hierarchy is flattened: every
// TRIANGLES primitive of every node reached from the scene's root nodes is appended with the node's
// world transform applied (normals by its inverse transpose), in depth-first order, parents before
// children, so a mesh used by two nodes appears twice (the MANIFEST's "after node instancing"
// counts). Accessor reads are bounds-checked here: a bad file gives an Error, never a read
// outside a buffer.
//
// Textures: a material's baseColorTexture (times baseColorFactor) with its sampler's wrap modes
// and KHR_texture_transform, which is folded into the primitive's UVs here (an affine map of the
// UVs commutes with their barycentric interpolation). Only images a used material samples are
// decoded, and UVs are kept only when some triangle's material has a texture. The first camera
// met in the node walk becomes Scene::fileCamera.
#include "scenes/formats.h"
#include "scenes/textures.h"

#include <tiny_gltf.h>

#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <sstream>
#include <tuple>

namespace raypack {
namespace {

// Images are decoded later, only those a material's base colour samples (DamagedHelmet's four
// other 2048x2048 JPEGs cost nothing): an embedded image (buffer view or data URI) keeps its
// encoded bytes in Image::image with width 0; an external one keeps only its URI, for
// loadTextureImage, which opens every texture file (the bytes tinygltf read here are dropped).
bool keepEncodedImage(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                      const unsigned char* bytes, int size, void*) {
    if (image->uri.empty() && bytes && size > 0) image->image.assign(bytes, bytes + size);
    image->width = image->height = 0;
    return true;
}

TextureWrap wrapOf(int gltfWrap) {
    switch (gltfWrap) {
        case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE: return TextureWrap::Clamp;
        case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT: return TextureWrap::Mirror;
        default: return TextureWrap::Repeat;
    }
}

double numberOr(const tinygltf::Value& object, const char* key, int element, double fallback) {
    if (!object.IsObject() || !object.Has(key)) return fallback;
    const tinygltf::Value& value = object.Get(key);
    if (element >= 0) {
        if (!value.IsArray() || int(value.ArrayLen()) <= element) return fallback;
        const tinygltf::Value& entry = value.Get(element);
        return entry.IsNumber() ? entry.GetNumberAsDouble() : fallback;
    }
    return value.IsNumber() ? value.GetNumberAsDouble() : fallback;
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
        texturing_.resize(model_.materials.size());
        for (int root : roots) visit(root, glm::dmat4(1.0), 0);
        if (scene_.triangles.empty()) fail("no TRIANGLES primitives in the scene");
        // Normals only when every primitive had them: a mesh cannot be half smooth-shaded.
        if (!allHaveNormals_) scene_.normals.clear();
        // UVs only when a triangle samples a texture.
        if (scene_.textures.empty()) scene_.uvs.clear();
        for (size_t m = 0; m < texturing_.size(); ++m)
            if (texturing_[m].resolved) materials_[m].texture = texturing_[m].texture;
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

    // A material's base colour texture, resolved when a primitive first uses the material.
    struct MaterialTexturing {
        bool resolved = false;
        uint32_t texture = kNoTexture;  // into scene_.textures
        int texCoord = 0;               // TEXCOORD_n
        glm::mat3 uvTransform{1.0f};    // KHR_texture_transform, as a 2D affine map
    };

    const MaterialTexturing& texturingOf(uint32_t material) {
        MaterialTexturing& t = texturing_[material];
        if (t.resolved) return t;
        t.resolved = true;
        const tinygltf::TextureInfo& info = model_.materials[material].pbrMetallicRoughness.baseColorTexture;
        if (info.index < 0) return t;
        if (size_t(info.index) >= model_.textures.size())
            fail("material " + std::to_string(material) + " refers to missing texture " + std::to_string(info.index));
        const tinygltf::Texture& texture = model_.textures[size_t(info.index)];
        if (texture.source < 0) return t;  // no image (an extension's source only): untextured
        if (size_t(texture.source) >= model_.images.size())
            fail("texture " + std::to_string(info.index) + " refers to missing image " + std::to_string(texture.source));
        TextureWrap wrapU = TextureWrap::Repeat, wrapV = TextureWrap::Repeat;
        if (texture.sampler >= 0) {
            if (size_t(texture.sampler) >= model_.samplers.size())
                fail("texture " + std::to_string(info.index) + " refers to missing sampler " + std::to_string(texture.sampler));
            wrapU = wrapOf(model_.samplers[size_t(texture.sampler)].wrapS);
            wrapV = wrapOf(model_.samplers[size_t(texture.sampler)].wrapT);
        }
        t.texCoord = info.texCoord;
        const auto transform = info.extensions.find("KHR_texture_transform");
        if (transform != info.extensions.end()) {
            // KHR_texture_transform: uv' = T * R * S * uv, R rotating by -rotation (the spec's matrix).
            const tinygltf::Value& x = transform->second;
            const float ox = float(numberOr(x, "offset", 0, 0.0)), oy = float(numberOr(x, "offset", 1, 0.0));
            const float rotation = float(numberOr(x, "rotation", -1, 0.0));
            const float sx = float(numberOr(x, "scale", 0, 1.0)), sy = float(numberOr(x, "scale", 1, 1.0));
            const float c = std::cos(rotation), s = std::sin(rotation);
            // Column-major: columns are the images of u, v and the translation.
            t.uvTransform = glm::mat3(glm::vec3(c * sx, -s * sx, 0.0f), glm::vec3(s * sy, c * sy, 0.0f),
                                      glm::vec3(ox, oy, 1.0f));
            if (x.IsObject() && x.Has("texCoord") && x.Get("texCoord").IsNumber())
                t.texCoord = int(x.Get("texCoord").GetNumberAsDouble());
        }
        const auto key = std::make_tuple(texture.source, int(wrapU), int(wrapV));
        const auto known = textureOfImage_.find(key);
        if (known != textureOfImage_.end()) {
            t.texture = known->second;
            return t;
        }
        const tinygltf::Image& image = model_.images[size_t(texture.source)];
        const std::string name = !image.uri.empty() ? image.uri
                                 : !image.name.empty() ? "image " + std::to_string(texture.source) + " (" + image.name + ")"
                                                       : "image " + std::to_string(texture.source);
        std::optional<Texture> decoded;
        if (!image.uri.empty()) {
            decoded = tryLoadTextureImage(path_, image.uri);
        } else if (image.bufferView >= 0) {
            decoded = tryDecodeTextureImage(bufferViewBytes(image.bufferView, name), bufferViewSize(image.bufferView), name, path_);
        } else {
            decoded = tryDecodeTextureImage(image.image.data(), image.image.size(), name, path_);
        }
        uint32_t index = kNoTexture;
        if (decoded) {
            decoded->wrapU = wrapU;
            decoded->wrapV = wrapV;
            index = uint32_t(scene_.textures.size());
            scene_.textures.push_back(std::move(*decoded));
        }
        textureOfImage_.emplace(key, index);
        t.texture = index;
        return t;
    }

    // The bytes of an image's buffer view, checked to lie inside its buffer.
    const unsigned char* bufferViewBytes(int index, const std::string& what) const {
        if (index < 0 || size_t(index) >= model_.bufferViews.size()) fail(what + ": buffer view " + std::to_string(index) + " does not exist");
        const tinygltf::BufferView& view = model_.bufferViews[size_t(index)];
        if (view.buffer < 0 || size_t(view.buffer) >= model_.buffers.size()) fail(what + ": its buffer view refers to a missing buffer");
        const std::vector<unsigned char>& buffer = model_.buffers[size_t(view.buffer)].data;
        if (view.byteOffset > buffer.size() || view.byteLength > buffer.size() - view.byteOffset)
            fail(what + ": buffer view " + std::to_string(index) + " lies outside its buffer (truncated file?)");
        return buffer.data() + view.byteOffset;
    }
    size_t bufferViewSize(int index) const { return model_.bufferViews[size_t(index)].byteLength; }

    void visit(int nodeIndex, const glm::dmat4& parent, int depth) {
        if (nodeIndex < 0 || size_t(nodeIndex) >= model_.nodes.size()) fail("node " + std::to_string(nodeIndex) + " does not exist");
        // A node hierarchy is a forest; a cycle would recurse forever, so depth is bounded by the
        // node count.
        if (size_t(depth) > model_.nodes.size()) fail("the node hierarchy has a cycle");
        const tinygltf::Node& node = model_.nodes[size_t(nodeIndex)];
        const glm::dmat4 world = parent * localTransform(node);
        if (node.camera >= 0 && !scene_.fileCamera) addCamera(node.camera, world);
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

    // A glTF camera looks down its node's -z with +y up (glTF 2.0, 3.10.1). Orthographic cameras
    // and perspective ones without a field of view are skipped.
    void addCamera(int cameraIndex, const glm::dmat4& world) {
        if (size_t(cameraIndex) >= model_.cameras.size()) fail("a node refers to missing camera " + std::to_string(cameraIndex));
        const tinygltf::Camera& camera = model_.cameras[size_t(cameraIndex)];
        if (camera.type != "perspective") return;
        const double yfov = camera.perspective.yfov;
        if (!(yfov > 0.0 && yfov < 3.14159)) return;
        const glm::dvec3 eye(world * glm::dvec4(0.0, 0.0, 0.0, 1.0));
        const glm::dvec3 forward(world * glm::dvec4(0.0, 0.0, -1.0, 0.0));
        const glm::dvec3 up(world * glm::dvec4(0.0, 1.0, 0.0, 0.0));
        if (glm::length(forward) == 0.0 || glm::length(glm::cross(forward, up)) == 0.0) return;
        Camera c;
        c.eye = glm::vec3(eye);
        c.at = glm::vec3(eye + glm::normalize(forward));
        c.up = glm::vec3(glm::normalize(up));
        c.fovYDegrees = float(glm::degrees(yfov));
        if (!std::isfinite(c.eye.x + c.eye.y + c.eye.z + c.at.x + c.at.y + c.at.z + c.up.x + c.up.y + c.up.z)) return;
        scene_.fileCamera = c;
    }

    // UV accessors are float, or unsigned byte/short normalized (glTF 2.0, 3.7.2.1).
    glm::vec2 readUv(const AccessorView& v, size_t i) const {
        const unsigned char* p = v.data + i * v.stride;
        glm::vec2 uv(0.0f);
        switch (v.componentType) {
            case TINYGLTF_COMPONENT_TYPE_FLOAT: std::memcpy(&uv, p, sizeof uv); break;
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: uv = glm::vec2(p[0], p[1]) / 255.0f; break;
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
                uint16_t value[2];
                std::memcpy(value, p, sizeof value);
                uv = glm::vec2(value[0], value[1]) / 65535.0f;
                break;
            }
            default: fail("TEXCOORD accessor is not float, or normalized unsigned byte or short");
        }
        return std::isfinite(uv.x) && std::isfinite(uv.y) ? uv : glm::vec2(0.0f);
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
        // UVs of every vertex (zero where the material has no texture), kept at the end only when
        // some material has one.
        scene_.uvs.resize(base, glm::vec2(0.0f));
        if (material != kDefaultMaterial) {
            const MaterialTexturing& texturing = texturingOf(material);
            const auto texcoord = primitive.attributes.find("TEXCOORD_" + std::to_string(texturing.texCoord));
            if (texturing.texture != kNoTexture && texcoord != primitive.attributes.end()) {
                const AccessorView uvs = view(texcoord->second, TINYGLTF_TYPE_VEC2, "TEXCOORD");
                if (uvs.count != positions.count) fail("TEXCOORD and POSITION accessors differ in length");
                for (size_t i = 0; i < uvs.count; ++i)
                    scene_.uvs.push_back(glm::vec2(texturing.uvTransform * glm::vec3(readUv(uvs, i), 1.0f)));
            }
        }
        scene_.uvs.resize(scene_.positions.size(), glm::vec2(0.0f));
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
    std::vector<MaterialTexturing> texturing_;                          // per material
    std::map<std::tuple<int, int, int>, uint32_t> textureOfImage_;    // (image, wrap u, wrap v)
    Scene scene_;
    bool allHaveNormals_ = true;
    bool usesMaterials_ = false;
    bool usesDefaultMaterial_ = false;
};

}  // namespace

Scene loadGltf(const std::filesystem::path& path, LoadProgress* progress) {
    const FileBytes file = readWholeFile(path, progress);
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(keepEncodedImage, nullptr);
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
    // tinygltf's warnings about external images it could not read are left out: the image is
    // loaded (or reported missing) by loadTextureImage, and only when a material uses it.
    std::istringstream lines(warnings);
    for (std::string line; std::getline(lines, line);) {
        if (line.empty() || line.find("for image[") != std::string::npos) continue;
        bool aboutAnImage = false;
        for (const tinygltf::Image& image : model.images)
            if (!image.uri.empty() && line.rfind("File not found", 0) == 0 && line.find(image.uri) != std::string::npos)
                aboutAnImage = true;
        if (!aboutAnImage) std::fprintf(stderr, "raypack: warning: %s: %s\n", path.string().c_str(), line.c_str());
    }
    Scene scene = GltfConverter(model, path).convert();
    scene.sourceBytes = file.size;
    for (const tinygltf::Buffer& buffer : model.buffers)
        if (!buffer.uri.empty() && buffer.uri.rfind("data:", 0) != 0) scene.sourceBytes += buffer.data.size();
    for (const Texture& texture : scene.textures) scene.sourceBytes += texture.fileBytes;
    reportParsed(progress, path, file.size, file.size);
    return scene;
}

}  // namespace raypack
