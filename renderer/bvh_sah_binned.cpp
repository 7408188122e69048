// Binned SAH builder after Wald 2007, "On fast Construction of SAH-based Bounding Volume
// Hierarchies": instead of every centroid, only the boundaries of `binCount` equal bins over the
// node's centroid bounds are split candidates, on each of the three axes. One pass drops every
// primitive into its bin (count and box per bin), a sweep over the bins prices all candidates, and
// one pass partitions the node's range.
//
// The primitives travel as 32-byte references (box and index, Wald 2007's and Embree's PrimRef), so
// that binning and partitioning read memory in order instead of gathering boxes and centroids
// through an index list; the box arithmetic runs four lanes wide (GCC/Clang vector extensions,
// SSE on x86-64, whatever the target has elsewhere).
//
// Parallel and deterministic: bins of large nodes are filled by a parallel reduction whose merge
// (integer sums, box min/max) is exact and associative, so any split of the work gives the same
// bins; large partitions run in fixed-size chunks (each partitioned within its range, then the
// misplaced runs swapped across the split), so the order does not depend on the scheduler; every
// subtree owns its slots of one node array before it is built (build(), compact()), whichever
// task builds it. The tree does not depend on the thread count.
#include "renderer/bvh_build.h"
#include "renderer/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>

namespace raypack::bvh_detail {
namespace {

// The thresholds of the parallel work, measured on the H200 machine's 16 threads (2026-12-02,
// docs/bvh.md): nodes with more references than this bin and partition in parallel...
constexpr uint32_t kParallelNodeMinPrimitives = 16384;
// ...in pieces of this many references (fixed, so the result does not depend on the scheduler);
constexpr uint32_t kPartitionChunk = 4096;
// subtrees of more references than this are built by tasks of their own.
constexpr uint32_t kTaskMinPrimitives = 1024;
// Nodes of at least this many references fill their bins in two grids (fillBins).
constexpr uint32_t kTwoGridMinPrimitives = 64;
// Ranges of at most this many references partition through a per-thread buffer (partitionRange).
constexpr uint32_t kBranchlessPartitionMax = 4096;

// A split whose larger child keeps at least this share of its node's area (a node's few large
// primitives, such as a room's floor and ceiling, stuck in one bin with small ones) is refined: the
// references of the two bins beside the chosen boundary are sorted and every position between them
// priced, as sah-exact prices every position (refine()). Only nodes from kRefineMinPrimitives to
// kParallelNodeMinPrimitives references (serial ones), and only when those two bins hold at most
// 1/kRefineMaxShare of the node. On Conference this took the SAH cost from 1.059x sah-exact's to
// 1.017x (docs/bvh.md); the scans and terrains never meet the condition.
constexpr double kRefineAreaShare = 0.9;
constexpr uint32_t kRefineMinPrimitives = 64;
constexpr uint32_t kRefineMaxShare = 4;

constexpr uint32_t kMaxBins = 256;
// Nodes of at most this many references are split by pricing every partition (buildSmall).
constexpr uint32_t kSmallNodeMaxPrimitives = 4;
// Set bits of each mask of a small node's references (std::popcount is a library call where the
// target has no popcount instruction, as baseline x86-64).
constexpr auto kBitCount = [] {
    std::array<uint8_t, 1u << kSmallNodeMaxPrimitives> counts{};
    for (uint32_t mask = 0; mask < counts.size(); ++mask) counts[mask] = uint8_t(std::popcount(mask));
    return counts;
}();

using Vec4 = float __attribute__((vector_size(16)));
using Int4 = int32_t __attribute__((vector_size(16)));
using UInt4 = uint32_t __attribute__((vector_size(16)));

inline Vec4 min4(Vec4 a, Vec4 b) { return a < b ? a : b; }
inline Vec4 max4(Vec4 a, Vec4 b) { return a > b ? a : b; }

// A primitive as the builder moves it: its box, with the primitive's index in the fourth lane of
// `lo` (as bits; that lane never takes part in arithmetic) and 0 in the fourth lane of `hi`.
struct alignas(32) Ref {
    Vec4 lo, hi;

    uint32_t prim() const { return std::bit_cast<uint32_t>(lo[3]); }
    // 0.5·lo + 0.5·hi as centroidOf computes it (no overflow near FLT_MAX); lane 3 is 0.
    Vec4 centroid() const {
        const Vec4 xyz = (Vec4)((Int4)lo & Int4{-1, -1, -1, 0});
        return 0.5f * xyz + 0.5f * hi;
    }
};
static_assert(sizeof(Ref) == 32);

Ref makeRef(const Aabb& box, uint32_t prim) {
    return {Vec4{box.lo.x, box.lo.y, box.lo.z, std::bit_cast<float>(prim)}, Vec4{box.hi.x, box.hi.y, box.hi.z, 0.0f}};
}
Aabb toAabb(Vec4 lo, Vec4 hi) { return {glm::vec3(lo[0], lo[1], lo[2]), glm::vec3(hi[0], hi[1], hi[2])}; }

// A box as four-lane bounds (lane 3 unused). No member initialisers, so that arrays of bins cost
// nothing until used: `Box4::empty()` is the empty box (as Aabb's).
struct Box4 {
    Vec4 lo, hi;

    static Box4 empty() { return {Vec4{} + FLT_MAX, Vec4{} - FLT_MAX}; }
    void grow(Vec4 point) {
        lo = min4(lo, point);
        hi = max4(hi, point);
    }
    void grow(const Box4& box) {
        lo = min4(lo, box.lo);
        hi = max4(hi, box.hi);
    }
    // By a reference's box (lane 3 of `lo` takes the index bits; it is never read).
    void grow(const Ref& ref) {
        lo = min4(lo, ref.lo);
        hi = max4(hi, ref.hi);
    }
    Aabb aabb() const { return toAabb(lo, hi); }
};

// SahMeasure::halfArea of a box that is not empty (the sweeps' hot path).
inline double halfArea(const Box4& box) {
    const double ex = double(box.hi[0]) - double(box.lo[0]);
    const double ey = double(box.hi[1]) - double(box.lo[1]);
    const double ez = double(box.hi[2]) - double(box.lo[2]);
    return ex * ey + ey * ez + ez * ex;
}

// Maps centroids to bins, all three axes at once. Binning and partitioning call the same
// function, so a primitive's side of the split is decided by the very bin that counted it.
struct Binning {
    uint32_t binCount = 0;
    bool active[3] = {false, false, false};  // false where the centroids do not spread along the axis
    Vec4 lo{};                               // centroid bounds' lower corner (0 on inactive axes)
    Vec4 scale{};                            // binCount / extent (0 on inactive axes: everything in bin 0)
    Vec4 lastBin{};

