// BVH entry points, statistics and the pieces the builders share (see renderer/bvh_build.h).
#include "renderer/bvh.h"

#include "renderer/bvh_build.h"
#include "renderer/error.h"
#include "renderer/scene.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <new>
#include <string>

namespace raypack {

namespace bvh_detail {

BvhNodes assembleFragments(Fragment& root) {
    // Depth-first placement: each fragment's non-root nodes get a contiguous block; its root goes to
    // the slot its parent reserved for it (0 for the whole tree's root).
    struct Placement {
        Fragment* fragment;
        uint32_t rootSlot;  // global slot of local node 0
        uint32_t base;      // global slot of local node 1
    };
    std::vector<Placement> placements;
    uint32_t next = 1;
    auto place = [&](auto&& self, Fragment& fragment, uint32_t rootSlot) -> void {
        const uint32_t base = next;
        next += uint32_t(fragment.nodes.size()) - 1;
        placements.push_back({&fragment, rootSlot, base});
        for (auto& [slot, child] : fragment.links) self(self, *child, base + slot - 1);
    };
    place(place, root, 0);

    BvhNodes nodes = makeNodeArray(next);
    tbb::parallel_for(size_t(0), placements.size(), [&](size_t p) {
        const Placement& placement = placements[p];
        const std::vector<BvhNode>& local = placement.fragment->nodes;
        for (size_t j = 0; j < local.size(); ++j) {
            BvhNode node = local[j];
            if (node.count == kLinkPlaceholder) continue;  // the child fragment writes this slot
            if (node.count == 0) node.index = placement.base + node.index - 1;
            nodes[j == 0 ? placement.rootSlot : placement.base + j - 1] = node;
        }
    });
    return nodes;
}

void validateOptions(const BvhBuildOptions& options) {
    if (options.leafSize == 0) throw Error("BVH build: leafSize must be at least 1, got 0");
    if (options.leafSize > kMaxLeafPrimitives)
        throw Error("BVH build: leafSize must be at most " + std::to_string(kMaxLeafPrimitives) +
                    " (what a GPU ray can test within its traversal budget), got " + std::to_string(options.leafSize));
    auto checkCost = [](float cost, const char* name) {
        if (!(cost > 0.0f) || !std::isfinite(cost))
            throw Error(std::string("BVH build: ") + name + " must be positive and finite, got " +
                        std::to_string(cost));
    };
    checkCost(options.traversalCost, "traversalCost (C_trav)");
    checkCost(options.intersectionCost, "intersectionCost (C_isect)");
    if (options.builder == BvhBuilder::SahBinned && (options.binCount < 2 || options.binCount > 256))
        throw Error("BVH build: binCount must be in 2..256, got " + std::to_string(options.binCount));
    if ((options.builder == BvhBuilder::GpuPloc || options.builder == BvhBuilder::GpuHploc) &&
        options.plocRadius > kMaxPlocRadius)
        throw Error("BVH build: plocRadius must be in 1.." + std::to_string(kMaxPlocRadius) +
                    " (or 0, the builder's own), got " + std::to_string(options.plocRadius));
    if (options.treeletRounds > kMaxTreeletRounds)
        throw Error("BVH build: treeletRounds must be in 0.." + std::to_string(kMaxTreeletRounds) + ", got " +
                    std::to_string(options.treeletRounds));
    if (options.treeletGamma < kMinTreeletGamma)
        throw Error("BVH build: treeletGamma must be at least " + std::to_string(kMinTreeletGamma) + ", got " +
                    std::to_string(options.treeletGamma));
    if (options.builder == BvhBuilder::SahSplit) {
        if (!(options.splitAlpha >= 0.0f && options.splitAlpha <= 1.0f))
            throw Error("BVH build: splitAlpha must be in 0..1, got " + std::to_string(options.splitAlpha));
        if (!(options.splitBudget >= 1.0f && options.splitBudget <= 4.0f))
            throw Error("BVH build: splitBudget must be in 1..4 (references per triangle), got " +
                        std::to_string(options.splitBudget));
    }
}

size_t firstBadPrimitive(std::span<const Aabb> primitiveBounds, size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
        const Aabb& box = primitiveBounds[i];
        bool finite = true;
        for (int axis = 0; axis < 3; ++axis)
            finite = finite && std::isfinite(box.lo[axis]) && std::isfinite(box.hi[axis]);
        if (!finite || box.empty()) return i;
    }
    return end;
}

void throwBadPrimitive(std::span<const Aabb> primitiveBounds, size_t index) {
    const Aabb& box = primitiveBounds[index];
    char text[256];
    std::snprintf(text, sizeof text,
                  "BVH build: primitive %zu has an empty or non-finite box "
                  "(lo %g %g %g, hi %g %g %g)",
                  index, box.lo.x, box.lo.y, box.lo.z, box.hi.x, box.hi.y, box.hi.z);
    throw Error(text);
}

Aabb validateAndBound(std::span<const Aabb> primitiveBounds, BuildProgress* progress) {
    struct Result {
        Aabb box;
        size_t firstBad = SIZE_MAX;
    };
    const Result result = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, primitiveBounds.size(), kCancelCheckInterval), Result{},
        [&](const tbb::blocked_range<size_t>& range, Result acc) {
            throwIfCancelled(progress);
            const size_t bad = firstBadPrimitive(primitiveBounds, range.begin(), range.end());
            if (bad != range.end()) acc.firstBad = std::min(acc.firstBad, bad);
            for (size_t i = range.begin(); i < bad; ++i) acc.box.grow(primitiveBounds[i]);
            return acc;
        },
        [](Result a, const Result& b) {
            a.box.grow(b.box);
            a.firstBad = std::min(a.firstBad, b.firstBad);
            return a;
        });
    if (result.firstBad != SIZE_MAX) throwBadPrimitive(primitiveBounds, result.firstBad);
    return result.box;
}

}  // namespace bvh_detail

