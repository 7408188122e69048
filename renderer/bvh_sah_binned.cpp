// Binned SAH builder after Wald 2007, "On fast Construction of SAH-based Bounding Volume
// Hierarchies": instead of every centroid, only the boundaries of `binCount` equal bins over the
// node's centroid bounds are split candidates, on each of the three axes. One pass drops every
// primitive into its bin (count and box per bin), a sweep over the bins prices all candidates, and
// one pass partitions the node's range. Large nodes refine the best boundary with finer bins
// (refine(), measured on Conference).
//
// Data layout, as in Embree's builders (Wald et al. 2014, "Embree: A Kernel Framework for
// Efficient CPU Ray Tracing", section 5): one array of 32-byte references (box + primitive index)
// that every node partitions in place, so binning and partitioning read memory sequentially and
// nothing is allocated per node; boxes are handled as 4-lane SSE vectors (renderer/bvh_simd.h).
//
// Parallel and deterministic: the tree depends only on *which* primitives each node holds, never
// on their order within the node (bins are integer counts and min/max boxes, the median fallback
// uses a total order, leaves are sorted by primitive index when they are made). So the bins of
// large nodes can be filled by a parallel reduction and large nodes partitioned by chunks in any
// schedule; subtrees go into fragments (renderer/bvh_build.h), spliced in a fixed order. The tree
// does not depend on the thread count (tests/test_bvh.cpp, BvhDeterminism).
#include "renderer/bvh_build.h"
#include "renderer/bvh_simd.h"
#include "renderer/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <limits>

namespace raypack::bvh_detail {
namespace {

using simd::F4;

// Nodes with more primitives than this bin and partition in parallel.
constexpr uint32_t kParallelNodeMinPrimitives = 65536;
// Chunk of the parallel partition (fixed, so the work split does not depend on the scheduler).
constexpr uint32_t kPartitionChunk = 16384;
// Nodes of more than this many primitives refine their best binned split (see refine()).
constexpr uint32_t kRefineMinPrimitives = 4096;

constexpr uint32_t kMaxBins = 256;

// One primitive as the builder moves it: its box, lanes 0-2 of lo and hi; lane 3 of lo holds the
// primitive index, lane 3 of hi is 0. 32 bytes, so a node's references are one contiguous block.
struct alignas(32) PrimRef {
    float lo[3];
    uint32_t prim;
    float hi[3];
    uint32_t zero;

    F4 boxLo() const { return F4::load(lo); }  // lane 3: garbage (the index's bits)
    F4 boxHi() const { return F4::load(hi); }
    // 0.5·lo + 0.5·hi as centroidOf (no overflow near FLT_MAX); lane 3 is 0.
    F4 centroid() const { return simd::centroidXYZ(boxLo(), boxHi()); }
};
static_assert(sizeof(PrimRef) == 32);

Aabb toAabb(const F4& lo, const F4& hi) {
    Aabb box;
    box.lo = lo.xyz();
    box.hi = hi.xyz();
    return box;
}

// measure.of(box) for a box that holds at least one primitive, without leaving the vector lanes in
// the common case (SahMeasure::Area): the sweeps price about six boxes per primitive per level.
inline __attribute__((always_inline)) double measureOf(const SahMeasure& measure, const F4& lo, const F4& hi) {
    if (measure.kind == SahMeasureKind::Area) return simd::halfArea(lo, hi);
    return measure.of(toAabb(lo, hi));
}

// Maps centroids to bins on all three axes at once. Binning and partitioning call the same
// function, so a primitive's side of the split is decided by the very bin that counted it.
struct Binner {
    F4 base = F4::zero();          // the node's centroid box lo
    F4 scale = F4::zero();         // binCount / extent per axis; 0 on an inactive axis (all in bin 0)
    F4 lastBin = F4::zero();       // binCount - 1
    std::array<bool, 3> active{};  // false where the centroids do not spread along the axis
    uint32_t binCount = 0;

    // clamp((c - lo) · scale, 0, binCount - 1) per lane: the position in bin widths, clamped in
    // float because the last centroid lands on binCount exactly.
    F4 positionsOf(const F4& centroid) const {
        return F4::min(F4::max((centroid - base) * scale, F4::zero()), lastBin);
    }
    // The bin of each lane: its position truncated.
    simd::I4 binsOf(const F4& centroid) const { return simd::truncate(positionsOf(centroid)); }
};

// Refinement (see findBinnedSplit): the two bins around the best boundary, cut into kFineBins.
constexpr uint32_t kFineBins = 32;
// The fine bin of a position (Binner::positionsOf) inside bins `first` and `first + 1`.
inline uint32_t fineBinOf(float position, uint32_t first) {
    const float fine = (position - float(first)) * float(kFineBins / 2);  // exact: power of 2
    return uint32_t(std::clamp(fine, 0.0f, float(kFineBins - 1)));
}

struct FineGrid {
    F4 lo[kFineBins];
    F4 hi[kFineBins];
    uint32_t count[kFineBins];