    bool any() const { return active[0] || active[1] || active[2]; }
    Int4 binsOf(Vec4 centroid) const {
        Vec4 position = (centroid - lo) * scale;
        // Clamp in float first: the last centroid lands on binCount exactly.
        position = position < 0.0f ? Vec4{} : position;
        position = position > lastBin ? lastBin : position;
        return __builtin_convertvector(position, Int4);
    }
};

// One bin of one axis: the box of the references that fell into it and their count. The count lives
// in lane 3 of `hi`, which no user of a Box4 reads, as integer bits above those of FLT_MIN, so that
// the lane always holds a normal positive float: a reference's `hi` has 0 there, so the max keeps
// the count (MAXPS returns an operand's bits; a denormal would read as 0 where a thread runs with
// denormals-are-zero, which an application or a library may set), and an integer add increments it.
// That is one vector add instead of a load, add and store of a count in memory for every reference
// and axis (on one thread of a Xeon, 2026-12-06, Conference built 1.21x faster with this alone, the
// 1M terrain 1.18x; docs/bvh.md). The counts stay at most FLT_MAX's bits (kMaxBinnedPrimitives).
constexpr uint32_t kCountZero = std::bit_cast<uint32_t>(FLT_MIN);
constexpr size_t kMaxBinnedPrimitives = std::bit_cast<uint32_t>(FLT_MAX) - kCountZero;  // below INT32_MAX
static_assert(kMaxBinnedPrimitives < size_t(INT32_MAX));

struct Bin : Box4 {
    static Bin empty() {
        Bin bin{Box4::empty()};
        bin.hi[3] = std::bit_cast<float>(kCountZero);
        return bin;
    }
    // add and merge are written out rather than through grow(): with grow(), GCC 12 compiled a loop
    // that made the tree phase 1.5-3.5% slower here (2026-12-06).
    void add(const Ref& ref) {
        lo = min4(lo, ref.lo);
        hi = (Vec4)((UInt4)max4(hi, ref.hi) + UInt4{0, 0, 0, 1});
    }
    // Exact (integer sums, min/max), so any order of merging gives the same bins.
    void merge(const Bin& other) {
        const uint32_t counted = std::bit_cast<uint32_t>(hi[3]) + other.count();
        lo = min4(lo, other.lo);
        hi = max4(hi, other.hi);
        hi[3] = std::bit_cast<float>(counted);
    }
    uint32_t count() const { return std::bit_cast<uint32_t>(hi[3]) - kCountZero; }
};

// The bins of all three axes of one node, by bin and then axis, so that the bins in use lie
// together at the front: up to 32 bins (the default) take 3 KiB. Laid out by axis, with room for
// kMaxBins, the three axes' bins of one index were 8 KiB apart, and on Intel cores a load whose
// address matches an earlier store's in its low 12 bits waits for that store (4K aliasing); by bin
// the 1M terrain built another 1.09x faster there. The rows from binCount on hold the odd
// references' bins while fillBins fills two sets (no constructor clears them). No default member
// initialisers, so a node's bins live on the stack and only the ones in use are cleared.
struct BinGrid {
    uint32_t binCount;
    Bin bins[2 * kMaxBins][3];

    explicit BinGrid(uint32_t count) : binCount(count) { clearRows(0, count); }
    void clearRows(uint32_t from, uint32_t to) {
        for (uint32_t b = from; b < to; ++b)
            for (int axis = 0; axis < 3; ++axis) bins[b][axis] = Bin::empty();
    }
    // Into the bins from row `base` on (0, or binCount for the odd references' set).
    void add(const Binning& binning, const Ref& ref, uint32_t base = 0) {
        const Int4 index = binning.binsOf(ref.centroid());
        for (int axis = 0; axis < 3; ++axis) bins[base + uint32_t(index[axis])][axis].add(ref);
    }
    void mergeRows(const Bin (*rows)[3]) {
        for (uint32_t b = 0; b < binCount; ++b)
            for (int axis = 0; axis < 3; ++axis) bins[b][axis].merge(rows[b][axis]);
    }
    void merge(const BinGrid& other) { mergeRows(other.bins); }
    const Bin& bin(int axis, uint32_t b) const { return bins[b][axis]; }
};

struct Split {
    bool found = false;
    int axis = 0;
    uint32_t lastLeftBin = 0;                                           // bins 0..lastLeftBin go left
    double weightedMeasures = std::numeric_limits<double>::infinity();  // A_L·N_L + A_R·N_R
    Aabb leftBox, rightBox;
    uint32_t leftCount = 0;
    // A refined split (refine()): a reference goes left when its centroid on the axis is below
    // `value`, or equal to it and its primitive index at most `prim` (partitionRange).
    bool refined = false;
    float value = 0.0f;
    uint32_t prim = 0;
};

class SahBinnedBuilder {
public:
    SahBinnedBuilder(std::span<const Aabb> bounds, const BvhBuildOptions& options, BuildProgress* progress)
        : bounds_(bounds), options_(options), progress_(progress) {}

