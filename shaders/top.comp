#version 460
// The top of a clustered tree (gpu-ploc, gpu-hploc; shaders/lbvh.h) rebuilt top down by the binned
// SAH (Wald 2007) over the subtrees below it. The clustering merges within Morton order, so its top
// splits follow the Morton curve's bits more than the surface areas, and every ray crosses the top:
// a tree whose SAH cost is within a tenth of sah-exact's traced a 13M-triangle scan at 0.72 of its
// speed, and treelet rounds at the top alone recovered most of it. The top is every inner node of at
// least G triangles (counts.z); the items are its children below G, whole subtrees (or triangles)
// kept as they are. A full binary tree over c items has c - 1 inner nodes, as many as the old top
// had, so the new nodes take the old top's records (the root record 0, which the layout starts
// from), and nothing else of the tree changes.
//
// kLbvhPhaseTopStart, one workgroup:
//   1. The old top listed breadth first from the root, a level at a time: its records in that order
//      (the new nodes take them in the order they are made) and the items in the order they are
//      met. The order is the tree's, so the new tree is the same on every run.
//   2. Splitting, in turns. Each turn every team of kTopTeam invocations takes the next node waiting
//      (a range of items) and splits it: the items' centroid bounds; kTopTeam bins per axis, each
//      invocation the bin of its own index (it reads every item, so no atomics are needed, which
//      lavapipe miscounts in loops that differ between subgroups; a node of more than kTopSample
//      items bins an even sample of them, a node of at most kTopTeam is swept exactly, its items by
//      rank); every boundary's SAH cost, the items on each side times its box's area (the items'
//      own costs are fixed: what the split changes is the areas of the inner nodes still to make
//      over each side, one fewer than its items; weighting by triangles gave costlier trees on
//      every scene tried, docs/bvh.md); the least, lower axis and boundary first on ties; and a stable
//      partition into the other items array. A node whose centroids all coincide, or whose best
//      boundary's partition leaves a side empty, is split at its middle item. Children of one item
//      are that item; larger ones wait for a later turn. The start stops once kTopFrontier nodes
//      wait (or none does).
// kLbvhPhaseTopFinish, a workgroup per node the start left: that node's subtree, by the same turns.
// Its nodes' places follow from the sizes of the nodes before it, so no counter is shared.
//
// What it writes: the new nodes' records (children, triangle count) and boxes by cluster id, as
// ploc.comp and hploc.comp make them. S, the collapse and the parents are the layout's (and the
// treelet rounds', which may follow) to compute. Scratch it borrows, all rewritten by what follows
// (cluster_layout.comp's parent listing first): the old top's records in kLbvhBindScan, the two
// items arrays in kLbvhBindKeysB and kLbvhBindValuesB, and per node made its items' range in
// kLbvhBindKeysA (first item, bit 31: which items array) and kLbvhBindCosts (end).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require

#include "gpu_types.h"
#include "lbvh.h"

layout(local_size_x = kTopGroupSize) in;
layout(constant_id = kLbvhSpecPhase) const uint kPhase = kLbvhPhaseTopStart;
layout(push_constant) uniform Params { LbvhParams params; };

layout(std430, set = 0, binding = kLbvhBindInner) coherent buffer Inner { uvec4 inner[]; };
layout(std430, set = 0, binding = kLbvhBindBoxes) coherent buffer Boxes { vec4 boxes[]; };
layout(std430, set = 0, binding = kLbvhBindScan) coherent buffer TopRecords { uint topRecords[]; };
layout(std430, set = 0, binding = kLbvhBindKeysB) coherent buffer ItemsA { uint itemsA[]; };
layout(std430, set = 0, binding = kLbvhBindValuesB) coherent buffer ItemsB { uint itemsB[]; };
layout(std430, set = 0, binding = kLbvhBindKeysA) coherent buffer RangeFirst { uint rangeFirst[]; };
layout(std430, set = 0, binding = kLbvhBindCosts) coherent buffer RangeEnd { uint rangeEnd[]; };
layout(std430, set = 0, binding = kLbvhBindState) coherent buffer State { uint state[]; };
layout(std430, set = 0, binding = kLbvhBindIndirect) writeonly buffer Indirect { uvec4 indirect[]; };