    FineGrid() {
        for (uint32_t b = 0; b < kFineBins; ++b) {
            lo[b] = F4::splat(FLT_MAX);
            hi[b] = F4::splat(-FLT_MAX);
            count[b] = 0;
        }
    }
    std::unique_ptr<FineGrid> emptyLike() const { return std::make_unique<FineGrid>(); }
    void merge(const FineGrid& other) {
        for (uint32_t b = 0; b < kFineBins; ++b) {
            lo[b] = F4::min(lo[b], other.lo[b]);
            hi[b] = F4::max(hi[b], other.hi[b]);
            count[b] += other.count[b];
        }
    }
};

// The bins of all three axes of one node. No initialisers: only the bins in use are cleared.
struct BinGrid {
    uint32_t binCount;
    F4 lo[3][kMaxBins];
    F4 hi[3][kMaxBins];
    uint32_t count[3][kMaxBins];

    std::unique_ptr<BinGrid> emptyLike() const { return std::make_unique<BinGrid>(binCount); }
    explicit BinGrid(uint32_t bins) : binCount(bins) {
        for (int axis = 0; axis < 3; ++axis)
            for (uint32_t b = 0; b < bins; ++b) {
                lo[axis][b] = F4::splat(FLT_MAX);
                hi[axis][b] = F4::splat(-FLT_MAX);
                count[axis][b] = 0;
            }
    }
    void add(const Binner& binner, const PrimRef& ref) {
        const F4 boxLo = ref.boxLo(), boxHi = ref.boxHi();
        const simd::I4 bins = binner.binsOf(simd::centroidXYZ(boxLo, boxHi));
        for (int axis = 0; axis < 3; ++axis) {
            const int b = bins[axis];
            lo[axis][b] = F4::min(lo[axis][b], boxLo);
            hi[axis][b] = F4::max(hi[axis][b], boxHi);
            ++count[axis][b];
        }
    }
    // Exact (integer sums, min/max; no -0 in the references), so any merge order gives the same bins.
    void merge(const BinGrid& other) {
        for (int axis = 0; axis < 3; ++axis)
            for (uint32_t b = 0; b < binCount; ++b) {
                lo[axis][b] = F4::min(lo[axis][b], other.lo[axis][b]);
                hi[axis][b] = F4::max(hi[axis][b], other.hi[axis][b]);
                count[axis][b] += other.count[axis][b];
            }
    }
};

enum class SplitKind { None, Binned };

struct Split {
    SplitKind kind = SplitKind::None;
    int axis = 0;
    Binner binner;              // Binned: of the node
    uint32_t lastLeftBin = 0;   // Binned: bins 0..lastLeftBin go left
    bool refined = false;       // Binned: bins lastLeftBin, lastLeftBin + 1 split at a fine boundary
    uint32_t lastLeftFine = 0;  // refined: their fine bins 0..lastLeftFine go left

    // The side of a reference with this centroid; binning and partitioning decide by this alone.
    bool goesLeft(const F4& centroid) const {
        const F4 positions = binner.positionsOf(centroid);
        const uint32_t bin = uint32_t(simd::truncate(positions)[axis]);
        if (!refined || bin < lastLeftBin) return bin <= lastLeftBin;
        if (bin > lastLeftBin + 1) return false;
        return fineBinOf(positions[axis], lastLeftBin) <= lastLeftFine;
    }
    double weightedMeasures = std::numeric_limits<double>::infinity();  // A_L·N_L + A_R·N_R
    Aabb leftBox, rightBox;
    uint32_t leftCount = 0;
};

// The power of 2 that scales the node's largest extent into [0.5, 1), for the sweep's single
// precision areas (exact scaling: the choice does not change when the scene is scaled by a power
// of 2); 0 where the double path must price (a measure other than area, or extents so large or
// small that the scale itself would leave the float range).
float areaScaleOf(const Aabb& box, const SahMeasure& measure) {
    if (measure.kind != SahMeasureKind::Area) return 0.0f;
    const glm::vec3 extent = box.hi - box.lo;
    const float largest = std::max(extent.x, std::max(extent.y, extent.z));
    if (!(largest > 0.0f) || !std::isfinite(largest)) return 0.0f;
    int exponent = 0;
    std::frexp(largest, &exponent);
    if (exponent < -100 || exponent > 100) return 0.0f;
    return std::ldexp(1.0f, -exponent);
}

class SahBinnedBuilder {
public:
    SahBinnedBuilder(std::span<const Aabb> bounds, const BvhBuildOptions& options, BuildProgress* progress)
        : bounds_(bounds), options_(options), progress_(progress) {}

