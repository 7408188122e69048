#version 460
// The clustered trees' layout (gpu-ploc, gpu-hploc; shaders/lbvh.h): from the records the clustering
// (and the treelet rounds) left, the tracers' nodes (shaders/gpu_types.h) and every triangle's slot
// in the depth-first leaf order, in a number of dispatches that does not grow with the tree's depth.
//
// The tree is the one lbvh.comp's level-by-level passes gave it before (the same S, collapses, node
// slots and leaf order; the tests compare them with a CPU recomputation), in four steps:
//   1. kLbvhPhaseClusterParents: every node's parent record, every arrival count zeroed (also run
//      before each treelet round, treelet.comp).
//   2. kLbvhPhaseClusterCosts: a climb from every sorted triangle; the second of a node's two
//      children to arrive computes its S = min(leaf: A N C_isect, split: A C_trav + S(left) + S(right))
//      and whether it collapses into one leaf, as lbvh.comp's bottom-up pass does.
//   3. kLbvhPhaseClusterPathStart, then kLbvhPhaseClusterPathJump a round at a time: pointer
//      jumping (Wyllie 1979) over each inner node's path to the root. A path record is (leaf offset
//      so far, the ancestor it has reached, the steps taken, whether a collapsed node lies on them);
//      a round adds the record of the ancestor reached and takes its ancestor, doubling every
//      path's reach, so ceil(log2(depth + 1)) rounds finish every path: its depth-first leaf offset
//      (the triangles of every left sibling on the way), its depth, and whether it is below a leaf.
//      Rounds after every path finished return at once. The records live in the output triangle
//      array, two halves of n - 1 records each (read one, write the other), which the gather then
//      fills.
//   4. kLbvhPhaseClusterEmit: every inner node reached from the root that is not a leaf writes its two
//      children into slots 1 + 2r and 2 + 2r (its record r), leaves with their first slot in the leaf
//      order, and every node gives its triangle children their slots (ploc.comp's reorder then moves
//      the triangles there).
// Every phase returns at once when the clustering left a broken tree (the host reports it), and the
// emission when a path is deeper than the rounds reach (kLbvhStatusTooDeep).
//
// The climb keeps its arrival exchange behind an if, in a loop the whole workgroup runs, as
// hploc.comp's and treelet.comp's: lavapipe (Mesa 22.3) miscounted arrivals in a loop only the
// subgroup ran (inner nodes left without S, 0.1% of Sibenik's), as it did in loops each invocation
// left on its own.
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_arithmetic : require

#include "gpu_types.h"
#include "lbvh.h"

layout(local_size_x = kLbvhGroupSize) in;
layout(constant_id = kLbvhSpecPhase) const uint kPhase = kLbvhPhaseClusterParents;
layout(push_constant) uniform Params { LbvhParams params; };

layout(std430, set = 0, binding = kLbvhBindInner) readonly buffer Inner { uvec4 inner[]; };
layout(std430, set = 0, binding = kLbvhBindBoxes) readonly buffer Boxes { vec4 boxes[]; };
// S of every inner node by record, and its kLbvhCollapsed bit.
layout(std430, set = 0, binding = kLbvhBindCosts) coherent buffer Costs { float costs[]; };
layout(std430, set = 0, binding = kLbvhBindFlags) buffer Flags { uint flags[]; };
// The parent record of every inner node (by record) and of every sorted triangle.
layout(std430, set = 0, binding = kLbvhBindScan) buffer InnerParents { uint innerParents[]; };
layout(std430, set = 0, binding = kLbvhBindKeysA) buffer LeafParents { uint leafParents[]; };
// By record: how many of each inner node's children have climbed to it (the second goes on); then,
// by sorted triangle, its slot in the leaf order (what ploc.comp's reorder reads).
layout(std430, set = 0, binding = kLbvhBindValuesB) coherent buffer ValuesB { uint arrivalsThenSlots[]; };
layout(std430, set = 0, binding = kLbvhBindState) coherent buffer State { uint state[]; };
// Step 3's path records, in the output triangles until the gather writes them.
layout(std430, set = 0, binding = kLbvhBindTriangles) buffer Paths { uvec4 paths[]; };
layout(std430, set = 0, binding = kLbvhBindNodes) writeonly buffer Nodes { GpuNode nodes[]; };