Bvh buildBvh(std::span<const Aabb> primitiveBounds, const BvhBuildOptions& options, BuildProgress* progress,
             const BvhTriangles* triangles) {
    using namespace bvh_detail;
    const auto start = std::chrono::steady_clock::now();
    validateOptions(options);
    if (options.builder == BvhBuilder::GpuLbvh || options.builder == BvhBuilder::GpuPloc ||
        options.builder == BvhBuilder::GpuHploc)
        throw Error(std::string("BVH build: ") + toString(options.builder) +
                    " builds on a Vulkan device (buildBvhOnDevice, renderer/gpu_bvh.h), not on the CPU");
    if (primitiveBounds.size() >= size_t(UINT32_MAX))
        throw Error("BVH build: " + std::to_string(primitiveBounds.size()) + " primitives do not fit 32-bit indices");
    if (options.builder == BvhBuilder::SahSplit &&
        double(primitiveBounds.size()) * double(options.splitBudget) >= double(UINT32_MAX))
        throw Error("BVH build: " + std::to_string(primitiveBounds.size()) + " primitives with split budget " +
                    std::to_string(options.splitBudget) + " may need more references than 32-bit indices reach");
    if (triangles && triangles->triangles.size() != primitiveBounds.size())
        throw Error("BVH build: " + std::to_string(triangles->triangles.size()) + " triangles for " +
                    std::to_string(primitiveBounds.size()) + " primitive boxes");
    if (progress) {
        progress->total.store(primitiveBounds.size());
        progress->done.store(0);
    }
    throwIfCancelled(progress);

    Bvh bvh;
    if (primitiveBounds.empty()) {
        bvh.nodes.resize(1);  // a root leaf holding nothing, with an empty box
        bvh.nodes[0].lo = Aabb{}.lo;
        bvh.nodes[0].hi = Aabb{}.hi;
        bvh.nodes[0].index = 0;
        bvh.nodes[0].count = 0;
    } else {
        // sah-binned checks the boxes and bounds them in its own first pass over them.
        const Aabb rootBox =
            options.builder == BvhBuilder::SahBinned ? Aabb{} : validateAndBound(primitiveBounds, progress);
        switch (options.builder) {
        case BvhBuilder::SahExact: bvh = buildSahExact(primitiveBounds, rootBox, options, progress); break;
        case BvhBuilder::SahBinned: bvh = buildSahBinned(primitiveBounds, options, progress); break;
        case BvhBuilder::SahSplit: bvh = buildSahSplit(primitiveBounds, rootBox, options, progress, triangles); break;
        case BvhBuilder::GpuLbvh:
        case BvhBuilder::GpuPloc:
        case BvhBuilder::GpuHploc: break;  // refused above
        }
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    bvh.options = options;
    bvh.stats = computeBvhStats(bvh, options);
    bvh.stats.buildSeconds = seconds;
    return bvh;
}

PrimitiveBounds trianglePrimitiveBounds(const Scene& scene) {
    const size_t count = scene.triangleCount();
    const size_t vertexCount = scene.positions.size();
    PrimitiveBounds bounds;
    const size_t bytes = count * sizeof(Aabb);
    bounds.boxes_ = {static_cast<Aabb*>(allocateLarge(bytes)), LargeStorageFree{bytes}};
    Aabb* const boxes = bounds.boxes_.get();
    // Aabb is trivially destructible: a throw part of the way leaves nothing to destroy.
    static_assert(std::is_trivially_destructible_v<Aabb>);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 65536), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t i = range.begin(); i < range.end(); ++i) {
            const glm::uvec3& t = scene.triangles[i];
            RAYPACK_CHECK_MSG(t[0] < vertexCount && t[1] < vertexCount && t[2] < vertexCount,
                              "triangle index out of range");
            ::new (static_cast<void*>(boxes + i)) Aabb(scene.triangleBounds(uint32_t(i)));
        }
    });
    bounds.count_ = count;
    return bounds;
}

