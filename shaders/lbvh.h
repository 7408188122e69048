// The GPU BVH builder gpu-lbvh (renderer/gpu_bvh.h, issue 13), defined once for GLSL and C++: its
// descriptor bindings, specialization constants, push constants and the layout of its small state
// buffer. The kernels are shaders/lbvh_prepare.comp (bounds, Morton codes), radix_sort.comp and
// prefix_scan.comp (the key sort), and lbvh.comp (hierarchy, gather, boxes and SAH collapse, the
// top-down emission of the tracers' node layout, shaders/gpu_types.h).
//
// The algorithm (Karras 2012, "Maximizing Parallelism in the Construction of BVHs, Octrees, and k-d
// Trees"; the collapse by the SAH as in Karras and Aila 2013, section 4):
//   1. bounds of the triangles' boxes and of their centroids (lbvh_prepare, kLbvhPhaseBounds);
//   2. a 30-bit Morton code per triangle from its centroid in the centroid bounds (kLbvhPhaseMorton),
//      the bits shared among the axes by their extents (Vinkler, Bittner and Havran 2017);
//   3. a stable LSD radix sort of (code, triangle) by the code: 8 bits a pass, 4 passes;
//   4. the binary radix tree over the sorted codes, ties broken by the sorted position (so every
//      key is distinct): inner node i's children, range and the parent of every node;
//   5. the triangles (and normals, UVs, colours) gathered into sorted order: the tracers' leaf order;
//   6. the inner nodes listed level by level, top down (one indirect dispatch a level, each level
//      appending the next to one queue);
//   7. bottom up, level by level from the deepest, each inner node's box and SAH cost
//      S(node) = min(leaf: A·N·C_isect, inner: A·C_trav + S(left) + S(right)), and whether the node
//      is better as one leaf (it must be when N <= leafSize, it may not when N > kMaxLeafPrimitives);
//   (gpu-ploc replaces steps 4-8 by Meister and Bittner 2018's locally-ordered clustering over the
//   sorted triangles, shaders/ploc.comp; gpu-hploc clusters in one kernel instead, shaders/hploc.comp:
//   Benthin et al. 2024's hierarchical PLOC. Both trees are laid out by
//   shaders/cluster_layout.comp in a fixed number of dispatches, whatever their depth: S and the
//   collapse by a climb from the leaves, every node's depth-first leaf offset and depth by pointer
//   jumping, then the same node emission and leaf order as steps 5 and 8 would give.)
//   8. top down again, every node reached from the root that is not a leaf writes its two children
//      into the node array; Karras' inner node i's children go to slots 1 + 2i and 2 + 2i, so
//      siblings are adjacent as the kernels require. Slots below a collapsed node are never written
//      and never reached.
// Steps 6-8 walk levels rather than climbing from the leaves with one atomic counter per node
// (Karras 2012, section 4): on lavapipe (Mesa 22.3) that counter's atomics returned the same value to
// two invocations of one subgroup, and the levels need no communication within a dispatch. (A Karras
// tree is at most kLbvhMaxDepth deep; the clustered trees' climbs keep their atomics behind an if in
// a loop the whole workgroup runs, which lavapipe counts right.)
// The statistics (leaves, the sum of their depths, inner nodes, the deepest leaf, the root's SAH
// cost) are summed on the way and read back: a hundred bytes, never the tree.
#ifndef RAYPACK_SHADERS_LBVH_H
#define RAYPACK_SHADERS_LBVH_H
#include "common.h"

RP_BEGIN_NAMESPACE

