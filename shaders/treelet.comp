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
// As Karras and Aila's, a treelet is rebuilt by a whole workgroup of 32 together (one warp on NVIDIA):
// each turn of the climb, which the whole workgroup runs one step a turn, gathers the treelet roots
// its invocations reached, and the workgroup rebuilds them one after another, every subset's box and
// then every split of each subset size spread over the invocations, in shared memory. A node below
// gamma triangles only has its S updated, by the invocation that reached it. The arrival count's
// atomic is behind an if, as in hploc.comp: lavapipe (Mesa 22.3) miscounted atomics of a subgroup
// whose other invocations had left their loop.
//
// What a round rewrites: the records of the treelets' inner nodes (children, triangle count, as
// ploc.comp and hploc.comp make them), their boxes by cluster id, and their costs. Parents are listed
// again before each round (cluster_layout.comp's kLbvhPhaseClusterParents); the layout then works
// from the root, record 0, which keeps its record.
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require

#include "gpu_types.h"
#include "lbvh.h"

layout(local_size_x = kTreeletGroupSize) in;
layout(push_constant) uniform Params { LbvhParams params; };

// Records and boxes as shaders/cluster_tree.h names them.
layout(std430, set = 0, binding = kLbvhBindInner) coherent buffer Inner { uvec4 inner[]; };
layout(std430, set = 0, binding = kLbvhBindBoxes) coherent buffer Boxes { vec4 boxes[]; };
// S of every inner node by record, in the area units of plocAreaUnit.
layout(std430, set = 0, binding = kLbvhBindCosts) coherent buffer Costs { float costs[]; };
// The parent record of every inner node (by record) and of every sorted triangle
// (cluster_layout.comp's kLbvhPhaseClusterParents).
layout(std430, set = 0, binding = kLbvhBindScan) readonly buffer InnerParents { uint innerParents[]; };
layout(std430, set = 0, binding = kLbvhBindKeysA) readonly buffer LeafParents { uint leafParents[]; };
// How many of each inner node's children have climbed to it (the second goes on).
layout(std430, set = 0, binding = kLbvhBindValuesB) coherent buffer Arrivals { uint arrivals[]; };
layout(std430, set = 0, binding = kLbvhBindState) readonly buffer State { uint state[]; };

#include "cluster_tree.h"

// S of a node of `count` triangles and half area `area` whose children's S sum to `split`.
float nodeCost(float area, uint count, float split) {
    const float leaf = area * float(count) * params.costs.y;
    if (count <= params.counts.y) return leaf;
    const float inner = area * params.costs.x + split;
    return count <= kLbvhMaxLeafPrimitives ? min(leaf, inner) : inner;
}

#include "workgroup_ballot.h"

const uint kSubsets = 1u << kTreeletLeaves;
const float kNoCost = 3.402823466e38f;

// Subsets of the kTreeletLeaves leaves ordered by size (bySize[sizeStart[k]...] those of k leaves,
// in increasing order), filled once per workgroup.
shared uint bySize[kSubsets - 1u];
shared uint sizeStart[kTreeletLeaves + 2u];

// The treelet the workgroup rebuilds together: its leaves (names, boxes, triangle counts, S), the inner
// nodes whose records it reuses (the root first), and per subset of its leaves the half area and
// triangle count of their union, the least S of a subtree over them and that subtree's left child.
shared uint leafName[kTreeletLeaves], madeName[kTreeletLeaves - 1u], treeletLeaves;
shared vec3 leafLo[kTreeletLeaves], leafHi[kTreeletLeaves];
shared uint leafCount[kTreeletLeaves];
shared float leafCost[kTreeletLeaves];
shared float subsetArea[kSubsets], best[kSubsets];
shared uint subsetTriangles[kSubsets], part[kSubsets];
// One size's splits: lowest | q (q a proper subset of the rest) of every subset of that size.
shared float splitCost[kTreeletMostSplits];

// The treelets whose roots this turn's climbs reached.
shared uint readyCount, readyRoot[kTreeletGroupSize];

// The box and triangle count of the leaves in subset s.
void subsetBounds(uint s, uint leaves, out vec3 l, out vec3 h, out uint triangles) {
    l = vec3(kNoCost);
    h = vec3(-kNoCost);
    triangles = 0u;
    for (uint i = 0u; i < leaves; ++i) {
        if (((s >> i) & 1u) == 0u) continue;
        l = min(l, leafLo[i]);
        h = max(h, leafHi[i]);
        triangles += leafCount[i];
    }
}

