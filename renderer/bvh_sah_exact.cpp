// The report's builder (sections 2.1 and 3.1), after Wald, Boulos and Shirley 2007, "Ray Tracing
// Deformable Scenes using Dynamic Bounding Volume Hierarchies": top-down; every primitive centroid
// on x, y and z is a split candidate; the primitives are sorted once per axis and the three sorted
// lists are partitioned stably at each split, never re-sorted; the SAH cost of all candidates of an
// axis comes from one prefix and one suffix sweep of bounding boxes.
//
// Determinism: the sort breaks ties by primitive index (a stable radix sort of indices in ascending
// order); the best split is the lowest cost, ties going to x before y before z and then to the
// lower position; subtrees of more than kFragmentMinPrimitives primitives are built as tasks into
// fragments of their own and spliced in a fixed order. So the tree does not depend on the thread
// count.
//
// Memory: besides the input boxes and the output, three index lists, three sweep scratch arrays
// (one double per primitive and axis), two spill lists for the stable partitions and one byte per
// primitive: about 37 bytes per primitive, whatever the tree's shape.
#include "renderer/bvh_build.h"
#include "renderer/error.h"

#include <tbb/parallel_invoke.h>
#include <tbb/task_group.h>

#include <array>
#include <bit>
#include <cstring>
#include <limits>
#include <numeric>

namespace raypack::bvh_detail {
namespace {

// Nodes with more primitives than this sweep their three axes and partition their two other lists
// in parallel (below it the task overhead outweighs the work).
constexpr uint32_t kParallelNodeMinPrimitives = 65536;

// A float's bits mapped to an unsigned integer with the same order (-0 is mapped like +0 by the
// caller, see centroidOf).
uint32_t orderedKey(float value) {
    const uint32_t bits = std::bit_cast<uint32_t>(value);
    return (bits & 0x80000000u) ? ~bits : (bits | 0x80000000u);
}

// Sorts 0..n-1 by key with an LSD radix sort (11, 11, 10 bits). Stable, and the indices start in
// ascending order, so equal keys stay ordered by primitive index.
// The values are a PrimIndices (Bvh::primIndices' type), so that the first axis' list becomes the
// tree's leaf order without a copy.
PrimIndices sortIndicesByKey(std::vector<uint32_t> keys, BuildProgress* progress) {
    const size_t n = keys.size();
    PrimIndices values = makeLargeVector<uint32_t, UninitializedAllocator<uint32_t>>(n);
    std::vector<uint32_t> spareKeys = makeLargeVector<uint32_t>(n);
    PrimIndices spareValues = makeLargeVector<uint32_t, UninitializedAllocator<uint32_t>>(n);
    std::iota(values.begin(), values.end(), 0u);
    constexpr int kDigitBits[3] = {11, 11, 10};
    int shift = 0;
    for (int pass = 0; pass < 3; ++pass) {
        const uint32_t mask = (1u << kDigitBits[pass]) - 1;
        std::array<size_t, 2048> offsets{};
        for (size_t begin = 0; begin < n; begin += kCancelCheckInterval) {
            throwIfCancelled(progress);
            const size_t end = std::min(n, begin + kCancelCheckInterval);
            for (size_t i = begin; i < end; ++i) ++offsets[(keys[i] >> shift) & mask];
        }
        const bool oneBucket = offsets[(keys[0] >> shift) & mask] == n;
        if (!oneBucket) {
            size_t sum = 0;
            for (size_t& offset : offsets) sum += std::exchange(offset, sum);
            for (size_t begin = 0; begin < n; begin += kCancelCheckInterval) {
                throwIfCancelled(progress);
                const size_t end = std::min(n, begin + kCancelCheckInterval);
                for (size_t i = begin; i < end; ++i) {
                    const size_t to = offsets[(keys[i] >> shift) & mask]++;
                    spareKeys[to] = keys[i];
                    spareValues[to] = values[i];
                }
            }
            keys.swap(spareKeys);
            values.swap(spareValues);
        }
        shift += kDigitBits[pass];
    }
    return values;
}

struct Split {
    bool found = false;
    int axis = 0;
    uint32_t mid = 0;  // first position of the right child in the axis' list
    double weightedMeasures = std::numeric_limits<double>::infinity();  // A_L·N_L + A_R·N_R
};

class SahExactBuilder {
public:
    SahExactBuilder(std::span<const Aabb> bounds, const BvhBuildOptions& options, BuildProgress* progress)
        : bounds_(bounds), options_(options), progress_(progress) {}

