// The spatial-split builder (sah-split, Stich et al. 2009): its tree invariants (every triangle
// referenced, references within the budget, children inside parents, every point of every triangle
// inside a leaf that references it, SAH cost recomputed), hits equal to brute force and to the
// sah-exact tree (closest hit and prim ties, occlusion), the GPU layout's duplicated triangles,
// determinism across thread counts, degenerate inputs, bad options, progress and cancellation.
#include "cli_runner.h"
#include "renderer/bvh.h"
#include "renderer/bvh_build.h"
#include "renderer/cpu_tracer.h"
#include "renderer/error.h"
#include "renderer/gpu_layout.h"
#include "renderer/scene.h"
#include "renderer/settings_json.h"
#include "scenes/generators.h"
#include "scenes/load.h"
#include "shaders/intersect.h"

#include "cancel_latency.h"
#include "random_geometry.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

using namespace raypack;
using raypack::test::bruteClosest;
using raypack::test::BruteHit;
using raypack::test::bruteOccluded;
using raypack::test::randomDirection;

namespace {

BvhBuildOptions splitOptions(uint32_t leafSize = 1, float alpha = 1e-5f, float budget = 1.3f) {
    BvhBuildOptions options;
    options.builder = BvhBuilder::SahSplit;
    options.leafSize = leafSize;
    options.splitAlpha = alpha;
    options.splitBudget = budget;
    return options;
}

// Random triangles, many long and thin (the case spatial splits are for), in [-extent, extent]^3.
Scene randomSoup(uint32_t count, uint32_t seed, float extent = 10.0f) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> centre(-extent, extent), offset(-1.0f, 1.0f), unit(0.0f, 1.0f);
    Scene scene;
    scene.source = "random soup";
    for (uint32_t i = 0; i < count; ++i) {
        const glm::vec3 c(centre(rng), centre(rng), centre(rng));
        const float length = unit(rng) < 0.3f ? extent * 0.8f : extent * 0.1f;
        const glm::vec3 along = glm::vec3(offset(rng), offset(rng), offset(rng)) * length;
        const glm::vec3 across = glm::vec3(offset(rng), offset(rng), offset(rng)) * (extent * 0.02f);
        const uint32_t base = uint32_t(scene.positions.size());
        scene.positions.push_back(c);
        scene.positions.push_back(c + along);
        scene.positions.push_back(c + across);
        scene.triangles.push_back(glm::uvec3(base, base + 1, base + 2));
    }
    return scene;
}

Aabb boxOf(const BvhNode& node) { return Aabb{node.lo, node.hi}; }

bool containsPoint(const Aabb& box, const glm::dvec3& p) {
    for (int k = 0; k < 3; ++k)
        if (p[k] < double(box.lo[k]) || p[k] > double(box.hi[k])) return false;
    return true;
}

