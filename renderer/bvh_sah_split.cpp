// Spatial-split SAH builder (SBVH) after Stich, Friedrich and Dietrich 2009, "Spatial Splits in
// Bounding Volume Hierarchies". The builder works on *references*: a triangle index with a box that
// bounds the part of the triangle the reference stands for. At each node it prices two kinds of
// candidates with the same SAH (bvh_build.h: splitCost):
//  - object splits: binned centroids as in sah-binned (Wald 2007), every reference on one side;
//  - spatial splits: equal-width bins over the node's box; a reference that straddles a bin plane
//    is clipped against it (the triangle's part on each side bounded, then intersected with the
//    reference's box: "chopped" boxes, section 4.2; the triangle is first clipped to the
//    reference's box, so a part cut on several axes keeps a tight box), so it enters every bin it overlaps. The sweep
//    counts entries and exits per bin (section 4.1).
// Spatial splits are only tried where the best object split's children overlap by more than
// splitAlpha × the root's surface area (section 4.3: most nodes deep in the tree need none, and the
// test keeps the build near the object builder's cost). A straddling reference of the chosen spatial
// split may still be sent whole to one side when that is cheaper ("reference unsplitting", section
// 4.5). The references grow at most to splitBudget × the triangle count: the budget not used by a
// split is shared between the children in proportion to their references' surface areas, so a
// subtree's share depends only on the tree above it, never on which thread built what.
//
// Determinism: every choice is made from one node's references in their order (which the partitions
// keep); subtrees of more than kFragmentMinPrimitives references are built in tasks into fragments
// spliced in depth-first order, with each fragment's leaf references in its own list that is
// concatenated in that same order. So the tree does not depend on the thread count.
//
// Correctness of clipped boxes: the clipped polygon is computed in double, its box widened by a
// bound on the rounding error and rounded outward to float; a reference's box thus always contains
// the exact part of its triangle, and the leaves that reference a triangle cover all of it
// (tests/test_bvh_split.cpp samples points of every triangle).
#include "renderer/bvh_build.h"
#include "renderer/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cfloat>
#include <cmath>
#include <limits>
#include <memory>

namespace raypack::bvh_detail {
namespace {

// Spatial bins per axis. Measured here (docs/bvh.md): 64 and 128 bins lower Sibenik's SAH cost by
// 0.4% and 1.0% for 1.6x and 2.2x the build time, and Conference's not at all.
constexpr uint32_t kSpatialBins = 32;
// Nodes with more references than this fill their spatial bins in parallel.
constexpr uint32_t kParallelNodeMinReferences = 65536;

struct Ref {
    Aabb box;
    uint32_t prim;
    // 1 for exactly one reference of each triangle (the first part keeps it when a reference is
    // split), so that counting these in leaves gives BuildProgress::done == total at the end.
    uint32_t primary;
};

struct Work {
    uint32_t slot = 0;
    std::vector<Ref> refs;
    Aabb box;         // union of the references' boxes
    uint64_t budget;  // references this subtree may still add
};

struct SplitFragment {
    std::vector<BvhNode> nodes;  // leaves index `prims`, inner nodes local slots (as Fragment)
    std::vector<uint32_t> prims;
    std::vector<std::pair<uint32_t, std::unique_ptr<SplitFragment>>> links;