// Set 0 of every build kernel; every binding a storage buffer (the indirect arguments are also an
// indirect buffer). Attributes absent from the scene bind a small unused buffer.
const uint kLbvhBindPositions = 0u;       // float[3 per vertex]: the scene's positions (uploaded once per scene)
const uint kLbvhBindKeysA = 1u;           // uint[]: Morton codes, sorted in place over 4 passes
const uint kLbvhBindValuesA = 2u;         // uint[]: triangle indices (file order), sorted with the codes
const uint kLbvhBindKeysB = 3u;           // uint[]: the radix sort's other half
const uint kLbvhBindValuesB = 4u;         // uint[]
const uint kLbvhBindScan = 5u;            // uint[]: digit counts per sort block, then their prefix sums
const uint kLbvhBindState = 6u;           // uint[kLbvhStateWords]: bounds, counters, statistics
const uint kLbvhBindInner = 7u;           // uvec4[n - 1]: left id, right id, first, last
const uint kLbvhBindLevels = 8u;          // uint[2 levels]: each level's first queue entry and count (gpu-lbvh)
const uint kLbvhBindBoxes = 9u;           // vec4[2 (n - 1)]: lo, hi of every inner node
const uint kLbvhBindCosts = 10u;          // float[n - 1]: S(inner node), area in units of the scene
const uint kLbvhBindFlags = 11u;          // uint[n - 1]: kLbvhCollapsed, kLbvhLive
const uint kLbvhBindQueue = 12u;          // uint[n - 1]: the inner nodes, level after level (gpu-lbvh)
const uint kLbvhBindIndirect = 13u;       // uvec4[levels]: the emission's dispatch per level
const uint kLbvhBindNodes = 14u;          // GpuNode[2n - 1]: the tracers' nodes (output)
const uint kLbvhBindTriangles = 15u;      // GpuTriangle[n]: leaf order (output; cluster_layout.comp's paths before)
const uint kLbvhBindVertexNormals = 16u;  // float[3 per vertex] (kLbvhHasNormals)
const uint kLbvhBindNormals = 17u;        // GpuTriangleNormals[] leaf order (output)
const uint kLbvhBindVertexUvs = 18u;      // float[2 per vertex] (kLbvhHasUvs)
const uint kLbvhBindUvs = 19u;            // GpuTriangleUvs[] leaf order (output)
const uint kLbvhBindVertexColors = 20u;   // uint[per vertex], RGBA8 (kLbvhHasColors)
const uint kLbvhBindColors = 21u;         // GpuTriangleColors[] leaf order (output)
const uint kLbvhBindIndices = 22u;        // uint[3 per triangle]: vertex indices, file order
const uint kLbvhBindMaterials = 23u;      // uint[per triangle]: material index (kLbvhHasMaterials)
const uint kLbvhBindingCount = 24u;

// Specialization constants of every build kernel.
const uint kLbvhSpecPhase = 0u;              // kLbvhPhase* (a kernel file holds several phases)
const uint kLbvhSpecSubgroupsPerGroup = 1u;  // radix_sort.comp: kLbvhGroupSize / subgroup size
const uint kLbvhSpecPlocRadius = 2u;         // ploc.comp, hploc.comp: clusters searched on either side (r)

// One workgroup is this many invocations in every build kernel.
const uint kLbvhGroupSize = 256u;
// The radix sort: 8-bit digits, 4 passes over the 32-bit keys (the codes use 30), each workgroup
// sorting a block of kLbvhSortItems x kLbvhGroupSize keys.
const uint kLbvhRadixBits = 8u;
const uint kLbvhRadixDigits = 256u;
const uint kLbvhSortItems = 8u;
const uint kLbvhSortBlock = kLbvhGroupSize * kLbvhSortItems;
// The scan: each workgroup scans kLbvhScanItems x kLbvhGroupSize entries.
const uint kLbvhScanItems = 4u;
const uint kLbvhScanBlock = kLbvhGroupSize * kLbvhScanItems;