Bvh buildBvh(const Scene& scene, const BvhBuildOptions& options, BuildProgress* progress) {
    const PrimitiveBounds bounds = trianglePrimitiveBounds(scene);  // checks the vertex indices
    const BvhTriangles triangles{scene.positions, scene.triangles};
    return buildBvh(bounds, options, progress, &triangles);
}

namespace {

// What computeBvhStats sums over a subtree.
struct SubtreeSums {
    uint64_t leafCount = 0, depthSum = 0, primSum = 0;
    uint32_t maxLeafDepth = 0;
    double innerMeasureSum = 0.0, leafMeasureSum = 0.0;

    void add(const SubtreeSums& other) {
        leafCount += other.leafCount;
        depthSum += other.depthSum;
        primSum += other.primSum;
        maxLeafDepth = std::max(maxLeafDepth, other.maxLeafDepth);
        innerMeasureSum += other.innerMeasureSum;
        leafMeasureSum += other.leafMeasureSum;
    }
};

// Subtrees whose roots lie above this depth are summed by tasks of their own, the two children's
// sums added left then right: the same sums, to the last bit, on any number of threads.
constexpr uint32_t kStatsTaskDepth = 10;

// The sums over the subtree of `root` at `rootDepth`, with walkBvh's checks; depth first, left
// child first, within each task.
SubtreeSums sumSubtree(const Bvh& bvh, const bvh_detail::SahMeasure& measure, uint32_t root, uint32_t rootDepth) {
    auto boxOf = [](const BvhNode& node) { return Aabb{node.lo, node.hi}; };
    const BvhNode& top = bvh.nodes[root];
    if (!top.isLeaf() && rootDepth < kStatsTaskDepth) {
        RAYPACK_CHECK_MSG(top.index > root && uint64_t(top.index) + 1 < bvh.nodes.size(),
                          "children after their parent, inside the node array");
        SubtreeSums left, right;
        tbb::parallel_invoke([&] { left = sumSubtree(bvh, measure, top.index, rootDepth + 1); },
                             [&] { right = sumSubtree(bvh, measure, top.index + 1, rootDepth + 1); });
        SubtreeSums sums;
        sums.innerMeasureSum = measure.of(boxOf(top));
        sums.add(left);
        sums.add(right);
        return sums;
    }
    SubtreeSums sums;
    struct Pending {
        uint32_t node;
        uint32_t depth;
    };
    std::vector<Pending> stack{{root, rootDepth}};
    while (!stack.empty()) {
        const Pending item = stack.back();
        stack.pop_back();
        const BvhNode& node = bvh.nodes[item.node];
        const double nodeMeasure = measure.of(boxOf(node));
        if (node.isLeaf()) {
            RAYPACK_CHECK_MSG(uint64_t(node.index) + node.count <= bvh.primIndices.size(),
                              "leaf range inside primIndices");
            ++sums.leafCount;
            sums.depthSum += item.depth;
            sums.maxLeafDepth = std::max(sums.maxLeafDepth, item.depth);
            sums.primSum += node.count;
            sums.leafMeasureSum += double(node.count) * nodeMeasure;
        } else {
            RAYPACK_CHECK_MSG(node.index > item.node && uint64_t(node.index) + 1 < bvh.nodes.size(),
                              "children after their parent, inside the node array");
            sums.innerMeasureSum += nodeMeasure;
            stack.push_back({node.index + 1, item.depth + 1});
            stack.push_back({node.index, item.depth + 1});
        }
    }
    return sums;
}

// Distinct entries of primIndices: a flag per index up to the largest, set and counted in parallel.
uint64_t countDistinct(const PrimIndices& prims) {
    if (prims.empty()) return 0;
    constexpr size_t kGrain = 65536;
    const uint32_t largest = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, prims.size(), kGrain), uint32_t(0),
        [&](const tbb::blocked_range<size_t>& range, uint32_t most) {
            for (size_t i = range.begin(); i < range.end(); ++i) most = std::max(most, prims[i]);
            return most;
        },
        [](uint32_t a, uint32_t b) { return std::max(a, b); });
    // Cleared in parallel, in allocateLarge's storage (kept between builds).
    std::vector<uint8_t, UninitializedAllocator<uint8_t>> seen =
        bvh_detail::makeLargeVector<uint8_t, UninitializedAllocator<uint8_t>>(size_t(largest) + 1);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, seen.size(), kGrain), [&](const tbb::blocked_range<size_t>& range) {
        std::fill(seen.begin() + ptrdiff_t(range.begin()), seen.begin() + ptrdiff_t(range.end()), uint8_t(0));
    });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, prims.size(), kGrain),
                      [&](const tbb::blocked_range<size_t>& range) {
                          for (size_t i = range.begin(); i < range.end(); ++i)
                              std::atomic_ref<uint8_t>(seen[prims[i]]).store(1, std::memory_order_relaxed);
                      });
    return tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, seen.size(), kGrain), uint64_t(0),
        [&](const tbb::blocked_range<size_t>& range, uint64_t count) {
            for (size_t i = range.begin(); i < range.end(); ++i) count += seen[i];
            return count;
        },
        std::plus<>());
}

}  // namespace

