#version 460
// Treelet restructuring of the clustered trees (gpu-ploc, gpu-hploc; shaders/lbvh.h), after Karras and
// Aila 2013, "Fast Parallel Construction of High-Quality Bounding Volume Hierarchies", section 4: a
// round climbs the tree bottom up, and at every inner node of at least gamma triangles takes the
// treelet below it (the node's two children, then repeatedly the treelet leaf of the largest area
// opened into its two children, up to kTreeletLeaves leaves) and rebuilds the treelet's inner nodes
// into the topology of least SAH cost over the same leaves, found by dynamic programming over every
// subset of the leaves. The cost is the one lbvh.comp's bottom-up pass collapses by, S = min(leaf:
// A N C_isect, split: A C_trav + S(left) + S(right)), with a leaf forced at N <= leafSize and
// refused above kLbvhMaxLeafPrimitives, so the optimum is for the tree as it is finally laid out.
// The subtrees below a treelet's leaves were finished before it (a node is processed by the second
// of its children's climbs to arrive), and its own box does not change, so what is above it sees
// the same leaves' union at a lower or equal cost.
//
// Where Karras and Aila share a treelet among a warp's 32 lanes, here one invocation takes a treelet
// alone: its 127 subsets and their 966 splits are a few thousand operations, and the climb keeps
// every invocation busy on its own path while the tree is wide. The climb is the loop the whole
// workgroup runs, one step a turn, with the arrival count's atomic behind an if, as in hploc.comp:
// lavapipe (Mesa 22.3) miscounted atomics of a subgroup whose other invocations had left their loop.
//
// What a round rewrites: the records of the treelets' inner nodes (children, triangle count, as
// ploc.comp and hploc.comp make them), their boxes by cluster id, and their costs. Parents are listed
// again before each round (kLbvhPhaseTreeletParents); gpu-ploc's layout then lists the levels of the
// restructured tree from the root, record 0, which keeps its record.
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require

#include "gpu_types.h"
#include "lbvh.h"

layout(local_size_x = kTreeletGroupSize) in;
layout(constant_id = kLbvhSpecPhase) const uint kPhase = kLbvhPhaseTreeletParents;
layout(push_constant) uniform Params { LbvhParams params; };

// Records as ploc.comp's: children named as lbvh.comp names them (an inner node by its record, sorted
// triangle k as n - 1 + k), the triangle count in z.
layout(std430, set = 0, binding = kLbvhBindInner) coherent buffer Inner { uvec4 inner[]; };
// By cluster id (sorted triangle k is id k, record r is id 2n - 2 - r): lo, hi.
layout(std430, set = 0, binding = kLbvhBindBoxes) coherent buffer Boxes { vec4 boxes[]; };
// S of every inner node by record, in the area units of plocAreaUnit.
layout(std430, set = 0, binding = kLbvhBindCosts) coherent buffer Costs { float costs[]; };
// The parent record of every inner node (by record) and of every sorted triangle.
layout(std430, set = 0, binding = kLbvhBindScan) buffer InnerParents { uint innerParents[]; };
layout(std430, set = 0, binding = kLbvhBindKeysA) buffer LeafParents { uint leafParents[]; };
// How many of each inner node's children have climbed to it (the second goes on).
layout(std430, set = 0, binding = kLbvhBindValuesB) coherent buffer Arrivals { uint arrivals[]; };
layout(std430, set = 0, binding = kLbvhBindState) readonly buffer State { uint state[]; };

uint n() { return params.counts.x; }
bool isTriangle(uint name) { return name >= n() - 1u; }
uint boxIndex(uint name) { return isTriangle(name) ? name - (n() - 1u) : 2u * n() - 2u - name; }
uint parentOf(uint name) { return isTriangle(name) ? leafParents[name - (n() - 1u)] : innerParents[name]; }

void listParents() {
    const uint stride = gl_NumWorkGroups.x * kTreeletGroupSize;
    for (uint r = gl_GlobalInvocationID.x; r + 1u < n(); r += stride) {
        const uvec4 record = inner[r];
        for (uint c = 0u; c < 2u; ++c) {
            const uint child = record[c];
            if (isTriangle(child))
                leafParents[child - (n() - 1u)] = r;
            else
                innerParents[child] = r;
        }
        arrivals[r] = 0u;
    }
}

// S of a node of `count` triangles and half area `area` whose children's S sum to `split`.
float nodeCost(float area, uint count, float split) {
    const float leaf = area * float(count) * params.costs.y;
    if (count <= params.counts.y) return leaf;
    const float inner = area * params.costs.x + split;
    return count <= kLbvhMaxLeafPrimitives ? min(leaf, inner) : inner;
}

#include "workgroup_ballot.h"

const uint kSubsets = 1u << kTreeletLeaves;

// The treelet's leaves: boxes and triangle counts (at module scope, so that subsetBounds takes no
// array parameter, which GLSL would copy).
vec3 leafLo[kTreeletLeaves], leafHi[kTreeletLeaves];
uint leafCount[kTreeletLeaves];

// The box and triangle count of the leaves in subset s of the treelet's first `leaves` leaves.
void subsetBounds(uint s, uint leaves, out vec3 l, out vec3 h, out uint triangles) {
    l = vec3(3.402823466e38f);
    h = vec3(-3.402823466e38f);
    triangles = 0u;
    for (uint i = 0u; i < leaves; ++i) {
        if (((s >> i) & 1u) == 0u) continue;
        l = min(l, leafLo[i]);
        h = max(h, leafHi[i]);
        triangles += leafCount[i];
    }
}

