#pragma once
// What the BVH builders share (internal to renderer/bvh*.cpp): the SAH measure, cancellation and
// progress, and the node fragments that let independent subtrees be built on different threads and
// still be spliced into one array in an order that does not depend on the thread count.
#include "renderer/bvh.h"
#include "renderer/huge_pages.h"

#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_group.h>

#include <algorithm>
#include <type_traits>

#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <utility>
#include <vector>

namespace raypack::bvh_detail {

// The SAH weighs a child by the probability that a ray hitting its parent also hits it, the ratio of
// their surface areas (Goldsmith and Salmon 1987; MacDonald and Booth 1990). A parent box of zero
// area (all primitives on one line or in one point) would make that ratio 0/0, so the measure
// follows the limit of the SAH for boxes inflated by an epsilon that goes to 0: the area when the
// parent has area; else the sum of the extents (a line's area grows with its length); else (a point)
// every box counts 1, so no split ever beats a leaf. Computed in double so that extents of 1e30 or
// 1e-30 neither overflow nor underflow when squared.
enum class SahMeasureKind { Area, Length, Count };

struct SahMeasure {
    SahMeasureKind kind = SahMeasureKind::Area;

    static double halfArea(const Aabb& box) {
        if (box.empty()) return 0.0;
        const double ex = double(box.hi.x) - double(box.lo.x);
        const double ey = double(box.hi.y) - double(box.lo.y);
        const double ez = double(box.hi.z) - double(box.lo.z);
        return ex * ey + ey * ez + ez * ex;
    }
    static double extentSum(const Aabb& box) {
        if (box.empty()) return 0.0;
        return (double(box.hi.x) - double(box.lo.x)) + (double(box.hi.y) - double(box.lo.y)) +
               (double(box.hi.z) - double(box.lo.z));
    }
    static SahMeasure forParent(const Aabb& parent) {
        if (halfArea(parent) > 0.0) return {SahMeasureKind::Area};
        if (extentSum(parent) > 0.0) return {SahMeasureKind::Length};
        return {SahMeasureKind::Count};
    }
    double of(const Aabb& box) const {
        switch (kind) {
        case SahMeasureKind::Area: return halfArea(box);
        case SahMeasureKind::Length: return extentSum(box);
        case SahMeasureKind::Count: return box.empty() ? 0.0 : 1.0;
        }
        return 0.0;
    }
};

// SAH cost of splitting a node into children holding `weightedChildMeasures` = A_L·N_L + A_R·N_R
// (report 2.1, Wald et al. 2007): C_trav + (A_L·N_L + A_R·N_R) / A_parent · C_isect. Both builders
// and the tests' reference evaluate exactly this expression, so their choices agree to the bit.
inline double splitCost(double weightedChildMeasures, double parentMeasure, const BvhBuildOptions& options) {
    return double(options.traversalCost) + weightedChildMeasures / parentMeasure * double(options.intersectionCost);
}
inline double leafCost(uint32_t count, const BvhBuildOptions& options) {
    return double(count) * double(options.intersectionCost);
}

// Throws BuildCancelled when the caller asked to stop. Cheap (one relaxed load), called every few
// thousand primitives so that a 10M-primitive build stops within a few milliseconds.
inline void throwIfCancelled(BuildProgress* progress) {
    if (progress && progress->cancel.load(std::memory_order_relaxed)) throw BuildCancelled{};
}
// A parallel loop or parallel_invoke run inside a task whose group is being cancelled (a sibling
// task threw, e.g. BuildCancelled) stops early *without* an exception of its own, leaving its result
// partial. Every nested parallel step of a builder calls this before it uses that result.
inline void throwIfInterrupted(BuildProgress* progress) {
    if (tbb::is_current_task_group_canceling()) throw BuildCancelled{};
    throwIfCancelled(progress);
}
inline void addPlaced(BuildProgress* progress, uint64_t count) {
    if (progress) progress->done.fetch_add(count, std::memory_order_relaxed);
}
// Loops over large ranges check for cancellation once per this many elements.
inline constexpr uint32_t kCancelCheckInterval = 16384;

// A node of a fragment holds this count while it waits for the root of a child fragment.
inline constexpr uint32_t kLinkPlaceholder = 0xFFFFFFFFu;

// Part of the tree built by one task: nodes[0] is the fragment's root; every inner node's index is
// local to this fragment (a pair at local slots index, index + 1, never 0). A child whose subtree is
// large enough to be worth a task of its own is a placeholder here (count kLinkPlaceholder) and the
// root of the fragment in `links`. Which subtrees become fragments depends only on their primitive
// counts, never on the thread count, so the assembled tree is the same on any number of threads.
struct Fragment {
    std::vector<BvhNode> nodes;
    std::vector<std::pair<uint32_t, std::unique_ptr<Fragment>>> links;  // placeholder slot, child