// The walk of every invariant. `triangles` null: the tree was built from boxes only.
void expectValidSplitTree(const Bvh& bvh, const Scene& scene, const BvhBuildOptions& options,
                          uint32_t pointsPerTriangle = 24) {
    const size_t n = scene.triangleCount();
    ASSERT_FALSE(bvh.nodes.empty());
    if (n == 0) {
        EXPECT_EQ(bvh.nodes.size(), 1u);
        EXPECT_TRUE(bvh.primIndices.empty());
        return;
    }
    // References within the budget, every triangle at least once.
    EXPECT_GE(bvh.primIndices.size(), n);
    EXPECT_LE(double(bvh.primIndices.size()), std::floor(double(n) * options.splitBudget));
    std::vector<std::vector<uint32_t>> leavesOf(n);
    std::vector<uint32_t> timesReached(bvh.nodes.size(), 0);
    std::vector<uint8_t> entryUsed(bvh.primIndices.size(), 0);
    std::vector<uint32_t> stack{0};
    timesReached[0] = 1;
    while (!stack.empty()) {
        const uint32_t index = stack.back();
        stack.pop_back();
        const BvhNode& node = bvh.nodes[index];
        ASSERT_FALSE(boxOf(node).empty()) << "node " << index;
        if (node.isLeaf()) {
            ASSERT_GT(node.count, 0u);
            ASSERT_LE(node.count, std::max(kMaxLeafPrimitives, options.leafSize));
            ASSERT_LE(uint64_t(node.index) + node.count, bvh.primIndices.size());
            for (uint32_t k = node.index; k < node.index + node.count; ++k) {
                ASSERT_EQ(entryUsed[k], 0) << "two leaves share primIndices entry " << k;
                entryUsed[k] = 1;
                const uint32_t prim = bvh.primIndices[k];
                ASSERT_LT(prim, n);
                if (k > node.index) {
                    ASSERT_LT(bvh.primIndices[k - 1], prim) << "leaf " << index << ": file order, once";
                }
                leavesOf[prim].push_back(index);
                // The leaf bounds a part of the triangle, so it meets the triangle's box.
                const Aabb tri = scene.triangleBounds(prim);
                const Aabb meet{glm::max(tri.lo, node.lo), glm::min(tri.hi, node.hi)};
                EXPECT_FALSE(meet.empty()) << "leaf " << index << " does not meet triangle " << prim;
            }
        } else {
            ASSERT_GE(node.index, 1u);
            ASSERT_LT(node.index + 1, bvh.nodes.size());
            for (uint32_t child : {node.index, node.index + 1}) {
                EXPECT_TRUE(boxOf(node).contains(boxOf(bvh.nodes[child])))
                    << "child " << child << " outside its parent";
                ASSERT_EQ(timesReached[child]++, 0u) << "node " << child << " has two parents";
                stack.push_back(child);
            }
        }
    }
    for (size_t entry = 0; entry < entryUsed.size(); ++entry) ASSERT_EQ(entryUsed[entry], 1) << "entry " << entry;
    for (size_t node = 0; node < bvh.nodes.size(); ++node) ASSERT_EQ(timesReached[node], 1u) << "node " << node;

    // Every point of every triangle lies in a leaf that references the triangle: the vertices, the
    // edge midpoints and random interior points, computed in double from the float vertices and
    // compared in double with the float boxes.
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (uint32_t prim = 0; prim < n; ++prim) {
        ASSERT_FALSE(leavesOf[prim].empty()) << "triangle " << prim << " is in no leaf";
        const glm::dvec3 a = scene.vertex(prim, 0), b = scene.vertex(prim, 1), c = scene.vertex(prim, 2);
        for (uint32_t s = 0; s < pointsPerTriangle; ++s) {
            glm::dvec3 p;
            if (s < 3)
                p = s == 0 ? a : s == 1 ? b : c;
            else if (s < 6)
                p = s == 3 ? 0.5 * (a + b) : s == 4 ? 0.5 * (b + c) : 0.5 * (c + a);
            else {
                double u = unit(rng), v = unit(rng);
                if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
                p = a + u * (b - a) + v * (c - a);
            }
            bool covered = false;
            for (uint32_t leaf : leavesOf[prim]) covered = covered || containsPoint(boxOf(bvh.nodes[leaf]), p);
            ASSERT_TRUE(covered) << "point " << s << " of triangle " << prim << " is in none of its "
                                 << leavesOf[prim].size() << " leaves";
        }
    }
}