    Bvh build() {
        const uint32_t n = uint32_t(bounds_.size());
        // Not value-initialised: the pass below writes every reference (and first touches its page).
        // It also bounds the boxes and checks them (validateAndBound's work, without another pass
        // over the boxes): finite and not empty, by lanes, so without a branch per reference.
        refs_ = makeLargeVector<Ref, UninitializedAllocator<Ref>>(n);
        struct FirstPass {
            Box4 centroids = Box4::empty(), box = Box4::empty();
            size_t firstBad = SIZE_MAX;
        };
        const FirstPass first = tbb::parallel_reduce(
            tbb::blocked_range<uint32_t>(0, n, kCancelCheckInterval), FirstPass{},
            [&](const tbb::blocked_range<uint32_t>& range, FirstPass pass) {
                throwIfCancelled(progress_);
                constexpr Int4 kXyz{-1, -1, -1, 0};
                constexpr UInt4 kAbs{0x7fffffffu, 0x7fffffffu, 0x7fffffffu, 0x7fffffffu};
                Int4 good = kXyz;
                for (uint32_t i = range.begin(); i < range.end(); ++i) {
                    const Ref ref = makeRef(bounds_[i], i);
                    refs_[i] = ref;
                    pass.centroids.grow(ref.centroid());
                    pass.box.grow(ref);
                    const Vec4 lo = (Vec4)((Int4)ref.lo & kXyz);  // lane 3: the index's bits
                    good &= ((Vec4)((UInt4)lo & kAbs) <= FLT_MAX) & ((Vec4)((UInt4)ref.hi & kAbs) <= FLT_MAX) &
                            (lo <= ref.hi);
                }
                if (good[0] == 0 || good[1] == 0 || good[2] == 0)
                    pass.firstBad = std::min(pass.firstBad, firstBadPrimitive(bounds_, range.begin(), range.end()));
                return pass;
            },
            [](FirstPass a, const FirstPass& b) {
                a.centroids.grow(b.centroids);
                a.box.grow(b.box);
                a.firstBad = std::min(a.firstBad, b.firstBad);
                return a;
            });
        throwIfInterrupted(progress_);
        if (first.firstBad != SIZE_MAX) throwBadPrimitive(bounds_, first.firstBad);
        const Box4& rootCentroids = first.centroids;
        const Aabb rootBox = first.box.aabb();

        // A subtree of k references has at most k - 1 inner nodes, so it can own 2(k - 1) slots
        // for its children's pairs before any thread builds it: the tree is laid out depth first
        // (a node's pair, the left subtree's pairs, the right subtree's) in 2n - 1 slots, whichever
        // thread builds which part. Leaves of more than one reference leave some of their
        // subtree's slots unused; compact() closes those gaps. Not value-initialised: only the
        // slots in use are written and read.
        arena_ = makeNodeArray(2 * size_t(n) - 1);
        pairUsed_ = makeLargeVector<uint8_t>(n);
        arena_[0].lo = rootBox.lo;
        arena_[0].hi = rootBox.hi;
        tbb::task_group tasks;
        buildSubtree({0, 1, 0, n, rootCentroids}, tasks);
        tasks.wait();  // rethrows BuildCancelled from any task

        Bvh bvh;
        bvh.nodes = compact();
        bvh.primIndices = makeLargeVector<uint32_t, UninitializedAllocator<uint32_t>>(n);
        tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 16384), [&](const tbb::blocked_range<uint32_t>& range) {
            for (uint32_t i = range.begin(); i < range.end(); ++i) bvh.primIndices[i] = refs_[i].prim();
        });
        return bvh;
    }

private:
    // A node to build: its slot in arena_ (its box is written there already), the first slot its
    // subtree's pairs may use, and its references.
    struct Work {
        uint32_t slot, pairBase, begin, end;
        Box4 centroidBox;
    };

    // Builds the subtree of `first` depth first; subtrees of more than kTaskMinPrimitives
    // references become tasks of their own.
    void buildSubtree(const Work& first, tbb::task_group& tasks) {
        std::vector<Work> stack{first};
        uint64_t placedSinceReport = 0;
        while (!stack.empty()) {
            const Work work = stack.back();
            stack.pop_back();
            const uint32_t count = work.end - work.begin;
            if (count <= kSmallNodeMaxPrimitives) {
                buildSmall(work.slot, work.pairBase, work.begin, work.end, placedSinceReport);
                continue;
            }
            const Aabb box{arena_[work.slot].lo, arena_[work.slot].hi};
            Split split;
            Binning binning;
            if (count > options_.leafSize) {
                binning = binningOf(work.centroidBox, count);
                if (binning.any()) split = findBestSplit(work, box, binning);
            }
            const bool median = !split.found && count > kMaxLeafPrimitives;
            if (!split.found && !median) {
                makeLeaf(arena_[work.slot], work.begin, count, placedSinceReport);
                continue;
            }
            Box4 leftCentroids = Box4::empty(), rightCentroids = Box4::empty();
            uint32_t mid = 0;
            if (median) {
                // The SAH refuses, but the leaf would be too large: the object median.
                mid = medianSplit(work, split.leftBox, split.rightBox, leftCentroids, rightCentroids);
            } else {
                mid = partition(split, binning, work, leftCentroids, rightCentroids);
                RAYPACK_CHECK(mid - work.begin == split.leftCount);
            }
            const uint32_t pair = makeInner(work.slot, work.pairBase, split.leftBox, split.rightBox);
            const Work children[2] = {{pair, pair + 2, work.begin, mid, leftCentroids},
                                      {pair + 1, pair + 2 * (mid - work.begin), mid, work.end, rightCentroids}};
            for (int k = 1; k >= 0; --k) {  // left on top of the stack: depth first, left first
                const Work& child = children[k];
                if (child.end - child.begin > kTaskMinPrimitives)
                    tasks.run([this, child, &tasks] { buildSubtree(child, tasks); });
                else
                    stack.push_back(child);
            }
        }
        addPlaced(progress_, placedSinceReport);
    }