    Bvh build(const Aabb& rootBox) {
        const uint32_t n = uint32_t(bounds_.size());
        refs_ = makeLargeVector<PrimRef>(n);
        struct Extent {
            F4 lo = F4::splat(FLT_MAX), hi = F4::splat(-FLT_MAX);
        };
        const Extent rootCentroids = tbb::parallel_reduce(
            tbb::blocked_range<uint32_t>(0, n, kCancelCheckInterval), Extent{},
            [&](const tbb::blocked_range<uint32_t>& range, Extent box) {
                throwIfCancelled(progress_);
                for (uint32_t i = range.begin(); i < range.end(); ++i) {
                    PrimRef& ref = refs_[i];
                    // + 0.0f turns -0 into +0: min and max of ±0 depend on the operand order, and
                    // the bins' merge must not (see BinGrid::merge).
                    for (int axis = 0; axis < 3; ++axis) {
                        ref.lo[axis] = bounds_[i].lo[axis] + 0.0f;
                        ref.hi[axis] = bounds_[i].hi[axis] + 0.0f;
                    }
                    ref.prim = i;
                    ref.zero = 0;
                    const F4 c = ref.centroid();
                    box.lo = F4::min(box.lo, c);
                    box.hi = F4::max(box.hi, c);
                }
                return box;
            },
            [](Extent a, const Extent& b) {
                a.lo = F4::min(a.lo, b.lo);
                a.hi = F4::max(a.hi, b.hi);
                return a;
            });
        throwIfInterrupted(progress_);

        Fragment root;
        root.nodes.resize(1);
        tbb::task_group tasks;
        buildFragment(root, {0, 0, n, rootBox, toAabb(rootCentroids.lo, rootCentroids.hi)}, tasks);
        tasks.wait();  // rethrows BuildCancelled from any task

        Bvh bvh;
        bvh.nodes = assembleFragments(root);
        bvh.primIndices = makeLargeVector<uint32_t>(n);
        tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 65536), [&](const tbb::blocked_range<uint32_t>& range) {
            for (uint32_t i = range.begin(); i < range.end(); ++i) bvh.primIndices[i] = refs_[i].prim;
        });
        return bvh;
    }

private:
    struct Work {
        uint32_t slot, begin, end;
        Aabb box;
        Aabb centroidBox;
    };

    void buildFragment(Fragment& fragment, const Work& first, tbb::task_group& tasks) {
        std::vector<Work> stack{first};
        uint64_t placedSinceReport = 0;
        while (!stack.empty()) {
            const Work work = stack.back();
            stack.pop_back();
            const uint32_t count = work.end - work.begin;
            fragment.nodes[work.slot].lo = work.box.lo;
            fragment.nodes[work.slot].hi = work.box.hi;

            Split split;
            if (count > options_.leafSize) split = findBinnedSplit(work);
            const bool median = split.kind == SplitKind::None && count > kMaxLeafPrimitives;
            if (split.kind == SplitKind::None && !median) {
                makeLeaf(fragment.nodes[work.slot], work.begin, work.end);
                placedSinceReport += count;
                if (placedSinceReport >= kCancelCheckInterval) {
                    addPlaced(progress_, std::exchange(placedSinceReport, 0));
                    throwIfCancelled(progress_);
                }
                continue;
            }
            Aabb leftCentroids, rightCentroids;
            uint32_t mid = 0;
            if (median) {
                // The SAH refuses, but the leaf would be too large: the object median.
                mid = medianSplit(work, split.leftBox, split.rightBox, leftCentroids, rightCentroids);
            } else {
                mid = partition(split, work, leftCentroids, rightCentroids);
                RAYPACK_CHECK(mid - work.begin == split.leftCount);
            }
            const uint32_t pair = fragment.addPair();
            fragment.nodes[work.slot].index = pair;
            fragment.nodes[work.slot].count = 0;
            const Work children[2] = {{pair, work.begin, mid, split.leftBox, leftCentroids},
                                      {pair + 1, mid, work.end, split.rightBox, rightCentroids}};
            for (int k = 1; k >= 0; --k) {  // left on top of the stack: depth first, left first
                const Work& child = children[k];
                if (child.end - child.begin > kFragmentMinPrimitives) {
                    Fragment& own = fragment.link(child.slot);
                    Work root = child;
                    root.slot = 0;
                    tasks.run([this, &own, root, &tasks] { buildFragment(own, root, tasks); });
                } else {
                    stack.push_back(child);
                }
            }
        }
        addPlaced(progress_, placedSinceReport);
    }

