// Binned SAH builder after Wald 2007, "On fast Construction of SAH-based Bounding Volume
// Hierarchies": instead of every centroid, only the boundaries of `binCount` equal bins over the
// node's centroid bounds are split candidates, on each of the three axes. One pass drops every
// primitive into its bin (count and box per bin), a sweep over the bins prices all candidates, and
// one stable pass partitions the node's index range.
//
// Parallel and deterministic: bins of large nodes are filled by a parallel reduction whose merge
// (integer sums, box min/max) is exact and associative, so any split of the work gives the same
// bins; large partitions run in fixed-size chunks with a prefix sum; subtrees go into fragments
// (renderer/bvh_build.h) as in the exact builder. The tree does not depend on the thread count.
#include "renderer/bvh_build.h"
#include "renderer/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
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

// Nodes with more primitives than this bin and partition in parallel.
constexpr uint32_t kParallelNodeMinPrimitives = 65536;
// Chunk of the parallel partition (fixed, so the result does not depend on the scheduler).
constexpr uint32_t kPartitionChunk = 16384;

constexpr uint32_t kMaxBins = 256;

// A bin: the primitives whose centroids fall into it, counted and bounded. No default member
// initialisers, so a node's bins live on the stack and only the ones in use are cleared.
struct Bin {
    glm::vec3 lo, hi;
    uint32_t count;
};

// Maps a centroid coordinate to its bin on one axis. Binning and partitioning call the same
// function, so a primitive's side of the split is decided by the very bin that counted it.
struct AxisBinning {
    bool active = false;  // false when the centroids do not spread along this axis
    float lo = 0.0f;
    float scale = 0.0f;  // binCount / extent
    uint32_t binCount = 0;

    uint32_t binOf(float coordinate) const {
        const float position = (coordinate - lo) * scale;
        // Clamp in float first: the last centroid lands on binCount exactly.
        return uint32_t(std::clamp(position, 0.0f, float(binCount - 1)));
    }
};

// The bins of all three axes of one node.
struct BinGrid {
    uint32_t binCount;
    Bin bins[3][kMaxBins];

    explicit BinGrid(uint32_t count) : binCount(count) {
        for (auto& axisBins : bins)
            for (uint32_t b = 0; b < count; ++b) axisBins[b] = {glm::vec3(FLT_MAX), glm::vec3(-FLT_MAX), 0};
    }
    void add(const std::array<AxisBinning, 3>& binning, const Aabb& box, const glm::vec3& centroid) {
        for (int axis = 0; axis < 3; ++axis) {
            if (!binning[axis].active) continue;
            Bin& bin = bins[axis][binning[axis].binOf(centroid[axis])];
            bin.lo = glm::min(bin.lo, box.lo);
            bin.hi = glm::max(bin.hi, box.hi);
            ++bin.count;
        }
    }
    // Exact (integer sums, min/max), so any order of merging gives the same bins.
    void merge(const BinGrid& other) {
        for (int axis = 0; axis < 3; ++axis)
            for (uint32_t b = 0; b < binCount; ++b) {
                bins[axis][b].lo = glm::min(bins[axis][b].lo, other.bins[axis][b].lo);
                bins[axis][b].hi = glm::max(bins[axis][b].hi, other.bins[axis][b].hi);
                bins[axis][b].count += other.bins[axis][b].count;
            }
    }
};

struct Split {
    bool found = false;
    int axis = 0;
    AxisBinning binning;                                                // of `axis`
    uint32_t lastLeftBin = 0;                                           // bins 0..lastLeftBin go left
    double weightedMeasures = std::numeric_limits<double>::infinity();  // A_L·N_L + A_R·N_R
    Aabb leftBox, rightBox;
    uint32_t leftCount = 0;
};

class SahBinnedBuilder {
public:
    SahBinnedBuilder(std::span<const Aabb> bounds, const BvhBuildOptions& options, BuildProgress* progress)
        : bounds_(bounds), options_(options), progress_(progress) {}