// The SAH cost and Table 1 statistics recomputed by a recursive walk.
void expectStatsRecomputed(const Bvh& bvh, size_t triangles) {
    struct Walk {
        const Bvh& bvh;
        double rootArea;
        uint64_t leaves = 0, refs = 0;
        double sah = 0.0;
        static double area(const BvhNode& node) {
            const double x = double(node.hi.x) - node.lo.x, y = double(node.hi.y) - node.lo.y,
                         z = double(node.hi.z) - node.lo.z;
            return 2.0 * (x * y + y * z + z * x);
        }
        void visit(uint32_t index) {
            const BvhNode& node = bvh.nodes[index];
            const double share = area(node) / rootArea;
            if (node.isLeaf()) {
                ++leaves;
                refs += node.count;
                sah += bvh.options.intersectionCost * node.count * share;
            } else {
                sah += bvh.options.traversalCost * share;
                visit(node.index);
                visit(node.index + 1);
            }
        }
    } walk{bvh, Walk::area(bvh.nodes[0])};
    ASSERT_GT(walk.rootArea, 0.0);
    walk.visit(0);
    EXPECT_NEAR(bvh.stats.sahCost, walk.sah, 1e-9 * walk.sah);
    EXPECT_EQ(bvh.stats.leafCount, walk.leaves);
    EXPECT_EQ(bvh.stats.references, walk.refs);
    EXPECT_EQ(bvh.stats.references, bvh.primIndices.size());
    EXPECT_EQ(bvh.stats.primitives, triangles);
    EXPECT_DOUBLE_EQ(bvh.stats.avgPrimsPerLeaf, double(walk.refs) / double(walk.leaves));
    EXPECT_EQ(bvh.stats.bytes, bvh.nodes.size() * 32 + bvh.primIndices.size() * 4);
    EXPECT_EQ(computeBvhStats(bvh, bvh.options).sahCost, bvh.stats.sahCost);
}

// Rays from random points and towards vertices, edge midpoints and random triangle points.
struct TestRay {
    glm::vec3 origin, dir;
};
std::vector<TestRay> testRays(const Scene& scene, uint32_t count, uint32_t seed, glm::vec3 lift = glm::vec3(0.0f)) {
    std::mt19937 rng(seed);
    const Aabb bounds = scene.bounds();
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::uniform_int_distribution<uint32_t> pick(0, uint32_t(scene.triangleCount()) - 1);
    std::vector<TestRay> rays;
    for (uint32_t i = 0; i < count; ++i) {
        const glm::vec3 e = bounds.hi - bounds.lo;
        const glm::vec3 origin = bounds.lo - 0.25f * e + 1.5f * e * glm::vec3(unit(rng), unit(rng), unit(rng)) + lift;
        glm::vec3 target;
        const uint32_t prim = pick(rng);
        switch (i % 4) {
        case 0: rays.push_back({origin, randomDirection(rng)}); continue;
        case 1: target = scene.vertex(prim, i % 3); break;
        case 2: target = 0.5f * (scene.vertex(prim, 0) + scene.vertex(prim, 1)); break;
        default: {
            float u = unit(rng), v = unit(rng);
            if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
            target = scene.vertex(prim, 0) + u * (scene.vertex(prim, 1) - scene.vertex(prim, 0)) +
                     v * (scene.vertex(prim, 2) - scene.vertex(prim, 0));
        }
        }
        if (target == origin) continue;
        rays.push_back({origin, target - origin});
    }
    return rays;
}

// Closest hits (t and prim to the bit) and occlusion of the sah-split tree equal brute force
// (`brute`) or the sah-exact tree's.
void expectHitsMatch(const Scene& scene, const Bvh& split, uint32_t rayCount, bool brute,
                     glm::vec3 lift = glm::vec3(0.0f)) {
    BvhBuildOptions exactOptions;
    const Bvh exact = buildBvh(scene, exactOptions);
    const CpuSceneView splitView = makeCpuSceneView(scene, split);
    const CpuSceneView exactView = makeCpuSceneView(scene, exact);
    uint32_t hits = 0;
    for (const TestRay& ray : testRays(scene, rayCount, 5, lift)) {
        const ClosestHit got = traceClosestHit(splitView, ray.origin, ray.dir);
        BruteHit expected;
        if (brute) {
            expected = bruteClosest(scene, ray.origin, ray.dir);
        } else {
            const ClosestHit reference = traceClosestHit(exactView, ray.origin, ray.dir);
            expected = {reference.hit() ? reference.t : std::numeric_limits<float>::infinity(),
                        reference.hit() ? reference.prim : gpu::kNoHit};
        }
        ASSERT_EQ(got.hit(), expected.prim != gpu::kNoHit);
        if (!got.hit()) continue;
        ++hits;
        ASSERT_EQ(got.prim, expected.prim) << "t " << got.t << " vs " << expected.t;
        ASSERT_EQ(got.t, expected.t);
        const float tmax = got.t * 0.999f;
        ASSERT_EQ(traceOccluded(splitView, ray.origin, ray.dir, tmax),
                  traceOccluded(exactView, ray.origin, ray.dir, tmax));
        // Occlusion up to just beyond the hit, skipping the hit triangle: the twins of a tie occlude.
        // (Exactly at the hit's t the answer hangs on the rounding of t against the box entry
        // distance, which depends on which leaves the twins' parts are in.)
        if (brute) {
            const float beyond = got.t * 1.001f;
            ASSERT_EQ(traceOccluded(splitView, ray.origin, ray.dir, beyond, got.prim),
                      bruteOccluded(scene, ray.origin, ray.dir, beyond, got.prim));
        }
    }
    EXPECT_GT(hits, rayCount / 4) << "the rays must mostly hit for the comparison to mean anything";
}

