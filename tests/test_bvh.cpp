// BVH builders: structural invariants, statistics against an independent walk, the exact builder
// against a brute-force implementation of the same algorithm, determinism across thread counts,
// edge cases, bad input, progress and cancellation.
#include "cancel_latency.h"
#include "renderer/bvh.h"
#include "renderer/bvh_build.h"
#include "renderer/error.h"
#include "renderer/huge_pages.h"
#include "renderer/scene.h"
#include "scenes/load.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <numeric>
#include <random>

#if defined(__x86_64__)
#include <xmmintrin.h>
#endif

using namespace raypack;
using bvh_detail::centroidOf;
using bvh_detail::SahMeasure;

namespace {

BvhBuildOptions optionsFor(BvhBuilder builder, uint32_t leafSize = 1, float traversalCost = 1.0f,
                           float intersectionCost = 2.0f) {
    BvhBuildOptions options;
    options.builder = builder;
    options.leafSize = leafSize;
    options.traversalCost = traversalCost;
    options.intersectionCost = intersectionCost;
    return options;
}

Aabb triangleBox(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
    Aabb box;
    box.grow(a);
    box.grow(b);
    box.grow(c);
    return box;
}

// Random triangles of varied size in [0, extent]^3.
std::vector<Aabb> randomSoup(uint32_t count, uint32_t seed, float extent = 100.0f) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> position(0.0f, extent), size(0.0f, extent * 0.05f);
    std::vector<Aabb> boxes(count);
    for (Aabb& box : boxes) {
        const glm::vec3 a(position(rng), position(rng), position(rng));
        const float s = size(rng);
        const glm::vec3 b = a + glm::vec3(size(rng), s, 0.0f);
        const glm::vec3 c = a + glm::vec3(0.0f, size(rng), s);
        box = triangleBox(a, b, c);
    }
    return boxes;
}

// Triangles with corners on a small integer grid: many equal centroids and boxes, so every tie
// rule (sort order, equal costs) is exercised.
std::vector<Aabb> gridSoup(uint32_t count, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> cell(0, 3);
    std::vector<Aabb> boxes(count);
    for (Aabb& box : boxes) {
        auto corner = [&] { return glm::vec3(float(cell(rng)), float(cell(rng)), float(cell(rng))); };
        box = triangleBox(corner(), corner(), corner());
    }
    return boxes;
}

Aabb boxOf(const BvhNode& node) { return Aabb{node.lo, node.hi}; }
bool sameBox(const Aabb& a, const Aabb& b) { return a.lo == b.lo && a.hi == b.hi; }

// Walks the tree and checks every structural invariant. Returns the leaves' depths in walk order.
void expectValidTree(const Bvh& bvh, std::span<const Aabb> bounds) {
    ASSERT_FALSE(bvh.nodes.empty());
    const size_t n = bounds.size();
    ASSERT_EQ(bvh.primIndices.size(), n);
    if (n == 0) {
        EXPECT_TRUE(bvh.nodes[0].isLeaf());
        EXPECT_EQ(bvh.nodes[0].count, 0u);
        EXPECT_EQ(bvh.nodes.size(), 1u);
        return;
    }
    std::vector<uint32_t> timesInLeaf(n, 0);
    std::vector<uint32_t> timesReached(bvh.nodes.size(), 0);
    std::vector<uint8_t> entryUsed(n, 0);
    std::vector<uint32_t> stack{0};
    timesReached[0] = 1;
    while (!stack.empty()) {
        const uint32_t index = stack.back();
        stack.pop_back();
        const BvhNode& node = bvh.nodes[index];
        if (node.isLeaf()) {
            ASSERT_GT(node.count, 0u) << "only the root of an empty tree may hold nothing";
            ASSERT_LE(uint64_t(node.index) + node.count, n);
            Aabb tight;
            for (uint32_t k = node.index; k < node.index + node.count; ++k) {
                ASSERT_EQ(entryUsed[k], 0) << "two leaves share primIndices entry " << k;
                entryUsed[k] = 1;
                const uint32_t prim = bvh.primIndices[k];
                ASSERT_LT(prim, n);
                ++timesInLeaf[prim];
                EXPECT_TRUE(boxOf(node).contains(bounds[prim])) << "leaf " << index << " prim " << prim;
                tight.grow(bounds[prim]);
            }
            EXPECT_TRUE(sameBox(tight, boxOf(node))) << "leaf box is not its primitives' union";
        } else {
            ASSERT_GE(node.index, 1u);
            ASSERT_LT(node.index + 1, bvh.nodes.size());
            const BvhNode& left = bvh.nodes[node.index];
            const BvhNode& right = bvh.nodes[node.index + 1];
            EXPECT_TRUE(boxOf(node).contains(boxOf(left))) << "node " << node.index;
            EXPECT_TRUE(boxOf(node).contains(boxOf(right))) << "node " << node.index + 1;
            Aabb tight = boxOf(left);
            tight.grow(boxOf(right));
            EXPECT_TRUE(sameBox(tight, boxOf(node))) << "inner box is not its children's union";
            for (uint32_t child : {node.index, node.index + 1}) {
                ASSERT_EQ(timesReached[child]++, 0u) << "node " << child << " has two parents";
                stack.push_back(child);
            }
        }
    }
    for (size_t prim = 0; prim < n; ++prim)
        ASSERT_EQ(timesInLeaf[prim], 1u) << "primitive " << prim << " is in " << timesInLeaf[prim] << " leaves";
    for (size_t node = 0; node < bvh.nodes.size(); ++node)
        ASSERT_EQ(timesReached[node], 1u) << "node " << node << " is unreachable";
}

