#pragma once
// The scene as every part of raypack sees it: triangles in the file's order, so that a triangle
// index ("prim") means the same thing to the loaders, the BVH, the CPU and GPU tracers and the
// hits file. Only what the file has is kept: normals, materials, UVs, vertex colours and textures
// are empty when absent, and UVs are kept only when a material has a texture.
#include "renderer/aabb.h"
#include "renderer/camera.h"
#include "shaders/texture.h"  // kDefaultDiffuse

#include <glm/glm.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace raypack {

// No texture: Material::texture's value when the material has none.
constexpr uint32_t kNoTexture = 0xFFFFFFFFu;

// How a texture coordinate outside [0, 1] is mapped (glTF samplers, OBJ's -clamp); the values
// are shaders/texture.h's kWrap* constants.
enum class TextureWrap : uint32_t { Repeat = 0, Clamp = 1, Mirror = 2 };

// A decoded image, RGBA8 with R in the low byte of each texel (shaders/texture.h), rows from the
// top: texel (x, y) at texels[y * width + x], UV (0, 0) at the top-left corner; then its further
// mip levels, each max(1, size / 2) of the one before (`levels` in all, 1 when none were built).
struct Texture {
    std::string name;  // the file or image it came from, for messages
    uint32_t width = 0;
    uint32_t height = 0;
    uint32_t levels = 1;
    TextureWrap wrapU = TextureWrap::Repeat;
    TextureWrap wrapV = TextureWrap::Repeat;
    std::vector<uint32_t> texels;
    uint64_t fileBytes = 0;  // size of the image file it was read from; 0 when embedded

    // Texels of all `levels` levels of a width x height image.
    static size_t texelCount(uint32_t width, uint32_t height, uint32_t levels) {
        size_t n = 0;
        for (uint32_t k = 0; k < levels; ++k) {
            n += size_t(width) * height;
            width = width > 1 ? width / 2 : 1;
            height = height > 1 ? height / 2 : 1;
        }
        return n;
    }
};

struct Material {
    std::string name;
    glm::vec3 diffuse{gpu::kDefaultDiffuse};  // multiplies the texture, when there is one
    uint32_t texture = kNoTexture;            // index into Scene::textures
};

struct Scene {
    std::string source;                      // file path or generator description
    std::vector<glm::vec3> positions;        // vertex positions
    std::vector<glm::uvec3> triangles;       // vertex indices, one entry per triangle, file order
    std::vector<glm::vec3> normals;          // per vertex (same indexing as positions), or empty
    std::vector<Material> materials;         // or empty: then every triangle uses the default material
    std::vector<uint32_t> triangleMaterial;  // per triangle index into materials, or empty
    std::vector<glm::vec2> uvs;              // per vertex, or empty: present when textures is not empty
    std::vector<uint32_t> vertexColors;      // per vertex RGBA8 (R low byte), or empty
    std::vector<Texture> textures;           // those the materials use, or empty
    std::optional<Camera> fileCamera;        // the file's own camera (glTF), when it has one
    // Bytes of every file loading read: the scene file, glTF buffers and texture images (0 for a
    // generated scene); what load speeds (MB/s) are measured in.
    uint64_t sourceBytes = 0;

    size_t triangleCount() const { return triangles.size(); }
    bool hasNormals() const { return !normals.empty(); }
    bool hasMaterials() const { return !triangleMaterial.empty(); }
    bool hasUvs() const { return !uvs.empty(); }
    bool hasVertexColors() const { return !vertexColors.empty(); }
    // Bytes of decoded texels (reported beside the BVH's bytes).
    size_t textureBytes() const {
        size_t n = 0;
        for (const Texture& t : textures) n += t.texels.size() * sizeof(uint32_t);
        return n;
    }

    glm::vec3 vertex(uint32_t tri, int corner) const { return positions[triangles[tri][corner]]; }
    Aabb triangleBounds(uint32_t tri) const {
        Aabb b;
        b.grow(vertex(tri, 0));
        b.grow(vertex(tri, 1));
        b.grow(vertex(tri, 2));
        return b;
    }
    Aabb bounds() const {
        Aabb b;
        for (const glm::uvec3& t : triangles)
            for (int c = 0; c < 3; ++c) b.grow(positions[t[c]]);
        return b;
    }
    // Number of triangles with zero area (kept in the scene, counted for statistics).
    size_t degenerateCount() const {
        size_t n = 0;
        for (uint32_t i = 0; i < triangles.size(); ++i) {
            const glm::vec3 a = vertex(i, 0), b = vertex(i, 1), c = vertex(i, 2);
            if (glm::cross(b - a, c - a) == glm::vec3(0.0f)) ++n;
        }
        return n;
    }
    // Bytes the scene occupies in memory.
    size_t bytes() const {
        return positions.size() * sizeof(glm::vec3) + triangles.size() * sizeof(glm::uvec3) +
               normals.size() * sizeof(glm::vec3) + triangleMaterial.size() * sizeof(uint32_t) +
               materials.size() * sizeof(Material) + uvs.size() * sizeof(glm::vec2) +
               vertexColors.size() * sizeof(uint32_t) + textures.size() * sizeof(Texture) + textureBytes();
    }
};

}  // namespace raypack