Bvh buildOnThreads(int threads, const Scene& scene, const BvhBuildOptions& options) {
    tbb::task_arena arena(threads);
    return arena.execute([&] { return buildBvh(scene, options); });
}

bool identical(const Bvh& a, const Bvh& b) {
    return a.nodes.size() == b.nodes.size() && a.primIndices == b.primIndices &&
           std::memcmp(a.nodes.data(), b.nodes.data(), a.nodes.size() * sizeof(BvhNode)) == 0;
}

}  // namespace

TEST(BvhSplit, NameAndBuilderLists) {
    EXPECT_EQ(parseBvhBuilder("sah-split"), BvhBuilder::SahSplit);
    EXPECT_STREQ(toString(BvhBuilder::SahSplit), "sah-split");
    EXPECT_FALSE(referencesEachPrimitiveOnce(BvhBuilder::SahSplit));
    EXPECT_NE(std::find(std::begin(kAllBvhBuilders), std::end(kAllBvhBuilders), BvhBuilder::SahSplit),
              std::end(kAllBvhBuilders));
    for (BvhBuilder builder : kPartitioningBvhBuilders) EXPECT_TRUE(referencesEachPrimitiveOnce(builder));
}

TEST(BvhSplit, InvariantsOnRandomSoups) {
    for (uint32_t count : {3u, 17u, 400u, 6000u}) {
        for (uint32_t leafSize : {1u, 4u}) {
            SCOPED_TRACE("n=" + std::to_string(count) + " leaf size " + std::to_string(leafSize));
            const Scene scene = randomSoup(count, count + leafSize);
            const BvhBuildOptions options = splitOptions(leafSize);
            const Bvh bvh = buildBvh(scene, options);
            expectValidSplitTree(bvh, scene, options);
            expectStatsRecomputed(bvh, count);
            if (count >= 400) {
                EXPECT_GT(bvh.primIndices.size(), count) << "slivers must get spatial splits";
            }
        }
    }
}

// The budget bounds the references whatever it is; 1 means no spatial split at all.
TEST(BvhSplit, ReferencesWithinBudget) {
    const Scene scene = randomSoup(5000, 3);
    for (float budget : {1.0f, 1.05f, 1.3f, 2.0f}) {
        SCOPED_TRACE("budget " + std::to_string(budget));
        const BvhBuildOptions options = splitOptions(1, 0.0f, budget);
        const Bvh bvh = buildBvh(scene, options);
        EXPECT_LE(double(bvh.primIndices.size()), std::floor(5000.0 * budget));
        if (budget == 1.0f) {
            EXPECT_EQ(bvh.primIndices.size(), 5000u);
        }
        if (budget >= 1.3f) {
            EXPECT_GT(bvh.primIndices.size(), 5000u);
        }
        expectValidSplitTree(bvh, scene, options, 8);
    }
}