#define RAYPACK_CLUSTER_TREE_NO_PARENTS
#include "cluster_tree.h"

const float kHuge = 3.402823466e38f;
const uint kNone = 0xFFFFFFFFu;
const uint kFromB = 0x80000000u;

uint lane() { return gl_LocalInvocationIndex % kTopTeam; }
uint team() { return gl_LocalInvocationIndex / kTopTeam; }

// ---- The workgroup's exclusive prefix sum (Hillis and Steele, two arrays in turn).

shared uint sumsA[kTopGroupSize], sumsB[kTopGroupSize];

uint groupExclusiveSum(uint value, out uint total) {
    const uint i = gl_LocalInvocationIndex;
    sumsA[i] = value;
    barrier();
    bool inA = true;
    for (uint d = 1u; d < kTopGroupSize; d <<= 1u) {
        if (inA)
            sumsB[i] = sumsA[i] + (i >= d ? sumsA[i - d] : 0u);
        else
            sumsA[i] = sumsB[i] + (i >= d ? sumsB[i - d] : 0u);
        inA = !inA;
        barrier();
    }
    const uint inclusive = inA ? sumsA[i] : sumsB[i];
    total = inA ? sumsA[kTopGroupSize - 1u] : sumsB[kTopGroupSize - 1u];
    barrier();
    return inclusive - value;
}

// ---- Step 1: the old top and its items.

shared uint listedTop, listedItems;

void listTop() {
    const uint gamma = params.counts.z;
    if (gl_LocalInvocationIndex == 0u) {
        topRecords[0] = 0u;
        listedTop = 1u;
        listedItems = 0u;
    }
    memoryBarrierBuffer();
    barrier();
    uint levelBegin = 0u, levelEnd = 1u;
    while (levelBegin < levelEnd) {
        for (uint base = levelBegin; base < levelEnd; base += kTopGroupSize) {
            const uint i = base + gl_LocalInvocationIndex;
            uvec2 children = uvec2(0u);
            uint tops = 0u, items = 0u;  // bit c: child c is in the top, or an item
            if (i < levelEnd) {
                children = inner[topRecords[i]].xy;
                for (uint c = 0u; c < 2u; ++c) {
                    if (countOf(children[c]) >= gamma)
                        tops |= 1u << c;
                    else
                        items |= 1u << c;
                }
            }
            uint total;
            const uint before = groupExclusiveSum(bitCount(tops) | (bitCount(items) << 16u), total);
            uint top = listedTop + (before & 0xFFFFu), item = listedItems + (before >> 16u);
            for (uint c = 0u; c < 2u; ++c) {
                if (((tops >> c) & 1u) != 0u) topRecords[top++] = children[c];
                if (((items >> c) & 1u) != 0u) itemsA[item++] = children[c];
            }
            memoryBarrierBuffer();
            barrier();
            if (gl_LocalInvocationIndex == 0u) {
                listedTop += total & 0xFFFFu;
                listedItems += total >> 16u;
            }
            barrier();
        }
        levelBegin = levelEnd;
        levelEnd = listedTop;
    }
}

// ---- Step 2: the splitting turns.

float unit;                   // areas in the scene's units (lbvh.h plocAreaUnit)
uint rootPosition, restBase;  // where this workgroup's nodes go: its first, then the others in order

// Where the workgroup's k-th node (0: the one it starts from) keeps its range and finds its record.
uint positionOf(uint k) { return k == 0u ? rootPosition : restBase + k - 1u; }