    // Appends a sibling pair and returns its first slot.
    uint32_t addPair() {
        const uint32_t slot = uint32_t(nodes.size());
        nodes.resize(nodes.size() + 2);
        return slot;
    }
    // Makes `slot` a placeholder for a new child fragment and returns that fragment.
    Fragment& link(uint32_t slot) {
        nodes[slot].count = kLinkPlaceholder;
        nodes[slot].index = 0;
        links.emplace_back(slot, std::make_unique<Fragment>());
        Fragment& child = *links.back().second;
        child.nodes.resize(1);
        return child;
    }
};

// Splices a fragment tree into one node array: the root fragment first (its root at 0), then every
// child fragment without its root, in depth-first order of the links; a child's root takes its
// placeholder's slot. Copies in parallel; the result does not depend on how the copy is scheduled.
BvhNodes assembleFragments(Fragment& root);

// Subtrees with more primitives than this get a fragment (and a task) of their own.
inline constexpr uint32_t kFragmentMinPrimitives = 4096;

// makeLargeVector's first writes: vectors of at least this many bytes, in pieces of a huge page.
inline constexpr size_t kParallelFirstTouchBytes = size_t(8) << 20;
inline constexpr size_t kFirstTouchPiece = size_t(2) << 20;

// Writes one byte of every page of [data, data + bytes) from all threads, when that is at least
// kParallelFirstTouchBytes: the kernel clears a fresh page when it is first written, and this way
// not on one thread. The bytes written are 0; the storage is raw (about to be initialised).
inline void touchPagesInParallel(void* data, size_t bytes) {
    if (bytes < kParallelFirstTouchBytes) return;
    unsigned char* const storage = static_cast<unsigned char*>(data);
    tbb::parallel_for(size_t(0), (bytes + kFirstTouchPiece - 1) / kFirstTouchPiece, [&](size_t piece) {
        for (size_t at = piece * kFirstTouchPiece; at < std::min(bytes, (piece + 1) * kFirstTouchPiece); at += 4096)
            storage[at] = 0;
    });
}

// A vector of `count` elements whose storage is advised to use huge pages before it is first written
// (renderer/huge_pages.h). With std::allocator the elements are value-initialised, after
// touchPagesInParallel. With
// UninitializedAllocator (BvhNodes) the elements are left for the caller to write.
template <typename T, typename Allocator = std::allocator<T>>
std::vector<T, Allocator> makeLargeVector(size_t count) {
    static_assert(std::is_trivially_copyable_v<T>);
    std::vector<T, Allocator> vector;
    vector.reserve(count);
    const size_t bytes = count * sizeof(T);
    adviseHugePages(vector.data(), bytes);
    if (std::is_same_v<Allocator, std::allocator<T>>) touchPagesInParallel(vector.data(), bytes);
    vector.resize(count);
    return vector;
}
// `count` nodes for a builder to write, every one of them.
inline BvhNodes makeNodeArray(size_t count) { return makeLargeVector<BvhNode, UninitializedAllocator<BvhNode>>(count); }

// Throws raypack::Error when the options are out of range.
void validateOptions(const BvhBuildOptions& options);
// Throws raypack::Error naming the first primitive whose box is empty or not finite. Returns the
// union of all boxes.
Aabb validateAndBound(std::span<const Aabb> primitiveBounds, BuildProgress* progress);
// The first primitive of [begin, end) whose box is empty or not finite, or end.
size_t firstBadPrimitive(std::span<const Aabb> primitiveBounds, size_t begin, size_t end);
// Throws validateAndBound's raypack::Error for primitive `index`.
[[noreturn]] void throwBadPrimitive(std::span<const Aabb> primitiveBounds, size_t index);

// Centroids as the builders see them: 0.5·lo + 0.5·hi (no overflow near FLT_MAX), with -0 turned
// into +0 so that sorting by bit pattern agrees with comparing floats.
inline glm::vec3 centroidOf(const Aabb& box) { return (0.5f * box.lo + 0.5f * box.hi) + glm::vec3(0.0f); }

// The builders. Both return nodes and primIndices; buildBvh fills options and stats.
Bvh buildSahExact(std::span<const Aabb> primitiveBounds, const Aabb& rootBox, const BvhBuildOptions& options,
                  BuildProgress* progress);
// sah-binned validates and bounds the boxes itself (as validateAndBound would), in its first pass.
Bvh buildSahBinned(std::span<const Aabb> primitiveBounds, const BvhBuildOptions& options, BuildProgress* progress);
// `triangles` may be null (boxes are chopped instead of triangles clipped).
Bvh buildSahSplit(std::span<const Aabb> primitiveBounds, const Aabb& rootBox, const BvhBuildOptions& options,
                  BuildProgress* progress, const BvhTriangles* triangles);

}  // namespace raypack::bvh_detail