// Statistics recomputed by a recursive walk, independent of computeBvhStats' stack walk; the SAH
// cost with areas computed here (the trees under test have roots of positive area).
void expectStatsMatchWalk(const Bvh& bvh) {
    struct Walk {
        const Bvh& bvh;
        double rootArea;
        uint64_t leaves = 0, depthSum = 0, prims = 0, nodes = 0;
        uint32_t maxDepth = 0;
        double sah = 0.0;
        static double area(const BvhNode& node) {
            const double x = double(node.hi.x) - node.lo.x, y = double(node.hi.y) - node.lo.y,
                         z = double(node.hi.z) - node.lo.z;
            return 2.0 * (x * y + y * z + z * x);
        }
        void visit(uint32_t index, uint32_t depth) {
            const BvhNode& node = bvh.nodes[index];
            ++nodes;
            const double share = area(node) / rootArea;
            if (node.isLeaf()) {
                ++leaves;
                depthSum += depth;
                maxDepth = std::max(maxDepth, depth);
                prims += node.count;
                sah += bvh.options.intersectionCost * node.count * share;
            } else {
                sah += bvh.options.traversalCost * share;
                visit(node.index, depth + 1);
                visit(node.index + 1, depth + 1);
            }
        }
    } walk{bvh, Walk::area(bvh.nodes[0])};
    ASSERT_GT(walk.rootArea, 0.0);
    walk.visit(0, 0);
    const BvhStats& stats = bvh.stats;
    EXPECT_EQ(stats.nodeCount, walk.nodes);
    EXPECT_EQ(stats.nodeCount, bvh.nodes.size());
    EXPECT_EQ(stats.leafCount, walk.leaves);
    EXPECT_EQ(stats.maxLeafDepth, walk.maxDepth);
    EXPECT_DOUBLE_EQ(stats.avgLeafDepth, double(walk.depthSum) / double(walk.leaves));
    EXPECT_DOUBLE_EQ(stats.avgPrimsPerLeaf, double(walk.prims) / double(walk.leaves));
    EXPECT_NEAR(stats.sahCost, walk.sah, 1e-9 * walk.sah);
    EXPECT_EQ(stats.bytes, bvh.nodes.size() * 32 + bvh.primIndices.size() * 4);
    EXPECT_EQ(stats.leafCount, (stats.nodeCount + 1) / 2) << "a binary tree has N_L = (nodes+1)/2";
    // What buildBvh stored equals a fresh computation.
    const BvhStats fresh = computeBvhStats(bvh, bvh.options);
    EXPECT_EQ(fresh.sahCost, stats.sahCost);
    EXPECT_EQ(fresh.leafCount, stats.leafCount);
}

