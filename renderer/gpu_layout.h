#pragma once
// The explicit conversion from the canonical tree (renderer/bvh.h) and the scene to what the GPU
// kernels read (shaders/gpu_types.h). The BVH that is built is not the BVH that is traced
// (../shared/STYLE.md; tinybvh's BVH_GPU::ConvertFrom, pbrt's flattenBVH).
#include "renderer/bvh.h"
#include "renderer/scene.h"
#include "shaders/gpu_types.h"

#include <cstdint>
#include <span>
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

// How many entries each array of the layout has, from the scene and the tree alone (no conversion):
// what the upload allocates before writing the layout straight into its staging memory.
struct GpuLayoutCounts {
    size_t nodes = 0;
    size_t triangles = 0;  // also normals, uvs and colours where present (leaf order)
    bool normals = false;
    bool uvs = false;
    bool colors = false;
    size_t materials = 0;
    size_t textures = 0;
    size_t texels = 0;
};
// Throws raypack::Error when the textures hold 2^32 texels or more (the kernels' indices are 32-bit).
GpuLayoutCounts gpuLayoutCounts(const Scene& scene, const Bvh& bvh);

// Where writeGpuLayout puts each array: at least the counts' entries each; null where the count is
// zero or the array is absent (leafToFile may always be null).
struct GpuLayoutTargets {
    gpu::GpuNode* nodes = nullptr;
    gpu::GpuTriangle* triangles = nullptr;
    gpu::GpuTriangleNormals* normals = nullptr;
    gpu::GpuMaterial* materials = nullptr;
    gpu::GpuTriangleUvs* uvs = nullptr;
    gpu::GpuTriangleColors* colors = nullptr;
    gpu::GpuTexture* textures = nullptr;
    uint32_t* texels = nullptr;
    uint32_t* leafToFile = nullptr;
};

// Converts every node and gathers each leaf's triangles into one contiguous range (the kernels then
// need no index indirection), keeping the file-order index in GpuTriangle::v0.w. Leaf order is the
// tree's own reference order: slot k holds the triangle of Bvh::primIndices[k], so a leaf's range
// is its [index, index + count) and nodes and triangles convert independently, in parallel, with
// no walk of the tree (the builders lay references out depth first, so this is the walk's order
// too). Every entry is written exactly once, so the targets may be uninitialised memory (the
// upload writes into mapped staging buffers, which no one zero-fills first).
void writeGpuLayout(const Scene& scene, const Bvh& bvh, const GpuLayoutCounts& counts, const GpuLayoutTargets& targets);

// Step 2 of writeGpuLayout alone: slot k of triangles (normals, UVs, colours, leafToFile where the
// targets have them) gets triangle order[k]; counts.triangles (= order.size()) entries are written.
// (The device builder gathers the same layout on the device: shaders/lbvh.comp's gather.)
void writeGpuTriangles(const Scene& scene, std::span<const uint32_t> order, const GpuLayoutCounts& counts,
                       const GpuLayoutTargets& targets);
// The materials, the texture table and the texels (the parts of the layout that do not depend on the
// tree), where counts has them.
void writeGpuMaterials(const Scene& scene, const GpuLayoutCounts& counts, const GpuLayoutTargets& targets);

// The deepest node below the root (root = 0), which sizes the traversal stacks: the builder's
// statistics where they describe this tree, else a walk.
uint32_t gpuTreeDepth(const Bvh& bvh);

// The layout in host vectors (tests, tools): gpuLayoutCounts, writeGpuLayout and gpuTreeDepth.
GpuLayout makeGpuLayout(const Scene& scene, const Bvh& bvh);

}  // namespace raypack