uint itemAt(uint fromB, uint i) { return fromB != 0u ? itemsB[i] : itemsA[i]; }
void putItem(uint toB, uint i, uint name) {
    if (toB != 0u)
        itemsB[i] = name;
    else
        itemsA[i] = name;
}
void boxOf(uint name, out vec3 lo, out vec3 hi) {
    const uint b = boxIndex(name);
    lo = boxes[2u * b].xyz;
    hi = boxes[2u * b + 1u].xyz;
}
// precise: the partition decides an item's side again where the bins did, bit for bit.
vec3 centroidOf(vec3 lo, vec3 hi) {
    precise const vec3 c = 0.5f * lo + 0.5f * hi;
    return c;
}

// Items are read kBatch at a time, their names and then their boxes, so that a lane waits for one
// batch's loads rather than for each item's two in turn.
const uint kBatch = 8u;
void loadBatch(uint fromB, uint first, uint step, uint end, out uint names[kBatch], out vec3 los[kBatch],
               out vec3 his[kBatch]) {
    [[unroll]] for (uint k = 0u; k < kBatch; ++k) {
        const uint i = first + k * step;
        names[k] = i < end ? itemAt(fromB, i) : kNone;
    }
    [[unroll]] for (uint k = 0u; k < kBatch; ++k) {
        los[k] = vec3(0.0f);
        his[k] = vec3(0.0f);
        if (names[k] != kNone) boxOf(names[k], los[k], his[k]);
    }
}

shared uint queueHead, queueTail;  // the workgroup's nodes: split before head, waiting up to tail
// Per team: the lanes' centroid bounds, boxes and triangles (13 words a lane), then one axis's bins
// (box and items, 7 words a lane).
shared float teamWords[kTopTeams][kTopTeam * 13u];
shared float candidateCost[kTopGroupSize];
shared uint candidateCode[kTopGroupSize], laneLefts[kTopGroupSize], teamMade[kTopTeams];

// Bin of centroid coordinate c on an axis of bounds from lo, scale bins per half extent.
uint binOf(float c, float lo, float scale) {
    precise const float at = (0.5f * c - 0.5f * lo) * scale;
    return uint(min(float(kTopTeam - 1u), max(0.0f, at)));
}

// Whether the item of box lo, hi goes left of `boundary` on `axis` by its bin. (A node swept
// exactly goes by its items' ranks instead, which only the lane holding the item knows.)
bool goesLeft(vec3 lo, vec3 hi, uint axis, uint boundary, vec3 cLo, vec3 scale) {
    return binOf(centroidOf(lo, hi)[axis], cLo[axis], scale[axis]) <= boundary;
}

