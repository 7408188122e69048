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
    std::vector<gpu::GpuNode> nodes;               // same order and shape as Bvh::nodes
    std::vector<gpu::GpuTriangle> triangles;       // leaf order: leaf ranges index this directly
    std::vector<gpu::GpuTriangleNormals> normals;  // leaf order, empty when the scene has none
    std::vector<gpu::GpuMaterial> materials;       // per material, empty when none
    std::vector<gpu::GpuTriangleUvs> uvs;          // leaf order, empty when the scene has no UVs
    std::vector<gpu::GpuTriangleColors> colors;    // leaf order, empty without vertex colours
    std::vector<gpu::GpuTexture> textures;         // per Scene::textures entry
    std::vector<uint32_t> texels;                  // every texture's texels, one after another
    std::vector<uint32_t> leafToFile;              // leaf-order triangle -> file-order triangle
    uint32_t maxDepth = 0;                         // deepest node below the root (root = 0)

    size_t bytes() const;         // everything above
    size_t textureBytes() const;  // textures and texels (included in bytes())
};

// A texture's descriptor for shaders/texture.h, its texels starting at `offset`.
gpu::GpuTexture gpuTexture(const Texture& texture, uint32_t offset);

// Gathers each leaf's triangles into one contiguous range (the kernels then need no index
// indirection), keeps the file-order index in GpuTriangle::v0.w, and measures the tree's depth,
// which sizes the traversal stacks. UVs and vertex colours are gathered the same way, and only
// when the scene has them. Throws raypack::Error when the textures hold 2^32 texels or more.
GpuLayout makeGpuLayout(const Scene& scene, const Bvh& bvh);

}  // namespace raypack