// ---- The brute-force reference: the report's algorithm written the slow, obvious way. Each node
// sorts its primitives afresh per axis (by centroid, then index) and computes both boxes of every
// candidate split by looping over the primitives, O(N^2) per axis.
struct RefNode {
    Aabb box;
    std::vector<uint32_t> prims;  // leaves only, ordered by (centroid x, index)
    std::unique_ptr<RefNode> left, right;
};

std::unique_ptr<RefNode> referenceBuild(std::span<const Aabb> bounds, std::vector<uint32_t> prims,
                                        const BvhBuildOptions& options) {
    auto node = std::make_unique<RefNode>();
    for (uint32_t p : prims) node->box.grow(bounds[p]);
    auto sortedOn = [&](int axis) {
        std::vector<uint32_t> sorted = prims;
        std::sort(sorted.begin(), sorted.end(), [&](uint32_t a, uint32_t b) {
            const float ca = centroidOf(bounds[a])[axis], cb = centroidOf(bounds[b])[axis];
            return ca < cb || (ca == cb && a < b);
        });
        return sorted;
    };
    const uint32_t count = uint32_t(prims.size());
    auto makeLeaf = [&] {
        node->prims = sortedOn(0);
        return std::move(node);
    };
    if (count <= options.leafSize) return makeLeaf();

    const SahMeasure measure = SahMeasure::forParent(node->box);
    double best = std::numeric_limits<double>::infinity();
    std::vector<uint32_t> bestLeft, bestRight;
    for (int axis = 0; axis < 3; ++axis) {
        const std::vector<uint32_t> sorted = sortedOn(axis);
        for (uint32_t split = 1; split < count; ++split) {
            Aabb left, right;
            for (uint32_t k = 0; k < split; ++k) left.grow(bounds[sorted[k]]);
            for (uint32_t k = split; k < count; ++k) right.grow(bounds[sorted[k]]);
            const double weighted = measure.of(left) * double(split) + measure.of(right) * double(count - split);
            if (weighted < best) {
                best = weighted;
                bestLeft.assign(sorted.begin(), sorted.begin() + split);
                bestRight.assign(sorted.begin() + split, sorted.end());
            }
        }
    }
    const double cost = bvh_detail::splitCost(best, measure.of(node->box), options);
    if (!(cost < bvh_detail::leafCost(count, options))) return makeLeaf();
    node->left = referenceBuild(bounds, bestLeft, options);
    node->right = referenceBuild(bounds, bestRight, options);
    return node;
}

void expectSameTree(const RefNode& ref, const Bvh& bvh, uint32_t index, int depth = 0) {
    const BvhNode& node = bvh.nodes[index];
    ASSERT_TRUE(sameBox(ref.box, boxOf(node))) << "node " << index << " depth " << depth;
    ASSERT_EQ(ref.left == nullptr, node.isLeaf()) << "node " << index << " depth " << depth;
    if (node.isLeaf()) {
        const std::vector<uint32_t> prims(bvh.primIndices.begin() + node.index,
                                          bvh.primIndices.begin() + node.index + node.count);
        ASSERT_EQ(prims, ref.prims) << "leaf " << index << " depth " << depth;
        return;
    }
    expectSameTree(*ref.left, bvh, node.index, depth + 1);
    expectSameTree(*ref.right, bvh, node.index + 1, depth + 1);
}

void expectMatchesReference(std::span<const Aabb> bounds, const BvhBuildOptions& options) {
    const Bvh bvh = buildBvh(bounds, options);
    std::vector<uint32_t> all(bounds.size());
    std::iota(all.begin(), all.end(), 0u);
    const std::unique_ptr<RefNode> ref = referenceBuild(bounds, all, options);
    expectSameTree(*ref, bvh, 0);
}

Bvh buildOnThreads(int threads, std::span<const Aabb> bounds, const BvhBuildOptions& options) {
    tbb::task_arena arena(threads);
    return arena.execute([&] { return buildBvh(bounds, options); });
}