// Spatial splits lower the SAH cost of a sliver soup well below the object builders'.
TEST(BvhSplit, SahCostBelowObjectSplits) {
    const Scene scene = randomSoup(20000, 9);
    BvhBuildOptions exactOptions;
    const Bvh exact = buildBvh(scene, exactOptions);
    const Bvh split = buildBvh(scene, splitOptions());
    std::printf("  soup of 20000: SAH cost sah-exact %.3f, sah-split %.3f (%zu references)\n", exact.stats.sahCost,
                split.stats.sahCost, split.primIndices.size());
    EXPECT_LT(split.stats.sahCost, 0.9 * exact.stats.sahCost);
    // A larger alpha tries spatial splits at fewer nodes: never more references.
    const Bvh lax = buildBvh(scene, splitOptions(1, 1e-2f));
    EXPECT_LE(lax.primIndices.size(), split.primIndices.size());
}

TEST(BvhSplit, HitsEqualBruteForceOnRandomSoups) {
    for (uint32_t seed : {1u, 2u}) {
        const Scene scene = randomSoup(1500, seed);
        for (uint32_t leafSize : {1u, 4u}) {
            SCOPED_TRACE("seed " + std::to_string(seed) + " leaf size " + std::to_string(leafSize));
            const Bvh bvh = buildBvh(scene, splitOptions(leafSize, 0.0f, 2.0f));
            ASSERT_GT(bvh.primIndices.size(), scene.triangleCount());
            expectHitsMatch(scene, bvh, 3000, true);
        }
    }
}

// Coincident twins (the same three vertices in the same order, so the same t to the bit, different
// indices) across split planes: the duplicated references must not change the winner of a t tie,
// the lower index (gpu::isCloserHit).
TEST(BvhSplit, PrimTiesKeepTheLowerIndex) {
    Scene scene;
    scene.source = "twins";
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> coord(-8.0f, 8.0f);
    for (uint32_t i = 0; i < 600; ++i) {
        // Each pair of twins in a plane of its own: the only t ties are the twins' (overlapping
        // coplanar triangles of different vertices would tie in exact arithmetic only, and which of
        // them wins depends on the rounding of t, the "accurate t" item of issue 15).
        const float z = float(i) * 0.01f;
        const uint32_t base = uint32_t(scene.positions.size());
        const glm::vec3 a(coord(rng), coord(rng), z);
        scene.positions.push_back(a);
        scene.positions.push_back(a + glm::vec3(12.0f, 1.0f, 0.0f));  // long: crosses many planes
        scene.positions.push_back(a + glm::vec3(0.5f, 3.0f, 0.0f));
        scene.triangles.push_back(glm::uvec3(base, base + 1, base + 2));
        if (i % 3 == 0) scene.triangles.push_back(glm::uvec3(base, base + 1, base + 2));  // a twin
    }
    std::reverse(scene.triangles.begin(), scene.triangles.end());  // twins on both sides in index order
    const Bvh bvh = buildBvh(scene, splitOptions(1, 0.0f, 2.0f));
    ASSERT_GT(bvh.primIndices.size(), scene.triangleCount());
    expectValidSplitTree(bvh, scene, splitOptions(1, 0.0f, 2.0f), 8);
    expectHitsMatch(scene, bvh, 3000, true);
}

// The GPU layout duplicates each referenced triangle into leaf order; its file-order indices are
// the references.
TEST(BvhSplit, GpuLayoutDuplicatesReferencedTriangles) {
    const Scene scene = randomSoup(3000, 6);
    const Bvh bvh = buildBvh(scene, splitOptions(2, 0.0f, 1.5f));
    ASSERT_GT(bvh.primIndices.size(), scene.triangleCount());
    const GpuLayout layout = makeGpuLayout(scene, bvh);
    ASSERT_EQ(layout.triangles.size(), bvh.primIndices.size());
    ASSERT_EQ(layout.nodes.size(), bvh.nodes.size());
    std::vector<uint32_t> leafOrder;
    std::vector<uint32_t> stack{0};
    while (!stack.empty()) {
        const BvhNode& node = bvh.nodes[stack.back()];
        stack.pop_back();
        if (node.isLeaf()) {
            for (uint32_t k = 0; k < node.count; ++k) leafOrder.push_back(bvh.primIndices[node.index + k]);
        } else {
            stack.push_back(node.index + 1);
            stack.push_back(node.index);
        }
    }
    ASSERT_EQ(layout.leafToFile, leafOrder);
    for (size_t slot = 0; slot < layout.triangles.size(); ++slot) {
        const uint32_t tri = layout.leafToFile[slot];
        ASSERT_EQ(glm::vec3(layout.triangles[slot].v0), scene.vertex(tri, 0));
        ASSERT_EQ(glm::vec3(layout.triangles[slot].v2), scene.vertex(tri, 2));
    }
}

