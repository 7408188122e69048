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
#include "scenes/limits.h"
#include "scenes/textures.h"

#include <tiny_gltf.h>

#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <sstream>
#include <tuple>
#include <vector>

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

// Every file a glTF names (buffers, images) goes through resolveReferencedFile: tinygltf joins its
// base folder with the percent-decoded URI and asks whether the file exists, then reads it. The
// base folder is the scene's, so what follows it is the URI; tinygltf's fallback of the current
// folder ("./URI") is never taken, because the first lookup either finds the file or throws.
struct ReferencedFiles {
    const std::filesystem::path* sceneFile;
    std::string baseDir;
    std::vector<std::string> missing;  // names inside the folder that do not exist
};

bool referencedFileExists(const std::string& joined, void* user) {
    ReferencedFiles& files = *static_cast<ReferencedFiles*>(user);
    const std::string prefix = files.baseDir.back() == '/' ? files.baseDir : files.baseDir + "/";
    if (joined.compare(0, prefix.size(), prefix) != 0) return false;  // tinygltf's "./" fallback
    // A file that would lie inside the folder but does not exist is "not found" to tinygltf: a
    // missing image is a warning (the material draws untextured), a missing buffer fails the load,
    // which loadGltf then reports with resolveReferencedFile's message. Any escape throws here.
    const std::string name = joined.substr(prefix.size());
    if (findReferencedFile(*files.sceneFile, name, "referenced file", maxReferencedFileBytes())) return true;
    files.missing.push_back(name);
    return false;
}

std::string expandNothing(const std::string& path, void*) { return path; }  // no "~" or $VARIABLE expansion

bool readReferencedGltfFile(std::vector<unsigned char>* out, std::string*, const std::string& joined, void* user) {
    const ReferencedFiles& files = *static_cast<const ReferencedFiles*>(user);
    const std::string prefix = files.baseDir.back() == '/' ? files.baseDir : files.baseDir + "/";
    if (joined.compare(0, prefix.size(), prefix) != 0) return false;
    const std::string name = joined.substr(prefix.size());
    const std::filesystem::path resolved =
        resolveReferencedFile(*files.sceneFile, name, "referenced file", maxReferencedFileBytes());
    const std::string bytes =
        readReferencedFile(*files.sceneFile, resolved, "referenced file", maxReferencedFileBytes());
    out->assign(bytes.begin(), bytes.end());
    return true;
}

bool writeNothing(std::string*, const std::string&, const std::vector<unsigned char>&, void*) { return false; }

// Required extensions raypack can ignore without changing the geometry it traces. Anything else
// required (Draco or meshopt compression, quantized attributes) would load as wrong triangles.
bool ignorableRequiredExtension(const std::string& name) {
    return name.rfind("KHR_materials_", 0) == 0 || name == "KHR_texture_transform" || name == "KHR_lights_punctual" ||
           name == "KHR_texture_basisu";
}

// A URI's %XX escapes decoded (glTF URIs are URI references; "%2F" must not slip past the
// containment check as a name without a slash).
std::string percentDecoded(const std::string& uri) {
    std::string out;
    const auto hex = [](char c) { return std::isxdigit(static_cast<unsigned char>(c)) != 0; };
    for (size_t i = 0; i < uri.size(); ++i) {
        if (uri[i] == '%' && i + 2 < uri.size() && hex(uri[i + 1]) && hex(uri[i + 2])) {
            out.push_back(char(std::stoi(uri.substr(i + 1, 2), nullptr, 16)));
            i += 2;
        } else {
            out.push_back(uri[i]);
        }
    }
    return out;
}