// Phases (kLbvhSpecPhase).
const uint kLbvhPhaseBounds = 0u;        // lbvh_prepare.comp
const uint kLbvhPhaseMorton = 1u;        // lbvh_prepare.comp
const uint kLbvhPhaseHistogram = 2u;     // radix_sort.comp
const uint kLbvhPhaseScatter = 3u;       // radix_sort.comp
const uint kLbvhPhaseScanBlocks = 4u;    // prefix_scan.comp: exclusive scan per block, block sums out
const uint kLbvhPhaseAddBlockSums = 5u;  // prefix_scan.comp
const uint kLbvhPhaseHierarchy = 6u;     // lbvh.comp
const uint kLbvhPhaseGather = 7u;        // lbvh.comp
const uint kLbvhPhaseLevelRoot = 8u;     // lbvh.comp: one invocation, the queue's first level
const uint kLbvhPhaseEnumerate = 9u;     // lbvh.comp: one level's inner children into the queue
const uint kLbvhPhaseNextLevel = 10u;    // lbvh.comp: one invocation, the next level's dispatch
const uint kLbvhPhaseBottomUp = 11u;     // lbvh.comp: one level's boxes and costs
const uint kLbvhPhaseRoot = 12u;         // lbvh.comp: one invocation, the root's node
const uint kLbvhPhaseEmit = 13u;         // lbvh.comp: one level's children into the node array
// gpu-ploc (shaders/ploc.comp) instead of step 4, then the clustered trees' layout below:
const uint kLbvhPhasePlocInit = 14u;     // every sorted triangle a cluster, its box
const uint kLbvhPhasePlocNearest = 15u;  // each cluster's nearest neighbour within the radius
const uint kLbvhPhasePlocFlags = 16u;    // which clusters stay and which merge
const uint kLbvhPhasePlocApply = 17u;    // the merged nodes and the next cluster array
const uint kLbvhPhasePlocReorder = 18u;  // the triangles' order by their slots in the leaf order
const uint kLbvhPhasePlocSetup = 19u;    // one invocation: an iteration's cluster count and dispatch sizes
// gpu-hploc (shaders/hploc.comp) instead of gpu-ploc's iterations, then the same layout:
const uint kLbvhPhaseHplocInit = 20u;   // every sorted triangle a cluster, its box and triangle count
const uint kLbvhPhaseHplocBuild = 21u;  // the whole clustering: Apetrei's climb, PLOC in each workgroup
// The clustered trees (gpu-ploc, gpu-hploc), shaders/cluster_layout.comp, and their treelet
// restructuring, shaders/treelet.comp:
const uint kLbvhPhaseClusterParents = 22u;    // every node's parent, every inner node's arrival count zeroed
const uint kLbvhPhaseTreelet = 23u;           // one round: the climb, each treelet of >= gamma triangles rebuilt
const uint kLbvhPhaseClusterCosts = 24u;      // the climb: every inner node's S and whether it collapses
const uint kLbvhPhaseClusterPathStart = 25u;  // every inner node's step to its parent (below)
const uint kLbvhPhaseClusterPathJump = 26u;   // one round of pointer jumping over those steps
const uint kLbvhPhaseClusterEmit = 27u;       // the tracers' nodes and every triangle's leaf-order slot
// top.comp (gpu-ploc, gpu-hploc): the clustered tree's top rebuilt by the binned SAH.
const uint kLbvhPhaseTopStart = 28u;   // one workgroup: the top listed, its first splits
const uint kLbvhPhaseTopFinish = 29u;  // a workgroup per subtree the start left (indirect)

// gpu-hploc's workgroups: each one climbs from kHplocGroupSize sorted triangles at a time and merges a
// range's clusters together, at most kHplocGroupSize of them (both children's, up to kHplocThreshold
// each), until kHplocThreshold are left (one at the root).
const uint kHplocGroupSize = 32u;
const uint kHplocThreshold = kHplocGroupSize / 2u;
// Treelet restructuring (Karras and Aila 2013): a treelet is an inner node and up to
// kTreeletLeaves - 1 nodes below it, grown by opening its leaf of the largest area; its best
// topology over those leaves is found by dynamic programming over their 2^kTreeletLeaves - 1
// subsets. Each workgroup climbs from kTreeletGroupSize sorted triangles.
const uint kTreeletLeaves = 7u;
const uint kTreeletGroupSize = 32u;
// The most splits the subsets of one size have together, over every size k: C(7, k) subsets of
// 2^(k-1) - 1 splits each, the most at k = 5 (21 * 15).
const uint kTreeletMostSplits = 315u;