TEST(BvhSplit, SameTreeOnOneAndTwoThreads) {
    const Scene scene = randomSoup(60000, 99);
    const BvhBuildOptions options = splitOptions();
    const Bvh one = buildOnThreads(1, scene, options);
    const Bvh two = buildOnThreads(2, scene, options);
    const Bvh again = buildOnThreads(2, scene, options);
    EXPECT_GT(one.primIndices.size(), scene.triangleCount());
    EXPECT_TRUE(identical(one, two));
    EXPECT_TRUE(identical(two, again));
    expectValidSplitTree(two, scene, options, 6);
}

// Without triangles the primitive boxes are chopped: still a valid tree whose leaves cover every
// primitive box.
TEST(BvhSplit, BoxesOnlyChopsBoxes) {
    const Scene scene = randomSoup(3000, 8);
    const PrimitiveBounds bounds = trianglePrimitiveBounds(scene);
    const Bvh bvh = buildBvh(bounds, splitOptions(1, 0.0f));
    expectValidSplitTree(bvh, scene, splitOptions(1, 0.0f));
    expectStatsRecomputed(bvh, scene.triangleCount());
}

TEST(BvhSplit, ZeroOneAndTwoTriangles) {
    for (uint32_t count : {0u, 1u, 2u}) {
        SCOPED_TRACE(count);
        const Scene scene = randomSoup(count, 1);
        BuildProgress progress;
        const Bvh bvh = buildBvh(scene, splitOptions(), &progress);
        expectValidSplitTree(bvh, scene, splitOptions());
        EXPECT_EQ(progress.done.load(), count);
        if (count == 0) {
            EXPECT_EQ(bvh.stats.sahCost, 0.0);
        }
        if (count == 1) {
            EXPECT_EQ(bvh.nodes.size(), 1u);
        }
    }
}

// All triangles in one plane (the z extent 0), on one line and in one point.
TEST(BvhSplit, DegenerateInputs) {
    Scene plane = randomSoup(3000, 12);
    for (glm::vec3& p : plane.positions) p.z = 2.5f;
    Bvh bvh = buildBvh(plane, splitOptions(1, 0.0f));
    expectValidSplitTree(bvh, plane, splitOptions(1, 0.0f));
    expectHitsMatch(plane, bvh, 1500, true, glm::vec3(0.0f, 0.0f, 4.0f));  // origins above the plane

    Scene line = randomSoup(2000, 13);
    for (glm::vec3& p : line.positions) p = glm::vec3(p.x, 0.0f, 0.0f);
    bvh = buildBvh(line, splitOptions(1, 0.0f));
    expectValidSplitTree(bvh, line, splitOptions(1, 0.0f));
    EXPECT_EQ(bvh.primIndices.size(), line.triangleCount()) << "no area: no spatial split";

    Scene point = randomSoup(2500, 14);
    for (glm::vec3& p : point.positions) p = glm::vec3(1.0f, 2.0f, 3.0f);
    bvh = buildBvh(point, splitOptions());
    expectValidSplitTree(bvh, point, splitOptions());
    for (const BvhNode& node : bvh.nodes) EXPECT_LE(node.count, kMaxLeafPrimitives);
}