    uint32_t addPair() {
        const uint32_t slot = uint32_t(nodes.size());
        nodes.resize(nodes.size() + 2);
        return slot;
    }
    SplitFragment& link(uint32_t slot) {
        nodes[slot].count = kLinkPlaceholder;
        nodes[slot].index = 0;
        links.emplace_back(slot, std::make_unique<SplitFragment>());
        SplitFragment& child = *links.back().second;
        child.nodes.resize(1);
        return child;
    }
};

struct ObjectSplit {
    bool found = false;
    int axis = 0;
    double weighted = std::numeric_limits<double>::infinity();  // A_L·N_L + A_R·N_R
    Aabb leftBox, rightBox;
    // The references in the axis' centroid order; the first `mid` of them go left.
    std::vector<uint32_t> order;
    uint32_t mid = 0;
};

// A reference's sort key: centroid order, then triangle index (unique within a node).
struct SortKey {
    uint64_t key;
    uint32_t ref;
};

// LSD radix sort by key, 11 bits a pass, skipping passes whose digit is the same everywhere (the
// triangle index's high bits, mostly). Checks for cancellation every kCancelCheckInterval keys:
// std::sort of a million keys ran 0.3 s without a check on the loaded test machine. Ranges of at
// most kCancelCheckInterval keys use std::sort (keys are unique, so any correct sort agrees).
void radixSort(std::vector<SortKey>& keys, BuildProgress* progress) {
    const size_t n = keys.size();
    if (n <= kCancelCheckInterval) {  // small: in cache, std::sort is faster than six passes
        std::sort(keys.begin(), keys.end(), [](const SortKey& a, const SortKey& b) { return a.key < b.key; });
        return;
    }
    std::vector<SortKey> spare(n);
    for (int shift = 0; shift < 64; shift += 11) {
        std::array<size_t, 2048> offsets{};
        for (size_t begin = 0; begin < n; begin += kCancelCheckInterval) {
            throwIfCancelled(progress);
            const size_t end = std::min(n, begin + kCancelCheckInterval);
            for (size_t i = begin; i < end; ++i) ++offsets[(keys[i].key >> shift) & 2047];
        }
        if (offsets[(keys[0].key >> shift) & 2047] == n) continue;  // one bucket: nothing moves
        size_t sum = 0;
        for (size_t& offset : offsets) sum += std::exchange(offset, sum);
        for (size_t begin = 0; begin < n; begin += kCancelCheckInterval) {
            throwIfCancelled(progress);
            const size_t end = std::min(n, begin + kCancelCheckInterval);
            for (size_t i = begin; i < end; ++i) spare[offsets[(keys[i].key >> shift) & 2047]++] = keys[i];
        }
        keys.swap(spare);
    }
}

// A float's bits mapped to an unsigned integer of the same order (-0 is +0 after centroidOf).
uint32_t orderedKey(float value) {
    const uint32_t bits = std::bit_cast<uint32_t>(value);
    return (bits & 0x80000000u) ? ~bits : (bits | 0x80000000u);
}

// Spatial binning of one axis over the node's box, in double so that boxes near ±FLT_MAX neither
// overflow the extent nor lose the scale, and so that scaling the input by a power of two scales
// every plane exactly (the huge/tiny coordinates test builds the same tree).
struct SpatialAxis {
    bool active = false;  // false where the node's box is flat on this axis
    double lo = 0.0, extent = 0.0, scale = 0.0;
    uint32_t binOf(float coordinate) const {
        const double position = (double(coordinate) - lo) * scale;
        return uint32_t(std::clamp(position, 0.0, double(kSpatialBins - 1)));
    }
    // The plane between bins b - 1 and b.
    float plane(uint32_t b) const { return float(lo + extent * double(b) / double(kSpatialBins)); }
};

struct SpatialSplit {
    bool found = false;
    int axis = 0;
    float plane = 0.0f;
    double weighted = std::numeric_limits<double>::infinity();
};

// std::nextafter toward ∓infinity for finite values, by the bits (the libm call was 7% of the
// build); infinities and NaN pass through.
float nextDown(float value) {
    if (!std::isfinite(value)) return value;
    if (value == 0.0f) return -std::numeric_limits<float>::denorm_min();
    const uint32_t bits = std::bit_cast<uint32_t>(value);
    return std::bit_cast<float>(value > 0.0f ? bits - 1 : bits + 1);
}
float nextUp(float value) { return -nextDown(-value); }

Aabb intersect(const Aabb& a, const Aabb& b) { return {glm::max(a.lo, b.lo), glm::min(a.hi, b.hi)}; }

// Directed rounding of a double to float.
float roundDown(double value) {
    const float f = float(value);
    return double(f) > value ? nextDown(f) : f;
}
float roundUp(double value) {
    const float f = float(value);
    return double(f) < value ? nextUp(f) : f;
}

// A convex polygon in double: a triangle clipped by up to seven planes has at most ten corners.
struct Polygon {
    std::array<glm::dvec3, 16> v;
    int count = 0;
    double scale = 0.0;  // the largest |coordinate| of the triangle, for the rounding bound
};

// The parts of `in` with x[axis] <= plane and >= plane (Sutherland-Hodgman). A crossing point
// takes the plane's coordinate exactly.
void splitPolygon(const Polygon& in, int axis, double plane, Polygon& below, Polygon& above) {
    below.count = above.count = 0;
    below.scale = above.scale = in.scale;
    for (int i = 0; i < in.count; ++i) {
        const glm::dvec3& a = in.v[i];
        const glm::dvec3& b = in.v[(i + 1) % in.count];
        // Rounding can make a clipped polygon slightly non-convex; never overflow the storage
        // (each input corner adds at most two output corners, and the storage holds 16).
        if (below.count > 13 || above.count > 13) break;
        if (a[axis] <= plane) below.v[below.count++] = a;
        if (a[axis] >= plane) above.v[above.count++] = a;
        if ((a[axis] < plane && b[axis] > plane) || (a[axis] > plane && b[axis] < plane)) {
            const double t = (plane - a[axis]) / (b[axis] - a[axis]);
            glm::dvec3 p = a + t * (b - a);
            p[axis] = plane;
            below.v[below.count++] = p;
            above.v[above.count++] = p;
        }
    }
}

class SahSplitBuilder {
public:
    SahSplitBuilder(std::span<const Aabb> bounds, const BvhBuildOptions& options, BuildProgress* progress,
                    const BvhTriangles* triangles)
        : bounds_(bounds), options_(options), progress_(progress), triangles_(triangles) {}