// The top rebuild (top.comp): teams of kTopTeam invocations, kTopTeams a workgroup, each splitting
// one node a turn over kTopTeam bins per axis (one an invocation); the start phase stops splitting
// once kTopFrontier nodes wait, and each of those is finished by a workgroup of its own. A node of
// more than kTopSample items is binned from kTopSample of them, evenly spaced.
const uint kTopTeam = 32u;
const uint kTopTeams = 8u;
const uint kTopGroupSize = kTopTeam * kTopTeams;
const uint kTopFrontier = 128u;
const uint kTopSample = 1024u;

// An entry of gpu-hploc's parent slots and cluster array that holds nothing yet.
const uint kHplocEmpty = 0xFFFFFFFFu;

// Push constants of every phase, 48 bytes.
struct LbvhParams {
    // x: triangle count n; y: leaf size; z: the sort's bit shift, the emitted level, the scan's
    // element count, a treelet round's gamma (the fewest triangles a treelet root has) or the top
    // rebuild's (the fewest triangles of a node it rebuilds); w:
    // attribute bits (kLbvhHas*)
    uvec4 counts;
    // x: the sort's block count or the scan's input offset (in uints); y: the scan's block-sums
    // offset; z: the sort's (and gpu-ploc's) source half, 1 = B, or for the scan 1 + the level L
    // of a scan whose counts follow gpu-ploc's clusters (0: counts.z entries); w: unused.
    // gpu-ploc's flags and apply read its two scans at x and y.
    uvec4 offsets;
    // x: C_trav, y: C_isect, z, w: unused
    vec4 costs;
};
RP_CHECK_SIZE(LbvhParams, 48);

const uint kLbvhHasNormals = 1u;
const uint kLbvhHasUvs = 2u;
const uint kLbvhHasColors = 4u;
const uint kLbvhHasMaterials = 8u;

// Bits of kLbvhBindFlags: the node is one leaf in the built tree; the node is reached from the root.
const uint kLbvhCollapsed = 1u;
const uint kLbvhLive = 2u;
// Ids in kLbvhBindInner's children: inner node i is id i, sorted triangle j is id n - 1 + j.

// The Morton code's bits (kLbvhPhaseMorton).
const uint kLbvhMortonBits = 30u;

// The most primitives one leaf may hold (renderer/bvh.h's kMaxLeafPrimitives, checked there).
const uint kLbvhMaxLeafPrimitives = 1024u;
// The deepest a Karras tree can be: every level down fixes one more bit of the 30-bit code extended
// by the 32-bit sorted position, so a path has at most 62 inner nodes and its leaf is at depth <= 62.
const uint kLbvhMaxDepth = 62u;