// Scaling by a power of two is exact; every plane, clip and cost scales with it, so coordinates
// near 1e30 and 1e-30 give exactly the unscaled tree (no overflow or underflow in planes or areas).
TEST(BvhSplit, HugeAndTinyCoordinates) {
    const Scene base = randomSoup(4000, 11, 1.0f);
    const BvhBuildOptions options = splitOptions(1, 0.0f);
    const Bvh reference = buildBvh(base, options);
    ASSERT_GT(reference.primIndices.size(), base.triangleCount());
    for (int exponent : {100, -100}) {
        SCOPED_TRACE("scale 2^" + std::to_string(exponent));
        Scene scaled = base;
        for (glm::vec3& p : scaled.positions)
            p = glm::vec3(std::ldexp(p.x, exponent), std::ldexp(p.y, exponent), std::ldexp(p.z, exponent));
        const Bvh bvh = buildBvh(scaled, options);
        expectValidSplitTree(bvh, scaled, options, 8);
        EXPECT_EQ(bvh.primIndices, reference.primIndices);
        ASSERT_EQ(bvh.nodes.size(), reference.nodes.size());
        for (size_t i = 0; i < bvh.nodes.size(); ++i) {
            ASSERT_EQ(bvh.nodes[i].index, reference.nodes[i].index);
            ASSERT_EQ(bvh.nodes[i].count, reference.nodes[i].count);
        }
        EXPECT_DOUBLE_EQ(bvh.stats.sahCost, reference.stats.sahCost);
    }
}

TEST(BvhSplit, BadOptionsThrow) {
    const Scene scene = randomSoup(100, 1);
    for (float alpha : {-1e-3f, 2.0f, std::nanf("")})
        EXPECT_THROW(buildBvh(scene, splitOptions(1, alpha)), Error) << alpha;
    for (float budget : {0.5f, 0.99f, 5.0f, INFINITY, std::nanf("")}) {
        try {
            buildBvh(scene, splitOptions(1, 1e-5f, budget));
            ADD_FAILURE() << "budget " << budget << " must throw";
        } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find("splitBudget"), std::string::npos) << error.what();
        }
    }
    const PrimitiveBounds bounds = trianglePrimitiveBounds(scene);
    const BvhTriangles wrong{scene.positions, std::span(scene.triangles).first(50)};
    EXPECT_THROW(buildBvh(bounds, splitOptions(), nullptr, &wrong), Error);
}

TEST(BvhSplit, ProgressAndCancellation) {
    const Scene scene = randomSoup(50000, 4);
    BuildProgress progress;
    const Bvh bvh = buildBvh(scene, splitOptions(), &progress);
    EXPECT_GT(bvh.primIndices.size(), scene.triangleCount());
    EXPECT_EQ(progress.total.load(), scene.triangleCount());
    EXPECT_EQ(progress.done.load(), scene.triangleCount()) << "one primary reference per triangle";

    BuildProgress before;
    before.cancel = true;
    EXPECT_THROW(buildBvh(scene, splitOptions(), &before), BuildCancelled);

    const Scene large = randomSoup(1'000'000, 8);
    for (int delayMs : {5, 150})
        test::expectCancelledQuickly("sah-split", delayMs,
                                     [&](BuildProgress* progress) { buildBvh(large, splitOptions(), progress); });
}

// Shared scenes, when present: invariants, hits equal to the sah-exact tree's, and the SAH cost.
TEST(BvhSplit, SharedScenes) {
    const std::filesystem::path root = RAYPACK_SHARED_SCENES;
    const std::filesystem::path path = root / "sibenik/sibenik_geom_75284.ply";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path;
    const Scene scene = loadScene(path);
    const BvhBuildOptions options = splitOptions();
    const Bvh bvh = buildBvh(scene, options);
    expectValidSplitTree(bvh, scene, options, 8);
    expectStatsRecomputed(bvh, scene.triangleCount());
    expectHitsMatch(scene, bvh, 4000, false);
    BvhBuildOptions exactOptions;
    const Bvh exact = buildBvh(scene, exactOptions);
    std::printf("  Sibenik: SAH cost sah-exact %.3f, sah-split %.3f, %.3f references per triangle\n",
                exact.stats.sahCost, bvh.stats.sahCost, double(bvh.primIndices.size()) / scene.triangleCount());
    EXPECT_LT(bvh.stats.sahCost, exact.stats.sahCost);
}