    // A leaf lists its primitives in file order (ascending index), whatever order the partitions
    // left them in.
    void makeLeaf(BvhNode& node, uint32_t begin, uint32_t end) {
        auto byPrim = [](const PrimRef& a, const PrimRef& b) { return a.prim < b.prim; };
        if (end - begin <= 32) {
            for (uint32_t i = begin + 1; i < end; ++i) {
                const PrimRef value = refs_[i];
                uint32_t j = i;
                for (; j > begin && value.prim < refs_[j - 1].prim; --j) refs_[j] = refs_[j - 1];
                refs_[j] = value;
            }
        } else {
            std::sort(refs_.begin() + begin, refs_.begin() + end, byPrim);
        }
        node.index = begin;
        node.count = end - begin;
    }

    void childBoxes(uint32_t begin, uint32_t end, Aabb& box, Aabb& centroids) const {
        F4 lo = F4::splat(FLT_MAX), hi = F4::splat(-FLT_MAX);
        F4 cLo = lo, cHi = hi;
        for (uint32_t i = begin; i < end; ++i) {
            const F4 refLo = refs_[i].boxLo(), refHi = refs_[i].boxHi();
            const F4 c = simd::centroidXYZ(refLo, refHi);
            lo = F4::min(lo, refLo);
            hi = F4::max(hi, refHi);
            cLo = F4::min(cLo, c);
            cHi = F4::max(cHi, c);
        }
        box = toAabb(lo, hi);
        centroids = toAabb(cLo, cHi);
    }

    // Splits refs_[begin, end) at the middle of the order (centroid along the widest axis of the
    // centroids' box, ties by primitive index); returns the first right position and the halves'
    // boxes. When every centroid coincides the order is by index alone: the halves overlap, but
    // each is half as large.
    uint32_t medianSplit(const Work& work, Aabb& leftBox, Aabb& rightBox, Aabb& leftCentroids, Aabb& rightCentroids) {
        const glm::vec3 extent = work.centroidBox.hi - work.centroidBox.lo;
        const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
        const uint32_t mid = work.begin + (work.end - work.begin) / 2;
        auto before = [&](const PrimRef& a, const PrimRef& b) {
            const float ca = a.centroid()[axis], cb = b.centroid()[axis];
            return ca < cb || (ca == cb && a.prim < b.prim);
        };
        std::nth_element(refs_.begin() + work.begin, refs_.begin() + mid, refs_.begin() + work.end, before);
        throwIfCancelled(progress_);
        childBoxes(work.begin, mid, leftBox, leftCentroids);
        childBoxes(mid, work.end, rightBox, rightCentroids);
        return mid;
    }

    // A node of N primitives gets min(binCount, N) bins per axis: more bins than primitives only
    // repeat candidates, and evaluating 3·binCount bins dominated the time of the many small nodes.
    Binner binnerOf(const Aabb& centroidBox, uint32_t primitiveCount) const {
        Binner binner;
        binner.binCount = std::max(2u, std::min(options_.binCount, primitiveCount));
        float scale[3] = {0.0f, 0.0f, 0.0f};
        for (int axis = 0; axis < 3; ++axis) {
            const float extent = centroidBox.hi[axis] - centroidBox.lo[axis];
            const float s = float(binner.binCount) / extent;
            // Inactive when the centroids coincide on this axis, or when the extent is so small
            // (subnormal) or so large (overflowing) that the scale is not a usable finite number.
            binner.active[axis] = extent > 0.0f && std::isfinite(extent) && std::isfinite(s) && s > 0.0f;
            if (binner.active[axis]) scale[axis] = s;
        }
        binner.base = F4::set(centroidBox.lo.x, centroidBox.lo.y, centroidBox.lo.z, 0.0f);
        binner.scale = F4::set(scale[0], scale[1], scale[2], 0.0f);
        binner.lastBin = F4::splat(float(binner.binCount - 1));
        return binner;
    }

    void fillBins(const Binner& binner, uint32_t begin, uint32_t end, BinGrid& grid) const {
        for (uint32_t chunk = begin; chunk < end; chunk += kCancelCheckInterval) {
            throwIfCancelled(progress_);
            const uint32_t chunkEnd = std::min(end, chunk + kCancelCheckInterval);
            for (uint32_t i = chunk; i < chunkEnd; ++i) grid.add(binner, refs_[i]);
        }
    }