bool identical(const Bvh& a, const Bvh& b) {
    return a.nodes.size() == b.nodes.size() && a.primIndices == b.primIndices &&
           std::memcmp(a.nodes.data(), b.nodes.data(), a.nodes.size() * sizeof(BvhNode)) == 0;
}

}  // namespace

TEST(BvhBuilderNames, RoundTripAndRejectUnknown) {
    for (BvhBuilder builder : kAllBvhBuilders) EXPECT_EQ(parseBvhBuilder(toString(builder)), builder);
    try {
        parseBvhBuilder("sah-fast");
        FAIL() << "an unknown name must throw";
    } catch (const Error& error) {
        const std::string message = error.what();
        EXPECT_NE(message.find("sah-fast"), std::string::npos) << message;
        EXPECT_NE(message.find("sah-exact"), std::string::npos) << message;
        EXPECT_NE(message.find("sah-binned"), std::string::npos) << message;
    }
}

TEST(BvhExact, MatchesBruteForceReference) {
    for (uint32_t seed = 1; seed <= 6; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        expectMatchesReference(randomSoup(150, seed), optionsFor(BvhBuilder::SahExact));
        expectMatchesReference(randomSoup(120, seed), optionsFor(BvhBuilder::SahExact, 2, 1, 1));
        expectMatchesReference(randomSoup(100, seed), optionsFor(BvhBuilder::SahExact, 4, 1, 4));
        expectMatchesReference(gridSoup(120, seed), optionsFor(BvhBuilder::SahExact));
        expectMatchesReference(gridSoup(90, seed), optionsFor(BvhBuilder::SahExact, 3, 2, 1));
    }
}

TEST(BvhExact, InvariantsAndStatsOnRandomSoups) {
    for (uint32_t count : {2u, 3u, 17u, 1000u, 30000u}) {
        const std::vector<Aabb> bounds = randomSoup(count, count);
        for (BvhBuilder builder : kPartitioningBvhBuilders) {
            SCOPED_TRACE(std::string(toString(builder)) + " n=" + std::to_string(count));
            const Bvh bvh = buildBvh(bounds, optionsFor(builder));
            expectValidTree(bvh, bounds);
            expectStatsMatchWalk(bvh);
        }
    }
}

TEST(BvhExact, GridSoupWithManyTies) {
    const std::vector<Aabb> bounds = gridSoup(20000, 7);
    for (BvhBuilder builder : kPartitioningBvhBuilders) {
        SCOPED_TRACE(toString(builder));
        const Bvh bvh = buildBvh(bounds, optionsFor(builder));
        expectValidTree(bvh, bounds);
        expectStatsMatchWalk(bvh);
    }
}

// Above kFragmentMinPrimitives and the parallel-node threshold, so fragments, tasks and the
// parallel sweeps, binning and partitions all take part.
TEST(BvhDeterminism, SameTreeOnOneAndTwoThreads) {
    const std::vector<Aabb> bounds = randomSoup(150000, 99);
    for (BvhBuilder builder : kPartitioningBvhBuilders) {
        SCOPED_TRACE(toString(builder));
        const Bvh one = buildOnThreads(1, bounds, optionsFor(builder));
        const Bvh two = buildOnThreads(2, bounds, optionsFor(builder));
        const Bvh again = buildOnThreads(2, bounds, optionsFor(builder));
        EXPECT_TRUE(identical(one, two));
        EXPECT_TRUE(identical(two, again));
        expectValidTree(two, bounds);
    }
}

TEST(BvhEdgeCases, ZeroPrimitives) {
    for (BvhBuilder builder : kCpuBvhBuilders) {
        const Bvh bvh = buildBvh(std::span<const Aabb>(), optionsFor(builder));
        ASSERT_EQ(bvh.nodes.size(), 1u);
        EXPECT_TRUE(bvh.nodes[0].isLeaf());
        EXPECT_EQ(bvh.nodes[0].count, 0u);
        EXPECT_TRUE(boxOf(bvh.nodes[0]).empty());
        EXPECT_TRUE(bvh.primIndices.empty());
        EXPECT_EQ(bvh.stats.leafCount, 1u);
        EXPECT_EQ(bvh.stats.maxLeafDepth, 0u);
        EXPECT_EQ(bvh.stats.sahCost, 0.0);
    }
}