#include "cluster_tree.h"
#include "emit.h"

// A path that has reached the root: its ancestor.
const uint kNoAncestor = 0xFFFFFFFFu;

bool treeIsWhole() { return state[kLbvhStateNextMerged] == n() - 1u; }

void listParents() {
    const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint r = gl_GlobalInvocationID.x; r + 1u < n(); r += stride) {
        const uvec4 record = inner[r];
        for (uint c = 0u; c < 2u; ++c) {
            const uint child = record[c];
            if (isTriangle(child))
                leafParents[child - (n() - 1u)] = r;
            else
                innerParents[child] = r;
        }
        arrivalsThenSlots[r] = 0u;
    }
}

// ---- Step 2: S and the collapse, bottom up.

void childOf(uint name, float unit, out vec3 lo, out vec3 hi, out float cost) {
    const uint b = boxIndex(name);
    lo = boxes[2u * b].xyz;
    hi = boxes[2u * b + 1u].xyz;
    cost = isTriangle(name) ? plocArea(lo, hi, unit) * params.costs.y : costs[name];
}

// Inner node `node`, both children done: its S and whether it is one leaf, by lbvh.comp's rule (a
// leaf at N <= leafSize, never above kLbvhMaxLeafPrimitives, else the cheaper; the same arithmetic).
void settle(uint node, float unit) {
    const uvec4 record = inner[node];
    vec3 leftLo, leftHi, rightLo, rightHi;
    float leftCost, rightCost;
    childOf(record.x, unit, leftLo, leftHi, leftCost);
    childOf(record.y, unit, rightLo, rightHi, rightCost);
    const vec3 lo = min(leftLo, rightLo), hi = max(leftHi, rightHi);
    const uint count = record.z;
    const float area = plocArea(lo, hi, unit);
    const float leafCost = area * float(count) * params.costs.y;
    const float splitCost = area * params.costs.x + leftCost + rightCost;
    const bool collapse = count <= params.counts.y || (count <= kLbvhMaxLeafPrimitives && leafCost <= splitCost);
    const float cost = collapse ? leafCost : splitCost;
    costs[node] = cost;
    flags[node] = collapse ? kLbvhCollapsed : 0u;
    if (node == 0u) {
        state[kLbvhStateRootCost] = floatBitsToUint(cost);
        state[kLbvhStateRootArea] = floatBitsToUint(area);
    }
}

// Whether `value` holds for any invocation of the workgroup; every invocation must call it.
shared uint subgroupAnyOf[kLbvhGroupSize];
bool groupAny(bool value) {
    const bool any = subgroupAny(value);
    if (subgroupElect()) subgroupAnyOf[gl_SubgroupID] = any ? 1u : 0u;
    barrier();
    bool result = false;
    for (uint s = 0u; s < gl_NumSubgroups; ++s) result = result || subgroupAnyOf[s] != 0u;
    barrier();
    return result;
}

void climbCosts() {
    const float unit = sceneAreaUnit();
    const uint k = gl_GlobalInvocationID.x;
    bool climbing = k < n();
    uint node = n() - 1u + k;
    while (groupAny(climbing)) {
        if (climbing) {
            const uint parent = parentOf(node);
            memoryBarrierBuffer();  // this node's S, before the arrival
            if (atomicExchange(arrivalsThenSlots[parent], 1u) == 0u) {
                climbing = false;  // the sibling's climb goes on
            } else {
                memoryBarrierBuffer();  // the sibling's S, after it
                settle(parent, unit);
                node = parent;
                climbing = parent != 0u;
            }
        }
    }
}

// ---- Step 3: every inner node's leaf offset, depth and collapsed ancestors, by pointer jumping.

uint pathCount() { return n() - 1u; }

