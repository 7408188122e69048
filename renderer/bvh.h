#pragma once
// The canonical BVH: what the builders return and what the CPU reference traces. The GPU traces a
// layout converted from it explicitly (renderer/gpu_layout.h).
#include "renderer/aabb.h"
#include "renderer/error.h"       // RAYPACK_CHECK_MSG
#include "renderer/huge_pages.h"  // allocateLarge
#include "renderer/progress.h"    // BuildProgress, BuildCancelled

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

namespace raypack {

struct Scene;

// 32 bytes: two float3 corners, each with a packed 32-bit word in its fourth lane.
//  inner node: count == 0, index = left child; the right child is index + 1 (siblings adjacent,
//              so a packet visiting a node fetches both children with one read)
//  leaf:       count > 0,  index = first entry in Bvh::primIndices, count entries
// nodes[0] is the root; an empty scene has a root leaf with count 0 and an empty box.
struct BvhNode {
    glm::vec3 lo;
    uint32_t index;
    glm::vec3 hi;
    uint32_t count;
    bool isLeaf() const { return count != 0 || index == 0; }
};
static_assert(sizeof(BvhNode) == 32, "BvhNode must be 32 bytes");

enum class BvhBuilder {
    SahExact,   // the report's builder: every centroid a candidate, three presorted lists
    SahBinned,  // Wald 2007, "On fast Construction of SAH-based BVHs": binned centroids, 3 axes
    SahSplit,   // Stich, Friedrich and Dietrich 2009, "Spatial Splits in Bounding Volume Hierarchies"
    // Karras 2012 on the Vulkan device, leaves collapsed by the SAH (renderer/gpu_bvh.h): built by
    // GpuBvhBuilder / buildBvhOnDevice, not by buildBvh, which has no device.
    GpuLbvh,
    // Meister and Bittner 2018's locally-ordered clustering over the Morton-sorted triangles on the
    // device, the same collapse (renderer/gpu_bvh.h); likewise built by GpuBvhBuilder.
    GpuPloc,
    // Benthin et al. 2024's hierarchical PLOC: the same clustering within each range of the Morton
    // order's radix tree, climbed bottom up in one kernel (renderer/gpu_bvh.h); GpuBvhBuilder.
    GpuHploc,
};
// The builders that run on the CPU (buildBvh), in the order a menu lists them.
inline constexpr BvhBuilder kCpuBvhBuilders[] = {BvhBuilder::SahExact, BvhBuilder::SahBinned, BvhBuilder::SahSplit};
// Every builder, in the order a menu lists them: the CPU builders, then the device builders.
inline constexpr BvhBuilder kAllBvhBuilders[] = {BvhBuilder::SahExact, BvhBuilder::SahBinned, BvhBuilder::SahSplit,
                                                 BvhBuilder::GpuLbvh,  BvhBuilder::GpuPloc,   BvhBuilder::GpuHploc};
// The builders that partition the primitives: every primitive is in exactly one leaf, and a leaf's
// box is the union of its primitives' boxes. SahSplit is not one of them: a spatial split puts a
// triangle into several leaves, each bounding only the part of it on its side of the split planes.
// Code that needs one entry per primitive (or per-leaf boxes equal to whole primitive boxes) must
// not assume it of every builder; the CPU tracers and the GPU layout do not (they gather the
// referenced triangles per primIndices entry, and a duplicate reference to the closest triangle
// gives the same t and prim, so the tie rule keeps the same hit).
inline constexpr BvhBuilder kPartitioningBvhBuilders[] = {BvhBuilder::SahExact, BvhBuilder::SahBinned};
// True for SahExact and SahBinned: primIndices is a permutation of the primitive indices.
inline constexpr bool referencesEachPrimitiveOnce(BvhBuilder builder) { return builder != BvhBuilder::SahSplit; }

// The most primitives any leaf holds, whatever leafSize asks (larger values are refused) and even
// where the SAH finds no split worth its cost (a soup of long overlapping slivers, coincident
// triangles): such a node is split at its object median instead. Derived from the kernels'
// traversal budget, gpu::kMaxTraversalSteps = 60,000 (shaders/gpu_types.h): a ray may test 58
// full leaves, and no leaf loop comes near lavapipe's 65,535 loop iterations.
inline constexpr uint32_t kMaxLeafPrimitives = 1024;

// Defaults chosen so that O_AVG lands between 1 and 2 as in the report (3.1); docs/bvh.md has the
// measurements behind them.
// The leaves of a restructured treelet (shaders/lbvh.h's kTreeletLeaves) and the least gamma, at which
// every inner node is a treelet's root.
inline constexpr uint32_t kTreeletLeaves = 7;
inline constexpr uint32_t kMinTreeletGamma = 2;

struct BvhBuildOptions {
    BvhBuilder builder = BvhBuilder::SahExact;
    uint32_t leafSize = 1;          // a node with at most this many primitives becomes a leaf
    float traversalCost = 1.0f;     // C_trav of the SAH
    float intersectionCost = 2.0f;  // C_isect of the SAH
    uint32_t binCount = 32;         // SahBinned only: most bins per axis (min(this, 4 + N/20) for N), 2..256
    // SahSplit only. Spatial splits are tried at a node when its best object split's children
    // overlap by more than splitAlpha × the root's surface area (Stich et al. 2009, section 4.3;
    // 1e-5 is the paper's value); 0 tries them everywhere. Must be finite, 0..1.
    float splitAlpha = 1e-5f;
    // SahSplit only: at most splitBudget × (triangle count) references in all leaves together; once
    // a subtree has used its share, only object splits are tried there. 1 = no spatial splits. 1..4.
    float splitBudget = 1.3f;
    // GpuPloc and GpuHploc only: clusters searched on either side for each one's nearest neighbour
    // (Meister and Bittner 2018's r), 1..kMaxPlocRadius: smaller builds faster, larger finds better
    // pairs. GpuHploc searches a workgroup's clusters, at most 31 either side (16 reaches all).
    // 0: the builder's own (plocRadiusOf): kPlocRadius, or for GpuHploc by the scene's size.
    uint32_t plocRadius = 0;
    // GpuPloc and GpuHploc only: rounds of treelet restructuring (Karras and Aila 2013) over the
    // clustered tree before its layout, 0..kMaxTreeletRounds; each round rebuilds every treelet of
    // seven leaves below a node of at least treeletGamma triangles into its cheapest topology by the
    // SAH (shaders/treelet.comp). 0: none.
    uint32_t treeletRounds = 0;
    // GpuPloc and GpuHploc only: the least triangles below a node whose treelet a round rebuilds
    // (Karras and Aila's gamma), at least kMinTreeletGamma. Larger rebuilds fewer, larger treelets
    // (near the root, where the area and so the SAH's gain is), for a faster round (docs/bvh.md).
    uint32_t treeletGamma = kTreeletLeaves;
    // GpuPloc and GpuHploc only: the top of the clustered tree, every node of at least topRebuild
    // triangles, rebuilt top down by the binned SAH over the subtrees below it (shaders/top.comp),
    // before any treelet round. Smaller rebuilds more of the tree, for a longer build (docs/bvh.md).
    // 0: the builder's own (topRebuildOf); kNoTopRebuild: none.
    uint32_t topRebuild = 0;
};
inline constexpr uint32_t kMaxPlocRadius = 64;
inline constexpr uint32_t kMaxTreeletRounds = 8;
inline constexpr uint32_t kNoTopRebuild = 1;
// The builders' own radii, measured on the H200 (docs/bvh.md): gpu-ploc's within a few percent of
// Meister and Bittner's best SAH. gpu-hploc's depends on the scene's size: from
// kHplocLargeScene triangles 8, which builds 13-15% faster than 16 at 10M-13M triangles with the SAH
// cost within 1.4% (and keeps the build ahead of the driver's there); below it 16, whose trees
// traced 0.99-1.36x as fast as radius 8's on the report scenes for a build a few tenths of a
// millisecond longer, where the fixed cost of a device build dominates anyway.
inline constexpr uint32_t kPlocRadius = 16;
inline constexpr uint32_t kHplocRadius = 8;
inline constexpr uint32_t kHplocSmallSceneRadius = 16;
inline constexpr size_t kHplocLargeScene = size_t(1) << 19;
// The radius a build with `options` of `triangles` triangles searches (plocRadius, or the builder's
// own for 0).
constexpr uint32_t plocRadiusOf(const BvhBuildOptions& options, size_t triangles) {
    if (options.plocRadius != 0) return options.plocRadius;
    if (options.builder != BvhBuilder::GpuHploc) return kPlocRadius;
    return triangles < kHplocLargeScene ? kHplocSmallSceneRadius : kHplocRadius;
}
// gpu-hploc's own top rebuild, measured on the H200 (docs/bvh.md): from kHplocLargeScene triangles
// every node of kHplocTopRebuild triangles or more, which made the 13M-triangle dragon's tree trace
// 0.96-0.98x as fast as sah-exact's (0.73x without) at an SAH cost 1.085x sah-exact's (1.112x), for
// 2.6 ms more of a 20.5 ms build, still 1.05x the driver's BLAS build rate; none below, where the
// architecture's trees traced no faster with it. gpu-ploc's: none.
inline constexpr uint32_t kHplocTopRebuild = 8192;
// The least triangles of a node a build with `options` of `triangles` triangles rebuilds at the top
// (topRebuild, or the builder's own for 0); 0 for none.
constexpr uint32_t topRebuildOf(const BvhBuildOptions& options, size_t triangles) {
    if (options.topRebuild == kNoTopRebuild) return 0;
    if (options.topRebuild != 0) return options.topRebuild;
    return options.builder == BvhBuilder::GpuHploc && triangles >= kHplocLargeScene ? kHplocTopRebuild : 0;
}

// Table 1 of the report, plus what raypack adds.
struct BvhStats {
    uint32_t nodeCount = 0;
    uint32_t leafCount = 0;        // N_L
    double avgLeafDepth = 0.0;     // D_AVG (root at depth 0)
    uint32_t maxLeafDepth = 0;     // D_MAX
    double avgPrimsPerLeaf = 0.0;  // O_AVG: primitive references per leaf
    double buildSeconds = 0.0;     // T_B
    // A device builder's (gpu-lbvh) commands by the device's timestamps, without the host's
    // submission and scratch allocation that buildSeconds includes; 0 for the CPU builders.
    double deviceBuildSeconds = 0.0;
    // Its parts by the same timestamps: bounds, Morton codes and the key sort; the hierarchy
    // (gpu-lbvh's radix tree, or the clustering of gpu-ploc and gpu-hploc, gpu-ploc's host waits
    // between its submissions included); the layout (levels, leaf order, boxes, SAH collapse, nodes).
    double deviceSortSeconds = 0.0;
    double deviceHierarchySeconds = 0.0;
    double deviceLayoutSeconds = 0.0;
    uint64_t buildScratchBytes = 0;  // a device build's temporary device memory (freed after it)
    // gpu-ploc, gpu-hploc with BvhBuildOptions::topRebuild: the subtrees the top was rebuilt over
    // (0: no top rebuilt).
    uint32_t topRebuildItems = 0;
    // A device build's host time creating buffers (the tree's arrays and the scratch), in buildSeconds.
    double buildAllocationSeconds = 0.0;
    double sahCost = 0.0;  // SAH cost of the whole tree, relative to the root's area
    size_t bytes = 0;      // nodes + primitive indices
    // Entries of Bvh::primIndices (references) and distinct primitives they name. Equal for the
    // partitioning builders; SahSplit references a triangle once per leaf it overlaps.
    uint64_t references = 0;
    uint64_t primitives = 0;
};

// std::allocator, except that a resize or a sized construction leaves trivial elements as they are
// (default-initialised) instead of zeroing them: the builders write every node they make, and zeroing
// tens of megabytes first is a serial pass over fresh memory.
template <typename T>
struct UninitializedAllocator : std::allocator<T> {
    T* allocate(size_t count) {
        if (count > SIZE_MAX / sizeof(T)) throw std::bad_array_new_length();
        return static_cast<T*>(allocateLarge(count * sizeof(T)));
    }
    void deallocate(T* data, size_t count) noexcept { freeLarge(data, count * sizeof(T)); }
    template <typename U>
    struct rebind {
        using other = UninitializedAllocator<U>;
    };
    UninitializedAllocator() = default;
    template <typename U>
    UninitializedAllocator(const UninitializedAllocator<U>&) noexcept {}
    template <typename U>
    void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
        ::new (static_cast<void*>(p)) U;
    }
    template <typename U, typename... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};