TEST(BvhEdgeCases, OnePrimitive) {
    const std::vector<Aabb> bounds = randomSoup(1, 5);
    for (BvhBuilder builder : kPartitioningBvhBuilders) {
        const Bvh bvh = buildBvh(bounds, optionsFor(builder));
        expectValidTree(bvh, bounds);
        ASSERT_EQ(bvh.nodes.size(), 1u);
        EXPECT_EQ(bvh.nodes[0].count, 1u);
        EXPECT_EQ(bvh.stats.avgPrimsPerLeaf, 1.0);
    }
}

// Identical boxes: every split costs C_trav + N·C_isect, more than the leaf, so the SAH would make
// one leaf of all of them; a leaf may hold at most kMaxLeafPrimitives (what the GPU kernels can
// trace, issue 11), so both builders split at the median until the leaves fit.
TEST(BvhEdgeCases, AllCentroidsEqualIdenticalBoxes) {
    const Aabb box{glm::vec3(1, 2, 3), glm::vec3(2, 4, 5)};
    const std::vector<Aabb> bounds(5000, box);
    for (BvhBuilder builder : kPartitioningBvhBuilders) {
        const Bvh bvh = buildBvh(bounds, optionsFor(builder));
        expectValidTree(bvh, bounds);
        EXPECT_EQ(bvh.stats.leafCount, 8u);  // 5000 halved three times: 625 per leaf
        for (const BvhNode& node : bvh.nodes) EXPECT_LE(node.count, kMaxLeafPrimitives);
    }
}

// Equal centroids but nested boxes of different sizes: the exact builder may still split by
// sorted position (ties by index); both must terminate with a valid tree.
TEST(BvhEdgeCases, AllCentroidsEqualNestedBoxes) {
    std::vector<Aabb> bounds;
    for (int i = 0; i < 3000; ++i) {
        const float r = 1.0f + float(i % 37);
        bounds.push_back({glm::vec3(-r), glm::vec3(r)});
    }
    for (BvhBuilder builder : kPartitioningBvhBuilders) {
        const Bvh bvh = buildBvh(bounds, optionsFor(builder));
        expectValidTree(bvh, bounds);
    }
    expectMatchesReference(std::span(bounds).first(120), optionsFor(BvhBuilder::SahExact));
}

// Degenerate triangles: all on one line (boxes of zero area: the SAH falls back to lengths), all
// in one point (one leaf), and zero-area triangles spread in space (flat boxes).
TEST(BvhEdgeCases, DegenerateTriangles) {
    std::vector<Aabb> onLine, onePoint, flat;
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> t(0.0f, 100.0f);
    for (int i = 0; i < 4000; ++i) {
        const float a = t(rng), b = a + t(rng) * 0.01f;
        onLine.push_back(triangleBox(glm::vec3(a, 0, 0), glm::vec3(b, 0, 0), glm::vec3(a, 0, 0)));
        onePoint.push_back(triangleBox(glm::vec3(5), glm::vec3(5), glm::vec3(5)));
        const glm::vec3 p(t(rng), t(rng), t(rng));
        flat.push_back(triangleBox(p, p + glm::vec3(1, 0, 0), p + glm::vec3(2, 0, 0)));
    }
    for (BvhBuilder builder : kPartitioningBvhBuilders) {
        SCOPED_TRACE(toString(builder));
        const Bvh line = buildBvh(onLine, optionsFor(builder));
        expectValidTree(line, onLine);
        EXPECT_GT(line.stats.leafCount, 1000u) << "a line of segments still splits (by length)";
        EXPECT_TRUE(std::isfinite(line.stats.sahCost));

        const Bvh point = buildBvh(onePoint, optionsFor(builder));
        expectValidTree(point, onePoint);
        EXPECT_EQ(point.stats.leafCount, 4u);  // median splits down to at most kMaxLeafPrimitives

        const Bvh spread = buildBvh(flat, optionsFor(builder));
        expectValidTree(spread, flat);
        expectStatsMatchWalk(spread);
    }
    expectMatchesReference(std::span(onLine).first(150), optionsFor(BvhBuilder::SahExact));
}