    Bvh build(const Aabb& rootBox) {
        const uint32_t n = uint32_t(bounds_.size());
        centroids_ = makeLargeVector<glm::vec3>(n);
        prims_ = makeLargeVector<uint32_t>(n);
        spill_ = makeLargeVector<uint32_t>(n);
        const Aabb rootCentroids = tbb::parallel_reduce(
            tbb::blocked_range<uint32_t>(0, n, kCancelCheckInterval), Aabb{},
            [&](const tbb::blocked_range<uint32_t>& range, Aabb box) {
                throwIfCancelled(progress_);
                for (uint32_t i = range.begin(); i < range.end(); ++i) {
                    centroids_[i] = centroidOf(bounds_[i]);
                    prims_[i] = i;
                    box.grow(centroids_[i]);
                }
                return box;
            },
            [](Aabb a, const Aabb& b) {
                a.grow(b);
                return a;
            });
        throwIfInterrupted(progress_);

        Fragment root;
        root.nodes.resize(1);
        tbb::task_group tasks;
        buildFragment(root, {0, 0, n, rootBox, rootCentroids}, tasks);
        tasks.wait();  // rethrows BuildCancelled from any task

        Bvh bvh;
        bvh.nodes = assembleFragments(root);
        bvh.primIndices = std::move(prims_);
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
            if (count > options_.leafSize) split = findBestSplit(work);
            const bool median = !split.found && count > kMaxLeafPrimitives;
            if (!split.found && !median) {
                fragment.nodes[work.slot].index = work.begin;
                fragment.nodes[work.slot].count = count;
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
                split.leftBox = split.rightBox = Aabb{};  // the refused candidate's boxes
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

    // Orders prims_[begin, end) by centroid along the widest axis of the centroids' box (ties by
    // primitive index, so the order is total and the tree deterministic) and splits at the middle;
    // returns the first right position and the halves' boxes. When every centroid coincides the
    // order is by index alone: the halves overlap, but each is half as large.
    uint32_t medianSplit(const Work& work, Aabb& leftBox, Aabb& rightBox, Aabb& leftCentroids, Aabb& rightCentroids) {
        const glm::vec3 extent = work.centroidBox.hi - work.centroidBox.lo;
        const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
        const uint32_t mid = work.begin + (work.end - work.begin) / 2;
        auto before = [&](uint32_t a, uint32_t b) {
            const float ca = centroids_[a][axis], cb = centroids_[b][axis];
            return ca < cb || (ca == cb && a < b);
        };
        std::nth_element(prims_.begin() + work.begin, prims_.begin() + mid, prims_.begin() + work.end, before);
        // The two halves keep the order of their primitive indices, as the partition's stable
        // order would (leaf contents do not depend on nth_element's internal order).
        std::sort(prims_.begin() + work.begin, prims_.begin() + mid);
        std::sort(prims_.begin() + mid, prims_.begin() + work.end);
        throwIfCancelled(progress_);
        for (uint32_t i = work.begin; i < work.end; ++i) {
            const uint32_t prim = prims_[i];
            (i < mid ? leftBox : rightBox).grow(bounds_[prim]);
            (i < mid ? leftCentroids : rightCentroids).grow(centroids_[prim]);
        }
        return mid;
    }

    // A node of N primitives gets min(binCount, N) bins per axis: more bins than primitives only
    // repeat candidates, and evaluating 3·binCount bins dominated the time of the many small nodes.
    std::array<AxisBinning, 3> binningOf(const Aabb& centroidBox, uint32_t primitiveCount) const {
        const uint32_t binCount = std::max(2u, std::min(options_.binCount, primitiveCount));
        std::array<AxisBinning, 3> binning;
        for (int axis = 0; axis < 3; ++axis) {
            const float extent = centroidBox.hi[axis] - centroidBox.lo[axis];
            const float scale = float(binCount) / extent;
            // Inactive when the centroids coincide on this axis, or when the extent is so small
            // (subnormal) or so large (overflowing) that the scale is not a usable finite number.
            if (extent > 0.0f && std::isfinite(extent) && std::isfinite(scale) && scale > 0.0f)
                binning[axis] = {true, centroidBox.lo[axis], scale, binCount};
        }
        return binning;
    }

    void fillBins(const std::array<AxisBinning, 3>& binning, uint32_t begin, uint32_t end, BinGrid& grid) const {
        for (uint32_t chunk = begin; chunk < end; chunk += kCancelCheckInterval) {
            throwIfCancelled(progress_);
            const uint32_t chunkEnd = std::min(end, chunk + kCancelCheckInterval);
            for (uint32_t i = chunk; i < chunkEnd; ++i) {
                const uint32_t prim = prims_[i];
                grid.add(binning, bounds_[prim], centroids_[prim]);
            }
        }
    }

    // Parallel filling of a large node's bins (tbb::parallel_reduce's splitting body).
    struct BinFiller {
        const SahBinnedBuilder& builder;
        const std::array<AxisBinning, 3>& binning;
        std::unique_ptr<BinGrid> grid;
        BinFiller(const SahBinnedBuilder& b, const std::array<AxisBinning, 3>& axes, uint32_t count)
            : builder(b), binning(axes), grid(std::make_unique<BinGrid>(count)) {}
        BinFiller(BinFiller& other, tbb::split) : BinFiller(other.builder, other.binning, other.grid->binCount) {}
        void operator()(const tbb::blocked_range<uint32_t>& range) {
            builder.fillBins(binning, range.begin(), range.end(), *grid);
        }
        void join(const BinFiller& other) { grid->merge(*other.grid); }
    };

    Split findBestSplit(const Work& work) const {
        const uint32_t total = work.end - work.begin;
        const std::array<AxisBinning, 3> binning = binningOf(work.centroidBox, total);
        if (!binning[0].active && !binning[1].active && !binning[2].active) return {};  // one point
        const uint32_t binCount = binning[0].active   ? binning[0].binCount
                                  : binning[1].active ? binning[1].binCount
                                                      : binning[2].binCount;

        BinGrid localGrid(binCount);
        std::unique_ptr<BinGrid> parallelGrid;
        if (total > kParallelNodeMinPrimitives) {
            BinFiller filler(*this, binning, binCount);
            tbb::parallel_reduce(tbb::blocked_range<uint32_t>(work.begin, work.end, kCancelCheckInterval), filler);
            throwIfInterrupted(progress_);
            parallelGrid = std::move(filler.grid);
        } else {
            fillBins(binning, work.begin, work.end, localGrid);
        }
        const BinGrid& grid = parallelGrid ? *parallelGrid : localGrid;

        const SahMeasure measure = SahMeasure::forParent(work.box);
        Split best;
        double leftMeasure[kMaxBins];
        Bin leftBoxes[kMaxBins];                // only lo and hi used
        for (int axis = 0; axis < 3; ++axis) {  // strict < below: ties go to the lower axis
            if (!binning[axis].active) continue;
            const Bin* bins = grid.bins[axis];
            Aabb box;
            for (uint32_t b = 0; b + 1 < binCount; ++b) {
                box.grow(Aabb{bins[b].lo, bins[b].hi});
                leftBoxes[b] = {box.lo, box.hi, 0};
                leftMeasure[b] = measure.of(box);
            }
            Aabb rightBox;
            uint32_t rightCount = 0;
            for (uint32_t b = binCount - 1; b >= 1; --b) {  // split between bins b - 1 and b
                rightBox.grow(Aabb{bins[b].lo, bins[b].hi});
                rightCount += bins[b].count;
                const uint32_t leftCount = total - rightCount;
                if (rightCount == 0 || leftCount == 0) continue;
                const double weighted =
                    leftMeasure[b - 1] * double(leftCount) + measure.of(rightBox) * double(rightCount);
                if (weighted < best.weightedMeasures || (weighted == best.weightedMeasures && axis == best.axis)) {
                    best.weightedMeasures = weighted;
                    best.axis = axis;
                    best.binning = binning[axis];
                    best.lastLeftBin = b - 1;
                    best.leftBox = Aabb{leftBoxes[b - 1].lo, leftBoxes[b - 1].hi};
                    best.rightBox = rightBox;
                    best.leftCount = leftCount;
                }
            }
        }
        if (best.weightedMeasures == std::numeric_limits<double>::infinity()) return {};
        const double cost = splitCost(best.weightedMeasures, measure.of(work.box), options_);
        best.found = cost < leafCost(total, options_);
        return best;
    }

    // Stable partition of prims_[begin, end) by bin; returns the first right position and the
    // children's centroid boxes. Chunked, with the chunks' offsets from a prefix sum, so the serial
    // and the parallel path give the same order.
    uint32_t partition(const Split& split, const Work& work, Aabb& leftCentroids, Aabb& rightCentroids) {
        const AxisBinning& binning = split.binning;
        auto goesLeft = [&](uint32_t prim) { return binning.binOf(centroids_[prim][split.axis]) <= split.lastLeftBin; };
        const uint32_t count = work.end - work.begin;
        if (count <= kParallelNodeMinPrimitives) {
            uint32_t leftEnd = work.begin, spillEnd = work.begin;
            for (uint32_t i = work.begin; i < work.end; ++i) {
                const uint32_t prim = prims_[i];
                if (goesLeft(prim)) {
                    prims_[leftEnd++] = prim;  // leftEnd <= i: in place
                    leftCentroids.grow(centroids_[prim]);
                } else {
                    spill_[spillEnd++] = prim;
                    rightCentroids.grow(centroids_[prim]);
                }
            }
            std::memcpy(&prims_[leftEnd], &spill_[work.begin], (spillEnd - work.begin) * sizeof(uint32_t));
            return leftEnd;
        }

        const uint32_t chunkCount = (count + kPartitionChunk - 1) / kPartitionChunk;
        struct Chunk {
            uint32_t leftCount = 0;
            uint32_t leftOffset = 0, rightOffset = 0;
            Aabb leftCentroids, rightCentroids;
        };
        std::vector<Chunk> chunks(chunkCount);
        auto chunkRange = [&](uint32_t c) {
            const uint32_t from = work.begin + c * kPartitionChunk;
            return std::pair{from, std::min(work.end, from + kPartitionChunk)};
        };
        tbb::parallel_for(uint32_t(0), chunkCount, [&](uint32_t c) {
            throwIfCancelled(progress_);
            const auto [from, to] = chunkRange(c);
            for (uint32_t i = from; i < to; ++i) {
                const uint32_t prim = prims_[i];
                if (goesLeft(prim)) {
                    ++chunks[c].leftCount;
                    chunks[c].leftCentroids.grow(centroids_[prim]);
                } else {
                    chunks[c].rightCentroids.grow(centroids_[prim]);
                }
            }
        });
        throwIfInterrupted(progress_);
        uint32_t leftTotal = 0;
        for (const Chunk& chunk : chunks) leftTotal += chunk.leftCount;
        uint32_t leftOffset = work.begin, rightOffset = work.begin + leftTotal;
        for (uint32_t c = 0; c < chunkCount; ++c) {
            const auto [from, to] = chunkRange(c);
            chunks[c].leftOffset = leftOffset;
            chunks[c].rightOffset = rightOffset;
            leftOffset += chunks[c].leftCount;
            rightOffset += (to - from) - chunks[c].leftCount;
            leftCentroids.grow(chunks[c].leftCentroids);
            rightCentroids.grow(chunks[c].rightCentroids);
        }
        tbb::parallel_for(uint32_t(0), chunkCount, [&](uint32_t c) {
            throwIfCancelled(progress_);
            const auto [from, to] = chunkRange(c);
            uint32_t left = chunks[c].leftOffset, right = chunks[c].rightOffset;
            for (uint32_t i = from; i < to; ++i) {
                const uint32_t prim = prims_[i];
                spill_[goesLeft(prim) ? left++ : right++] = prim;
            }
        });
        throwIfInterrupted(progress_);
        tbb::parallel_for(uint32_t(0), chunkCount, [&](uint32_t c) {
            const auto [from, to] = chunkRange(c);
            std::memcpy(&prims_[from], &spill_[from], (to - from) * sizeof(uint32_t));
        });
        throwIfInterrupted(progress_);
        return work.begin + leftTotal;
    }

    std::span<const Aabb> bounds_;
    const BvhBuildOptions& options_;
    BuildProgress* progress_;
    std::vector<glm::vec3> centroids_;  // by primitive index
    std::vector<uint32_t> prims_;       // a node owns a range of this
    std::vector<uint32_t> spill_;       // partition scratch, same ranges as prims_
};

}  // namespace

Bvh buildSahBinned(std::span<const Aabb> primitiveBounds, const Aabb& rootBox, const BvhBuildOptions& options,
                   BuildProgress* progress) {
    SahBinnedBuilder builder(primitiveBounds, options, progress);
    return builder.build(rootBox);
}

}  // namespace raypack::bvh_detail