using BvhNodes = std::vector<BvhNode, UninitializedAllocator<BvhNode>>;
// A std::unique_ptr's deleter for storage from allocateLarge(bytes).
struct LargeStorageFree {
    size_t bytes = 0;
    void operator()(void* data) const noexcept { freeLarge(data, bytes); }
};
// Bvh::primIndices: every builder writes every entry, in allocateLarge's storage too.
using PrimIndices = std::vector<uint32_t, UninitializedAllocator<uint32_t>>;

struct Bvh {
    BvhNodes nodes;
    // Leaf ranges index this; entries are triangle indices (file order). A partitioning builder
    // lists each triangle once; SahSplit may list one in several leaves (never twice in one leaf).
    PrimIndices primIndices;
    BvhBuildOptions options;
    BvhStats stats;
};

// A build on a worker thread reports through BuildProgress (renderer/progress.h): `done` counts
// primitives that have reached a leaf, `total` is set by the builder at its start; setting `cancel`
// makes the builder throw BuildCancelled soon after.

// The triangles behind the primitive bounds, for SahSplit's clipping: triangle i has corners
// positions[triangles[i][0..2]]. Other builders ignore it.
struct BvhTriangles {
    std::span<const glm::vec3> positions;
    std::span<const glm::uvec3> triangles;
};