    // Fills the empty `grid` from refs_[begin, end) by fill(from, to, grid): serially, or for a
    // large node by a parallel reduction (its merge is exact, so the bins do not depend on the split
    // of the work). Small nodes' grids live on the stack: nothing is allocated per node.
    template <typename Grid, typename Fill>
    void fillGrid(uint32_t begin, uint32_t end, Grid& grid, const Fill& fill) const {
        if (end - begin <= kParallelNodeMinPrimitives) {
            fill(begin, end, grid);
            return;
        }
        struct Body {
            const Fill& fill;
            std::unique_ptr<Grid> grid;
            Body(const Fill& f, std::unique_ptr<Grid> g) : fill(f), grid(std::move(g)) {}
            Body(Body& other, tbb::split) : fill(other.fill), grid(other.grid->emptyLike()) {}
            void operator()(const tbb::blocked_range<uint32_t>& range) { fill(range.begin(), range.end(), *grid); }
            void join(const Body& other) { grid->merge(*other.grid); }
        } body(fill, grid.emptyLike());
        tbb::parallel_reduce(tbb::blocked_range<uint32_t>(begin, end, kCancelCheckInterval), body);
        throwIfInterrupted(progress_);
        grid.merge(*body.grid);
    }

    Split findBinnedSplit(const Work& work) const {
        const uint32_t total = work.end - work.begin;
        const Binner binner = binnerOf(work.centroidBox, total);
        if (!binner.active[0] && !binner.active[1] && !binner.active[2]) return Split();  // one point
        if (total == 2) return pairSplit(work, binner);
        const uint32_t binCount = binner.binCount;

        BinGrid grid(binCount);
        fillGrid(work.begin, work.end, grid,
                 [&](uint32_t from, uint32_t to, BinGrid& bins) { fillBins(binner, from, to, bins); });

        const SahMeasure measure = SahMeasure::forParent(work.box);
        const float areaScale = areaScaleOf(work.box, measure);
        Split best;
        // Prefix boxes (bins 0..b) and suffix boxes (bins b..end), padded for scaledHalfAreas.
        F4 leftLo[kMaxBins + 4], leftHi[kMaxBins + 4], rightLo[kMaxBins + 4], rightHi[kMaxBins + 4];
        uint32_t rightCounts[kMaxBins + 4];
        float rightCountsF[kMaxBins + 4], leftArea[kMaxBins + 4], rightArea[kMaxBins + 4], prices[kMaxBins + 4];
        double leftMeasure[kMaxBins], rightMeasure[kMaxBins];
        std::array<uint32_t, 3> axisBest{};     // per axis: the best boundary's last left bin
        for (int axis = 0; axis < 3; ++axis) {  // strict < below: ties go to the lower axis
            if (!binner.active[axis]) continue;
            F4 lo = F4::splat(FLT_MAX), hi = F4::splat(-FLT_MAX);
            for (uint32_t b = 0; b + 1 < binCount; ++b) {
                lo = F4::min(lo, grid.lo[axis][b]);
                hi = F4::max(hi, grid.hi[axis][b]);
                leftLo[b] = lo;
                leftHi[b] = hi;
            }
            lo = F4::splat(FLT_MAX);
            hi = F4::splat(-FLT_MAX);
            uint32_t rightCount = 0;
            for (uint32_t b = binCount - 1; b >= 1; --b) {
                lo = F4::min(lo, grid.lo[axis][b]);
                hi = F4::max(hi, grid.hi[axis][b]);
                rightCount += grid.count[axis][b];
                rightLo[b - 1] = lo;  // shifted: candidate b - 1 (between bins b - 1 and b) at b - 1
                rightHi[b - 1] = hi;
                rightCounts[b - 1] = rightCount;
                rightCountsF[b - 1] = float(rightCount);
            }
            const uint32_t candidates = binCount - 1;  // candidate c: bins 0..c left, c + 1.. right
            auto priceOf = [&](uint32_t c) -> double {
                if (areaScale > 0.0f) return double(prices[c]);
                return leftMeasure[c] * double(total - rightCounts[c]) + rightMeasure[c] * double(rightCounts[c]);
            };
            if (areaScale > 0.0f) {
                // Areas of the node's children in single precision, the extents scaled by a power of 2
                // (exact) into (0, 1], four candidates at a time; the winner is re-priced in double.
                for (uint32_t c = candidates; c < (candidates + 3) / 4 * 4; ++c)
                    leftLo[c] = leftHi[c] = rightLo[c] = rightHi[c] = F4::zero();
                for (uint32_t c = candidates; c < (candidates + 3) / 4 * 4; ++c) rightCountsF[c] = 0.0f;
                simd::scaledHalfAreas(leftLo, leftHi, candidates, areaScale, leftArea);
                simd::scaledHalfAreas(rightLo, rightHi, candidates, areaScale, rightArea);
                simd::sahPrices(leftArea, rightArea, rightCountsF, float(total), candidates, prices);
            } else {
                for (uint32_t c = 0; c < candidates; ++c) {
                    leftMeasure[c] = measureOf(measure, leftLo[c], leftHi[c]);
                    rightMeasure[c] = measureOf(measure, rightLo[c], rightHi[c]);
                }
            }
            // The axis' cheapest candidate, ties to the lowest; across axes strict <, ties to the
            // lower axis.
            double axisWeighted = std::numeric_limits<double>::infinity();
            for (uint32_t c = candidates; c-- > 0;) {  // high to low, as the suffix sweep ran
                const uint32_t rightCount = rightCounts[c];
                if (rightCount == 0 || rightCount == total) continue;
                const double weighted = priceOf(c);
                if (weighted <= axisWeighted) {
                    axisWeighted = weighted;
                    axisBest[axis] = c;
                }
            }
            if (axisWeighted < best.weightedMeasures) {
                const uint32_t c = axisBest[axis];
                best.weightedMeasures = axisWeighted;
                best.axis = axis;
                best.lastLeftBin = c;
                best.leftBox = toAabb(leftLo[c], leftHi[c]);
                best.rightBox = toAabb(rightLo[c], rightHi[c]);
                best.leftCount = total - rightCounts[c];
            }
        }
        if (best.weightedMeasures == std::numeric_limits<double>::infinity()) return Split();
        best.binner = binner;
        // The winner's price in double, as the refinement and the leaf test measure.
        best.weightedMeasures = measure.of(best.leftBox) * double(best.leftCount) +
                                measure.of(best.rightBox) * double(total - best.leftCount);
        if (total > kRefineMinPrimitives) refine(work, grid, measure, axisBest, best);
        const double cost = splitCost(best.weightedMeasures, measure.of(work.box), options_);
        if (cost < leafCost(total, options_)) best.kind = SplitKind::Binned;
        return best;
    }