// Rebuilds the treelet below inner node `root`, or, where it has fewer than three leaves, only sets
// the node's cost.
void restructure(uint root, float unit) {
    uint leaf[kTreeletLeaves], made[kTreeletLeaves - 1u];
    const uvec4 record = inner[root];
    leaf[0] = record.x;
    leaf[1] = record.y;
    made[0] = root;
    uint leaves = 2u;
    if (record.z >= params.counts.z) {
        while (leaves < kTreeletLeaves) {
            uint open = kTreeletLeaves;
            float largest = -1.0f;
            for (uint i = 0u; i < leaves; ++i) {
                if (isTriangle(leaf[i])) continue;
                const uint b = boxIndex(leaf[i]);
                const float area = plocArea(boxes[2u * b].xyz, boxes[2u * b + 1u].xyz, unit);
                if (area > largest) {
                    largest = area;
                    open = i;
                }
            }
            if (open == kTreeletLeaves) break;
            const uvec4 opened = inner[leaf[open]];
            made[leaves - 1u] = leaf[open];
            leaf[open] = opened.x;
            leaf[leaves++] = opened.y;
        }
    }
    float cost[kTreeletLeaves];
    for (uint i = 0u; i < leaves; ++i) {
        const uint b = boxIndex(leaf[i]);
        leafLo[i] = boxes[2u * b].xyz;
        leafHi[i] = boxes[2u * b + 1u].xyz;
        if (isTriangle(leaf[i])) {
            leafCount[i] = 1u;
            cost[i] = plocArea(leafLo[i], leafHi[i], unit) * params.costs.y;
        } else {
            leafCount[i] = inner[leaf[i]].z;
            cost[i] = costs[leaf[i]];
        }
    }
    // best[s]: the least S of a subtree over the leaves of subset s; part[s]: its left child's
    // subset, the one holding s's lowest leaf. Every proper subset of s is a smaller number, so one
    // pass in increasing order has every part's S ready.
    float best[kSubsets];
    uint part[kSubsets];
    const uint all = (1u << leaves) - 1u;
    for (uint s = 1u; s <= all; ++s) {
        if (bitCount(s) == 1u) {
            best[s] = cost[findLSB(s)];
            continue;
        }
        vec3 l, h;
        uint triangles;
        subsetBounds(s, leaves, l, h, triangles);
        const uint lowest = s & (0u - s), rest = s ^ lowest;
        float split = 3.402823466e38f;
        uint chosen = lowest;
        // Every part holding the lowest leaf but not all of s: lowest | q for the proper subsets q
        // of the rest, larger first (so ties keep the first found, the same on every device).
        for (uint q = (rest - 1u) & rest;; q = (q - 1u) & rest) {
            const uint p = lowest | q;
            const float c = best[p] + best[s ^ p];
            if (c < split) {
                split = c;
                chosen = p;
            }
            if (q == 0u) break;
        }
        best[s] = nodeCost(plocArea(l, h, unit), triangles, split);
        part[s] = chosen;
    }
    if (leaves == 2u) {
        costs[root] = best[all];
        return;
    }
    // The treelet's inner nodes again, top down, from the root's record and then the opened ones.
    uint stackSubset[kTreeletLeaves], stackName[kTreeletLeaves];
    uint depth = 1u, next = 1u;
    stackSubset[0] = all;
    stackName[0] = root;
    while (depth > 0u) {
        --depth;
        const uint s = stackSubset[depth], name = stackName[depth];
        uint children[2] = {part[s], s ^ part[s]};
        uint named[2];
        for (uint c = 0u; c < 2u; ++c) {
            if (bitCount(children[c]) == 1u) {
                named[c] = leaf[findLSB(children[c])];
            } else {
                named[c] = made[next++];
                stackSubset[depth] = children[c];
                stackName[depth] = named[c];
                ++depth;
            }
        }
        vec3 l, h;
        uint triangles;
        subsetBounds(s, leaves, l, h, triangles);
        inner[name] = uvec4(named[0], named[1], triangles, 0u);
        const uint b = boxIndex(name);
        boxes[2u * b] = vec4(l, uintBitsToFloat(triangles));
        boxes[2u * b + 1u] = vec4(h, 0.0f);
        costs[name] = best[s];
    }
}

void climb() {
    vec3 sceneLo, sceneHi;
    for (uint a = 0u; a < 3u; ++a) {
        sceneLo[a] = lbvhFromOrderedBits(state[kLbvhStateBoxLo + a]);
        sceneHi[a] = lbvhFromOrderedBits(state[kLbvhStateBoxHi + a]);
    }
    const float unit = plocAreaUnit(sceneLo, sceneHi);
    const uint chunks = (n() + kTreeletGroupSize - 1u) / kTreeletGroupSize;
    for (uint chunk = gl_WorkGroupID.x; chunk < chunks; chunk += gl_NumWorkGroups.x) {
        const uint k = chunk * kTreeletGroupSize + gl_LocalInvocationIndex;
        bool climbing = k < n();
        uint node = n() - 1u + k;
        while (groupBallot(climbing) != 0u) {
            if (!climbing) continue;
            const uint parent = parentOf(node);
            memoryBarrierBuffer();  // this node's record, box and cost, before the arrival
            if (atomicAdd(arrivals[parent], 1u) == 0u) {
                climbing = false;  // the sibling's climb goes on
            } else {
                memoryBarrierBuffer();  // the sibling's, after it
                restructure(parent, unit);
                node = parent;
                climbing = parent != 0u;
            }
        }
    }
}

void main() {
    if (kPhase == kLbvhPhaseTreeletParents)
        listParents();
    else
        climb();
}