// Scaling every coordinate by a power of two is exact in float and double, and the SAH is scale
// invariant, so coordinates near 1e30 and 1e-30 must give exactly the tree of the unscaled input:
// no overflow or underflow anywhere in the cost.
TEST(BvhEdgeCases, HugeAndTinyCoordinates) {
    const std::vector<Aabb> base = randomSoup(20000, 11, 1.0f);
    for (int exponent : {100, -100}) {
        SCOPED_TRACE("scale 2^" + std::to_string(exponent));
        std::vector<Aabb> scaled = base;
        for (Aabb& box : scaled) {
            box.lo = glm::vec3(std::ldexp(box.lo.x, exponent), std::ldexp(box.lo.y, exponent),
                               std::ldexp(box.lo.z, exponent));
            box.hi = glm::vec3(std::ldexp(box.hi.x, exponent), std::ldexp(box.hi.y, exponent),
                               std::ldexp(box.hi.z, exponent));
        }
        for (BvhBuilder builder : kPartitioningBvhBuilders) {
            SCOPED_TRACE(toString(builder));
            const Bvh reference = buildBvh(base, optionsFor(builder));
            const Bvh bvh = buildBvh(scaled, optionsFor(builder));
            expectValidTree(bvh, scaled);
            EXPECT_EQ(bvh.primIndices, reference.primIndices);
            ASSERT_EQ(bvh.nodes.size(), reference.nodes.size());
            for (size_t i = 0; i < bvh.nodes.size(); ++i) {
                ASSERT_EQ(bvh.nodes[i].index, reference.nodes[i].index);
                ASSERT_EQ(bvh.nodes[i].count, reference.nodes[i].count);
            }
            EXPECT_DOUBLE_EQ(bvh.stats.sahCost, reference.stats.sahCost);
            EXPECT_GT(bvh.stats.leafCount, 1000u);
        }
    }
}

TEST(BvhBadInput, NonFiniteOrEmptyBoxAndBadOptionsThrow) {
    // Every builder names the first bad primitive (sah-binned checks in its own first pass, in
    // ranges of kCancelCheckInterval: the bad boxes below lie in different ranges, the first one
    // not in the first range).
    std::vector<Aabb> bounds = randomSoup(100000, 1);
    const float kInf = std::numeric_limits<float>::infinity();
    for (BvhBuilder builder : kCpuBvhBuilders) {
        for (int kind = 0; kind < 5; ++kind) {
            std::vector<Aabb> bad = bounds;
            for (size_t at : {size_t(40000), size_t(90000), size_t(99999)}) {
                Aabb& box = bad[at];
                switch (kind) {
                case 0: box.hi.y = std::nanf(""); break;
                case 1: box.lo.z = std::nanf(""); break;
                case 2: box.hi.x = kInf; break;
                case 3: box.lo.x = -kInf; break;
                default: box = Aabb{}; break;  // empty
                }
            }
            try {
                buildBvh(bad, optionsFor(builder));
                FAIL() << "a bad box must throw (builder " << int(builder) << ", kind " << kind << ")";
            } catch (const Error& error) {
                EXPECT_NE(std::string(error.what()).find("primitive 40000 "), std::string::npos)
                    << "builder " << int(builder) << ", kind " << kind << ": " << error.what();
            }
        }
    }
    bounds.resize(100);

    BvhBuildOptions options;
    options.leafSize = 0;
    EXPECT_THROW(buildBvh(bounds, options), Error);
    options = {};
    options.intersectionCost = -1.0f;
    EXPECT_THROW(buildBvh(bounds, options), Error);
    options = {};
    options.builder = BvhBuilder::SahBinned;
    options.binCount = 1;
    EXPECT_THROW(buildBvh(bounds, options), Error);
}

TEST(BvhProgress, PlacedReachesTotal) {
    const std::vector<Aabb> bounds = randomSoup(100000, 4);
    for (BvhBuilder builder : kCpuBvhBuilders) {
        BuildProgress progress;
        buildBvh(bounds, optionsFor(builder), &progress);
        EXPECT_EQ(progress.total.load(), bounds.size());
        EXPECT_EQ(progress.done.load(), bounds.size());
    }
}