    // Makes the node in `slot` an inner node whose children take slots `pair` and `pair` + 1,
    // writes their boxes and returns `pair`. The left child's subtree may use the slots from
    // pair + 2 on, for up to 2(k - 1) nodes if it holds k references; the right one's follow.
    uint32_t makeInner(uint32_t slot, uint32_t pair, const Aabb& leftBox, const Aabb& rightBox) {
        pairUsed_[pairIndex(pair)] = 1;
        arena_[slot].index = pair;
        arena_[slot].count = 0;
        arena_[pair].lo = leftBox.lo;
        arena_[pair].hi = leftBox.hi;
        arena_[pair + 1].lo = rightBox.lo;
        arena_[pair + 1].hi = rightBox.hi;
        return pair;
    }

    static uint32_t pairIndex(uint32_t slot) { return (slot - 1) / 2; }

    // The tree without the arena's unused pairs, in the arena's order (depth first). A pair's new
    // slot counts the pairs in use before it: one bit per pair, and a count per 64 of them.
    BvhNodes compact() {
        const uint32_t pairs = uint32_t(pairUsed_.size());  // arena slots 2k + 1 and 2k + 2
        const uint32_t wordCount = (pairs + 63) / 64;
        // Blocks of 1024 pairs: the copy's first writes into the fresh node array fault its pages
        // in, on as many threads as there are blocks. Sibenik's 75k triangles made 5 blocks of 256
        // words, so 5 of the H200 machine's 16 threads took every fault; with 16 words its
        // compaction took 0.17-0.18 ms against 0.34-0.39 (docs/bvh.md, 2026-12-03).
        constexpr uint32_t kWordsPerBlock = 16;
        const uint32_t blockCount = (wordCount + kWordsPerBlock - 1) / kWordsPerBlock;
        std::unique_ptr<uint64_t[]> usedBits = std::make_unique_for_overwrite<uint64_t[]>(wordCount);
        std::unique_ptr<uint32_t[]> usedBefore = std::make_unique_for_overwrite<uint32_t[]>(wordCount);  // by word
        std::vector<uint32_t> blockUsed(blockCount + 1, 0);
        auto forBlocks = [&](auto&& body) {
            tbb::parallel_for(uint32_t(0), blockCount, [&](uint32_t block) {
                body(block, block * kWordsPerBlock, std::min(wordCount, (block + 1) * kWordsPerBlock));
            });
        };
        forBlocks([&](uint32_t block, uint32_t from, uint32_t to) {
            uint32_t used = 0;
            for (uint32_t word = from; word < to; ++word) {
                uint64_t bits = 0;
                for (uint32_t k = word * 64, end = std::min(pairs, k + 64); k < end; ++k)
                    bits |= uint64_t(pairUsed_[k]) << (k % 64);
                usedBits[word] = bits;
                usedBefore[word] = used;  // within the block, for now
                used += uint32_t(std::popcount(bits));
            }
            blockUsed[block + 1] = used;
        });
        for (uint32_t block = 0; block < blockCount; ++block) blockUsed[block + 1] += blockUsed[block];
        auto newSlot = [&](uint32_t pair) {
            const uint32_t word = pair / 64;
            const uint64_t below = usedBits[word] & ((uint64_t(1) << (pair % 64)) - 1);
            return 1 + 2 * (blockUsed[word / kWordsPerBlock] + usedBefore[word] + uint32_t(std::popcount(below)));
        };
        auto moved = [&](BvhNode node) {
            if (node.count == 0) node.index = newSlot(pairIndex(node.index));
            return node;
        };
        BvhNodes nodes = makeNodeArray(1 + 2 * size_t(blockUsed[blockCount]));
        nodes[0] = moved(arena_[0]);
        forBlocks([&](uint32_t, uint32_t from, uint32_t to) {
            for (uint32_t word = from; word < to; ++word)
                for (uint64_t bits = usedBits[word]; bits != 0; bits &= bits - 1) {
                    const uint32_t pair = word * 64 + uint32_t(std::countr_zero(bits));
                    const uint32_t slot = newSlot(pair);
                    nodes[slot] = moved(arena_[2 * pair + 1]);
                    nodes[slot + 1] = moved(arena_[2 * pair + 2]);
                }
        });
        return nodes;
    }

    void makeLeaf(BvhNode& node, uint32_t begin, uint32_t count, uint64_t& placedSinceReport) {
        node.index = begin;
        node.count = count;
        placedSinceReport += count;
        if (placedSinceReport >= kCancelCheckInterval) {
            addPlaced(progress_, std::exchange(placedSinceReport, 0));
            throwIfCancelled(progress_);
        }
    }

    // The subtree of a node of at most kSmallNodeMaxPrimitives references, whose box is already in
    // `slot`. Every two-way partition of its references is priced (not only the bins' boundaries:
    // with this few references that costs less than filling bins), and the cheapest is kept when
    // it beats the leaf; ties go to the partition whose mask is lower.
    void buildSmall(uint32_t slot, uint32_t pairBase, uint32_t begin, uint32_t end, uint64_t& placedSinceReport) {
        const uint32_t count = end - begin;
        Ref* const refs = refs_.data() + begin;
        const Aabb parent{arena_[slot].lo, arena_[slot].hi};
        uint32_t leftMask = 0;
        Box4 boxes[1u << kSmallNodeMaxPrimitives];  // of each subset of the references, by mask
        if (count > options_.leafSize) {
            const uint32_t full = (1u << count) - 1;
            double measures[1u << kSmallNodeMaxPrimitives];
            const SahMeasure measure = SahMeasure::forParent(parent);
            boxes[0] = Box4::empty();
            for (uint32_t mask = 1; mask <= full; ++mask) {
                const uint32_t lowest = uint32_t(std::countr_zero(mask));
                boxes[mask] = boxes[mask & (mask - 1)];
                boxes[mask].grow(refs[lowest]);
                measures[mask] =
                    measure.kind == SahMeasureKind::Area ? halfArea(boxes[mask]) : measure.of(boxes[mask].aabb());
            }
            double best = std::numeric_limits<double>::infinity();
            for (uint32_t mask = 1; mask < full; mask += 2) {  // reference 0 always on the left
                const double weighted =
                    measures[mask] * double(kBitCount[mask]) + measures[full ^ mask] * double(kBitCount[full ^ mask]);
                if (weighted < best) {
                    best = weighted;
                    leftMask = mask;
                }
            }
            if (!(splitCost(best, measure.of(parent), options_) < leafCost(count, options_))) leftMask = 0;
        }
        if (leftMask == 0) {
            makeLeaf(arena_[slot], begin, count, placedSinceReport);
            return;
        }
        // The left subset first, each side in its present order.
        Ref sorted[kSmallNodeMaxPrimitives];
        uint32_t leftCount = 0;
        for (uint32_t i = 0; i < count; ++i)
            if (leftMask >> i & 1) sorted[leftCount++] = refs[i];
        for (uint32_t i = 0, right = leftCount; i < count; ++i)
            if (!(leftMask >> i & 1)) sorted[right++] = refs[i];
        std::copy(sorted, sorted + count, refs);

        const uint32_t mid = begin + leftCount;
        const uint32_t rightMask = ((1u << count) - 1) ^ leftMask;
        const uint32_t pair = makeInner(slot, pairBase, boxes[leftMask].aabb(), boxes[rightMask].aabb());
        buildSmall(pair, pair + 2, begin, mid, placedSinceReport);
        buildSmall(pair + 1, pair + 2 * leftCount, mid, end, placedSinceReport);
    }

