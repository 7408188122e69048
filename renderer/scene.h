#pragma once
// The scene as every part of raypack sees it: triangles in the file's order, so that a triangle
// index ("prim") means the same thing to the loaders, the BVH, the CPU and GPU tracers and the
// hits file. Only what the file has is kept: normals and materials are empty when absent.
#include "renderer/aabb.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace raypack {

struct Material {
    std::string name;
    glm::vec3 diffuse{0.8f, 0.8f, 0.8f};
};

struct Scene {
    std::string source;                 // file path or generator description
    std::vector<glm::vec3> positions;   // vertex positions
    std::vector<glm::uvec3> triangles;  // vertex indices, one entry per triangle, file order
    std::vector<glm::vec3> normals;     // per vertex (same indexing as positions), or empty
    std::vector<Material> materials;    // or empty: then every triangle uses the default material
    std::vector<uint32_t> triangleMaterial;  // per triangle index into materials, or empty

    size_t triangleCount() const { return triangles.size(); }
    bool hasNormals() const { return !normals.empty(); }
    bool hasMaterials() const { return !triangleMaterial.empty(); }

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
               materials.size() * sizeof(Material);
    }
};

}  // namespace raypack