    Bvh build(const Aabb& rootBox) {
        const uint32_t n = uint32_t(bounds_.size());
        // Presort: one list of primitive indices per axis, ordered by centroid then index.
        tbb::parallel_invoke([&] { presort(0); }, [&] { presort(1); }, [&] { presort(2); });
        throwIfInterrupted(progress_);
        for (auto& scratch : leftMeasures_) scratch = makeLargeVector<double>(n);
        for (auto& spill : spill_) spill = makeLargeVector<uint32_t>(n);
        goesLeft_ = makeLargeVector<uint8_t>(n);

        Fragment root;
        root.nodes.resize(1);
        tbb::task_group tasks;
        buildFragment(root, {0, 0, n, rootBox}, tasks);
        tasks.wait();  // rethrows BuildCancelled from any task

        Bvh bvh;
        bvh.nodes = assembleFragments(root);
        bvh.primIndices = std::move(lists_[0]);  // every leaf's range holds its primitives in all lists
        return bvh;
    }

private:
    struct Work {
        uint32_t slot, begin, end;
        Aabb box;
    };

    void presort(int axis) {
        const size_t n = bounds_.size();
        std::vector<uint32_t> keys = makeLargeVector<uint32_t>(n);
        for (size_t begin = 0; begin < n; begin += kCancelCheckInterval) {
            throwIfCancelled(progress_);
            const size_t end = std::min(n, begin + kCancelCheckInterval);
            for (size_t i = begin; i < end; ++i) keys[i] = orderedKey(centroidOf(bounds_[i])[axis]);
        }
        lists_[axis] = sortIndicesByKey(std::move(keys), progress_);
    }

    // Builds the subtree whose root is fragment.nodes[first.slot], depth first with an explicit
    // stack (a degenerate input can make the tree as deep as it has primitives); children large
    // enough get fragments and tasks of their own.
    void buildFragment(Fragment& fragment, const Work& first, tbb::task_group& tasks) {
        std::vector<Work> stack{first};
        uint64_t placedSinceReport = 0;
        while (!stack.empty()) {
            const Work work = stack.back();
            stack.pop_back();
            const uint32_t count = work.end - work.begin;
            BvhNode& node = fragment.nodes[work.slot];
            node.lo = work.box.lo;
            node.hi = work.box.hi;

            Split split;
            if (count > options_.leafSize) split = findBestSplit(work);
            if (!split.found && count > kMaxLeafPrimitives) {
                // The SAH refuses, but the leaf would be too large: the object median of the
                // widest axis (its list is sorted by centroid, ties by index).
                const glm::vec3 extent = work.box.hi - work.box.lo;
                split.found = true;
                split.axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
                split.mid = work.begin + count / 2;
            }
            if (!split.found) {
                node.index = work.begin;
                node.count = count;
                placedSinceReport += count;
                if (placedSinceReport >= kCancelCheckInterval) {
                    addPlaced(progress_, std::exchange(placedSinceReport, 0));
                    throwIfCancelled(progress_);
                }
                continue;
            }
            Aabb leftBox, rightBox;
            partition(split, work, leftBox, rightBox);
            const uint32_t pair = fragment.addPair();
            fragment.nodes[work.slot].index = pair;  // `node` may have moved with the resize
            fragment.nodes[work.slot].count = 0;
            const Work children[2] = {{pair, work.begin, split.mid, leftBox},
                                      {pair + 1, split.mid, work.end, rightBox}};
            for (int k = 1; k >= 0; --k) {  // left on top of the stack: depth first, left first
                const Work& child = children[k];
                if (child.end - child.begin > kFragmentMinPrimitives) {
                    Fragment& own = fragment.link(child.slot);
                    const Work root{0, child.begin, child.end, child.box};
                    tasks.run([this, &own, root, &tasks] { buildFragment(own, root, tasks); });
                } else {
                    stack.push_back(child);
                }
            }
        }
        addPlaced(progress_, placedSinceReport);
    }

    // The cheapest split of the node over all three axes, or none when no split beats the leaf
    // cost N·C_isect.
    Split findBestSplit(const Work& work) {
        const SahMeasure measure = SahMeasure::forParent(work.box);
        std::array<Split, 3> perAxis;
        auto sweepAxis = [&](int axis) { perAxis[axis] = sweep(axis, work, measure); };
        if (work.end - work.begin > kParallelNodeMinPrimitives) {
            tbb::parallel_invoke([&] { sweepAxis(0); }, [&] { sweepAxis(1); }, [&] { sweepAxis(2); });
            throwIfInterrupted(progress_);
        } else {
            for (int axis = 0; axis < 3; ++axis) sweepAxis(axis);
        }

        Split best;
        for (const Split& candidate : perAxis)  // strict <: ties go to the lower axis
            if (candidate.weightedMeasures < best.weightedMeasures) best = candidate;
        const double cost = splitCost(best.weightedMeasures, measure.of(work.box), options_);
        best.found = cost < leafCost(work.end - work.begin, options_);
        return best;
    }