    // Orders the node's references by centroid along the widest axis of the centroids' box (ties by
    // primitive index, so the order is total and the tree deterministic) and splits at the middle;
    // returns the first right position and the halves' boxes. When every centroid coincides the
    // order is by index alone: the halves overlap, but each is half as large.
    uint32_t medianSplit(const Work& work, Aabb& leftBox, Aabb& rightBox, Box4& leftCentroids, Box4& rightCentroids) {
        const Vec4 extent = work.centroidBox.hi - work.centroidBox.lo;
        const int axis = extent[0] >= extent[1] && extent[0] >= extent[2] ? 0 : extent[1] >= extent[2] ? 1 : 2;
        const uint32_t mid = work.begin + (work.end - work.begin) / 2;
        Ref* const refs = refs_.data();
        // Positions are ordered, then the references gathered (sorting 32-byte-aligned values
        // would pass them by value through the standard library's heap functions).
        std::vector<uint32_t> order(work.end - work.begin);
        for (uint32_t i = 0; i < order.size(); ++i) order[i] = work.begin + i;
        auto before = [&](uint32_t a, uint32_t b) {
            const float ca = refs[a].centroid()[axis], cb = refs[b].centroid()[axis];
            return ca < cb || (ca == cb && refs[a].prim() < refs[b].prim());
        };
        auto byIndex = [&](uint32_t a, uint32_t b) { return refs[a].prim() < refs[b].prim(); };
        const auto half = order.begin() + (mid - work.begin);
        std::nth_element(order.begin(), half, order.end(), before);
        // Each half in the order of its primitive indices, so that leaf contents do not depend on
        // nth_element's internal order.
        std::sort(order.begin(), half, byIndex);
        std::sort(half, order.end(), byIndex);
        std::vector<Ref> gathered(order.size());
        for (uint32_t i = 0; i < order.size(); ++i) gathered[i] = refs[order[i]];
        std::copy(gathered.begin(), gathered.end(), refs + work.begin);
        throwIfCancelled(progress_);
        Box4 left = Box4::empty(), right = Box4::empty();
        for (uint32_t i = work.begin; i < work.end; ++i) {
            (i < mid ? left : right).grow(refs[i]);
            (i < mid ? leftCentroids : rightCentroids).grow(refs[i].centroid());
        }
        leftBox = left.aabb();
        rightBox = right.aabb();
        return mid;
    }

    // A node of N references gets min(binCount, 4 + N/20) bins per axis (Embree's rule): the many
    // small nodes price few candidates, which cost more of the build than the few large nodes' bins
    // (min(binCount, N) took 1.05-1.9x the build time here, for SAH costs within -0.9%..+0.8%).
    Binning binningOf(const Box4& centroidBox, uint32_t primitiveCount) const {
        Binning binning;
        binning.binCount = std::max(2u, std::min(options_.binCount, uint32_t(4.0f + 0.05f * float(primitiveCount))));
        for (int axis = 0; axis < 3; ++axis) {
            const float extent = centroidBox.hi[axis] - centroidBox.lo[axis];
            const float scale = float(binning.binCount) / extent;
            // Inactive when the centroids coincide on this axis, or when the extent is so small
            // (subnormal) or so large (overflowing) that the scale is not a usable finite number.
            if (extent > 0.0f && std::isfinite(extent) && std::isfinite(scale) && scale > 0.0f) {
                binning.active[axis] = true;
                binning.lo[axis] = centroidBox.lo[axis];
                binning.scale[axis] = scale;
            }
            binning.lastBin[axis] = float(binning.binCount - 1);
        }
        return binning;
    }

    // Ranges of at least kTwoGridMinPrimitives fill two sets of bins, the even and the odd
    // references (the odd ones in the grid's rows after binCount), and merge them: neighbouring
    // references (neighbours in the mesh) often fall into the same bins, and with one set each
    // update would wait for the previous one's store.
    void fillBins(const Binning& binning, uint32_t begin, uint32_t end, BinGrid& grid) const {
        const bool twoGrids = end - begin >= kTwoGridMinPrimitives;
        const uint32_t odd = grid.binCount;
        if (twoGrids) grid.clearRows(odd, 2 * odd);
        for (uint32_t chunk = begin; chunk < end; chunk += kCancelCheckInterval) {
            throwIfCancelled(progress_);
            const uint32_t chunkEnd = std::min(end, chunk + kCancelCheckInterval);
            uint32_t i = chunk;
            if (twoGrids)
                for (; i + 1 < chunkEnd; i += 2) {
                    grid.add(binning, refs_[i]);
                    grid.add(binning, refs_[i + 1], odd);
                }
            for (; i < chunkEnd; ++i) grid.add(binning, refs_[i]);
        }
        if (twoGrids) grid.mergeRows(grid.bins + odd);
    }