void turns(bool start) {
    while (true) {
        const uint head = queueHead, tail = queueTail;
        if (head >= tail || (start && tail - head >= kTopFrontier)) break;
        const uint t = team(), l = lane(), entry = head + t;
        const bool taking = entry < tail;
        uint position = 0u, begin = 0u, end = 0u, fromB = 0u;
        if (taking) {
            position = positionOf(entry);
            const uint first = rangeFirst[position];
            begin = first & ~kFromB;
            fromB = first >> 31u;
            end = rangeEnd[position];
        }

        // The node's centroid bounds, box and triangles.
        vec3 cLo = vec3(kHuge), cHi = vec3(-kHuge), lo = vec3(kHuge), hi = vec3(-kHuge);
        uint triangles = 0u;
        for (uint first = begin + l; first < end; first += kBatch * kTopTeam) {
            uint names[kBatch];
            vec3 bl[kBatch], bh[kBatch];
            loadBatch(fromB, first, kTopTeam, end, names, bl, bh);
            [[unroll]] for (uint k = 0u; k < kBatch; ++k) {
                if (names[k] == kNone) continue;
                const vec3 c = centroidOf(bl[k], bh[k]);
                cLo = min(cLo, c);
                cHi = max(cHi, c);
                lo = min(lo, bl[k]);
                hi = max(hi, bh[k]);
                triangles += countOf(names[k]);
            }
        }
        for (uint a = 0u; a < 3u; ++a) {
            teamWords[t][13u * l + a] = cLo[a];
            teamWords[t][13u * l + 3u + a] = cHi[a];
            teamWords[t][13u * l + 6u + a] = lo[a];
            teamWords[t][13u * l + 9u + a] = hi[a];
        }
        teamWords[t][13u * l + 12u] = uintBitsToFloat(triangles);
        barrier();
        triangles = 0u;
        for (uint j = 0u; j < kTopTeam; ++j) {
            for (uint a = 0u; a < 3u; ++a) {
                cLo[a] = min(cLo[a], teamWords[t][13u * j + a]);
                cHi[a] = max(cHi[a], teamWords[t][13u * j + 3u + a]);
                lo[a] = min(lo[a], teamWords[t][13u * j + 6u + a]);
                hi[a] = max(hi[a], teamWords[t][13u * j + 9u + a]);
            }
            triangles += floatBitsToUint(teamWords[t][13u * j + 12u]);
        }
        barrier();

        // Every lane's bin on each axis; an axis whose centroids coincide (or whose extent is too
        // small for its scale to be finite) has none.
        vec3 scale;
        bool usable[3];
        for (uint a = 0u; a < 3u; ++a) {
            const float extent = 0.5f * cHi[a] - 0.5f * cLo[a];
            scale[a] = extent > 0.0f ? float(kTopTeam) / extent : 0.0f;
            usable[a] = extent > 0.0f && !isinf(scale[a]);
        }
        vec3 binLo[3], binHi[3];
        uint binItems[3];
        for (uint a = 0u; a < 3u; ++a) {
            binLo[a] = vec3(kHuge);
            binHi[a] = vec3(-kHuge);
            binItems[a] = 0u;
        }
        // A node of at most kTopTeam items is swept exactly: on each axis the item of rank k by
        // centroid (ties by position) is bin k, and lanes without an item keep their bin empty.
        const bool exact = end - begin <= kTopTeam;
        uint rank[3] = uint[3](l, l, l);
        if (exact) {
            for (uint a = 0u; a < 3u; ++a) usable[a] = true;
            if (begin + l < end) {
                const uint name = itemAt(fromB, begin + l);
                vec3 bl, bh;
                boxOf(name, bl, bh);
                const vec3 c = centroidOf(bl, bh);
                for (uint a = 0u; a < 3u; ++a) {
                    rank[a] = 0u;
                    binLo[a] = bl;
                    binHi[a] = bh;
                    binItems[a] = 1u;
                }
                for (uint j = begin; j < end; ++j) {
                    vec3 ol, oh;
                    boxOf(itemAt(fromB, j), ol, oh);
                    const vec3 o = centroidOf(ol, oh);
                    for (uint a = 0u; a < 3u; ++a)
                        if (o[a] < c[a] || (o[a] == c[a] && j < begin + l)) ++rank[a];
                }
            }
        } else {
            // A node of more than kTopSample items is binned from every stride-th: the bins only
            // choose the boundary, and the partition counts what it makes.
            const uint stride = (end - begin + kTopSample - 1u) / kTopSample;
            for (uint first = begin; first < end; first += kBatch * stride) {
                uint names[kBatch];
                vec3 bl[kBatch], bh[kBatch];
                loadBatch(fromB, first, stride, end, names, bl, bh);
                [[unroll]] for (uint k = 0u; k < kBatch; ++k) {
                    if (names[k] == kNone) continue;
                    const vec3 c = centroidOf(bl[k], bh[k]);
                    for (uint a = 0u; a < 3u; ++a) {
                        if (!usable[a] || binOf(c[a], cLo[a], scale[a]) != l) continue;
                        binLo[a] = min(binLo[a], bl[k]);
                        binHi[a] = max(binHi[a], bh[k]);
                        ++binItems[a];
                    }
                }
            }
        }

        // Each lane prices the boundary after its bin on each axis and keeps its cheapest.
        float bestCost = kHuge;
        uint bestCode = kNone;
        for (uint a = 0u; a < 3u; ++a) {
            const uint slot = exact ? rank[a] : l;
            for (uint k = 0u; k < 3u; ++k) {
                teamWords[t][8u * slot + k] = binLo[a][k];
                teamWords[t][8u * slot + 3u + k] = binHi[a][k];
            }
            teamWords[t][8u * slot + 6u] = uintBitsToFloat(binItems[a]);
            barrier();
            if (taking && usable[a] && l + 1u < kTopTeam) {
                vec3 leftLo = vec3(kHuge), leftHi = vec3(-kHuge), rightLo = vec3(kHuge), rightHi = vec3(-kHuge);
                uint leftItems = 0u, rightItems = 0u;
                for (uint j = 0u; j < kTopTeam; ++j) {
                    const vec3 jl = vec3(teamWords[t][8u * j], teamWords[t][8u * j + 1u], teamWords[t][8u * j + 2u]);
                    const vec3 jh =
                        vec3(teamWords[t][8u * j + 3u], teamWords[t][8u * j + 4u], teamWords[t][8u * j + 5u]);
                    const uint items = floatBitsToUint(teamWords[t][8u * j + 6u]);
                    if (j <= l) {
                        leftLo = min(leftLo, jl);
                        leftHi = max(leftHi, jh);
                        leftItems += items;
                    } else {
                        rightLo = min(rightLo, jl);
                        rightHi = max(rightHi, jh);
                        rightItems += items;
                    }
                }
                if (leftItems > 0u && rightItems > 0u) {
                    const float cost = plocArea(leftLo, leftHi, unit) * float(leftItems) +
                                       plocArea(rightLo, rightHi, unit) * float(rightItems);
                    if (cost < bestCost) {
                        bestCost = cost;
                        bestCode = a * kTopTeam + l;
                    }
                }
            }
            barrier();
        }
        candidateCost[gl_LocalInvocationIndex] = bestCost;
        candidateCode[gl_LocalInvocationIndex] = bestCode;
        barrier();
        float chosenCost = kHuge;
        uint chosen = kNone;
        for (uint j = 0u; j < kTopTeam; ++j) {
            const float cost = candidateCost[t * kTopTeam + j];
            const uint code = candidateCode[t * kTopTeam + j];
            if (cost < chosenCost || (cost == chosenCost && code < chosen)) {
                chosenCost = cost;
                chosen = code;
            }
        }

        // The stable partition: each lane a run of the range, its lefts counted, then placed.
        const uint axis = chosen == kNone ? 0u : chosen / kTopTeam, boundary = chosen % kTopTeam;
        const uint count = end - begin, run = (count + kTopTeam - 1u) / kTopTeam;
        const uint runBegin = min(end, begin + l * run), runEnd = min(end, runBegin + run);
        uint lefts = 0u;
        if (chosen != kNone) {
            if (exact) {
                if (runBegin < runEnd && rank[axis] <= boundary) ++lefts;
            } else {
                for (uint first = runBegin; first < runEnd; first += kBatch) {
                    uint names[kBatch];
                    vec3 bl[kBatch], bh[kBatch];
                    loadBatch(fromB, first, 1u, runEnd, names, bl, bh);
                    [[unroll]] for (uint k = 0u; k < kBatch; ++k)
                        if (names[k] != kNone && goesLeft(bl[k], bh[k], axis, boundary, cLo, scale)) ++lefts;
                }
            }
        }
        laneLefts[gl_LocalInvocationIndex] = lefts;
        barrier();
        uint leftCount = 0u, leftBefore = 0u;
        for (uint j = 0u; j < kTopTeam; ++j) {
            const uint v = laneLefts[t * kTopTeam + j];
            leftCount += v;
            if (j < l) leftBefore += v;
        }
        const bool byPosition = chosen == kNone || leftCount == 0u || leftCount == count;
        if (byPosition) {
            leftCount = count / 2u;
            leftBefore = min(runBegin - begin, leftCount);
        }
        const uint toB = 1u - fromB;
        if (taking) {
            uint lefts = begin + leftBefore, rights = begin + leftCount + (runBegin - begin - leftBefore);
            for (uint first = runBegin; first < runEnd; first += kBatch) {
                uint names[kBatch];
                vec3 bl[kBatch], bh[kBatch];
                loadBatch(fromB, first, 1u, runEnd, names, bl, bh);
                [[unroll]] for (uint k = 0u; k < kBatch; ++k) {
                    if (names[k] == kNone) continue;
                    const bool left = byPosition ? first + k - begin < leftCount
                                      : exact    ? rank[axis] <= boundary
                                                 : goesLeft(bl[k], bh[k], axis, boundary, cLo, scale);
                    putItem(toB, left ? lefts++ : rights++, names[k]);
                }
            }
        }
        memoryBarrierBuffer();
        barrier();

        // The children: an item where one is left, else a node that waits; the node's record.
        const uint rightCount = count - leftCount;
        if (l == 0u) teamMade[t] = taking ? uint(leftCount >= 2u) + uint(rightCount >= 2u) : 0u;
        barrier();
        uint madeBefore = 0u, made = 0u;
        for (uint j = 0u; j < kTopTeams; ++j) {
            if (j < t) madeBefore += teamMade[j];
            made += teamMade[j];
        }
        if (taking && l == 0u) {
            const uint leftNode = tail + madeBefore, rightNode = leftNode + uint(leftCount >= 2u);
            uint names[2];
            names[0] = leftCount == 1u ? itemAt(toB, begin) : topRecords[positionOf(leftNode)];
            names[1] = rightCount == 1u ? itemAt(toB, begin + leftCount) : topRecords[positionOf(rightNode)];
            if (leftCount >= 2u) {
                rangeFirst[positionOf(leftNode)] = begin | (toB << 31u);
                rangeEnd[positionOf(leftNode)] = begin + leftCount;
            }
            if (rightCount >= 2u) {
                rangeFirst[positionOf(rightNode)] = (begin + leftCount) | (toB << 31u);
                rangeEnd[positionOf(rightNode)] = end;
            }
            const uint record = topRecords[position], b = boxIndex(record);
            inner[record] = uvec4(names[0], names[1], triangles, 0u);
            boxes[2u * b] = vec4(lo, uintBitsToFloat(triangles));
            boxes[2u * b + 1u] = vec4(hi, 0.0f);
        }
        memoryBarrierBuffer();
        barrier();
        if (gl_LocalInvocationIndex == 0u) {
            queueHead = min(tail, head + kTopTeams);
            queueTail = tail + made;
        }
        barrier();
    }
}