TEST(BvhCancel, CancelledBeforeStartThrows) {
    const std::vector<Aabb> bounds = randomSoup(1000, 4);
    for (BvhBuilder builder : kCpuBvhBuilders) {
        BuildProgress progress;
        progress.cancel = true;
        EXPECT_THROW(buildBvh(bounds, optionsFor(builder), &progress), BuildCancelled);
    }
}

// Cancels a multi-million-primitive build in flight (tests/cancel_latency.h).
TEST(BvhCancel, CancelledMidBuildStopsQuickly) {
    const std::vector<Aabb> bounds = randomSoup(3'000'000, 8);
    for (BvhBuilder builder : kCpuBvhBuilders)
        for (int delayMs : {5, 150})
            test::expectCancelledQuickly(toString(builder), delayMs, [&](BuildProgress* progress) {
                buildBvh(bounds, optionsFor(builder), progress);
            });
}

// allocateLarge's storage (the builders' scratch): aligned, all of it writable, on both sides of the
// 2 MiB bound where it becomes a mapping of its own; storage given back and taken again (a kept
// mapping, possibly larger than asked for) holds what is written into it; a container over it moves.
TEST(LargeStorage, AlignedWritableAndReusable) {
    const size_t twoMiB = size_t(2) << 20;
    for (const size_t bytes : {size_t(1), size_t(4096), twoMiB - 1, twoMiB, twoMiB + 1, 3 * twoMiB + 12345}) {
        SCOPED_TRACE(bytes);
        for (int round = 0; round < 3; ++round) {  // the later rounds may reuse the first's storage
            unsigned char* const data = static_cast<unsigned char*>(allocateLarge(bytes));
            ASSERT_NE(data, nullptr);
            EXPECT_EQ(reinterpret_cast<uintptr_t>(data) % 64, 0u);
            for (size_t at = 0; at < bytes; at += 997) data[at] = static_cast<unsigned char>(at * 7 + round);
            data[bytes - 1] = 0xA5;
            for (size_t at = 0; at < bytes - 1; at += 997)
                ASSERT_EQ(data[at], static_cast<unsigned char>(at * 7 + round)) << at;
            EXPECT_EQ(data[bytes - 1], 0xA5);
            freeLarge(data, bytes);
        }
    }
    // A larger request after a smaller one was given back, and the other way round.
    for (const size_t bytes : {5 * twoMiB, 9 * twoMiB, 4 * twoMiB + 1}) {
        std::vector<uint64_t*> held;
        for (int k = 0; k < 3; ++k) {
            uint64_t* const data = static_cast<uint64_t*>(allocateLarge(bytes));
            const size_t words = bytes / sizeof(uint64_t);
            for (size_t i = 0; i < words; i += 511) data[i] = i ^ uint64_t(k);
            for (size_t i = 0; i < words; i += 511) ASSERT_EQ(data[i], i ^ uint64_t(k));
            held.push_back(data);
        }
        for (uint64_t* data : held) freeLarge(data, bytes);
    }
    freeLarge(nullptr, twoMiB);  // a no-op, as for operator delete

    // The containers over it (UninitializedAllocator: BvhNodes, PrimIndices, the builders' scratch).
    PrimIndices array(twoMiB);  // 8 MiB
    for (size_t i = 0; i < array.size(); i += 4096) array[i] = uint32_t(i);
    PrimIndices moved(std::move(array));
    EXPECT_EQ(array.data(), nullptr);
    EXPECT_EQ(array.size(), 0u);
    ASSERT_EQ(moved.size(), twoMiB);
    for (size_t i = 0; i < moved.size(); i += 4096) ASSERT_EQ(moved[i], uint32_t(i));
    PrimIndices assigned(16);
    assigned = std::move(moved);
    EXPECT_EQ(assigned.size(), twoMiB);
    EXPECT_EQ(assigned[4096], 4096u);
}