    // Two primitives (about a third of the inner nodes): the binned search's only candidate, one
    // primitive on each side, priced directly. The same split as the bins give: the first active
    // axis (ties go to the lower axis), the lower centroid in bin 0.
    Split pairSplit(const Work& work, const Binner& binner) const {
        const int axis = binner.active[0] ? 0 : binner.active[1] ? 1 : 2;
        const PrimRef& a = refs_[work.begin];
        const PrimRef& b = refs_[work.begin + 1];
        const bool aLeft = binner.binsOf(a.centroid())[axis] == 0;
        const PrimRef& left = aLeft ? a : b;
        const PrimRef& right = aLeft ? b : a;
        const SahMeasure measure = SahMeasure::forParent(work.box);
        Split split;
        split.axis = axis;
        split.binner = binner;
        split.lastLeftBin = 0;
        split.weightedMeasures =
            measureOf(measure, left.boxLo(), left.boxHi()) + measureOf(measure, right.boxLo(), right.boxHi());
        split.leftBox = toAabb(left.boxLo(), left.boxHi());
        split.rightBox = toAabb(right.boxLo(), right.boxHi());
        split.leftCount = 1;
        if (splitCost(split.weightedMeasures, measure.of(work.box), options_) < leafCost(2, options_))
            split.kind = SplitKind::Binned;
        return split;
    }