// In parallel: at 10M triangles the serial walk took 93-100 ms here, 7% of sah-binned's T_B.
BvhStats computeBvhStats(const Bvh& bvh, const BvhBuildOptions& options) {
    BvhStats stats;
    stats.nodeCount = uint32_t(bvh.nodes.size());
    stats.bytes = bvh.nodes.size() * sizeof(BvhNode) + bvh.primIndices.size() * sizeof(uint32_t);
    stats.references = bvh.primIndices.size();
    stats.primitives = countDistinct(bvh.primIndices);
    if (bvh.nodes.empty()) return stats;

    const Aabb rootBox{bvh.nodes[0].lo, bvh.nodes[0].hi};
    const bvh_detail::SahMeasure measure = bvh_detail::SahMeasure::forParent(rootBox);
    const double rootMeasure = measure.of(rootBox);
    const SubtreeSums sums = sumSubtree(bvh, measure, 0, 0);
    stats.leafCount = uint32_t(sums.leafCount);
    stats.maxLeafDepth = sums.maxLeafDepth;
    stats.avgLeafDepth = double(sums.depthSum) / double(sums.leafCount);
    stats.avgPrimsPerLeaf = double(sums.primSum) / double(sums.leafCount);
    // Sum over inner nodes of C_trav·A(n)/A(root) plus over leaves of C_isect·count·A(n)/A(root).
    // The empty tree costs nothing.
    stats.sahCost = rootMeasure > 0.0 ? (double(options.traversalCost) * sums.innerMeasureSum +
                                         double(options.intersectionCost) * sums.leafMeasureSum) /
                                            rootMeasure
                                      : 0.0;
    return stats;
}

uint32_t bvhMaxDepth(const Bvh& bvh) {
    uint32_t maxDepth = 0;
    walkBvh(bvh, [&](uint32_t, const BvhNode&, uint32_t depth) { maxDepth = std::max(maxDepth, depth); });
    return maxDepth;
}

const char* toString(BvhBuilder builder) {
    switch (builder) {
    case BvhBuilder::SahExact: return "sah-exact";
    case BvhBuilder::SahBinned: return "sah-binned";
    case BvhBuilder::SahSplit: return "sah-split";
    case BvhBuilder::GpuLbvh: return "gpu-lbvh";
    case BvhBuilder::GpuPloc: return "gpu-ploc";
    case BvhBuilder::GpuHploc: return "gpu-hploc";
    }
    return "unknown";
}

std::optional<BvhBuilder> findBvhBuilder(std::string_view name) {
    for (BvhBuilder builder : kAllBvhBuilders)
        if (name == toString(builder)) return builder;
    return std::nullopt;
}

BvhBuilder parseBvhBuilder(std::string_view name) {
    if (const std::optional<BvhBuilder> builder = findBvhBuilder(name)) return *builder;
    std::string valid;
    for (BvhBuilder builder : kAllBvhBuilders) {
        valid += valid.empty() ? "" : ", ";
        valid += toString(builder);
    }
    throw Error("unknown BVH builder \"" + std::string(name) + "\" (valid: " + valid + ")");
}

}  // namespace raypack
