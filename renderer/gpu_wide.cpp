#include "renderer/gpu_wide.h"

#include "renderer/error.h"
#include "shaders/wide_node.h"

#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <string>

namespace raypack {
namespace {

constexpr uint32_t kWidth = 8;
constexpr uint32_t kRange = UINT32_MAX;  // Source::node of a range of references, not a binary node
// The grid's exponents: scale 2^e stays normal, and 255 * 2^e finite.
constexpr int kMinExponent = -126;
constexpr int kMaxExponent = 120;
// Subtrees of fewer references than this are collapsed on one thread (GpuWideTree's parallel parts).
constexpr uint32_t kParallelGrain = 16384;

// What a child slot holds before it is written: a binary node (its leaf range in first/count when
// it is a leaf) or a part of a leaf's range (node kRange), with its box.
struct Source {
    Aabb box;
    uint32_t node = kRange;
    uint32_t first = 0, count = 0;
};

class Collapser {
public:
    Collapser(const Scene& scene, const Bvh& bvh) : scene_(scene), bvh_(bvh), references_(bvh.nodes.size(), 0) {
        // References below each binary node (children follow their parents in the node array, so
        // one backward pass sums them).
        for (size_t i = bvh.nodes.size(); i-- > 0;) {
            const BvhNode& n = bvh.nodes[i];
            references_[i] = n.isLeaf() ? n.count : references_[n.index] + references_[n.index + 1];
        }
    }

    GpuWideTree run() {
        GpuWideTree tree;
        tree.nodes.emplace_back();
        const BvhNode& root = bvh_.nodes[0];
        if (root.isLeaf() && root.count == 0) {
            tree.nodes[0] = emptyNode();  // an empty scene: a root with no children
            return tree;
        }
        // The top of the tree is collapsed on this thread down to subtrees of at most `deferBelow`
        // references, which are then collapsed in parallel, each into a part of its own, and spliced
        // in (node and triangle indices shifted) in the order they were met: the same tree for any
        // number of threads.
        const uint64_t references = bvh_.primIndices.size();
        const uint32_t deferBelow = uint32_t(std::max<uint64_t>(kParallelGrain, references / 256));
        tree.order.reserve(references);
        std::vector<Work> deferred;
        collapseSubtree(tree, {0u, binarySource(0), 0u}, references > 2 * uint64_t(deferBelow) ? deferBelow : 0u,
                        deferred);
        if (deferred.empty()) return tree;
        std::vector<GpuWideTree> parts(deferred.size());
        tbb::parallel_for(size_t(0), deferred.size(), [&](size_t k) {
            parts[k].nodes.emplace_back();
            std::vector<Work> none;
            collapseSubtree(parts[k], {0u, deferred[k].source, 0u}, 0u, none);
        });
        std::vector<size_t> nodeOffset(parts.size()), triangleOffset(parts.size());
        size_t nodes = tree.nodes.size(), triangles = tree.order.size();
        for (size_t k = 0; k < parts.size(); ++k) {
            nodeOffset[k] = nodes;
            triangleOffset[k] = triangles;
            nodes += parts[k].nodes.size() - 1;  // a part's root goes into the slot made for it
            triangles += parts[k].order.size();
            tree.maxDepth = std::max(tree.maxDepth, deferred[k].depth + parts[k].maxDepth);
            tree.innerSlots += parts[k].innerSlots;
            tree.leafSlots += parts[k].leafSlots;
        }
        RAYPACK_CHECK(nodes < UINT32_MAX && triangles == references);
        tree.nodes.resize(nodes);
        tree.order.resize(triangles);
        tbb::parallel_for(size_t(0), parts.size(), [&](size_t k) {
            const GpuWideTree& part = parts[k];
            const auto global = [&](uint32_t local) {
                return local == 0 ? deferred[k].wide : uint32_t(nodeOffset[k] + local - 1);
            };
            for (uint32_t local = 0; local < part.nodes.size(); ++local) {
                gpu::GpuWideNode n = part.nodes[local];
                n.index.x = global(n.index.x);  // a node without inner children never reads it
                n.index.y += uint32_t(triangleOffset[k]);
                tree.nodes[global(local)] = n;
            }
            std::copy(part.order.begin(), part.order.end(), tree.order.begin() + ptrdiff_t(triangleOffset[k]));
        });
        return tree;
    }

private:
    static gpu::GpuWideNode emptyNode() {
        gpu::GpuWideNode n{};
        const uint32_t unitScale = 127u | 127u << 8u | 127u << 16u;
        n.origin = glm::vec4(0.0f, 0.0f, 0.0f, glm::uintBitsToFloat(unitScale));
        return n;
    }

    struct Work {
        uint32_t wide;  // the node to fill
        Source source;
        uint32_t depth;
    };
    struct Children {
        std::array<Source, kWidth> at;
        uint32_t count = 0;
    };