    Bvh build(const Aabb& rootBox) {
        const uint32_t n = uint32_t(bounds_.size());
        const uint64_t maxReferences = std::max<uint64_t>(n, uint64_t(std::floor(double(n) * options_.splitBudget)));
        overlapThreshold_ = double(options_.splitAlpha) * SahMeasure::halfArea(rootBox);
        spatialAllowed_ = SahMeasure::forParent(rootBox).kind == SahMeasureKind::Area;

        auto first = std::make_shared<Work>();
        first->refs.resize(n);
        tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, kCancelCheckInterval),
                          [&](const tbb::blocked_range<uint32_t>& range) {
                              throwIfCancelled(progress_);
                              for (uint32_t i = range.begin(); i < range.end(); ++i)
                                  first->refs[i] = {bounds_[i], i, 1u};
                          });
        throwIfInterrupted(progress_);
        first->box = rootBox;
        first->budget = maxReferences - n;

        SplitFragment root;
        root.nodes.resize(1);
        tbb::task_group tasks;
        buildFragment(root, std::move(first), tasks);
        tasks.wait();  // rethrows BuildCancelled from any task
        return assemble(root);
    }

private:
    // Builds the subtree of `first` depth first with an explicit stack; children with more than
    // kFragmentMinPrimitives references get fragments and tasks of their own.
    void buildFragment(SplitFragment& fragment, std::shared_ptr<Work> first, tbb::task_group& tasks) {
        std::vector<std::shared_ptr<Work>> stack{std::move(first)};
        uint64_t placedSinceReport = 0;
        while (!stack.empty()) {
            const std::shared_ptr<Work> work = std::move(stack.back());
            stack.pop_back();
            throwIfCancelled(progress_);
            const uint32_t count = uint32_t(work->refs.size());
            fragment.nodes[work->slot].lo = work->box.lo;
            fragment.nodes[work->slot].hi = work->box.hi;

            std::shared_ptr<Work> left = std::make_shared<Work>(), right = std::make_shared<Work>();
            const bool split = count > options_.leafSize && splitNode(*work, *left, *right);
            if (!split) {
                // A leaf: its triangles in file order (a node never holds two references of one
                // triangle: the parts of a split reference go to different children).
                std::sort(work->refs.begin(), work->refs.end(),
                          [](const Ref& a, const Ref& b) { return a.prim < b.prim; });
                fragment.nodes[work->slot].index = uint32_t(fragment.prims.size());
                fragment.nodes[work->slot].count = count;
                for (const Ref& ref : work->refs) {
                    fragment.prims.push_back(ref.prim);
                    placedSinceReport += ref.primary;
                }
                if (placedSinceReport >= kCancelCheckInterval)
                    addPlaced(progress_, std::exchange(placedSinceReport, 0));
                continue;
            }
            // The node's box tightens to its children's: after a spatial split the clipped parts
            // may bound less than the references' boxes did.
            Aabb tight = left->box;
            tight.grow(right->box);
            fragment.nodes[work->slot].lo = tight.lo;
            fragment.nodes[work->slot].hi = tight.hi;
            const uint32_t pair = fragment.addPair();
            fragment.nodes[work->slot].index = pair;
            fragment.nodes[work->slot].count = 0;
            left->slot = pair;
            right->slot = pair + 1;
            std::shared_ptr<Work> children[2] = {std::move(left), std::move(right)};
            for (int k = 1; k >= 0; --k) {  // left on top of the stack: depth first, left first
                std::shared_ptr<Work>& child = children[k];
                if (child->refs.size() > kFragmentMinPrimitives) {
                    SplitFragment& own = fragment.link(child->slot);
                    child->slot = 0;
                    tasks.run([this, &own, child, &tasks] { buildFragment(own, child, tasks); });
                } else {
                    stack.push_back(std::move(child));
                }
            }
        }
        addPlaced(progress_, placedSinceReport);
    }

    // Chooses and performs the split of `work` into `left` and `right` (references, boxes and
    // budgets); false when the node stays a leaf.
    bool splitNode(Work& work, Work& left, Work& right) const {
        const uint32_t count = uint32_t(work.refs.size());
        const SahMeasure measure = SahMeasure::forParent(work.box);
        const ObjectSplit object = findObjectSplit(work, measure);
        SpatialSplit spatial;
        if (spatialAllowed_ && work.budget > 0 &&
            (!object.found || options_.splitAlpha == 0.0f ||
             SahMeasure::halfArea(intersect(object.leftBox, object.rightBox)) > overlapThreshold_))
            spatial = findSpatialSplit(work, measure);

        const double parent = measure.of(work.box);
        if (spatial.found && spatial.weighted < object.weighted &&
            splitCost(spatial.weighted, parent, options_) < leafCost(count, options_) &&
            partitionSpatial(work, spatial, measure, left, right))
            return true;
        if (object.found && splitCost(object.weighted, parent, options_) < leafCost(count, options_)) {
            partitionObject(work, object, left, right);
            return true;
        }
        if (count <= kMaxLeafPrimitives) return false;
        // The SAH refuses, but the leaf would be too large (kMaxLeafPrimitives): the object median.
        medianSplit(work, left, right);
        return true;
    }