void startPath() {
    const uint r = gl_GlobalInvocationID.x;
    if (r >= pathCount()) return;
    uvec4 path = uvec4(0u, kNoAncestor, 0u, 0u);
    if (r != 0u) {
        const uint parent = innerParents[r];
        const uvec4 record = inner[parent];
        path = uvec4(record.y == r ? countOf(record.x) : 0u, parent, 1u, flags[parent] & kLbvhCollapsed);
    }
    paths[r] = path;
}

// Round params.counts.z: from half round % 2 into the other.
void jump() {
    const uint round = params.counts.z;
    if (round > 0u && state[kLbvhStatePathRounds] < round) return;  // the last round finished every path
    const uint r = gl_GlobalInvocationID.x;
    const uint from = (round & 1u) * pathCount(), to = pathCount() - from;
    bool open = false;
    if (r < pathCount()) {
        uvec4 path = paths[from + r];
        if (path.y != kNoAncestor) {
            const uvec4 above = paths[from + path.y];
            path = uvec4(path.x + above.x, above.y, path.z + above.z, path.w | above.w);
        }
        paths[to + r] = path;
        open = path.y != kNoAncestor;
    }
    // Read first: after the first subgroups, the word says so already.
    if (subgroupAny(open) && subgroupElect() && state[kLbvhStatePathRounds] <= round)
        atomicMax(state[kLbvhStatePathRounds], round + 1u);
}

// ---- Step 4: the tracers' nodes and the leaf order.

// params.counts.z: the rounds recorded.
void emit() {
    const uint rounds = state[kLbvhStatePathRounds];
    if (rounds >= params.counts.z) {
        if (gl_GlobalInvocationID.x == 0u) atomicOr(state[kLbvhStateStatus], kLbvhStatusTooDeep);
        return;
    }
    // The last round that ran, `rounds`, wrote half (rounds + 1) % 2.
    const uint finished = ((rounds + 1u) & 1u) * pathCount();
    const uint r = gl_GlobalInvocationID.x;
    uint leaves = 0u, inners = 0u, depth = 0u;
    if (r < pathCount()) {
        const uvec4 path = paths[finished + r];
        const uvec4 record = inner[r];
        const uint first[2] = {path.x, path.x + countOf(record.x)};
        for (uint c = 0u; c < 2u; ++c)
            if (isTriangle(record[c])) arrivalsThenSlots[record[c] - (n() - 1u)] = first[c];
        const bool leaf = (flags[r] & kLbvhCollapsed) != 0u;
        if (r == 0u) {
            const uint b = boxIndex(0u);
            const vec3 lo = boxes[2u * b].xyz, hi = boxes[2u * b + 1u].xyz;
            nodes[0] = leaf ? leafNode(lo, hi, 0u, n()) : innerNode(lo, hi, 1u);
            if (leaf)
                leaves = 1u;
            else
                inners = 1u;
        }
        depth = path.z + 1u;
        if (path.w == 0u && !leaf) {  // reached from the root, and split
            for (uint c = 0u; c < 2u; ++c) {
                const uint child = record[c], b = boxIndex(child), slot = 1u + 2u * r + c;
                const vec3 lo = boxes[2u * b].xyz, hi = boxes[2u * b + 1u].xyz;
                if (isTriangle(child) || (flags[child] & kLbvhCollapsed) != 0u) {
                    nodes[slot] = leafNode(lo, hi, first[c], countOf(child));
                    ++leaves;
                } else {
                    nodes[slot] = innerNode(lo, hi, 1u + 2u * child);
                    ++inners;
                }
            }
        } else if (r == 0u) {
            depth = 0u;  // the root is the one leaf
        }
    }
    addStatistics(leaves, depth, inners);
}

void main() {
    if (!treeIsWhole()) return;  // the host reports the clustering's count
    if (kPhase == kLbvhPhaseClusterParents)
        listParents();
    else if (kPhase == kLbvhPhaseClusterCosts)
        climbCosts();
    else if (kPhase == kLbvhPhaseClusterPathStart)
        startPath();
    else if (kPhase == kLbvhPhaseClusterPathJump)
        jump();
    else
        emit();
}