    // Collapses the subtree of `root` into `tree` depth first (the node root.wide exists; its
    // children's nodes and its references are appended). With deferBelow > 0 an inner child of at
    // most that many references gets its node but is listed in `deferred` instead of collapsed.
    void collapseSubtree(GpuWideTree& tree, const Work& root, uint32_t deferBelow, std::vector<Work>& deferred) const {
        std::vector<Work> work{root};
        while (!work.empty()) {
            const Work item = work.back();
            work.pop_back();
            tree.maxDepth = std::max(tree.maxDepth, item.depth);
            const Children children = collapse(item.source);
            const std::array<int, kWidth> slots = assignSlots(item.source, children);
            gpu::GpuWideNode node = emptyNode();
            Aabb box;
            for (uint32_t c = 0; c < children.count; ++c) box.grow(children.at[c].box);
            const std::array<int, 3> exponents = quantize(box, children, slots, node);
            uint32_t innerMask = 0;
            const uint32_t firstChild = uint32_t(tree.nodes.size());
            const uint32_t firstTriangle = uint32_t(tree.order.size());
            node.index.x = firstChild;
            node.index.y = firstTriangle;
            uint32_t innerCount = 0, pushed = 0;
            for (uint32_t slot = 0; slot < kWidth; ++slot) {
                if (slots[slot] < 0) continue;
                const Source& c = children.at[size_t(slots[slot])];
                uint32_t meta;
                if (isInner(c)) {
                    innerMask |= 1u << slot;
                    meta = gpu::kWideInnerMeta | (24u + slot);
                    const Work child{firstChild + innerCount, c, item.depth + 1};
                    if (deferBelow > 0 && referencesOf(c) <= deferBelow) {
                        deferred.push_back(child);
                    } else {
                        work.push_back(child);
                        ++pushed;
                    }
                    ++innerCount;
                    ++tree.innerSlots;
                } else {
                    const uint32_t offset = uint32_t(tree.order.size()) - firstTriangle;
                    const uint32_t count = appendReferences(c, tree.order);
                    meta = (((1u << count) - 1u) << 5u) | offset;
                    ++tree.leafSlots;
                }
                (slot < 4 ? node.index.z : node.index.w) |= meta << (8u * (slot & 3u));
            }
            RAYPACK_CHECK(tree.order.size() - firstTriangle <= gpu::kWideNodeTriangles);
            const uint32_t bits = uint32_t(exponents[0] + 127) | uint32_t(exponents[1] + 127) << 8u |
                                  uint32_t(exponents[2] + 127) << 16u | innerMask << 24u;
            node.origin.w = glm::uintBitsToFloat(bits);
            tree.nodes.resize(tree.nodes.size() + innerCount);
            tree.nodes[item.wide] = node;
            // The children are filled depth first, the lowest slot next (it was pushed first, so
            // reverse the ones just pushed): deterministic, and a subtree's nodes stay together.
            std::reverse(work.end() - pushed, work.end());
        }
    }

    Source binarySource(uint32_t index) const {
        const BvhNode& n = bvh_.nodes[index];
        Source s;
        s.node = index;
        s.box.lo = n.lo;
        s.box.hi = n.hi;
        if (n.isLeaf()) {
            s.first = n.index;
            s.count = n.count;
        }
        return s;
    }

    bool isBinaryInner(const Source& s) const { return s.node != kRange && !bvh_.nodes[s.node].isLeaf(); }
    uint32_t referencesOf(const Source& s) const { return s.node != kRange ? references_[s.node] : s.count; }
    // An inner child of a wide node: what a leaf slot cannot hold. A binary subtree of at most three
    // references is one leaf slot (its leaves merged), as the wide tree's leaves hold up to three:
    // Sibenik's tree has 10,758 wide nodes instead of 12,741, the Dragon's 31,044 instead of 42,843,
    // at the same speed on the H200 (0.99-1.01x, docs/gpu.md).
    bool isInner(const Source& s) const { return referencesOf(s) > gpu::kWideMaxLeafTriangles; }

    // Whether the collapse may replace `s` by its two halves while the node has a free slot: a binary
    // inner node (also one of at most three references, which would otherwise be a merged leaf: a
    // free slot holds it better as two children), or more than three references.
    bool canOpen(const Source& s) const { return isBinaryInner(s) || s.count > gpu::kWideMaxLeafTriangles; }