// Words of kLbvhBindState.
const uint kLbvhStateBoxLo = 0u;          // 3 words: the triangles' bounds, ordered uints (below)
const uint kLbvhStateBoxHi = 3u;          // 3 words
const uint kLbvhStateCentroidLo = 6u;     // 3 words: the centroids' bounds
const uint kLbvhStateCentroidHi = 9u;     // 3 words
const uint kLbvhStateInnerCount = 12u;    // inner nodes reached from the root
const uint kLbvhStateMaxDepth = 13u;      // the deepest leaf (root 0)
const uint kLbvhStateQueueTail = 14u;     // entries of kLbvhBindQueue pushed so far
const uint kLbvhStateRootCost = 15u;      // float bits: S(root)
const uint kLbvhStateRootArea = 16u;      // float bits: the root's half area, same units
const uint kLbvhStatePathRounds = 17u;    // clustered layout: 1 + the last jump round that left a path unfinished
const uint kLbvhStateStatus = 19u;        // kLbvhStatus* bits: 0 after a good build
const uint kLbvhStateClusters = 20u;      // gpu-ploc: clusters in this iteration
const uint kLbvhStateMerged = 21u;        // gpu-ploc: inner nodes made before this iteration
const uint kLbvhStateLeafCount = 22u;     // leaves of the laid out tree
const uint kLbvhStateNextClusters = 23u;  // gpu-ploc: clusters after this iteration
const uint kLbvhStateNextMerged = 24u;    // gpu-ploc: inner nodes made after it (gpu-hploc: all)
const uint kLbvhStateDepthSum = 25u;      // 2 words, low then high: the sum of every leaf's depth
const uint kLbvhStateTopHead = 27u;       // top.comp: the first node its start phase left unsplit
const uint kLbvhStateTopTail = 28u;       // top.comp: the nodes its start phase made
const uint kLbvhStateTopItems = 29u;      // top.comp: the subtrees the top was rebuilt over
// gpu-ploc's dispatch arguments in kLbvhBindIndirect while clustering: the clusters' at entry 0,
// the scan's level L at entry 1 + L.
const uint kPlocIndirectClusters = 0u;
const uint kPlocIndirectScan = 1u;
const uint kLbvhStateWords = 32u;

// A radix sort workgroup found its subgroups other than the host assumed (radix_sort.comp).
const uint kLbvhStatusSubgroupLayout = 1u;
// A clustered tree is deeper than the layout's pointer-jumping rounds reach (cluster_layout.comp).
const uint kLbvhStatusTooDeep = 2u;

// Floats as uints whose unsigned order is the floats' order (for atomicMin / atomicMax).
RP_FUNC uint lbvhOrderedBits(float f) {
    const uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : (u | 0x80000000u);
}
RP_FUNC float lbvhFromOrderedBits(uint u) { return uintBitsToFloat((u & 0x80000000u) != 0u ? (u & 0x7FFFFFFFu) : ~u); }

// Clustering (gpu-ploc, gpu-hploc): union areas are compared in units of the scene's largest extent
// (as lbvh.comp's SAH areas), so that scenes near 1e30 or 1e-30 neither overflow nor underflow.
RP_FUNC float plocAreaUnit(vec3 sceneLo, vec3 sceneHi) {
    const vec3 extent = 0.5f * sceneHi - 0.5f * sceneLo;
    const float largest = max(max(extent.x, extent.y), extent.z);
    return largest > 0.0f ? 1.0f / largest : 0.0f;
}
RP_FUNC float plocArea(vec3 lo, vec3 hi, float unit) {
    const vec3 e = (0.5f * hi - 0.5f * lo) * unit;
    return e.x * e.y + e.y * e.z + e.z * e.x;
}
// Whether cluster j, at the same union area as `current`, is the nearer neighbour of cluster i (all
// three positions in one ordered array). Pairs of equal area are ordered by their distance in the
// array, then with the pair whose lower position is even first: one order on pairs, the same from
// both sides, so the first pair is mutual and every iteration merges at least once; and where
// everything ties (identical triangles) positions 2k and 2k + 1 pair up and the clusters halve,
// instead of one merge an iteration growing a chain.
RP_FUNC bool plocCloserTie(uint i, uint j, uint current) {
    if (current == i) return true;
    const uint dj = j > i ? j - i : i - j;
    const uint dc = current > i ? current - i : i - current;
    if (dj != dc) return dj < dc;
    const bool jEven = (min(i, j) & 1u) == 0u;
    const bool currentEven = (min(i, current) & 1u) == 0u;
    if (jEven != currentEven) return jEven;
    return j < current;
}

RP_END_NAMESPACE

#endif  // RAYPACK_SHADERS_LBVH_H