    // Every centroid a candidate on each axis, as sah-exact: the references sorted by centroid
    // (ties by triangle index), a prefix sweep of box measures and a suffix sweep pricing each
    // position; the lowest cost wins, ties to the lower axis, then to the lower position.
    ObjectSplit findObjectSplit(const Work& work, const SahMeasure& measure) const {
        const uint32_t total = uint32_t(work.refs.size());
        struct AxisResult {
            double weighted = std::numeric_limits<double>::infinity();
            uint32_t mid = 0;
            std::vector<uint32_t> order;  // reference indices in centroid order
        };
        std::array<AxisResult, 3> results;
        auto sweepAxis = [&](int axis) {
            throwIfCancelled(progress_);
            std::vector<SortKey> keys(total);
            for (uint32_t i = 0; i < total; ++i) {
                if (i % kCancelCheckInterval == kCancelCheckInterval - 1) throwIfCancelled(progress_);
                keys[i] = {(uint64_t(orderedKey(centroidOf(work.refs[i].box)[axis])) << 32) | work.refs[i].prim, i};
            }
            radixSort(keys, progress_);
            std::vector<double> leftMeasure(total);
            Aabb box;
            for (uint32_t i = 0; i + 1 < total; ++i) {
                if (i % kCancelCheckInterval == kCancelCheckInterval - 1) throwIfCancelled(progress_);
                box.grow(work.refs[keys[i].ref].box);
                leftMeasure[i] = measure.of(box);
            }
            AxisResult& result = results[axis];
            box = Aabb{};
            for (uint32_t i = total - 1; i >= 1; --i) {  // right child keys[i..), left keys[..i)
                if (i % kCancelCheckInterval == 0) throwIfCancelled(progress_);
                box.grow(work.refs[keys[i].ref].box);
                const double weighted = leftMeasure[i - 1] * double(i) + measure.of(box) * double(total - i);
                if (weighted <= result.weighted) {  // <=: ties go to the lower position
                    result.weighted = weighted;
                    result.mid = i;
                }
            }
            throwIfCancelled(progress_);
            result.order.resize(total);
            for (uint32_t i = 0; i < total; ++i) result.order[i] = keys[i].ref;
        };
        if (total > kParallelNodeMinReferences) {
            tbb::parallel_invoke([&] { sweepAxis(0); }, [&] { sweepAxis(1); }, [&] { sweepAxis(2); });
            throwIfInterrupted(progress_);
        } else {
            for (int axis = 0; axis < 3; ++axis) sweepAxis(axis);
        }
        ObjectSplit best;
        for (int axis = 0; axis < 3; ++axis) {  // strict <: ties go to the lower axis
            if (!(results[axis].weighted < best.weighted)) continue;
            best.found = true;
            best.weighted = results[axis].weighted;
            best.axis = axis;
            best.mid = results[axis].mid;
        }
        if (!best.found) return best;
        best.order = std::move(results[best.axis].order);
        for (uint32_t i = 0; i < total; ++i) {
            if (i % kCancelCheckInterval == kCancelCheckInterval - 1) throwIfCancelled(progress_);
            (i < best.mid ? best.leftBox : best.rightBox).grow(work.refs[best.order[i]].box);
        }
        return best;
    }

    Polygon wholeTriangle(uint32_t prim) const {
        const glm::uvec3 corners = triangles_->triangles[prim];
        Polygon polygon;
        polygon.count = 3;
        polygon.scale = 0.0;
        for (int c = 0; c < 3; ++c) {
            polygon.v[c] = glm::dvec3(triangles_->positions[corners[c]]);
            for (int k = 0; k < 3; ++k) polygon.scale = std::max(polygon.scale, std::abs(polygon.v[c][k]));
        }
        return polygon;
    }

    Polygon clippedTriangle(const Ref& ref) const {
        Polygon polygon = wholeTriangle(ref.prim);
        for (int axis = 0; axis < 3; ++axis) {
            Polygon below, above;
            splitPolygon(polygon, axis, double(ref.box.lo[axis]), below, above);
            if (above.count == 0) return polygon;  // rounding: keep what is left, still conservative
            splitPolygon(above, axis, double(ref.box.hi[axis]), below, above);
            if (below.count == 0) return polygon;
            polygon = below;
        }
        return polygon;
    }