    // Appends the references of leaf child `s` (a range, a binary leaf, or a binary subtree of at
    // most three references, its leaves left to right) and returns how many.
    uint32_t appendReferences(const Source& s, std::vector<uint32_t>& order) const {
        if (!isBinaryInner(s)) {
            for (uint32_t k = 0; k < s.count; ++k) order.push_back(bvh_.primIndices[s.first + k]);
            return s.count;
        }
        std::array<uint32_t, 8> pending{s.node};
        uint32_t size = 1, count = 0;
        while (size > 0) {
            const BvhNode& n = bvh_.nodes[pending[--size]];
            if (n.isLeaf()) {
                for (uint32_t k = 0; k < n.count; ++k) order.push_back(bvh_.primIndices[n.index + k]);
                count += n.count;
            } else {
                pending[size++] = n.index + 1;  // a subtree of three references has at most five nodes
                pending[size++] = n.index;
            }
        }
        return count;
    }

    // The references [first, first + count) as a source: their triangles' box, clipped to `within`
    // (a spatial-split leaf bounds only the parts of its triangles inside its box; those parts are
    // all this leaf has to find).
    Source rangeSource(uint32_t first, uint32_t count, const Aabb& within) const {
        Source s;
        s.first = first;
        s.count = count;
        for (uint32_t k = first; k < first + count; ++k) s.box.grow(scene_.triangleBounds(bvh_.primIndices[k]));
        s.box.lo = glm::max(s.box.lo, within.lo);
        s.box.hi = glm::min(s.box.hi, within.hi);
        return s;
    }

    std::array<Source, 2> open(const Source& s) const {
        if (isBinaryInner(s)) {
            const uint32_t left = bvh_.nodes[s.node].index;
            return {binarySource(left), binarySource(left + 1)};
        }
        const uint32_t half = s.count / 2;
        return {rangeSource(s.first, half, s.box), rangeSource(s.first + half, s.count - half, s.box)};
    }

    // The node's children: its own two halves, then the largest child that can be opened (canOpen)
    // opened until there are eight or none is left to open; what is then left of more than three
    // references is an inner child, the rest are leaves. A source of at most three references (a
    // small root) is the node's only child.
    Children collapse(const Source& s) const {
        Children children;
        if (!isInner(s)) {
            children.at[children.count++] = s;
            return children;
        }
        const std::array<Source, 2> halves = open(s);
        children.at[0] = halves[0];
        children.at[1] = halves[1];
        children.count = 2;
        while (children.count < kWidth) {
            int widest = -1;
            float widestArea = -1.0f;
            for (uint32_t c = 0; c < children.count; ++c) {
                if (!canOpen(children.at[c])) continue;
                const float area = children.at[c].box.area();
                if (area > widestArea) {
                    widest = int(c);
                    widestArea = area;
                }
            }
            if (widest < 0) break;
            const std::array<Source, 2> opened = open(children.at[size_t(widest)]);
            children.at[size_t(widest)] = opened[0];
            children.at[children.count++] = opened[1];
        }
        return children;
    }

    // slots[s]: the child in slot s, or -1. Slot s should hold the child that comes first for a ray
    // of octant s (shaders/wide_node.h, rayOctant): the lowest projection of its centre, relative to
    // the parent's, on the octant's sign vector. Greedy over every (child, slot) pair, cheapest first.
    static std::array<int, kWidth> assignSlots(const Source& parent, const Children& children) {
        std::array<int, kWidth> slots;
        slots.fill(-1);
        struct Pair {
            float cost;
            uint32_t child, slot;
        };
        std::array<Pair, kWidth * kWidth> pairs;
        uint32_t pairCount = 0;
        const glm::vec3 centre = parent.box.center();
        for (uint32_t c = 0; c < children.count; ++c) {
            const glm::vec3 d = children.at[c].box.center() - centre;
            for (uint32_t s = 0; s < kWidth; ++s) {
                const glm::vec3 sign((s & 1u) ? -1.0f : 1.0f, (s & 2u) ? -1.0f : 1.0f, (s & 4u) ? -1.0f : 1.0f);
                pairs[pairCount++] = {glm::dot(d, sign), c, s};
            }
        }
        std::sort(pairs.begin(), pairs.begin() + pairCount, [](const Pair& a, const Pair& b) {
            if (a.cost != b.cost) return a.cost < b.cost;
            return a.child != b.child ? a.child < b.child : a.slot < b.slot;
        });
        std::array<bool, kWidth> placed{};
        for (uint32_t k = 0; k < pairCount; ++k) {
            const Pair& p = pairs[k];
            if (placed[p.child] || slots[p.slot] >= 0) continue;
            slots[p.slot] = int(p.child);
            placed[p.child] = true;
        }
        return slots;
    }