    // Parallel filling of a large node's bins (tbb::parallel_reduce's splitting body).
    struct BinFiller {
        const SahBinnedBuilder& builder;
        const Binning& binning;
        std::unique_ptr<BinGrid> grid;
        BinFiller(const SahBinnedBuilder& b, const Binning& axes)
            : builder(b), binning(axes), grid(std::make_unique<BinGrid>(axes.binCount)) {}
        BinFiller(BinFiller& other, tbb::split) : BinFiller(other.builder, other.binning) {}
        void operator()(const tbb::blocked_range<uint32_t>& range) {
            builder.fillBins(binning, range.begin(), range.end(), *grid);
        }
        void join(const BinFiller& other) { grid->merge(*other.grid); }
    };

    Split findBestSplit(const Work& work, const Aabb& box, const Binning& binning) const {
        const uint32_t total = work.end - work.begin;
        const uint32_t binCount = binning.binCount;
        BinGrid localGrid(total > kParallelNodeMinPrimitives ? 0 : binCount);
        std::unique_ptr<BinGrid> parallelGrid;
        if (total > kParallelNodeMinPrimitives) {
            BinFiller filler(*this, binning);
            tbb::parallel_reduce(tbb::blocked_range<uint32_t>(work.begin, work.end, kPartitionChunk), filler);
            throwIfInterrupted(progress_);
            parallelGrid = std::move(filler.grid);
        } else {
            fillBins(binning, work.begin, work.end, localGrid);
        }
        const BinGrid& grid = parallelGrid ? *parallelGrid : localGrid;

        const SahMeasure measure = SahMeasure::forParent(box);
        Split best;
        if (measure.kind == SahMeasureKind::Area)
            sweepBins(grid, binning, best, [](const Box4& box) { return halfArea(box); });
        else
            sweepBins(grid, binning, best, [&](const Box4& box) { return measure.of(box.aabb()); });
        if (best.weightedMeasures == std::numeric_limits<double>::infinity()) return {};
        if (total >= kRefineMinPrimitives && total <= kParallelNodeMinPrimitives &&
            measure.kind == SahMeasureKind::Area &&
            std::max(SahMeasure::halfArea(best.leftBox), SahMeasure::halfArea(best.rightBox)) >=
                kRefineAreaShare * SahMeasure::halfArea(box))
            refine(grid, binning, work, best);
        const double cost = splitCost(best.weightedMeasures, measure.of(box), options_);
        best.found = cost < leafCost(total, options_);
        return best;
    }

    // Prices every position between the references of the two bins beside `best`'s boundary, in
    // the order of their centroids on its axis (ties by primitive index, a total order), and keeps
    // the cheapest in `best` when it is cheaper. The bins below the pair all go left and those
    // above all right: binsOf is monotonic in the centroid, so partitionRange's comparison with a
    // centroid of the pair sends them the same way.
    void refine(const BinGrid& grid, const Binning& binning, const Work& work, Split& best) const {
        const int axis = best.axis;
        const int32_t b0 = int32_t(best.lastLeftBin), b1 = b0 + 1;
        const uint32_t total = work.end - work.begin;
        if (size_t(grid.bin(axis, b0).count() + grid.bin(axis, b1).count()) * kRefineMaxShare > total) return;
        struct Near {
            float c;
            uint32_t prim, index;
        };
        thread_local std::vector<Near> near;
        thread_local std::vector<Box4> suffix;  // suffix[k]: the right child's box from near[k] on
        near.clear();
        Box4 left = Box4::empty(), right = Box4::empty();
        uint32_t leftBase = 0;
        for (int32_t b = 0; b < int32_t(binning.binCount); ++b) {
            if (b < b0) {
                left.grow(grid.bin(axis, b));
                leftBase += grid.bin(axis, b).count();
            }
            if (b > b1) right.grow(grid.bin(axis, b));
        }
        for (uint32_t i = work.begin; i < work.end; ++i) {
            const Vec4 centroid = refs_[i].centroid();
            const int32_t bin = binning.binsOf(centroid)[axis];
            if (bin == b0 || bin == b1) near.push_back({centroid[axis], refs_[i].prim(), i});
        }
        std::sort(near.begin(), near.end(),
                  [](const Near& a, const Near& b) { return a.c < b.c || (a.c == b.c && a.prim < b.prim); });
        const size_t m = near.size();
        suffix.resize(m + 1);
        suffix[m] = right;
        for (size_t k = m; k-- > 0;) {
            suffix[k] = suffix[k + 1];
            suffix[k].grow(refs_[near[k].index]);
        }
        for (size_t k = 0; k < m && leftBase + k + 1 < total; ++k) {  // while the right child holds some
            left.grow(refs_[near[k].index]);                          // the left child: the bins below and near[0..k]
            const uint32_t leftCount = leftBase + uint32_t(k) + 1;
            const double weighted =
                halfArea(left) * double(leftCount) + halfArea(suffix[k + 1]) * double(total - leftCount);
            if (weighted < best.weightedMeasures) {
                best.weightedMeasures = weighted;
                best.refined = true;
                best.value = near[k].c;
                best.prim = near[k].prim;
                best.leftBox = left.aabb();
                best.rightBox = suffix[k + 1].aabb();
                best.leftCount = leftCount;
            }
        }
    }