    // Prefix sweep: leftMeasures_[axis][i] = measure of the box of list[begin..i]. Suffix sweep:
    // the right child's box grows from the end; each position's A_L·N_L + A_R·N_R is compared.
    Split sweep(int axis, const Work& work, const SahMeasure& measure) {
        const uint32_t* list = lists_[axis].data();
        double* left = leftMeasures_[axis].data();
        const uint32_t begin = work.begin, end = work.end;
        Aabb box;
        for (uint32_t chunk = begin; chunk + 1 < end; chunk += kCancelCheckInterval) {
            throwIfCancelled(progress_);
            const uint32_t chunkEnd = std::min(end - 1, chunk + kCancelCheckInterval);
            for (uint32_t i = chunk; i < chunkEnd; ++i) {
                box.grow(bounds_[list[i]]);
                left[i] = measure.of(box);
            }
        }
        Split best;
        best.axis = axis;
        box = Aabb{};
        for (uint32_t chunk = end; chunk > begin + 1;) {
            throwIfCancelled(progress_);
            const uint32_t chunkBegin =
                chunk - begin - 1 > kCancelCheckInterval ? chunk - kCancelCheckInterval : begin + 1;
            for (uint32_t i = chunk - 1; i >= chunkBegin; --i) {
                // Right child list[i..end), left child list[begin..i).
                box.grow(bounds_[list[i]]);
                const double weighted = left[i - 1] * double(i - begin) + measure.of(box) * double(end - i);
                if (weighted <= best.weightedMeasures) {  // <=: ties go to the lower position
                    best.weightedMeasures = weighted;
                    best.mid = i;
                }
            }
            chunk = chunkBegin;
        }
        return best;
    }

    // Splits the node's range of all three lists at split.mid of split.axis' list, keeping each
    // list's order (so the children's lists stay sorted), and returns the children's boxes.
    void partition(const Split& split, const Work& work, Aabb& leftBox, Aabb& rightBox) {
        const uint32_t* list = lists_[split.axis].data();
        auto mark = [&](uint32_t from, uint32_t to, uint8_t side, Aabb& box) {
            for (uint32_t chunk = from; chunk < to; chunk += kCancelCheckInterval) {
                throwIfCancelled(progress_);
                const uint32_t chunkEnd = std::min(to, chunk + kCancelCheckInterval);
                for (uint32_t i = chunk; i < chunkEnd; ++i) {
                    goesLeft_[list[i]] = side;
                    box.grow(bounds_[list[i]]);
                }
            }
        };
        auto stablePartition = [&](int axis, std::vector<uint32_t>& spill) {
            uint32_t* other = lists_[axis].data();
            uint32_t leftEnd = work.begin, spillEnd = work.begin;
            for (uint32_t chunk = work.begin; chunk < work.end; chunk += kCancelCheckInterval) {
                throwIfCancelled(progress_);
                const uint32_t chunkEnd = std::min(work.end, chunk + kCancelCheckInterval);
                for (uint32_t i = chunk; i < chunkEnd; ++i) {
                    const uint32_t prim = other[i];
                    if (goesLeft_[prim])
                        other[leftEnd++] = prim;  // leftEnd <= i: in place
                    else
                        spill[spillEnd++] = prim;
                }
            }
            RAYPACK_CHECK(leftEnd == split.mid);
            std::memcpy(other + leftEnd, spill.data() + work.begin, (spillEnd - work.begin) * sizeof(uint32_t));
        };
        const int otherA = (split.axis + 1) % 3, otherB = (split.axis + 2) % 3;
        if (work.end - work.begin > kParallelNodeMinPrimitives) {
            tbb::parallel_invoke([&] { mark(work.begin, split.mid, 1, leftBox); },
                                 [&] { mark(split.mid, work.end, 0, rightBox); });
            throwIfInterrupted(progress_);
            tbb::parallel_invoke([&] { stablePartition(otherA, spill_[0]); },
                                 [&] { stablePartition(otherB, spill_[1]); });
            throwIfInterrupted(progress_);
        } else {
            mark(work.begin, split.mid, 1, leftBox);
            mark(split.mid, work.end, 0, rightBox);
            stablePartition(otherA, spill_[0]);
            stablePartition(otherB, spill_[1]);
        }
    }

    std::span<const Aabb> bounds_;
    const BvhBuildOptions& options_;
    BuildProgress* progress_;
    // Per axis, the primitive indices ordered by centroid; a node owns the same range of all three.
    std::array<PrimIndices, 3> lists_;
    // Sweep scratch: subtrees own disjoint ranges, so concurrent tasks never share an element.
    std::array<std::vector<double>, 3> leftMeasures_;
    std::array<std::vector<uint32_t>, 2> spill_;
    std::vector<uint8_t> goesLeft_;  // by primitive index
};

}  // namespace

Bvh buildSahExact(std::span<const Aabb> primitiveBounds, const Aabb& rootBox, const BvhBuildOptions& options,
                  BuildProgress* progress) {
    SahExactBuilder builder(primitiveBounds, options, progress);
    return builder.build(rootBox);
}

}  // namespace raypack::bvh_detail