    // The box of a part of `ref` on one side of the plane x[axis] = plane: the polygon's box widened
    // by a bound on the clipping's rounding error and rounded outward to float, then intersected with
    // the reference's box and the half-space, so it contains the exact part of the triangle.
    static Aabb partBox(const Polygon& polygon, const Ref& ref, int axis, float plane, bool below) {
        if (polygon.count == 0) return Aabb{};
        glm::dvec3 lo = polygon.v[0], hi = polygon.v[0];
        for (int i = 1; i < polygon.count; ++i) {
            lo = glm::min(lo, polygon.v[i]);
            hi = glm::max(hi, polygon.v[i]);
        }
        // Each clip interpolates between two vertices: a few ulps of the largest coordinate per
        // step, at most 7 steps; 64 ulps is a generous bound.
        const double error = 64.0 * std::numeric_limits<double>::epsilon() * polygon.scale;
        Aabb box;
        for (int k = 0; k < 3; ++k) {
            box.lo[k] = roundDown(lo[k] - error);
            box.hi[k] = roundUp(hi[k] + error);
        }
        box = intersect(box, ref.box);
        if (below)
            box.hi[axis] = std::min(box.hi[axis], plane);
        else
            box.lo[axis] = std::max(box.lo[axis], plane);
        return box;
    }

    // The boxes of the parts of `ref` on either side of the plane x[axis] = plane (an empty box for
    // a part that does not exist). Without triangles the reference's box itself is chopped.
    void splitReference(const Ref& ref, int axis, float plane, Aabb& left, Aabb& right) const {
        if (!triangles_) {
            left = right = ref.box;
            left.hi[axis] = std::min(left.hi[axis], plane);
            right.lo[axis] = std::max(right.lo[axis], plane);
            return;
        }
        Polygon below, above;
        splitPolygon(clippedTriangle(ref), axis, double(plane), below, above);
        left = partBox(below, ref, axis, plane, true);
        right = partBox(above, ref, axis, plane, false);
    }

    // The spatial bins of all three axes of one node: per bin the box of the reference parts in it
    // and the references entering and leaving there. Filling is exact (integer counts, min/max),
    // so a large node's bins filled by a parallel reduction equal the serial ones.
    struct SpatialBins {
        struct Bin {
            Aabb box;
            uint32_t entries = 0, exits = 0;
        };
        std::array<SpatialAxis, 3> axes;
        std::array<std::array<Bin, kSpatialBins>, 3> bins;
        void merge(const SpatialBins& other) {
            for (int axis = 0; axis < 3; ++axis)
                for (uint32_t b = 0; b < kSpatialBins; ++b) {
                    bins[axis][b].box.grow(other.bins[axis][b].box);
                    bins[axis][b].entries += other.bins[axis][b].entries;
                    bins[axis][b].exits += other.bins[axis][b].exits;
                }
        }
    };

    void fillSpatialBins(const Work& work, uint32_t begin, uint32_t end, SpatialBins& grid) const {
        Polygon clipped, scratch[3];
        for (uint32_t i = begin; i < end; ++i) {
            // Every 1024: a reference crossing many planes costs a hundred clips.
            if ((i - begin) % 1024 == 1023) throwIfCancelled(progress_);
            const Ref& ref = work.refs[i];
            std::array<uint32_t, 3> firstBin{}, lastBin{};
            bool straddles = false;
            for (int axis = 0; axis < 3; ++axis) {
                if (!grid.axes[axis].active) continue;
                firstBin[axis] = grid.axes[axis].binOf(ref.box.lo[axis]);
                lastBin[axis] = grid.axes[axis].binOf(ref.box.hi[axis]);
                ++grid.bins[axis][firstBin[axis]].entries;
                ++grid.bins[axis][lastBin[axis]].exits;
                if (firstBin[axis] == lastBin[axis])
                    grid.bins[axis][firstBin[axis]].box.grow(ref.box);
                else
                    straddles = true;
            }
            if (!straddles) continue;
            // The triangle clipped to the reference's box once, for all three axes (a reference
            // never split is its whole triangle: no clipping needed).
            if (triangles_) {
                const Aabb& whole = bounds_[ref.prim];
                clipped = ref.box.contains(whole) ? wholeTriangle(ref.prim) : clippedTriangle(ref);
            }
            for (int axis = 0; axis < 3; ++axis) {
                if (!grid.axes[axis].active || firstBin[axis] == lastBin[axis]) continue;
                auto& bins = grid.bins[axis];
                Ref rest = ref;
                if (!triangles_) {
                    // Chopped boxes: each bin gets the reference's box within its slab.
                    for (uint32_t b = firstBin[axis]; b < lastBin[axis]; ++b) {
                        Aabb leftPart, rightPart;
                        splitReference(rest, axis, grid.axes[axis].plane(b + 1), leftPart, rightPart);
                        if (!leftPart.empty()) bins[b].box.grow(leftPart);
                        if (rightPart.empty()) break;
                        rest.box = rightPart;
                        if (b + 1 == lastBin[axis]) bins[lastBin[axis]].box.grow(rest.box);
                    }
                    continue;
                }
                // Clip against each plane the reference crosses; each part enters its bin. The
                // remainder alternates between scratch polygons; `clipped` stays for the next axis.
                const Polygon* remaining = &clipped;
                int current = -1;
                for (uint32_t b = firstBin[axis]; b < lastBin[axis] && remaining->count > 0; ++b) {
                    const float plane = grid.axes[axis].plane(b + 1);
                    const int belowIndex = (current + 1) % 3, aboveIndex = (current + 2) % 3;
                    Polygon& below = scratch[belowIndex];
                    Polygon& above = scratch[aboveIndex];
                    splitPolygon(*remaining, axis, double(plane), below, above);
                    const Aabb part = partBox(below, rest, axis, plane, true);
                    if (!part.empty()) bins[b].box.grow(part);
                    rest.box.lo[axis] = std::max(rest.box.lo[axis], plane);
                    remaining = &above;
                    current = aboveIndex;
                }
                const Aabb last = partBox(*remaining, rest, axis, rest.box.lo[axis], false);
                if (!last.empty()) bins[lastBin[axis]].box.grow(last);
            }
        }
    }

