#pragma once
// The explicit conversion from the canonical tree (renderer/bvh.h) and the scene to what the GPU
// kernels read (shaders/gpu_types.h). The BVH that is built is not the BVH that is traced
// (../shared/STYLE.md; tinybvh's BVH_GPU::ConvertFrom, pbrt's flattenBVH).
#include "renderer/bvh.h"
#include "renderer/scene.h"
#include "shaders/gpu_types.h"

#include <cstdint>
#include <vector>

namespace raypack {

struct GpuLayout {
    std::vector<gpu::GpuNode> nodes;                // same order and shape as Bvh::nodes
    std::vector<gpu::GpuTriangle> triangles;        // leaf order: leaf ranges index this directly
    std::vector<gpu::GpuTriangleNormals> normals;   // leaf order, empty when the scene has none
    std::vector<glm::vec4> materials;               // diffuse rgb per material, empty when none
    std::vector<uint32_t> leafToFile;               // leaf-order triangle -> file-order triangle
    uint32_t maxDepth = 0;                          // deepest node below the root (root = 0)

    size_t bytes() const;
};

// Gathers each leaf's triangles into one contiguous range (the kernels then need no index
// indirection), keeps the file-order index in GpuTriangle::v0.w, and measures the tree's depth,
// which sizes the traversal stacks.
GpuLayout makeGpuLayout(const Scene& scene, const Bvh& bvh);

}  // namespace raypack