// Builds over the given primitive bounds (one per triangle, in triangle order). Deterministic: the
// same input and options give the same tree on any thread count.
// Throws raypack::Error for options out of range (leafSize 0, a cost not positive and finite, a
// bin count outside 2..256, a split alpha or budget out of range) and for a primitive box that is
// empty or not finite; BuildCancelled when progress->cancel is set. Fills Bvh::stats, buildSeconds
// included. Throws raypack::Error for GpuLbvh (it needs a device: buildBvhOnDevice in
// renderer/gpu_bvh.h). SahSplit without `triangles` splits the primitive boxes themselves (a box chopped at
// the plane, valid for any primitive inside its box, looser than a clipped triangle's box).
Bvh buildBvh(std::span<const Aabb> primitiveBounds, const BvhBuildOptions& options, BuildProgress* progress = nullptr,
             const BvhTriangles* triangles = nullptr);
// The same over a scene's triangles (their boxes in triangle order; SahSplit clips the triangles).
Bvh buildBvh(const Scene& scene, const BvhBuildOptions& options, BuildProgress* progress = nullptr);
// One box per triangle, in triangle order, as trianglePrimitiveBounds makes them: in allocateLarge's
// storage, each box constructed by the thread that computes it. A std::vector<Aabb> would first
// initialise every box on one thread (Aabb's members have initialisers, so UninitializedAllocator
// cannot skip them), and with the C library's heap it mapped fresh 4 KiB pages for every build:
// 0.58-0.63 s of each build of the 10M-triangle terrain here, against 1.3 s for sah-binned's tree.
class PrimitiveBounds {
public:
    PrimitiveBounds() = default;
    size_t size() const { return count_; }
    bool empty() const { return count_ == 0; }
    const Aabb* data() const { return boxes_.get(); }
    const Aabb& operator[](size_t i) const { return boxes_[i]; }
    const Aabb* begin() const { return data(); }
    const Aabb* end() const { return data() + count_; }
    operator std::span<const Aabb>() const { return {data(), count_}; }

private:
    friend PrimitiveBounds trianglePrimitiveBounds(const Scene& scene);
    std::unique_ptr<Aabb[], LargeStorageFree> boxes_;
    size_t count_ = 0;
};
// Computed in parallel; throws raypack::Error when a triangle names a vertex the scene lacks.
PrimitiveBounds trianglePrimitiveBounds(const Scene& scene);