// The binned builder trades tree quality for speed; on a soup its SAH cost stays close to exact.
TEST(BvhBinned, SahCostCloseToExact) {
    const std::vector<Aabb> bounds = randomSoup(50000, 21);
    const Bvh exact = buildBvh(bounds, optionsFor(BvhBuilder::SahExact));
    const Bvh binned = buildBvh(bounds, optionsFor(BvhBuilder::SahBinned));
    EXPECT_GE(binned.stats.sahCost, exact.stats.sahCost * 0.95);
    EXPECT_LE(binned.stats.sahCost, exact.stats.sahCost * 1.15);
}

// sah-binned keeps its bins' counts in a float lane (bvh_sah_binned.cpp, Bin). A thread whose
// MXCSR flushes denormals to zero, as an application or a library (Embree's documentation asks for
// it) may set, builds the same tree.
TEST(BvhBinned, SameTreeWhenDenormalsAreZero) {
#if defined(__x86_64__)
    const std::vector<Aabb> bounds = randomSoup(20000, 31);
    const BvhBuildOptions options = optionsFor(BvhBuilder::SahBinned);
    const Bvh reference = buildOnThreads(1, bounds, options);
    const unsigned int saved = _mm_getcsr();
    _mm_setcsr(saved | 0x8040u);  // flush to zero (bit 15), denormals are zero (bit 6)
    Bvh flushed;
    try {
        flushed = buildOnThreads(1, bounds, options);  // one thread: the calling one, with these settings
    } catch (...) {
        _mm_setcsr(saved);
        throw;
    }
    _mm_setcsr(saved);
    EXPECT_TRUE(identical(reference, flushed));
    expectValidTree(flushed, bounds);
#else
    GTEST_SKIP() << "MXCSR is x86-64's";
#endif
}

// Conference's floor and ceiling (four triangles spanning the room) share their centroid bins with
// small triangles; without the refined splits sah-binned's SAH cost was 1.059x sah-exact's there
// (docs/bvh.md). Issue 13's bound is 1.02x. The tree stays valid with refined partitions.
TEST(BvhSharedScenes, BinnedSahWithinTwoPercentOfExactOnConference) {
    const std::filesystem::path path = std::filesystem::path(RAYPACK_SHARED_SCENES) / "conference/conference_geom.ply";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path;
    const Scene scene = loadScene(path);
    const PrimitiveBounds bounds = trianglePrimitiveBounds(scene);
    const Bvh exact = buildBvh(bounds, optionsFor(BvhBuilder::SahExact));
    const Bvh binned = buildBvh(bounds, optionsFor(BvhBuilder::SahBinned));
    expectValidTree(binned, bounds);
    EXPECT_LE(binned.stats.sahCost, exact.stats.sahCost * 1.02);
}

// Real scenes from ../shared/scenes, when present: invariants and statistics for both builders,
// and O_AVG in the report's band [1, 2] with the default options.
TEST(BvhSharedScenes, InvariantsOnRealScenes) {
    const std::filesystem::path root = RAYPACK_SHARED_SCENES;
    int tested = 0;
    for (const char* file :
         {"sibenik/sibenik_geom_75284.ply", "stanford/dragon_vrip_res3.ply", "gltf/DamagedHelmet/DamagedHelmet.glb"}) {
        const std::filesystem::path path = root / file;
        if (!std::filesystem::exists(path)) continue;
        SCOPED_TRACE(file);
        const Scene scene = loadScene(path);
        const PrimitiveBounds bounds = trianglePrimitiveBounds(scene);
        double exactCost = 0.0;
        for (BvhBuilder builder : kPartitioningBvhBuilders) {
            SCOPED_TRACE(toString(builder));
            BvhBuildOptions options;
            options.builder = builder;
            const Bvh bvh = buildBvh(bounds, options);
            expectValidTree(bvh, bounds);
            expectStatsMatchWalk(bvh);
            EXPECT_GE(bvh.stats.avgPrimsPerLeaf, 1.0);
            EXPECT_LE(bvh.stats.avgPrimsPerLeaf, 2.0);
            if (builder == BvhBuilder::SahExact)
                exactCost = bvh.stats.sahCost;
            else
                EXPECT_LE(bvh.stats.sahCost, exactCost * 1.2);
        }
        ++tested;
    }
    if (tested == 0) GTEST_SKIP() << "no shared scenes under " << root;
}