    // Whether plane q of the grid (origin, scale) lies at or below `lo` (coversLow) or at or above
    // `hi` (coversHigh) both ways the kernel reads it (shaders/wide_node.h): as the exact real
    // origin + scale * q, which the fused slab test uses, and as its rounded float decoding (also
    // with a subnormal result flushed to 0, as a device may), which the decoded-box path tests. The
    // real one is judged in double: scale * q is exact there and the difference of two floats is
    // rounded once (relative error at most 2^-53), so a margin of 2^-50 of it decides safely.
    static bool coversLow(float origin, float scale, uint32_t q, float lo) {
        const double gap = double(lo) - double(origin);  // >= 0: the origin is the lowest plane
        if (double(scale) * q > gap - std::fabs(gap) * 0x1p-50) return false;
        const float decoded = gpu::wideDecode(origin, scale, q);
        const float flushed = std::fabs(decoded) < FLT_MIN ? 0.0f : decoded;
        return std::isfinite(decoded) && decoded <= lo && flushed <= lo;
    }
    static bool coversHigh(float origin, float scale, uint32_t q, float hi) {
        const double gap = double(hi) - double(origin);
        if (double(scale) * q < gap + std::fabs(gap) * 0x1p-50) return false;
        const float decoded = gpu::wideDecode(origin, scale, q);
        const float flushed = std::fabs(decoded) < FLT_MIN ? 0.0f : decoded;
        return std::isfinite(decoded) && decoded >= hi && flushed >= hi;
    }

    // The grid's origin for a node whose box starts at `lo`: lo itself, unless it is subnormal, which
    // a device may flush to 0 before adding to it: then the normal value (or 0) just below it.
    static float normalBelow(float lo) {
        if (std::fabs(lo) >= FLT_MIN) return lo;
        return lo < 0.0f ? -FLT_MIN : 0.0f;
    }

    // Writes every child's quantized planes into `node`'s quant words and returns the exponent of
    // each axis (the grid's origin: normalBelow of the box's low corner): the finest grid (from the smallest e with 255
    // * 2^e >= the extent up) on which the decoding of shaders/wide_node.h contains each child's box.
    static std::array<int, 3> quantize(const Aabb& box, const Children& children, const std::array<int, kWidth>& slots,
                                       gpu::GpuWideNode& node) {
        std::array<int, 3> exponents{};
        for (int axis = 0; axis < 3; ++axis) {
            const float origin = normalBelow(box.lo[axis]);
            node.origin[axis] = origin;
            const double extent = double(box.hi[axis]) - double(origin);
            int e = kMinExponent;
            if (extent > 0.0) e = std::max(kMinExponent, int(std::ceil(std::log2(extent / 255.0))));
            std::array<uint32_t, kWidth> qlo{}, qhi{};
            for (;; ++e) {
                if (e > kMaxExponent)
                    throw Error("GPU: the 8-wide tree cannot quantize a node spanning " + std::to_string(extent) +
                                " on axis " + std::to_string(axis) + " (beyond the float range)");
                const float scale = gpu::wideScale(uint32_t(e + 127));
                bool fits = true;
                for (uint32_t slot = 0; slot < kWidth && fits; ++slot) {
                    if (slots[slot] < 0) continue;
                    const Aabb& b = children.at[size_t(slots[slot])].box;
                    const float lo = b.lo[axis], hi = b.hi[axis];
                    const double low = std::floor((double(lo) - double(origin)) / double(scale));
                    uint32_t l = uint32_t(std::clamp(low, 0.0, 255.0));
                    while (l > 0 && !coversLow(origin, scale, l, lo)) --l;
                    const double high = std::ceil((double(hi) - double(origin)) / double(scale));
                    uint32_t h = uint32_t(std::clamp(high, 0.0, 255.0));
                    while (h < 255 && !coversHigh(origin, scale, h, hi)) ++h;
                    fits = coversLow(origin, scale, l, lo) && coversHigh(origin, scale, h, hi);
                    qlo[slot] = l;
                    qhi[slot] = h;
                }
                if (fits) break;
            }
            exponents[size_t(axis)] = e;
            // quant[0] = (lo x, lo y), quant[1] = (lo z, hi x), quant[2] = (hi y, hi z), each a pair
            // of words for slots 0-3 and 4-7.
            const int loPlane = axis, hiPlane = 3 + axis;
            for (uint32_t slot = 0; slot < kWidth; ++slot) {
                const uint32_t shift = 8u * (slot & 3u), half = slot < 4 ? 0u : 1u;
                node.quant[loPlane / 2][2 * (loPlane % 2) + half] |= qlo[slot] << shift;
                node.quant[hiPlane / 2][2 * (hiPlane % 2) + half] |= qhi[slot] << shift;
            }
        }
        return exponents;
    }

    const Scene& scene_;
    const Bvh& bvh_;
    std::vector<uint32_t> references_;  // per binary node, the references below it
};

}  // namespace

GpuWideTree makeGpuWideTree(const Scene& scene, const Bvh& bvh) {
    RAYPACK_CHECK(!bvh.nodes.empty());
    return Collapser(scene, bvh).run();
}

}  // namespace raypack
