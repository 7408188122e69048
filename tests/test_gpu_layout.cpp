// The conversion from the canonical tree to the GPU layout (renderer/gpu_layout.h), on the CPU:
// the node bit packing of shaders/gpu_types.h (lo.w child or first triangle, hi.w 0 or the
// count), each leaf's triangles gathered into one contiguous range that no other leaf shares, the
// leaf order a permutation of the tree's primitive indices with the file-order index in v0.w, and
// the depth that sizes the traversal stacks.
#include "renderer/bvh.h"
#include "renderer/gpu_layout.h"
#include "scenes/load.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cfloat>
#include <cstring>
#include <numeric>
#include <string>

namespace raypack {
namespace {

uint32_t bitsOf(float f) {
    uint32_t bits;
    std::memcpy(&bits, &f, sizeof bits);
    return bits;
}

void expectLayoutOfTree(const std::string& spec, const BvhBuildOptions& options) {
    SCOPED_TRACE(spec + ", builder " + toString(options.builder) + ", leaf size " + std::to_string(options.leafSize));
    const Scene scene = openScene(spec);
    const Bvh bvh = buildBvh(scene, options);
    const GpuLayout layout = makeGpuLayout(scene, bvh);
    ASSERT_EQ(layout.nodes.size(), bvh.nodes.size());
    ASSERT_EQ(layout.triangles.size(), bvh.primIndices.size());
    ASSERT_EQ(layout.leafToFile.size(), bvh.primIndices.size());

    struct Range {
        uint32_t first, count;
    };
    std::vector<Range> ranges;
    for (size_t i = 0; i < bvh.nodes.size(); ++i) {
        const BvhNode& node = bvh.nodes[i];
        const gpu::GpuNode& g = layout.nodes[i];
        ASSERT_EQ(glm::vec3(g.lo), node.lo) << "node " << i;
        ASSERT_EQ(glm::vec3(g.hi), node.hi) << "node " << i;
        if (!node.isLeaf()) {
            ASSERT_EQ(bitsOf(g.lo.w), node.index) << "inner node " << i << ": left child";
            ASSERT_EQ(bitsOf(g.hi.w), 0u) << "inner node " << i;
            continue;
        }
        ASSERT_EQ(bitsOf(g.hi.w), node.count) << "leaf " << i << ": triangle count";
        const uint32_t first = bitsOf(g.lo.w);
        ASSERT_LE(uint64_t(first) + node.count, layout.triangles.size()) << "leaf " << i;
        ranges.push_back({first, node.count});
        // The leaf's triangles, in its order, are the canonical leaf's: file index in v0.w and the
        // vertices gathered from the scene.
        for (uint32_t k = 0; k < node.count; ++k) {
            const uint32_t file = bvh.primIndices[node.index + k];
            const gpu::GpuTriangle& t = layout.triangles[first + k];
            ASSERT_EQ(bitsOf(t.v0.w), file) << "leaf " << i << " triangle " << k;
            ASSERT_EQ(layout.leafToFile[first + k], file);
            const glm::uvec3 v = scene.triangles[file];
            ASSERT_EQ(glm::vec3(t.v0), scene.positions[v.x]);
            ASSERT_EQ(glm::vec3(t.v1), scene.positions[v.y]);
            ASSERT_EQ(glm::vec3(t.v2), scene.positions[v.z]);
            const uint32_t material = scene.triangleMaterial.empty() ? 0u : scene.triangleMaterial[file];
            ASSERT_EQ(bitsOf(t.v1.w), material);
        }
    }
    // Contiguous leaves: sorted by their first triangle, the ranges tile [0, n) without a gap or
    // an overlap.
    std::sort(ranges.begin(), ranges.end(), [](const Range& a, const Range& b) { return a.first < b.first; });
    uint32_t next = 0;
    for (const Range& r : ranges) {
        ASSERT_EQ(r.first, next) << "a gap or an overlap in leaf order";
        next += r.count;
    }
    EXPECT_EQ(next, layout.triangles.size());
    // Leaf order is a permutation of the tree's primitive indices (its references: sah-split lists
    // a triangle once per leaf it overlaps, the partitioning builders each triangle once).
    std::vector<uint32_t> leafOrder = layout.leafToFile, canonical(bvh.primIndices.begin(), bvh.primIndices.end());
    std::sort(leafOrder.begin(), leafOrder.end());
    std::sort(canonical.begin(), canonical.end());
    EXPECT_EQ(leafOrder, canonical);
    if (referencesEachPrimitiveOnce(options.builder)) {
        EXPECT_EQ(std::adjacent_find(leafOrder.begin(), leafOrder.end()), leafOrder.end()) << "a triangle placed twice";
    }
    // The deepest node of a binary tree is a leaf.
    EXPECT_EQ(layout.maxDepth, bvh.stats.maxLeafDepth);
    if (!scene.normals.empty()) {
        EXPECT_EQ(layout.normals.size(), layout.triangles.size());
    }
}

TEST(GpuLayout, PackingLeafOrderAndContiguousLeaves) {
    for (const char* spec : {"gen:default", "gen:sphereflake:20k", "gen:terrain:20k"})
        for (const BvhBuilder builder : kCpuBvhBuilders)
            for (const uint32_t leafSize : {1u, 4u, 8u}) {
                BvhBuildOptions options;
                options.builder = builder;
                options.leafSize = leafSize;
                expectLayoutOfTree(spec, options);
            }
}

TEST(GpuLayout, SharedSceneWithMaterials) {
    expectLayoutOfTree(std::string(RAYPACK_SHARED_SCENES) + "/sibenik/sibenik_geom_75284.ply", BvhBuildOptions{});
}

}  // namespace
}  // namespace raypack