glm::dmat4 localTransform(const tinygltf::Node& node) {
    if (node.matrix.size() == 16) return glm::make_mat4(node.matrix.data());  // column-major, as glTF
    glm::dmat4 t(1.0), r(1.0), s(1.0);
    if (node.translation.size() == 3)
        t = glm::translate(glm::dmat4(1.0), glm::dvec3(node.translation[0], node.translation[1], node.translation[2]));
    if (node.rotation.size() == 4)  // glTF stores (x, y, z, w); glm's constructor takes (w, x, y, z)
        r = glm::mat4_cast(glm::dquat(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]));
    if (node.scale.size() == 3)
        s = glm::scale(glm::dmat4(1.0), glm::dvec3(node.scale[0], node.scale[1], node.scale[2]));
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
            if (size_t(which) >= model_.scenes.size())
                fail("default scene " + std::to_string(which) + " does not exist");
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
        checkHierarchy(roots);
        visitAll(roots);
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
            fail("texture " + std::to_string(info.index) + " refers to missing image " +
                 std::to_string(texture.source));
        TextureWrap wrapU = TextureWrap::Repeat, wrapV = TextureWrap::Repeat;
        if (texture.sampler >= 0) {
            if (size_t(texture.sampler) >= model_.samplers.size())
                fail("texture " + std::to_string(info.index) + " refers to missing sampler " +
                     std::to_string(texture.sampler));
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
            t.uvTransform =
                glm::mat3(glm::vec3(c * sx, -s * sx, 0.0f), glm::vec3(s * sy, c * sy, 0.0f), glm::vec3(ox, oy, 1.0f));
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
                                 : !image.name.empty()
                                     ? "image " + std::to_string(texture.source) + " (" + image.name + ")"
                                     : "image " + std::to_string(texture.source);
        std::optional<Texture> decoded;
        if (!image.uri.empty()) {
            decoded = tryLoadTextureImage(path_, percentDecoded(image.uri));
        } else if (image.bufferView >= 0) {
            decoded = tryDecodeTextureImage(bufferViewBytes(image.bufferView, name), bufferViewSize(image.bufferView),
                                            name, path_);
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
        if (index < 0 || size_t(index) >= model_.bufferViews.size())
            fail(what + ": buffer view " + std::to_string(index) + " does not exist");
        const tinygltf::BufferView& view = model_.bufferViews[size_t(index)];
        if (view.buffer < 0 || size_t(view.buffer) >= model_.buffers.size())
            fail(what + ": its buffer view refers to a missing buffer");
        const std::vector<unsigned char>& buffer = model_.buffers[size_t(view.buffer)].data;
        if (view.byteOffset > buffer.size() || view.byteLength > buffer.size() - view.byteOffset)
            fail(what + ": buffer view " + std::to_string(index) + " lies outside its buffer (truncated file?)");
        return buffer.data() + view.byteOffset;
    }
    size_t bufferViewSize(int index) const { return model_.bufferViews[size_t(index)].byteLength; }

    // The node hierarchy, walked iteratively (a chain of 20,000 nested nodes must not overflow the
    // stack) in the documented order: depth first, parents before children, children in the order
    // a node lists them. checkHierarchy has already refused cycles and bounded the instances.
    void visitAll(const std::vector<int>& roots) {
        struct Pending {
            int node;
            glm::dmat4 parent;
        };
        std::vector<Pending> stack;
        for (auto root = roots.rbegin(); root != roots.rend(); ++root) stack.push_back({*root, glm::dmat4(1.0)});
        while (!stack.empty()) {
            const Pending pending = stack.back();
            stack.pop_back();
            const int nodeIndex = pending.node;
            const tinygltf::Node& node = model_.nodes[size_t(nodeIndex)];
            const glm::dmat4 world = pending.parent * localTransform(node);
            if (node.camera >= 0 && !scene_.fileCamera) addCamera(node.camera, world);
            if (node.mesh >= 0)
                for (const tinygltf::Primitive& primitive : model_.meshes[size_t(node.mesh)].primitives)
                    if (primitive.mode == TINYGLTF_MODE_TRIANGLES || primitive.mode == -1)
                        addPrimitive(primitive, world);
            for (auto child = node.children.rbegin(); child != node.children.rend(); ++child)
                stack.push_back({*child, world});
        }
    }

    static uint64_t saturatingAdd(uint64_t a, uint64_t b) { return a > UINT64_MAX - b ? UINT64_MAX : a + b; }

    // Triangles and vertices one instance of a node's mesh adds (from the accessors' counts; their
    // bounds are checked when they are read).
    struct MeshSize {
        uint64_t triangles = 0, vertices = 0;
    };
    MeshSize meshSize(int meshIndex) const {
        MeshSize size;
        if (meshIndex < 0) return size;
        for (const tinygltf::Primitive& primitive : model_.meshes[size_t(meshIndex)].primitives) {
            if (primitive.mode != TINYGLTF_MODE_TRIANGLES && primitive.mode != -1) continue;
            const auto position = primitive.attributes.find("POSITION");
            const auto countOf = [&](int accessor) -> uint64_t {
                return accessor >= 0 && size_t(accessor) < model_.accessors.size()
                           ? model_.accessors[size_t(accessor)].count
                           : 0;
            };
            const uint64_t vertices = position == primitive.attributes.end() ? 0 : countOf(position->second);
            // Saturating: a hostile count must not wrap the sum below the limits.
            size.vertices = saturatingAdd(size.vertices, vertices);
            size.triangles =
                saturatingAdd(size.triangles, (primitive.indices >= 0 ? countOf(primitive.indices) : vertices) / 3);
        }
        return size;
    }

    // Before anything is instanced: every node index exists, the hierarchy has no cycle and is at
    // most maxGltfNodeDepth() deep, and the number of node instances (paths from a root, which a
    // node listing the same child twice doubles at every level) and the triangles and vertices they
    // add are bounded. Iterative, with a colour per node: grey while on the DFS stack, so meeting a
    // grey node again is a cycle.
    void checkHierarchy(const std::vector<int>& roots) const {
        const size_t nodeCount = model_.nodes.size();
        auto checkNode = [&](int node, const std::string& where) {
            if (node < 0 || size_t(node) >= nodeCount)
                fail(where + " refers to node " + std::to_string(node) + ", which does not exist");
        };
        for (size_t n = 0; n < nodeCount; ++n) {
            for (int child : model_.nodes[n].children) checkNode(child, "node " + std::to_string(n));
            const int mesh = model_.nodes[n].mesh;
            if (mesh >= 0 && size_t(mesh) >= model_.meshes.size())
                fail("node " + std::to_string(n) + " refers to a missing mesh");
        }
        for (int root : roots) checkNode(root, "the scene");
        // Topological order of the nodes reachable from the roots (reverse post-order).
        enum : uint8_t { kWhite, kGrey, kBlack };
        std::vector<uint8_t> colour(nodeCount, kWhite);
        std::vector<int> postOrder;
        struct Frame {
            int node;
            size_t nextChild;
        };
        std::vector<Frame> stack;
        for (int root : roots) {
            if (colour[size_t(root)] != kWhite) continue;
            colour[size_t(root)] = kGrey;
            stack.push_back({root, 0});
            while (!stack.empty()) {
                Frame& frame = stack.back();
                const std::vector<int>& children = model_.nodes[size_t(frame.node)].children;
                if (frame.nextChild == children.size()) {
                    colour[size_t(frame.node)] = kBlack;
                    postOrder.push_back(frame.node);
                    stack.pop_back();
                    continue;
                }
                const int child = children[frame.nextChild++];
                if (colour[size_t(child)] == kGrey)
                    fail("the node hierarchy has a cycle (node " + std::to_string(child) + " is its own ancestor)");
                if (colour[size_t(child)] == kWhite) {
                    colour[size_t(child)] = kGrey;
                    stack.push_back({child, 0});
                }
            }
        }
        // Instances (saturating at the limit) and depth, parents before children.
        const LoadLimit depthLimit = maxGltfNodeDepth(), instanceLimit = maxGltfInstances();
        std::vector<uint64_t> instances(nodeCount, 0), depth(nodeCount, 0);
        for (int root : roots) instances[size_t(root)] = std::min(instances[size_t(root)] + 1, instanceLimit.value + 1);
        uint64_t totalInstances = 0, triangles = 0, vertices = 0, storedTriangles = 0, storedVertices = 0;
        std::vector<bool> meshCounted(model_.meshes.size(), false);
        for (auto it = postOrder.rbegin(); it != postOrder.rend(); ++it) {
            const size_t n = size_t(*it);
            if (depth[n] + 1 > depthLimit.value)
                throwLimitError(
                    path_,
                    "the node hierarchy is nested more than " + std::to_string(depthLimit.value) + " levels deep",
                    depthLimit);
            totalInstances = std::min(totalInstances + instances[n], instanceLimit.value + 1);
            if (totalInstances > instanceLimit.value)
                throwLimitError(path_,
                                "the node hierarchy makes more than " + std::to_string(instanceLimit.value) +
                                    " node instances (nodes listing a child more than once multiply them)",
                                instanceLimit);
            const tinygltf::Node& node = model_.nodes[n];
            const MeshSize size = meshSize(node.mesh);
            triangles =
                checkedAdd(triangles, checkedMul(instances[n], size.triangles, path_, "the instanced triangle count"),
                           path_, "the instanced triangle count");
            vertices =
                checkedAdd(vertices, checkedMul(instances[n], size.vertices, path_, "the instanced vertex count"),
                           path_, "the instanced vertex count");
            if (node.mesh >= 0 && !meshCounted[size_t(node.mesh)]) {
                meshCounted[size_t(node.mesh)] = true;
                storedTriangles = saturatingAdd(storedTriangles, size.triangles);
                storedVertices = saturatingAdd(storedVertices, size.vertices);
            }
            for (int child : node.children) {
                instances[size_t(child)] = std::min(instances[size_t(child)] + instances[n], instanceLimit.value + 1);
                depth[size_t(child)] = std::max(depth[size_t(child)], depth[n] + 1);
            }
        }
        // Instancing may multiply what the file stores by a bounded factor (with a floor of 1M,
        // so small scenes instance freely): a 1 KB file cannot ask for billions of triangles.
        const LoadLimit factor = maxInstancedTriangleFactor();
        constexpr uint64_t kFloor = uint64_t(1) << 20;
        const auto allowed = [&](uint64_t stored) {
            const uint64_t scaled = stored > UINT64_MAX / factor.value ? UINT64_MAX : stored * factor.value;
            return std::max(kFloor, scaled);
        };
        if (triangles > allowed(storedTriangles) || vertices > allowed(storedVertices))
            throwLimitError(path_,
                            "node instancing makes " + std::to_string(triangles) + " triangles and " +
                                std::to_string(vertices) + " vertices of " + std::to_string(storedTriangles) + " and " +
                                std::to_string(storedVertices) +
                                " stored, more than the instancing factor allows (at least 1048576 each)",
                            factor);
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
            fail(name + ": buffer view " + std::to_string(accessor.bufferView) +
                 " lies outside its buffer (truncated file?)");
        // In checked arithmetic: a byteOffset near 2^64 must not wrap past the check (issue 11).
        if (accessor.count > 0) {
            const std::string what = name + "'s byte range";
            const uint64_t last =
                checkedAdd(checkedAdd(uint64_t(accessor.byteOffset),
                                      checkedMul(uint64_t(stride), accessor.count - 1, path_, what), path_, what),
                           elementSize, path_, what);
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
        if (size_t(cameraIndex) >= model_.cameras.size())
            fail("a node refers to missing camera " + std::to_string(cameraIndex));
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
            if (positions.count % 3 != 0)
                fail("a non-indexed TRIANGLES primitive's vertex count is not a multiple of 3");
            for (size_t i = 0; i + 2 < positions.count; i += 3)
                addTriangle(uint32_t(i), uint32_t(i + 1), uint32_t(i + 2));
        }
        if (scene_.triangles.size() > std::numeric_limits<uint32_t>::max())
            fail("more triangles than 32-bit triangle indices can address");
    }

    const tinygltf::Model& model_;
    const std::filesystem::path& path_;
    std::vector<Material> materials_;
    std::vector<MaterialTexturing> texturing_;                      // per material
    std::map<std::tuple<int, int, int>, uint32_t> textureOfImage_;  // (image, wrap u, wrap v)
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
    if (binary) {
        // tinygltf reads a GLB's header without checking its version; version 1 (KHR_binary_glTF)
        // is a different layout that would parse as garbage.
        uint32_t version = 0;
        if (file.size >= 8) std::memcpy(&version, file.begin() + 4, 4);
        if (version != 2)
            throwFileError(path, "GLB version " + std::to_string(version) + " is not supported (only glTF 2.0)");
    }
    ReferencedFiles referenced{&path, baseDir};
    tinygltf::FsCallbacks callbacks{};
    callbacks.FileExists = referencedFileExists;
    callbacks.ExpandFilePath = expandNothing;
    callbacks.ReadWholeFile = readReferencedGltfFile;
    callbacks.WriteWholeFile = writeNothing;
    callbacks.user_data = &referenced;
    loader.SetFsCallbacks(callbacks);
    const bool ok =
        binary ? loader.LoadBinaryFromMemory(&model, &errors, &warnings,
                                             reinterpret_cast<const unsigned char*>(file.begin()), unsigned(file.size),
                                             baseDir)
               : loader.LoadASCIIFromString(&model, &errors, &warnings, file.begin(), unsigned(file.size), baseDir);
    if (progress && progress->cancel) throw LoadCancelled(path.string() + ": loading cancelled");
    if (!ok) {
        // A missing file fails a load only as a buffer: say so as for every file a scene names.
        if (!referenced.missing.empty())
            resolveReferencedFile(path, referenced.missing.front(), "referenced file", maxReferencedFileBytes());
        // tinygltf ends each of its messages with a newline; the error is one line (the first).
        const std::string first = errors.substr(0, errors.find('\n'));
        throwFileError(path, first.empty() ? "tinygltf could not parse the file" : first);
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
    for (const std::string& extension : model.extensionsRequired)
        if (!ignorableRequiredExtension(extension))
            throwFileError(path, "requires the extension " + extension + ", which raypack does not support");
    Scene scene = GltfConverter(model, path).convert();
    scene.sourceBytes = file.size;
    for (const tinygltf::Buffer& buffer : model.buffers)
        if (!buffer.uri.empty() && buffer.uri.rfind("data:", 0) != 0) scene.sourceBytes += buffer.data.size();
    for (const Texture& texture : scene.textures) scene.sourceBytes += texture.fileBytes;
    reportParsed(progress, path, file.size, file.size);
    return scene;
}

}  // namespace raypack
