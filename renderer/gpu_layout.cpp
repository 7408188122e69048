#include "renderer/gpu_layout.h"

#include "renderer/error.h"

#include <cstring>
#include <utility>

namespace raypack {

namespace {
float uintAsFloat(uint32_t bits) {
    float f;
    std::memcpy(&f, &bits, sizeof f);
    return f;
}
glm::vec4 withBits(const glm::vec3& xyz, uint32_t bits) { return {xyz, uintAsFloat(bits)}; }
}  // namespace

size_t GpuLayout::bytes() const {
    return nodes.size() * sizeof(gpu::GpuNode) + triangles.size() * sizeof(gpu::GpuTriangle) +
           normals.size() * sizeof(gpu::GpuTriangleNormals) + materials.size() * sizeof(glm::vec4);
}

GpuLayout makeGpuLayout(const Scene& scene, const Bvh& bvh) {
    RAYPACK_CHECK(!bvh.nodes.empty());
    GpuLayout layout;
    layout.nodes.resize(bvh.nodes.size());
    layout.triangles.reserve(bvh.primIndices.size());
    layout.leafToFile.reserve(bvh.primIndices.size());
    const bool normals = scene.hasNormals();
    const bool materials = scene.hasMaterials();
    if (normals) layout.normals.reserve(bvh.primIndices.size());

    // Depth-first walk from the root with an explicit stack: converts every node and gathers the
    // triangles of each leaf in the order the walk meets them.
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};  // (node, depth)
    while (!stack.empty()) {
        const auto [index, depth] = stack.back();
        stack.pop_back();
        RAYPACK_CHECK(index < bvh.nodes.size());
        layout.maxDepth = std::max(layout.maxDepth, depth);
        const BvhNode& node = bvh.nodes[index];
        if (node.isLeaf()) {
            const uint32_t first = uint32_t(layout.triangles.size());
            for (uint32_t k = 0; k < node.count; ++k) {
                const uint32_t tri = bvh.primIndices[node.index + k];
                RAYPACK_CHECK(tri < scene.triangles.size());
                const glm::uvec3 v = scene.triangles[tri];
                const uint32_t material = materials ? scene.triangleMaterial[tri] : 0u;
                layout.triangles.push_back({withBits(scene.positions[v.x], tri),
                                            withBits(scene.positions[v.y], material),
                                            glm::vec4(scene.positions[v.z], 0.0f)});
                layout.leafToFile.push_back(tri);
                if (normals)
                    layout.normals.push_back({glm::vec4(scene.normals[v.x], 0.0f),
                                              glm::vec4(scene.normals[v.y], 0.0f),
                                              glm::vec4(scene.normals[v.z], 0.0f)});
            }
            layout.nodes[index] = {withBits(node.lo, first), withBits(node.hi, node.count)};
            if (node.count == 0) {
                // Only an empty scene has an empty leaf: give it a box no ray can hit.
                layout.nodes[index] = {withBits(glm::vec3(FLT_MAX), first),
                                       withBits(glm::vec3(-FLT_MAX), 0u)};
            }
        } else {
            RAYPACK_CHECK(node.index + 1 < bvh.nodes.size());
            layout.nodes[index] = {withBits(node.lo, node.index), withBits(node.hi, 0u)};
            stack.push_back({node.index + 1, depth + 1});
            stack.push_back({node.index, depth + 1});
        }
    }
    if (materials) {
        layout.materials.reserve(scene.materials.size());
        for (const Material& m : scene.materials) layout.materials.emplace_back(m.diffuse, 1.0f);
    }
    return layout;
}

}  // namespace raypack