    // Parallel filling of a large node's spatial bins (tbb::parallel_reduce's splitting body).
    struct SpatialFiller {
        const SahSplitBuilder& builder;
        const Work& work;
        std::unique_ptr<SpatialBins> grid;
        SpatialFiller(const SahSplitBuilder& b, const Work& w, const SpatialBins& empty)
            : builder(b), work(w), grid(std::make_unique<SpatialBins>(empty)) {}
        SpatialFiller(SpatialFiller& other, tbb::split)
            : builder(other.builder), work(other.work), grid(std::make_unique<SpatialBins>()) {
            grid->axes = other.grid->axes;
        }
        void operator()(const tbb::blocked_range<uint32_t>& range) {
            builder.fillSpatialBins(work, range.begin(), range.end(), *grid);
        }
        void join(const SpatialFiller& other) { grid->merge(*other.grid); }
    };

    SpatialSplit findSpatialSplit(const Work& work, const SahMeasure& measure) const {
        const uint32_t total = uint32_t(work.refs.size());
        auto grid = std::make_unique<SpatialBins>();
        bool anyAxis = false;
        for (int axis = 0; axis < 3; ++axis) {
            SpatialAxis& binning = grid->axes[axis];
            binning.lo = double(work.box.lo[axis]);
            binning.extent = double(work.box.hi[axis]) - binning.lo;
            binning.active = binning.extent > 0.0;
            binning.scale = binning.active ? double(kSpatialBins) / binning.extent : 0.0;
            anyAxis = anyAxis || binning.active;
        }
        if (!anyAxis) return {};
        if (total > kParallelNodeMinReferences) {
            SpatialFiller filler(*this, work, *grid);
            tbb::parallel_reduce(tbb::blocked_range<uint32_t>(0, total, kCancelCheckInterval), filler);
            throwIfInterrupted(progress_);
            grid = std::move(filler.grid);
        } else {
            fillSpatialBins(work, 0, total, *grid);
        }

        SpatialSplit best;
        for (int axis = 0; axis < 3; ++axis) {
            const SpatialAxis& binning = grid->axes[axis];
            if (!binning.active) continue;
            const auto& bins = grid->bins[axis];
            std::array<double, kSpatialBins> leftMeasure;
            std::array<uint32_t, kSpatialBins> leftCount;
            Aabb box;
            uint32_t entries = 0;
            for (uint32_t b = 0; b + 1 < kSpatialBins; ++b) {
                box.grow(bins[b].box);
                entries += bins[b].entries;
                leftMeasure[b] = measure.of(box);
                leftCount[b] = entries;
            }
            Aabb rightBox;
            uint32_t rightCount = 0;
            for (uint32_t b = kSpatialBins - 1; b >= 1; --b) {  // plane between bins b - 1 and b
                rightBox.grow(bins[b].box);
                rightCount += bins[b].exits;
                const uint32_t left = leftCount[b - 1];
                if (left == 0 || rightCount == 0) continue;
                const uint64_t references = uint64_t(left) + rightCount;
                if (references > total && references - total > work.budget) continue;  // over the budget
                const float plane = binning.plane(b);
                if (!(plane > work.box.lo[axis] && plane < work.box.hi[axis])) continue;
                const double weighted = leftMeasure[b - 1] * double(left) + measure.of(rightBox) * double(rightCount);
                if (weighted < best.weighted || (weighted == best.weighted && axis == best.axis)) {
                    best.found = true;
                    best.weighted = weighted;
                    best.axis = axis;
                    best.plane = plane;
                }
            }
        }
        return best;
    }