// The subset of `mask` whose members are chosen by the bits of i, lowest member by lowest bit.
uint deposit(uint i, uint mask) {
    uint q = 0u;
    for (; mask != 0u; mask &= mask - 1u, i >>= 1u)
        if ((i & 1u) != 0u) q |= mask & (0u - mask);
    return q;
}

void orderSubsetsBySize() {
    for (uint s = gl_LocalInvocationIndex + 1u; s < kSubsets; s += kTreeletGroupSize) {
        const uint size = bitCount(s);
        uint position = 0u;
        for (uint t = 1u; t < kSubsets; ++t) {
            const uint other = bitCount(t);
            if (other < size || (other == size && t < s)) ++position;
        }
        bySize[position] = s;
    }
    if (gl_LocalInvocationIndex <= kTreeletLeaves + 1u) {
        uint smaller = 0u;
        for (uint t = 1u; t < kSubsets; ++t)
            if (bitCount(t) < gl_LocalInvocationIndex) ++smaller;
        sizeStart[gl_LocalInvocationIndex] = smaller;
    }
    if (gl_LocalInvocationIndex == 0u) readyCount = 0u;
    barrier();
}

float nameArea(uint name, float unit) {
    const uint b = boxIndex(name);
    return isTriangle(name) ? -1.0f : plocArea(boxes[2u * b].xyz, boxes[2u * b + 1u].xyz, unit);
}

// One invocation: the treelet below `root`, its two children and then repeatedly its leaf of the
// largest area (triangles are never opened) opened into its two children.
void gatherTreelet(uint root, float unit) {
    uint name[kTreeletLeaves];
    float area[kTreeletLeaves];
    const uvec4 record = inner[root];
    name[0] = record.x;
    name[1] = record.y;
    area[0] = nameArea(name[0], unit);
    area[1] = nameArea(name[1], unit);
    madeName[0] = root;
    uint leaves = 2u;
    while (leaves < kTreeletLeaves) {
        uint open = kTreeletLeaves;
        float largest = -1.0f;
        for (uint i = 0u; i < leaves; ++i) {
            if (area[i] > largest) {
                largest = area[i];
                open = i;
            }
        }
        if (open == kTreeletLeaves) break;
        const uvec4 opened = inner[name[open]];
        madeName[leaves - 1u] = name[open];
        name[open] = opened.x;
        name[leaves] = opened.y;
        area[open] = nameArea(opened.x, unit);
        area[leaves] = nameArea(opened.y, unit);
        ++leaves;
    }
    for (uint i = 0u; i < leaves; ++i) leafName[i] = name[i];
    treeletLeaves = leaves;
}