// Statistics of a built tree (everything but buildSeconds).
BvhStats computeBvhStats(const Bvh& bvh, const BvhBuildOptions& options);

// Calls visit(nodeIndex, node, depth) for every node of the tree, the root at depth 0, depth first
// with the left child before the right: the order in which it meets the leaves is the GPU layout's
// leaf order (renderer/gpu_layout.h), and the statistics sum in it. The one walk over a whole tree
// (the statistics, the depth that sizes the traversal stacks and the GPU layout conversion all use
// it). Checks that children lie after their parent inside the node array (a child pointing back
// would make the walk endless) and that leaf ranges lie inside primIndices.
template <class Visit>
void walkBvh(const Bvh& bvh, Visit&& visit) {
    RAYPACK_CHECK_MSG(!bvh.nodes.empty(), "a Bvh has at least its root");
    struct Pending {
        uint32_t node;
        uint32_t depth;
    };
    std::vector<Pending> stack{{0u, 0u}};
    while (!stack.empty()) {
        const Pending item = stack.back();
        stack.pop_back();
        const BvhNode& node = bvh.nodes[item.node];
        if (node.isLeaf()) {
            RAYPACK_CHECK_MSG(uint64_t(node.index) + node.count <= bvh.primIndices.size(),
                              "leaf range inside primIndices");
        } else {
            RAYPACK_CHECK_MSG(node.index > item.node && uint64_t(node.index) + 1 < bvh.nodes.size(),
                              "children after their parent, inside the node array");
            stack.push_back({node.index + 1, item.depth + 1});
            stack.push_back({node.index, item.depth + 1});
        }
        visit(item.node, node, item.depth);
    }
}

// The depth of the deepest leaf (the root at 0), by walkBvh: a traversal stack of depth + 1 entries
// never overflows.
uint32_t bvhMaxDepth(const Bvh& bvh);

// "sah-exact", "sah-binned", "sah-split", "gpu-lbvh", "gpu-ploc", "gpu-hploc".
const char* toString(BvhBuilder builder);
// The builder whose toString is `name`, or nothing.
std::optional<BvhBuilder> findBvhBuilder(std::string_view name);
// The builder whose toString is `name`; throws raypack::Error listing the valid names otherwise.
BvhBuilder parseBvhBuilder(std::string_view name);

}  // namespace raypack