    // Prices every boundary between bins on the active axes and keeps the cheapest in `best`: ties
    // go to the lower axis, then the lower boundary. `measureOf` is only asked about boxes that hold
    // primitives. The sweeps keep measures and counts only; the chosen split's two boxes are
    // gathered once at the end, each in its sweep's order (min and max of +0 and -0 depend on the
    // order, so another order would give the same boxes but for the signs of some zeros).
    template <typename Measure>
    static void sweepBins(const BinGrid& grid, const Binning& binning, Split& best, Measure measureOf) {
        const uint32_t binCount = binning.binCount;
        double rightMeasure[kMaxBins];  // of bins b..binCount-1, where they hold primitives
        uint32_t rightCount[kMaxBins];
        const double before = best.weightedMeasures;
        for (int axis = 0; axis < 3; ++axis) {
            if (!binning.active[axis]) continue;
            Box4 right = Box4::empty();
            uint32_t rightTotal = 0;
            for (uint32_t b = binCount - 1; b >= 1; --b) {
                right.grow(grid.bin(axis, b));
                rightTotal += grid.bin(axis, b).count();
                rightCount[b] = rightTotal;
                rightMeasure[b] = rightTotal ? measureOf(right) : 0.0;
            }
            Box4 left = Box4::empty();
            uint32_t leftCount = 0;
            for (uint32_t b = 1; b < binCount; ++b) {  // split between bins b - 1 and b
                left.grow(grid.bin(axis, b - 1));
                leftCount += grid.bin(axis, b - 1).count();
                if (leftCount == 0 || rightCount[b] == 0) continue;
                const double weighted = measureOf(left) * double(leftCount) + rightMeasure[b] * double(rightCount[b]);
                if (weighted < best.weightedMeasures) {
                    best.weightedMeasures = weighted;
                    best.axis = axis;
                    best.lastLeftBin = b - 1;
                    best.leftCount = leftCount;
                }
            }
        }
        if (!(best.weightedMeasures < before)) return;
        Box4 left = Box4::empty(), right = Box4::empty();
        for (uint32_t b = 0; b <= best.lastLeftBin; ++b) left.grow(grid.bin(best.axis, b));
        for (uint32_t b = binCount - 1; b > best.lastLeftBin; --b) right.grow(grid.bin(best.axis, b));
        best.leftBox = left.aabb();
        best.rightBox = right.aabb();
    }

    // Partitions refs_[begin, end) in place by the split's bin: the references that go left first.
    // Returns the first right position and grows the children's centroid boxes. Large nodes
    // partition fixed-size chunks in parallel, then swap the misplaced runs across the split; both
    // paths depend on the node's contents only, never on the schedule.
    uint32_t partition(const Split& split, const Binning& binning, const Work& work, Box4& leftCentroids,
                       Box4& rightCentroids) {
        const uint32_t count = work.end - work.begin;
        if (count <= kParallelNodeMinPrimitives)
            return partitionRange(split, binning, work.begin, work.end, leftCentroids, rightCentroids);

        const uint32_t chunkCount = (count + kPartitionChunk - 1) / kPartitionChunk;
        struct Chunk {
            uint32_t begin, end, mid;
            Box4 leftCentroids = Box4::empty(), rightCentroids = Box4::empty();
        };
        std::vector<Chunk> chunks(chunkCount);
        tbb::parallel_for(uint32_t(0), chunkCount, [&](uint32_t c) {
            throwIfCancelled(progress_);
            Chunk& chunk = chunks[c];
            chunk.begin = work.begin + c * kPartitionChunk;
            chunk.end = std::min(work.end, chunk.begin + kPartitionChunk);
            chunk.mid =
                partitionRange(split, binning, chunk.begin, chunk.end, chunk.leftCentroids, chunk.rightCentroids);
        });
        throwIfInterrupted(progress_);

        // Each chunk is [lefts | rights]. Below the split position the chunks' right runs are
        // misplaced, above it their left runs; both total the same count. The k-th misplaced right
        // reference swaps with the k-th misplaced left one.
        uint32_t leftTotal = 0;
        for (const Chunk& chunk : chunks) {
            leftTotal += chunk.mid - chunk.begin;
            leftCentroids.grow(chunk.leftCentroids);
            rightCentroids.grow(chunk.rightCentroids);
        }
        const uint32_t splitPosition = work.begin + leftTotal;
        struct Run {
            uint32_t begin, end;
        };
        // Where the k-th reference of a misplaced sequence lies, and how many follow it in its run.
        struct Runs {
            std::vector<Run> runs;
            std::vector<uint64_t> offsets{0};  // of each run in the sequence; the total last
            void add(Run run) {
                if (run.begin >= run.end) return;
                runs.push_back(run);
                offsets.push_back(offsets.back() + (run.end - run.begin));
            }
            std::pair<uint32_t, uint32_t> locate(uint64_t k) const {
                const size_t r = size_t(std::upper_bound(offsets.begin(), offsets.end(), k) - offsets.begin()) - 1;
                const uint32_t position = uint32_t(runs[r].begin + (k - offsets[r]));
                return {position, runs[r].end - position};
            }
        };
        Runs wrongRights, wrongLefts;
        for (const Chunk& chunk : chunks) {
            wrongRights.add({chunk.mid, std::min(chunk.end, splitPosition)});
            wrongLefts.add({std::max(chunk.begin, splitPosition), chunk.mid});
        }
        const uint64_t misplaced = wrongRights.offsets.back();
        RAYPACK_CHECK(misplaced == wrongLefts.offsets.back());
        const uint64_t pieceCount = (misplaced + kPartitionChunk - 1) / kPartitionChunk;
        Ref* const refs = refs_.data();
        tbb::parallel_for(uint64_t(0), pieceCount, [&](uint64_t piece) {
            const uint64_t to = std::min(misplaced, (piece + 1) * kPartitionChunk);
            for (uint64_t k = piece * kPartitionChunk; k < to;) {
                const auto [right, rightRemaining] = wrongRights.locate(k);
                const auto [left, leftRemaining] = wrongLefts.locate(k);
                const uint32_t stretch =
                    uint32_t(std::min({to - k, uint64_t(rightRemaining), uint64_t(leftRemaining)}));
                std::swap_ranges(refs + right, refs + right + stretch, refs + left);
                k += stretch;
            }
        });
        throwIfInterrupted(progress_);
        return splitPosition;
    }