void startTop() {
    listTop();
    if (gl_LocalInvocationIndex == 0u) {
        rangeFirst[0] = 0u;
        rangeEnd[0] = listedItems;
        queueHead = 0u;
        queueTail = 1u;
    }
    memoryBarrierBuffer();
    barrier();
    rootPosition = 0u;
    restBase = 1u;
    turns(true);
    if (gl_LocalInvocationIndex == 0u) {
        state[kLbvhStateTopHead] = queueHead;
        state[kLbvhStateTopTail] = queueTail;
        state[kLbvhStateTopItems] = listedItems;
        indirect[0] = uvec4(queueTail - queueHead, 1u, 1u, 0u);
    }
}

// Workgroup w finishes the start's waiting node head + w; the nodes below it go after the start's
// and after those of the waiting nodes before it (a node of s items makes s - 2 below its first).
void finishTop() {
    const uint head = state[kLbvhStateTopHead], tail = state[kLbvhStateTopTail], w = gl_WorkGroupID.x;
    uint below = 0u;
    for (uint v = gl_LocalInvocationIndex; v < w; v += kTopGroupSize)
        below += rangeEnd[head + v] - (rangeFirst[head + v] & ~kFromB) - 2u;
    uint before;
    groupExclusiveSum(below, before);
    rootPosition = head + w;
    restBase = tail + before;
    if (gl_LocalInvocationIndex == 0u) {
        queueHead = 0u;
        queueTail = 1u;
    }
    barrier();
    turns(false);
}

void main() {
    unit = sceneAreaUnit();
    if (kPhase == kLbvhPhaseTopStart)
        startTop();
    else
        finishTop();
}