// The options travel through the settings JSON exactly and are checked there; the CLI's stats
// command takes the builder and both flags and reports references apart from triangles.
TEST(BvhSplit, OptionsInSettingsJsonAndCli) {
    BvhBuildOptions options = splitOptions(2, 3e-4f, 1.7f);
    const BvhBuildOptions back = bvhBuildOptionsFromJson(toJson(options));
    EXPECT_EQ(back.builder, BvhBuilder::SahSplit);
    EXPECT_EQ(back.splitAlpha, options.splitAlpha);
    EXPECT_EQ(back.splitBudget, options.splitBudget);
    for (const char* bad :
         {R"({"split_alpha": -1})", R"({"split_alpha": 2})", R"({"split_budget": 0.5})", R"({"split_budget": 9})"}) {
        try {
            bvhBuildOptionsFromJson(nlohmann::json::parse(bad));
            ADD_FAILURE() << bad << " must throw";
        } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find("bvh.split_"), std::string::npos) << error.what();
        }
    }

    const test::CliResult result =
        test::runCli("stats gen:sphereflake:20000 --builder sah-split --split-alpha 0 --split-budget 1.5 --json");
    ASSERT_EQ(result.exitCode, 0) << result.output;
    const nlohmann::json row = nlohmann::json::parse(result.output);
    EXPECT_EQ(row.at("builder"), "sah-split");
    const uint64_t triangles = row.at("triangles").get<uint64_t>();
    const uint64_t references = row.at("triangle_references").get<uint64_t>();
    EXPECT_GE(references, triangles);
    EXPECT_LE(double(references), std::floor(double(triangles) * 1.5));
    EXPECT_DOUBLE_EQ(row.at("references_per_triangle").get<double>(), double(references) / double(triangles));
    EXPECT_EQ(row.at("bvh_bytes").get<uint64_t>(), row.at("nodes").get<uint64_t>() * 32 + references * 4);
    EXPECT_EQ(test::runCli("stats gen:sphereflake:2000 --builder sah-split --split-budget 0.5").exitCode, 2);
    EXPECT_EQ(test::runCli("stats gen:sphereflake:2000 --builder sah-split --split-alpha 3").exitCode, 2);
}

// With a budget of 1 no reference can be split, and the object splits are sah-exact's (every
// centroid, ties by triangle index, the same cost and tie rules): the very tree of sah-exact, each
// leaf listing the same triangles (in file order here, in x-centroid order there).
TEST(BvhSplit, BudgetOneIsTheExactTree) {
    for (uint32_t leafSize : {1u, 3u}) {
        const Scene scene = randomSoup(4000, 21 + leafSize);
        BvhBuildOptions exactOptions;
        exactOptions.leafSize = leafSize;
        const Bvh exact = buildBvh(scene, exactOptions);
        const Bvh split = buildBvh(scene, splitOptions(leafSize, 1e-5f, 1.0f));
        ASSERT_EQ(split.nodes.size(), exact.nodes.size());
        for (size_t i = 0; i < split.nodes.size(); ++i) {
            const BvhNode& a = split.nodes[i];
            const BvhNode& b = exact.nodes[i];
            ASSERT_EQ(a.lo, b.lo) << "node " << i;
            ASSERT_EQ(a.hi, b.hi) << "node " << i;
            ASSERT_EQ(a.count, b.count) << "node " << i;
            if (a.isLeaf()) {
                std::vector<uint32_t> x(split.primIndices.begin() + a.index,
                                        split.primIndices.begin() + a.index + a.count);
                std::vector<uint32_t> y(exact.primIndices.begin() + b.index,
                                        exact.primIndices.begin() + b.index + b.count);
                std::sort(y.begin(), y.end());
                ASSERT_EQ(x, y) << "leaf " << i;
            } else {
                ASSERT_EQ(a.index, b.index) << "node " << i;
            }
        }
        EXPECT_EQ(split.stats.sahCost, exact.stats.sahCost);
    }
}