    // Equal bins over the centroids' box resolve the dense part of a skewed distribution poorly:
    // on Conference the best exact split of the root and of a few nodes of 10-30k primitives lies
    // inside the first or last of 32 bins (a few far centroids stretch the box), and 256 bins did
    // not help (SAH cost 47.21 against exact 44.87), while exact splits on just those nodes did
    // (44.81). So large nodes re-bin the two bins around the best boundary of the best axis into
    // kFineBins and take a fine boundary where it is cheaper: one more pass, 16 times the
    // resolution where it matters.
    void refine(const Work& work, const BinGrid& grid, const SahMeasure& measure,
                const std::array<uint32_t, 3>& axisBest, Split& best) const {
        const Binner& binner = best.binner;
        struct FineGrids {
            FineGrid axes[3];
            std::unique_ptr<FineGrids> emptyLike() const { return std::make_unique<FineGrids>(); }
            void merge(const FineGrids& other) {
                for (int axis = 0; axis < 3; ++axis) axes[axis].merge(other.axes[axis]);
            }
        };
        FineGrids fine;
        fillGrid(work.begin, work.end, fine, [&](uint32_t from, uint32_t to, FineGrids& bins) {
            for (uint32_t chunk = from; chunk < to; chunk += kCancelCheckInterval) {
                throwIfCancelled(progress_);
                const uint32_t chunkEnd = std::min(to, chunk + kCancelCheckInterval);
                for (uint32_t i = chunk; i < chunkEnd; ++i) {
                    const F4 boxLo = refs_[i].boxLo(), boxHi = refs_[i].boxHi();
                    const F4 positions = binner.positionsOf(simd::centroidXYZ(boxLo, boxHi));
                    const simd::I4 coarse = simd::truncate(positions);
                    for (int axis = 0; axis < 3; ++axis) {
                        if (uint32_t(coarse[axis]) - axisBest[axis] > 1u) continue;  // not in the pair
                        FineGrid& axisBins = bins.axes[axis];
                        const uint32_t b = fineBinOf(positions[axis], axisBest[axis]);
                        axisBins.lo[b] = F4::min(axisBins.lo[b], boxLo);
                        axisBins.hi[b] = F4::max(axisBins.hi[b], boxHi);
                        ++axisBins.count[b];
                    }
                }
            }
        });
        const uint32_t total = work.end - work.begin;
        for (int axis = 0; axis < 3; ++axis) {
            if (!binner.active[axis]) continue;
            const uint32_t first = axisBest[axis];  // bins first and first + 1 were re-binned
            const FineGrid& bins = fine.axes[axis];
            // The coarse bins below and above the refined pair.
            F4 lo = F4::splat(FLT_MAX), hi = F4::splat(-FLT_MAX);
            uint32_t leftCount = 0;
            for (uint32_t b = 0; b < first; ++b) {
                lo = F4::min(lo, grid.lo[axis][b]);
                hi = F4::max(hi, grid.hi[axis][b]);
                leftCount += grid.count[axis][b];
            }
            double leftMeasure[kFineBins];
            F4 leftLo[kFineBins], leftHi[kFineBins];
            uint32_t leftCounts[kFineBins];
            for (uint32_t b = 0; b + 1 < kFineBins; ++b) {
                lo = F4::min(lo, bins.lo[b]);
                hi = F4::max(hi, bins.hi[b]);
                leftCount += bins.count[b];
                leftLo[b] = lo;
                leftHi[b] = hi;
                leftCounts[b] = leftCount;
                leftMeasure[b] = measureOf(measure, lo, hi);
            }
            lo = F4::splat(FLT_MAX);
            hi = F4::splat(-FLT_MAX);
            for (uint32_t b = first + 2; b < grid.binCount; ++b) {
                lo = F4::min(lo, grid.lo[axis][b]);
                hi = F4::max(hi, grid.hi[axis][b]);
            }
            for (uint32_t b = kFineBins - 1; b >= 1; --b) {  // split between fine bins b - 1 and b
                lo = F4::min(lo, bins.lo[b]);
                hi = F4::max(hi, bins.hi[b]);
                const uint32_t left = leftCounts[b - 1], right = total - left;
                if (left == 0 || right == 0) continue;
                const double weighted = leftMeasure[b - 1] * double(left) + measureOf(measure, lo, hi) * double(right);
                if (weighted < best.weightedMeasures) {  // strict: ties keep the coarse split
                    best.weightedMeasures = weighted;
                    best.axis = axis;
                    best.lastLeftBin = first;
                    best.refined = true;
                    best.lastLeftFine = b - 1;
                    best.leftBox = toAabb(leftLo[b - 1], leftHi[b - 1]);
                    best.rightBox = toAabb(lo, hi);
                    best.leftCount = left;
                }
            }
        }
    }

