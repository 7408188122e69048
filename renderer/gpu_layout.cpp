#include "renderer/gpu_layout.h"

#include "renderer/error.h"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <cfloat>
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
           normals.size() * sizeof(gpu::GpuTriangleNormals) + materials.size() * sizeof(gpu::GpuMaterial) +
           uvs.size() * sizeof(gpu::GpuTriangleUvs) + colors.size() * sizeof(gpu::GpuTriangleColors) + textureBytes();
}

size_t GpuLayout::textureBytes() const {
    return textures.size() * sizeof(gpu::GpuTexture) + texels.size() * sizeof(uint32_t);
}

gpu::GpuTexture gpuTexture(const Texture& texture, uint32_t offset) {
    gpu::GpuTexture t;
    t.offset = offset;
    t.width = texture.width;
    t.height = texture.height;
    t.wrap = uint32_t(texture.wrapU) | (uint32_t(texture.wrapV) << 2u) | (texture.levels << 8u);
    return t;
}

GpuLayoutCounts gpuLayoutCounts(const Scene& scene, const Bvh& bvh) {
    RAYPACK_CHECK(!bvh.nodes.empty());
    GpuLayoutCounts counts;
    counts.nodes = bvh.nodes.size();
    counts.triangles = bvh.primIndices.size();
    counts.normals = scene.hasNormals();
    counts.uvs = scene.hasUvs();
    counts.colors = scene.hasVertexColors();
    counts.materials = scene.hasMaterials() ? scene.materials.size() : 0;
    counts.textures = scene.textures.size();
    uint64_t texels = 0;
    for (const Texture& t : scene.textures) texels += t.texels.size();
    if (texels > 0xFFFFFFFFull)
        throw Error(scene.source + ": the textures hold " + std::to_string(texels) +
                    " texels, more than the GPU kernels' 32-bit texel indices reach");
    counts.texels = size_t(texels);
    return counts;
}

void writeGpuLayout(const Scene& scene, const Bvh& bvh, const GpuLayoutCounts& counts, const GpuLayoutTargets& out) {
    RAYPACK_CHECK(counts.nodes == bvh.nodes.size() && counts.triangles == bvh.primIndices.size());
    // 1. Nodes: a leaf's first slot is its index into primIndices (leaf order = reference order).
    tbb::parallel_for(tbb::blocked_range<size_t>(0, counts.nodes, 16384), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
            const BvhNode& node = bvh.nodes[i];
            if (!node.isLeaf()) {
                out.nodes[i] = {withBits(node.lo, node.index), withBits(node.hi, 0u)};
            } else if (node.count == 0) {
                // Only an empty scene has an empty leaf: give it a box no ray can hit.
                out.nodes[i] = {withBits(glm::vec3(FLT_MAX), node.index), withBits(glm::vec3(-FLT_MAX), 0u)};
            } else {
                RAYPACK_CHECK(uint64_t(node.index) + node.count <= counts.triangles);
                out.nodes[i] = {withBits(node.lo, node.index), withBits(node.hi, node.count)};
            }
        }
    });
    // 2. The references' triangles; 3. the materials and textures.
    writeGpuTriangles(scene, bvh.primIndices, counts, out);
    writeGpuMaterials(scene, counts, out);
}

void writeGpuTriangles(const Scene& scene, std::span<const uint32_t> order, const GpuLayoutCounts& counts,
                       const GpuLayoutTargets& out) {
    RAYPACK_CHECK(counts.triangles == order.size());
    const bool materials = counts.materials > 0;
    // Gathered in parallel (the gather reads vertices scattered over the scene; the writes are
    // sequential per range, and first touches of fresh staging pages are spread over the threads too).
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, counts.triangles, 16384), [&](const tbb::blocked_range<size_t>& range) {
            for (size_t slot = range.begin(); slot != range.end(); ++slot) {
                const uint32_t tri = order[slot];
                RAYPACK_CHECK(tri < scene.triangles.size());
                const glm::uvec3 v = scene.triangles[tri];
                const uint32_t material = materials ? scene.triangleMaterial[tri] : 0u;
                out.triangles[slot] = {withBits(scene.positions[v.x], tri), withBits(scene.positions[v.y], material),
                                       glm::vec4(scene.positions[v.z], 0.0f)};
                if (out.leafToFile) out.leafToFile[slot] = tri;
                if (counts.normals && out.normals)
                    out.normals[slot] = {glm::vec4(scene.normals[v.x], 0.0f), glm::vec4(scene.normals[v.y], 0.0f),
                                         glm::vec4(scene.normals[v.z], 0.0f)};
                if (counts.uvs && out.uvs)
                    out.uvs[slot] = {glm::vec4(scene.uvs[v.x], scene.uvs[v.y]), glm::vec4(scene.uvs[v.z], 0.0f, 0.0f)};
                if (counts.colors && out.colors)
                    out.colors[slot] = {
                        glm::uvec4(scene.vertexColors[v.x], scene.vertexColors[v.y], scene.vertexColors[v.z], 0u)};
            }
        });
}

void writeGpuMaterials(const Scene& scene, const GpuLayoutCounts& counts, const GpuLayoutTargets& out) {
    for (size_t m = 0; m < counts.materials; ++m) {
        const Material& material = scene.materials[m];
        RAYPACK_CHECK(material.texture == kNoTexture || (material.texture < scene.textures.size() && counts.uvs));
        out.materials[m] = {withBits(material.diffuse, material.texture)};
    }
    size_t texel = 0;
    for (size_t i = 0; i < counts.textures; ++i) {
        const Texture& t = scene.textures[i];
        RAYPACK_CHECK(t.levels >= 1 && t.levels <= 255 &&
                      t.texels.size() == Texture::texelCount(t.width, t.height, t.levels));
        out.textures[i] = gpuTexture(t, uint32_t(texel));
        std::copy(t.texels.begin(), t.texels.end(), out.texels + texel);
        texel += t.texels.size();
    }
}

uint32_t gpuTreeDepth(const Bvh& bvh) {
    if (bvh.stats.nodeCount == bvh.nodes.size() && bvh.stats.nodeCount > 0) return bvh.stats.maxLeafDepth;
    return bvhMaxDepth(bvh);
}

GpuLayout makeGpuLayout(const Scene& scene, const Bvh& bvh) {
    const GpuLayoutCounts counts = gpuLayoutCounts(scene, bvh);
    GpuLayout layout;
    layout.nodes.resize(counts.nodes);
    layout.triangles.resize(counts.triangles);
    layout.leafToFile.resize(counts.triangles);
    if (counts.normals) layout.normals.resize(counts.triangles);
    if (counts.uvs) layout.uvs.resize(counts.triangles);
    if (counts.colors) layout.colors.resize(counts.triangles);
    layout.materials.resize(counts.materials);
    layout.textures.resize(counts.textures);
    layout.texels.resize(counts.texels);
    GpuLayoutTargets targets;
    targets.nodes = layout.nodes.data();
    targets.triangles = layout.triangles.data();
    targets.normals = counts.normals ? layout.normals.data() : nullptr;
    targets.materials = layout.materials.data();
    targets.uvs = counts.uvs ? layout.uvs.data() : nullptr;
    targets.colors = counts.colors ? layout.colors.data() : nullptr;
    targets.textures = layout.textures.data();
    targets.texels = layout.texels.data();
    targets.leafToFile = layout.leafToFile.data();
    writeGpuLayout(scene, bvh, counts, targets);
    layout.maxDepth = gpuTreeDepth(bvh);
    return layout;
}

}  // namespace raypack