    // Shares the budget left after a split between the children in proportion to the summed
    // surface areas of their references: large triangles, not many small ones, are what spatial
    // splits cut, and sharing by reference count left a fifth of the budget unused in subtrees of
    // small triangles while subtrees of large ones ran out (Conference: SAH cost 42.27 by count,
    // 40.27 by area; docs/bvh.md). Deterministic: it depends only on the children's references.
    static void shareBudget(uint64_t remaining, Work& left, Work& right) {
        double leftArea = 0.0, rightArea = 0.0;
        for (const Ref& ref : left.refs) leftArea += SahMeasure::halfArea(ref.box);
        for (const Ref& ref : right.refs) rightArea += SahMeasure::halfArea(ref.box);
        const double total = leftArea + rightArea;
        const double share = total > 0.0 && std::isfinite(total)
                                 ? leftArea / total
                                 : double(left.refs.size()) / double(left.refs.size() + right.refs.size());
        left.budget = std::min(remaining, uint64_t(std::floor(double(remaining) * share)));
        right.budget = remaining - left.budget;
    }

    // Performs a spatial split; false (nothing changed) when one side would be empty.
    bool partitionSpatial(Work& work, const SpatialSplit& split, const SahMeasure& measure, Work& left,
                          Work& right) const {
        const int axis = split.axis;
        const float plane = split.plane;
        struct Straddler {
            uint32_t index;
            Aabb leftPart, rightPart;
        };
        std::vector<Straddler> straddlers;
        Aabb leftBox, rightBox;
        uint32_t leftOnly = 0, rightOnly = 0;
        // 0 left, 1 right, 2 straddles (decided below)
        std::vector<uint8_t> side(work.refs.size());
        for (uint32_t i = 0; i < work.refs.size(); ++i) {
            if (i % kCancelCheckInterval == kCancelCheckInterval - 1) throwIfCancelled(progress_);
            const Ref& ref = work.refs[i];
            if (ref.box.hi[axis] <= plane) {
                side[i] = 0;
                leftBox.grow(ref.box);
                ++leftOnly;
            } else if (ref.box.lo[axis] >= plane) {
                side[i] = 1;
                rightBox.grow(ref.box);
                ++rightOnly;
            } else {
                Straddler s{i, {}, {}};
                splitReference(ref, axis, plane, s.leftPart, s.rightPart);
                if (s.leftPart.empty() || s.rightPart.empty()) {  // the triangle misses one side
                    side[i] = s.leftPart.empty() ? 1 : 0;
                    Ref& changed = work.refs[i];
                    changed.box = s.leftPart.empty() ? s.rightPart : s.leftPart;
                    (side[i] ? rightBox : leftBox).grow(changed.box);
                    ++(side[i] ? rightOnly : leftOnly);
                    continue;
                }
                side[i] = 2;
                leftBox.grow(s.leftPart);
                rightBox.grow(s.rightPart);
                straddlers.push_back(s);
            }
        }
        // Reference unsplitting (section 4.5), straddler by straddler in reference order: keep both
        // parts, or the whole reference on one side, whichever SAH term is lowest; a split beyond
        // the node's budget is not allowed.
        uint64_t nl = leftOnly + straddlers.size(), nr = rightOnly + straddlers.size();
        uint64_t splits = 0;
        for (const Straddler& s : straddlers) {
            const Aabb& whole = work.refs[s.index].box;
            Aabb leftWithWhole = leftBox, rightWithWhole = rightBox;
            leftWithWhole.grow(whole);
            rightWithWhole.grow(whole);
            const double keepBoth = measure.of(leftBox) * double(nl) + measure.of(rightBox) * double(nr);
            const double allLeft = measure.of(leftWithWhole) * double(nl) + measure.of(rightBox) * double(nr - 1);
            const double allRight = measure.of(leftBox) * double(nl - 1) + measure.of(rightWithWhole) * double(nr);
            const bool budgetLeft = splits < work.budget;
            if ((allLeft < keepBoth || !budgetLeft) && allLeft <= allRight) {
                side[s.index] = 0;
                leftBox = leftWithWhole;
                --nr;
            } else if (allRight < keepBoth || !budgetLeft) {
                side[s.index] = 1;
                rightBox = rightWithWhole;
                --nl;
            } else {
                ++splits;
            }
        }
        if (nl == 0 || nr == 0) return false;

        left.refs.reserve(nl);
        right.refs.reserve(nr);
        size_t next = 0;
        for (uint32_t i = 0; i < work.refs.size(); ++i) {
            const Ref& ref = work.refs[i];
            if (side[i] == 0) {
                left.refs.push_back(ref);
            } else if (side[i] == 1) {
                right.refs.push_back(ref);
            } else {
                while (straddlers[next].index != i) ++next;
                left.refs.push_back({straddlers[next].leftPart, ref.prim, ref.primary});
                right.refs.push_back({straddlers[next].rightPart, ref.prim, 0u});
            }
        }
        // The children's exact boxes (the unsplitting pass only grew them).
        left.box = right.box = Aabb{};
        for (const Ref& ref : left.refs) left.box.grow(ref.box);
        for (const Ref& ref : right.refs) right.box.grow(ref.box);
        shareBudget(work.budget - splits, left, right);
        std::vector<Ref>().swap(work.refs);
        return true;
    }