    // In-place partition of refs_[begin, end) by bin (two-sided, Hoare); returns the first right
    // position and the children's centroid boxes. Large nodes: fixed chunks partitioned in
    // parallel, then the misplaced blocks swapped across the split in parallel.
    uint32_t partition(const Split& split, const Work& work, Aabb& leftCentroids, Aabb& rightCentroids) {
        struct Sides {
            F4 leftLo = F4::splat(FLT_MAX), leftHi = F4::splat(-FLT_MAX);
            F4 rightLo = F4::splat(FLT_MAX), rightHi = F4::splat(-FLT_MAX);
        };
        // Partitions [from, to) in place; returns the first right position.
        auto partitionRange = [&](uint32_t from, uint32_t to, Sides& sides) {
            PrimRef* refs = refs_.data();
            uint32_t i = from, j = to;
            while (true) {
                while (i < j) {
                    const F4 c = refs[i].centroid();
                    if (!split.goesLeft(c)) break;
                    sides.leftLo = F4::min(sides.leftLo, c);
                    sides.leftHi = F4::max(sides.leftHi, c);
                    ++i;
                }
                while (i < j) {
                    const F4 c = refs[j - 1].centroid();
                    if (split.goesLeft(c)) break;
                    sides.rightLo = F4::min(sides.rightLo, c);
                    sides.rightHi = F4::max(sides.rightHi, c);
                    --j;
                }
                if (i >= j) return i;
                std::swap(refs[i], refs[j - 1]);  // now refs[i] goes left and refs[j - 1] right
            }
        };
        const uint32_t count = work.end - work.begin;
        if (count <= kParallelNodeMinPrimitives) {
            Sides sides;
            const uint32_t mid = partitionRange(work.begin, work.end, sides);
            leftCentroids = toAabb(sides.leftLo, sides.leftHi);
            rightCentroids = toAabb(sides.rightLo, sides.rightHi);
            return mid;
        }

        const uint32_t chunkCount = (count + kPartitionChunk - 1) / kPartitionChunk;
        struct Chunk {
            uint32_t from, to, mid;
            Sides sides;
        };
        std::vector<Chunk> chunks(chunkCount);
        tbb::parallel_for(uint32_t(0), chunkCount, [&](uint32_t c) {
            throwIfCancelled(progress_);
            Chunk& chunk = chunks[c];
            chunk.from = work.begin + c * kPartitionChunk;
            chunk.to = std::min(work.end, chunk.from + kPartitionChunk);
            chunk.mid = partitionRange(chunk.from, chunk.to, chunk.sides);
        });
        throwIfInterrupted(progress_);
        uint32_t leftTotal = 0;
        Sides all;
        for (const Chunk& chunk : chunks) {
            leftTotal += chunk.mid - chunk.from;
            all.leftLo = F4::min(all.leftLo, chunk.sides.leftLo);
            all.leftHi = F4::max(all.leftHi, chunk.sides.leftHi);
            all.rightLo = F4::min(all.rightLo, chunk.sides.rightLo);
            all.rightHi = F4::max(all.rightHi, chunk.sides.rightHi);
        }
        leftCentroids = toAabb(all.leftLo, all.leftHi);
        rightCentroids = toAabb(all.rightLo, all.rightHi);
        const uint32_t mid = work.begin + leftTotal;
        // Misplaced: right-going references before mid and left-going ones from mid on. There are
        // as many of one as of the other; the k-th of the first kind swaps with the k-th of the
        // second. Each list is a sequence of ranges, one per chunk at most.
        struct Run {
            uint32_t from, to;
        };
        std::vector<Run> wrongRight, wrongLeft;
        for (const Chunk& chunk : chunks) {
            const uint32_t rightFrom = chunk.mid, rightTo = std::min(chunk.to, mid);
            if (rightFrom < rightTo) wrongRight.push_back({rightFrom, rightTo});
            const uint32_t leftFrom = std::max(chunk.from, mid), leftTo = chunk.mid;
            if (leftFrom < leftTo) wrongLeft.push_back({leftFrom, leftTo});
        }
        // Cut both lists into the same pieces (a new piece wherever either list's run ends).
        struct Piece {
            uint32_t a, b, length;
        };
        std::vector<Piece> pieces;
        size_t r = 0, l = 0;
        uint32_t rOffset = 0, lOffset = 0;
        while (r < wrongRight.size() && l < wrongLeft.size()) {
            const uint32_t rLeft = wrongRight[r].to - wrongRight[r].from - rOffset;
            const uint32_t lLeft = wrongLeft[l].to - wrongLeft[l].from - lOffset;
            const uint32_t length = std::min(rLeft, lLeft);
            pieces.push_back({wrongRight[r].from + rOffset, wrongLeft[l].from + lOffset, length});
            rOffset += length;
            lOffset += length;
            if (rOffset == wrongRight[r].to - wrongRight[r].from) ++r, rOffset = 0;
            if (lOffset == wrongLeft[l].to - wrongLeft[l].from) ++l, lOffset = 0;
        }
        RAYPACK_CHECK(r == wrongRight.size() && l == wrongLeft.size());
        tbb::parallel_for(size_t(0), pieces.size(), [&](size_t p) {
            const Piece& piece = pieces[p];
            std::swap_ranges(refs_.begin() + piece.a, refs_.begin() + piece.a + piece.length, refs_.begin() + piece.b);
        });
        throwIfInterrupted(progress_);
        return mid;
    }

    std::span<const Aabb> bounds_;
    const BvhBuildOptions& options_;
    BuildProgress* progress_;
    std::vector<PrimRef> refs_;  // a node owns a range of this
};

}  // namespace

Bvh buildSahBinned(std::span<const Aabb> primitiveBounds, const Aabb& rootBox, const BvhBuildOptions& options,
                   BuildProgress* progress) {
    SahBinnedBuilder builder(primitiveBounds, options, progress);
    return builder.build(rootBox);
}

}  // namespace raypack::bvh_detail