    // Serial partition of refs_[begin, end) by the split (partitionRangeBy); returns the first right
    // position. The kind of split is decided here, once, rather than for every reference. A binned
    // split goes by the bin that counted each reference, so the counts priced are the counts
    // partitioned; a refined one by the centroid and primitive index its sweep priced.
    uint32_t partitionRange(const Split& split, const Binning& binning, uint32_t begin, uint32_t end,
                            Box4& leftCentroids, Box4& rightCentroids) {
        const int axis = split.axis;
        if (split.refined)
            return partitionRangeBy(
                [&](const Ref& ref, Vec4 centroid) {
                    const float c = centroid[axis];
                    return c < split.value || (c == split.value && ref.prim() <= split.prim);
                },
                begin, end, leftCentroids, rightCentroids);
        // The axis as a constant, so that its lane is read from the register (with the axis in a
        // variable, GCC stored the bins to the stack and loaded the lane back).
        const int32_t lastLeftBin = int32_t(split.lastLeftBin);
        auto byBin = [&]<int kAxis>(std::integral_constant<int, kAxis>) {
            return partitionRangeBy(
                [&](const Ref&, Vec4 centroid) { return binning.binsOf(centroid)[kAxis] <= lastLeftBin; }, begin, end,
                leftCentroids, rightCentroids);
        };
        switch (axis) {
        case 0: return byBin(std::integral_constant<int, 0>{});
        case 1: return byBin(std::integral_constant<int, 1>{});
        default: return byBin(std::integral_constant<int, 2>{});
        }
    }

    // Grows `box` by the centroids of refs[0, count) in four boxes, each taking every fourth
    // reference, so that four chains of min and max run at once rather than one. The box is the
    // same but for the sign of a zero bound (min and max of +0 and -0 depend on the order), which
    // binningOf never tells apart: the tree is the same.
    static void growByCentroids(Box4& box, const Ref* refs, uint32_t count) {
        Box4 part[4] = {box, Box4::empty(), Box4::empty(), Box4::empty()};
        uint32_t i = 0;
        for (; i + 3 < count; i += 4)
            for (uint32_t k = 0; k < 4; ++k) part[k].grow(refs[i + k].centroid());
        for (; i < count; ++i) part[0].grow(refs[i].centroid());
        part[0].grow(part[1]);
        part[2].grow(part[3]);
        part[0].grow(part[2]);
        box = part[0];
    }

    // Serial partition of refs_[begin, end); returns the first right position. Up to
    // kBranchlessPartitionMax references go through a per-thread buffer, each written to the next
    // free place of its side without a branch (the side of a reference is a coin toss to the branch
    // predictor, and Hoare's scans mispredicted about once a reference); larger ranges use Hoare's
    // two scans in place.
    template <typename Side>
    uint32_t partitionRangeBy(const Side& goesLeftOf, uint32_t begin, uint32_t end, Box4& leftCentroids,
                              Box4& rightCentroids) {
        const uint32_t count = end - begin;
        if (count > kBranchlessPartitionMax)
            return partitionInPlaceBy(goesLeftOf, begin, end, leftCentroids, rightCentroids);
        thread_local const std::unique_ptr<Ref[]> buffer =
            std::make_unique_for_overwrite<Ref[]>(kBranchlessPartitionMax);
        Ref* const refs = refs_.data() + begin;
        uint32_t left = 0, right = count;  // buffer[0, left) go left, buffer[right, count) go right
        for (uint32_t i = 0; i < count; ++i) {
            const uint32_t goesLeft = goesLeftOf(refs[i], refs[i].centroid());
            // The place by arithmetic: with `goesLeft ? left : right - 1` GCC branches.
            const uint32_t leftMask = 0u - goesLeft;
            buffer[(left & leftMask) | ((right - 1) & ~leftMask)] = refs[i];
            left += goesLeft;
            right -= 1 - goesLeft;
        }
        std::copy(buffer.get(), buffer.get() + count, refs);
        growByCentroids(leftCentroids, refs, left);
        growByCentroids(rightCentroids, refs + left, count - left);
        return begin + left;
    }

    // Serial in-place partition of refs_[begin, end) (Hoare's two scans); returns the first right
    // position.
    template <typename Side>
    uint32_t partitionInPlaceBy(const Side& goesLeftOf, uint32_t begin, uint32_t end, Box4& leftCentroids,
                                Box4& rightCentroids) {
        Ref* left = refs_.data() + begin;
        Ref* right = refs_.data() + end;
        for (;;) {
            for (; left < right; ++left) {
                const Vec4 centroid = left->centroid();
                if (!goesLeftOf(*left, centroid)) break;
                leftCentroids.grow(centroid);
            }
            for (; left < right; --right) {
                const Vec4 centroid = right[-1].centroid();
                if (goesLeftOf(right[-1], centroid)) break;
                rightCentroids.grow(centroid);
            }
            if (left == right) break;
            // *left goes right and right[-1] goes left: swap them into place.
            std::swap(*left, right[-1]);
            leftCentroids.grow(left->centroid());
            rightCentroids.grow(right[-1].centroid());
            ++left;
            --right;
        }
        return uint32_t(left - refs_.data());
    }

    std::span<const Aabb> bounds_;
    const BvhBuildOptions& options_;
    BuildProgress* progress_;
    std::vector<Ref, UninitializedAllocator<Ref>> refs_;  // one per primitive; a node owns a range of this
    BvhNodes arena_;                                      // 2n - 1 slots: the root, then n - 1 pairs (see build)
    std::vector<uint8_t> pairUsed_;                       // 1 for each pair of arena_ that holds two children
};

}  // namespace

Bvh buildSahBinned(std::span<const Aabb> primitiveBounds, const BvhBuildOptions& options, BuildProgress* progress) {
    // The node array's slots (2n - 1) are indexed by 32 bits, as BvhNode::index is, and a bin's
    // count must stay a finite float's bits above kCountZero (Bin).
    if (primitiveBounds.size() > kMaxBinnedPrimitives)
        throw Error("BVH build: sah-binned takes at most " + std::to_string(kMaxBinnedPrimitives) +
                    " primitives (2n - 1 nodes in 32-bit indices, counts in a float lane), got " +
                    std::to_string(primitiveBounds.size()));
    SahBinnedBuilder builder(primitiveBounds, options, progress);
    return builder.build();
}

}  // namespace raypack::bvh_detail