    void partitionObject(Work& work, const ObjectSplit& split, Work& left, Work& right) const {
        left.refs.reserve(split.mid);
        right.refs.reserve(split.order.size() - split.mid);
        throwIfCancelled(progress_);
        for (uint32_t i = 0; i < split.order.size(); ++i) {
            if (i % kCancelCheckInterval == kCancelCheckInterval - 1) throwIfCancelled(progress_);
            (i < split.mid ? left : right).refs.push_back(work.refs[split.order[i]]);
        }
        RAYPACK_CHECK(!left.refs.empty() && !right.refs.empty());
        left.box = split.leftBox;  // the same union findObjectSplit grew, in the same order
        right.box = split.rightBox;
        shareBudget(work.budget, left, right);
        std::vector<Ref>().swap(work.refs);
    }

    // The object median of the widest centroid axis, ties by triangle index (a node holds each
    // triangle at most once, so the order is total).
    void medianSplit(Work& work, Work& left, Work& right) const {
        Aabb centroids;
        for (const Ref& ref : work.refs) centroids.grow(centroidOf(ref.box));
        const glm::vec3 extent = centroids.hi - centroids.lo;
        const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
        std::sort(work.refs.begin(), work.refs.end(), [axis](const Ref& a, const Ref& b) {
            const float ca = centroidOf(a.box)[axis], cb = centroidOf(b.box)[axis];
            return ca < cb || (ca == cb && a.prim < b.prim);
        });
        const size_t mid = work.refs.size() / 2;
        left.refs.assign(work.refs.begin(), work.refs.begin() + mid);
        right.refs.assign(work.refs.begin() + mid, work.refs.end());
        left.box = right.box = Aabb{};
        for (const Ref& ref : left.refs) left.box.grow(ref.box);
        for (const Ref& ref : right.refs) right.box.grow(ref.box);
        shareBudget(work.budget, left, right);
        std::vector<Ref>().swap(work.refs);
    }

    // Splices the fragments as assembleFragments does (root fragment first, children depth first,
    // a child's root in its placeholder's slot) and concatenates their leaf references in the same
    // order, rebasing each leaf's range.
    static Bvh assemble(SplitFragment& root) {
        struct Placement {
            SplitFragment* fragment;
            uint32_t rootSlot, base;
            uint64_t primBase;
        };
        std::vector<Placement> placements;
        uint32_t next = 1;
        uint64_t prims = 0;
        auto place = [&](auto&& self, SplitFragment& fragment, uint32_t rootSlot) -> void {
            const uint32_t base = next;
            next += uint32_t(fragment.nodes.size()) - 1;
            placements.push_back({&fragment, rootSlot, base, prims});
            prims += fragment.prims.size();
            for (auto& [slot, child] : fragment.links) self(self, *child, base + slot - 1);
        };
        place(place, root, 0);
        RAYPACK_CHECK(prims < uint64_t(UINT32_MAX));

        Bvh bvh;
        bvh.nodes = makeNodeArray(next);
        bvh.primIndices = makeLargeVector<uint32_t, UninitializedAllocator<uint32_t>>(size_t(prims));
        tbb::parallel_for(size_t(0), placements.size(), [&](size_t p) {
            const Placement& placement = placements[p];
            const std::vector<BvhNode>& local = placement.fragment->nodes;
            for (size_t j = 0; j < local.size(); ++j) {
                BvhNode node = local[j];
                if (node.count == kLinkPlaceholder) continue;  // the child fragment writes this slot
                if (node.count == 0)
                    node.index = placement.base + node.index - 1;
                else
                    node.index += uint32_t(placement.primBase);
                bvh.nodes[j == 0 ? placement.rootSlot : placement.base + j - 1] = node;
            }
            std::copy(placement.fragment->prims.begin(), placement.fragment->prims.end(),
                      bvh.primIndices.begin() + ptrdiff_t(placement.primBase));
        });
        return bvh;
    }

    std::span<const Aabb> bounds_;
    const BvhBuildOptions& options_;
    BuildProgress* progress_;
    const BvhTriangles* triangles_;
    double overlapThreshold_ = 0.0;  // splitAlpha × the root's half area
    bool spatialAllowed_ = false;    // the root has area (a line or point scene has no planes to cut)
};

}  // namespace

Bvh buildSahSplit(std::span<const Aabb> primitiveBounds, const Aabb& rootBox, const BvhBuildOptions& options,
                  BuildProgress* progress, const BvhTriangles* triangles) {
    SahSplitBuilder builder(primitiveBounds, options, progress, triangles);
    return builder.build(rootBox);
}

}  // namespace raypack::bvh_detail