// One invocation: the treelet's inner nodes again, top down, from the root's record and then the
// opened ones, by the subsets' best splits.
void rewriteTreelet(uint root, uint leaves) {
    const uint all = (1u << leaves) - 1u;
    uint stackSubset[kTreeletLeaves], stackName[kTreeletLeaves];
    uint depth = 1u, next = 1u;
    stackSubset[0] = all;
    stackName[0] = root;
    while (depth > 0u) {
        --depth;
        const uint s = stackSubset[depth], name = stackName[depth];
        const uint children[2] = {part[s], s ^ part[s]};
        uint named[2];
        for (uint c = 0u; c < 2u; ++c) {
            if (bitCount(children[c]) == 1u) {
                named[c] = leafName[findLSB(children[c])];
            } else {
                named[c] = madeName[next++];
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
    memoryBarrierBuffer();  // before the climb that goes on from the root arrives above it
}


// The whole workgroup: rebuilds the treelet below inner node `root` (of at least gamma triangles).
void restructure(uint root, float unit) {
    const uint lane = gl_LocalInvocationIndex;
    if (lane == 0u) gatherTreelet(root, unit);
    barrier();
    const uint leaves = treeletLeaves, all = (1u << leaves) - 1u;
    if (lane < leaves) {
        const uint name = leafName[lane], b = boxIndex(name);
        leafLo[lane] = boxes[2u * b].xyz;
        leafHi[lane] = boxes[2u * b + 1u].xyz;
        if (isTriangle(name)) {
            leafCount[lane] = 1u;
            leafCost[lane] = plocArea(leafLo[lane], leafHi[lane], unit) * params.costs.y;
        } else {
            leafCount[lane] = inner[name].z;
            leafCost[lane] = costs[name];
        }
    }
    barrier();
    for (uint s = lane + 1u; s <= all; s += kTreeletGroupSize) {
        vec3 l, h;
        uint triangles;
        subsetBounds(s, leaves, l, h, triangles);
        subsetArea[s] = plocArea(l, h, unit);
        subsetTriangles[s] = triangles;
        if (bitCount(s) == 1u) best[s] = leafCost[findLSB(s)];
    }
    barrier();
    // best[s] by increasing size, every split of every subset of one size at once: a split's parts
    // are smaller. Each subset's split is the lowest | q of least cost, the larger q on ties, which is
    // the same on every device.
    for (uint size = 2u; size <= leaves; ++size) {
        const uint first = sizeStart[size], subsets = sizeStart[size + 1u] - first;
        const uint splits = (1u << (size - 1u)) - 1u;
        for (uint j = lane; j < subsets * splits; j += kTreeletGroupSize) {
            const uint s = bySize[first + j / splits];
            if ((s & ~all) != 0u) continue;
            const uint lowest = s & (0u - s), p = lowest | deposit(j % splits, s ^ lowest);
            splitCost[j] = best[p] + best[s ^ p];
        }
        barrier();
        for (uint u = lane; u < subsets; u += kTreeletGroupSize) {
            const uint s = bySize[first + u];
            if ((s & ~all) != 0u) continue;
            float split = kNoCost;
            uint chosen = 0u;
            for (uint i = splits; i-- > 0u;) {
                const float c = splitCost[u * splits + i];
                if (c < split) {
                    split = c;
                    chosen = i;
                }
            }
            const uint lowest = s & (0u - s);
            best[s] = nodeCost(subsetArea[s], subsetTriangles[s], split);
            part[s] = lowest | deposit(chosen, s ^ lowest);
        }
        barrier();
    }
    if (lane == 0u) rewriteTreelet(root, leaves);
}

// One invocation: S of inner node `node` below gamma triangles, from its children's.
void updateCost(uint node, uvec4 record, float unit) {
    vec3 l = vec3(kNoCost), h = vec3(-kNoCost);
    float split = 0.0f;
    for (uint c = 0u; c < 2u; ++c) {
        const uint child = record[c], b = boxIndex(child);
        const vec3 cl = boxes[2u * b].xyz, ch = boxes[2u * b + 1u].xyz;
        l = min(l, cl);
        h = max(h, ch);
        split += isTriangle(child) ? plocArea(cl, ch, unit) * params.costs.y : costs[child];
    }
    costs[node] = nodeCost(plocArea(l, h, unit), record.z, split);
}

void climb() {
    const float unit = sceneAreaUnit();
    orderSubsetsBySize();
    const uint chunks = (n() + kTreeletGroupSize - 1u) / kTreeletGroupSize;
    for (uint chunk = gl_WorkGroupID.x; chunk < chunks; chunk += gl_NumWorkGroups.x) {
        const uint k = chunk * kTreeletGroupSize + gl_LocalInvocationIndex;
        bool climbing = k < n();
        uint node = n() - 1u + k;
        while (groupBallot(climbing) != 0u) {
            if (climbing) {
                const uint parent = parentOf(node);
                memoryBarrierBuffer();  // this node's record, box and cost, before the arrival
                if (atomicAdd(arrivals[parent], 1u) == 0u) {
                    climbing = false;  // the sibling's climb goes on
                } else {
                    memoryBarrierBuffer();  // the sibling's, after it
                    node = parent;
                    climbing = parent != 0u;
                    const uvec4 record = inner[parent];
                    if (record.z >= params.counts.z)
                        readyRoot[atomicAdd(readyCount, 1u)] = parent;
                    else
                        updateCost(parent, record, unit);
                }
            }
            barrier();
            const uint ready = readyCount;
            for (uint t = 0u; t < ready; ++t) {
                restructure(readyRoot[t], unit);
                barrier();
            }
            if (gl_LocalInvocationIndex == 0u) readyCount = 0u;
        }
    }
}

void main() { climb(); }
