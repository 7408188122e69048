#version 460
// gpu-hploc (shaders/lbvh.h): Benthin, Meister, Barczak, Mehalwal, Tsakok and Kensler 2024, "H-PLOC:
// Hierarchical Parallel Locally-Ordered Clustering for Bounding Volume Hierarchy Construction", over
// the triangles sorted by Morton code: gpu-ploc's clustering in one dispatch instead of an iteration
// of several dispatches per merge round.
//
// Every invocation starts at one sorted triangle, the range [L, R] = [k, k], and climbs the implicit
// radix tree of the sorted codes bottom up (Apetrei 2014, "Fast and Simple Agglomerative LBVH
// Construction"): a range's parent splits it from its neighbour across whichever end has the longer
// common prefix, and the two children meet in the parent's slot (the split position) by an atomic
// exchange. The first to arrive leaves its end there and stops; the second takes it and goes on with
// the union. A range of at most kHplocThreshold triangles holds them as its clusters, in place, in
// the cluster array. Once a range grows past that (or is the whole scene), the workgroup loads both
// children's clusters (at most kHplocThreshold each, from the start of each child's part) into
// shared memory and runs PLOC there: nearest neighbours within kPlocRadius positions (the smallest
// union area, gpu-ploc's tie order), mutual pairs merged into new inner nodes, until exactly
// kHplocThreshold clusters are left (the last round's merges cut short; one at the root), written
// back from the range's start. Nothing waits for anything: an invocation whose sibling has not arrived stops, so no
// invocation depends on another's progress, and the cluster writes a sibling reads are released
// before the exchange that hands the range over and acquired after it.
//
// Lavapipe (Mesa 22.3) returned the same old value to two invocations of one subgroup that added to
// one counter while others of the subgroup were inactive (lbvh.h), and here it ran the exchange for
// invocations that had already left a loop each invocation climbed on its own (the clustering made
// twenty times the inner nodes). So the climb is a loop the whole workgroup runs, one step a turn,
// with the exchange behind an if, which lavapipe honours; two siblings in one subgroup exchanging
// one slot in one instruction, which happens all the time, gave whole trees in every test. New
// nodes' ids follow from their range (freePositions), with no counter; one invocation per workgroup
// adds what the workgroup made to a count the host checks.
//
// The output is gpu-ploc's: inner nodes in lbvh.comp's record format, numbered so that the root (the
// last one made) is record 0; then ploc.comp's levels, offsets and reorder, and lbvh.comp's gather,
// bottom-up and emission finish the tree.
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require

#include "gpu_types.h"
#include "lbvh.h"

layout(local_size_x = kHplocGroupSize) in;
layout(constant_id = kLbvhSpecPhase) const uint kPhase = kLbvhPhaseHplocInit;
// Positions searched on either side within a workgroup's clusters (BvhBuildOptions::plocRadius;
// 16 or more searches all of them).
layout(constant_id = kLbvhSpecPlocRadius) const uint kPlocRadius = 16u;
layout(push_constant) uniform Params { LbvhParams params; };

layout(std430, set = 0, binding = kLbvhBindKeysA) readonly buffer Codes { uint codes[]; };
// The cluster array: position k of a range holds one of its clusters' ids (kHplocEmpty past them).
layout(std430, set = 0, binding = kLbvhBindKeysB) coherent buffer Clusters { uint clusters[]; };
// Parent slots: slot s is the node splitting s | s + 1.
layout(std430, set = 0, binding = kLbvhBindScan) coherent buffer Parents { uint parents[]; };
layout(std430, set = 0, binding = kLbvhBindState) coherent buffer State { uint state[]; };
layout(std430, set = 0, binding = kLbvhBindInner) writeonly buffer Inner { uvec4 inner[]; };
// By cluster id: lo with the triangle count's bits in w, hi.
layout(std430, set = 0, binding = kLbvhBindBoxes) coherent buffer Boxes { vec4 boxes[]; };
// The scene as uploaded, and the sorted order (sorted triangle k is triangle order[k]).
layout(std430, set = 0, binding = kLbvhBindPositions) readonly buffer Positions { float positions[]; };
layout(std430, set = 0, binding = kLbvhBindIndices) readonly buffer Indices { uint indices[]; };
layout(std430, set = 0, binding = kLbvhBindValuesA) readonly buffer Order { uint order[]; };

// Cluster ids as ploc.comp's: sorted triangle k is id k, the j-th inner node made is id n + j, and
// inner node id p is record 2n - 2 - p.
uint n() { return params.counts.x; }
uint recordOf(uint id) { return 2u * n() - 2u - id; }
uint childName(uint id) { return id >= n() ? recordOf(id) : n() - 1u + id; }

vec3 position(uint v) { return vec3(positions[3u * v], positions[3u * v + 1u], positions[3u * v + 2u]); }

// Each sorted triangle's box straight from the scene's arrays (the leaf-order triangles are gathered
// once the tree's order is known).
void init() {
    const uint stride = gl_NumWorkGroups.x * kHplocGroupSize;
    for (uint k = gl_GlobalInvocationID.x; k < n(); k += stride) {
        const uint t = order[k];
        const vec3 a = position(indices[3u * t]), b = position(indices[3u * t + 1u]), c = position(indices[3u * t + 2u]);
        boxes[2u * k] = vec4(min(min(a, b), c), uintBitsToFloat(1u));
        boxes[2u * k + 1u] = vec4(max(max(a, b), c), 0.0f);
        clusters[k] = k;
    }
}

#include "workgroup_ballot.h"

uint below(uint mask) { return bitCount(mask & ((1u << gl_LocalInvocationIndex) - 1u)); }

// Length of the common prefix of the sorted codes at a and a + 1, extended by the positions where
// the codes are equal (so every key is distinct), as lbvh.comp's commonPrefix.
uint prefixAfter(uint a) {
    const uint x = codes[a] ^ codes[a + 1u];
    return x != 0u ? 31u - uint(findMSB(x)) : 63u - uint(findMSB(a ^ (a + 1u)));
}

// The clusters of the range being merged, compacted to the front.
shared uint windowId[kHplocGroupSize];
shared vec4 windowLo[kHplocGroupSize];  // w: the triangle count's bits
shared vec3 windowHi[kHplocGroupSize];
shared uint windowNearest[kHplocGroupSize];
shared uvec4 task;  // L, R, the right child's first position

// The ids of the inner nodes a range makes, without a counter shared by the workgroups. Every range
// of s > kHplocThreshold triangles ends with exactly kHplocThreshold clusters (the last round of
// merges is cut short to land there), so a subtree of s triangles has made s - kHplocThreshold inner
// nodes: the range [L, R] owns the inner positions [L, L + s - kHplocThreshold) (the root [0, n - 1)),
// its children own their parts of it from their own first positions, and what they leave free is at
// most two runs, [free.x, free.y) and [free.z, free.w). The root's last node takes position n - 2,
// the id 2n - 2: record 0. Positions are ids less n.
uvec4 freePositions(uint left, uint right, uint split) {
    const uint sizeLeft = split - left, sizeRight = right - split + 1u;
    const uint end = sizeLeft + sizeRight == n() ? n() - 1u : left + sizeLeft + sizeRight - kHplocThreshold;
    const uint first = left + (sizeLeft > kHplocThreshold ? sizeLeft - kHplocThreshold : 0u);
    const uint second = split + (sizeRight > kHplocThreshold ? sizeRight - kHplocThreshold : 0u);
    return uvec4(first, max(first, min(split, end)), second, max(second, end));
}
uint madeId(uvec4 free, uint k) {
    const uint firstRun = free.y - free.x;
    return n() + (k < firstRun ? free.x + k : free.z + k - firstRun);
}

// PLOC over the range [left, right] whose right child starts at `split`, by the whole workgroup;
// returns the inner nodes made.
uint mergeRange(uint left, uint right, uint split, float unit) {
    const uint lane = gl_LocalInvocationIndex;
    const uvec4 free = freePositions(left, right, split);
    uint made = 0u;
    const uint leftSlots = min(split - left, kHplocThreshold), rightSlots = min(right - split + 1u, kHplocThreshold);
    uint id = kHplocEmpty;
    if (lane < leftSlots)
        id = clusters[left + lane];
    else if (lane < leftSlots + rightSlots)
        id = clusters[split + lane - leftSlots];
    const uint loaded = groupBallot(id != kHplocEmpty);
    if (id != kHplocEmpty) {
        const uint at = below(loaded);
        windowId[at] = id;
        windowLo[at] = boxes[2u * id];
        windowHi[at] = boxes[2u * id + 1u].xyz;
    }
    barrier();
    uint count = bitCount(loaded);
    const bool root = right - left + 1u == n();
    const uint target = root ? 1u : kHplocThreshold;
    while (count > target) {
        if (lane < count) {
            const vec3 lo = windowLo[lane].xyz, hi = windowHi[lane];
            float best = 3.402823466e38f;
            uint nearest = lane;
            const uint first = lane >= kPlocRadius ? lane - kPlocRadius : 0u, last = min(count - 1u, lane + kPlocRadius);
            for (uint j = first; j <= last; ++j) {
                if (j == lane) continue;
                const float d = plocArea(min(lo, windowLo[j].xyz), max(hi, windowHi[j]), unit);
                if (d < best || (d == best && plocCloserTie(lane, j, nearest))) {
                    best = d;
                    nearest = j;
                }
            }
            windowNearest[lane] = nearest;
        }
        barrier();
        const uint nearest = lane < count ? windowNearest[lane] : lane;
        const bool mutual = nearest != lane && windowNearest[nearest] == lane;
        // The mutual pairs, by their lower position; the first count - target of them merge.
        const uint pairs = groupBallot(mutual && lane < nearest);
        const uint merges = min(bitCount(pairs), count - target);
        const uint lower = min(lane, nearest);
        const bool merged = mutual && bitCount(pairs & ((1u << lower) - 1u)) < merges;
        const bool makes = merged && lane < nearest, dropped = merged && lane > nearest;
        const bool keeps = lane < count && !dropped;
        uint keptId = 0u;
        vec4 keptLo = vec4(0.0f);
        vec3 keptHi = vec3(0.0f);
        if (keeps) {
            keptId = windowId[lane];
            keptLo = windowLo[lane];
            keptHi = windowHi[lane];
        }
        if (makes) {
            const uint other = windowId[nearest];
            const uint triangles = floatBitsToUint(keptLo.w) + floatBitsToUint(windowLo[nearest].w);
            const uint id = madeId(free, made + below(pairs));
            keptLo = vec4(min(keptLo.xyz, windowLo[nearest].xyz), uintBitsToFloat(triangles));
            keptHi = max(keptHi, windowHi[nearest]);
            boxes[2u * id] = keptLo;
            boxes[2u * id + 1u] = vec4(keptHi, 0.0f);
            inner[recordOf(id)] = uvec4(childName(keptId), childName(other), triangles, 0u);
            keptId = id;
        }
        // Every read of the window above happens before this ballot's barriers.
        const uint kept = groupBallot(keeps);
        if (keeps) {
            const uint at = below(kept);
            windowId[at] = keptId;
            windowLo[at] = keptLo;
            windowHi[at] = keptHi;
        }
        barrier();
        count = bitCount(kept);
        made += merges;
    }
    if (!root && lane < kHplocThreshold) clusters[left + lane] = lane < count ? windowId[lane] : kHplocEmpty;
    memoryBarrierBuffer();
    barrier();
    return made;
}

void build() {
    const uint lane = gl_LocalInvocationIndex;
    const uint count = n();
    vec3 sceneLo, sceneHi;
    for (uint a = 0u; a < 3u; ++a) {
        sceneLo[a] = lbvhFromOrderedBits(state[kLbvhStateBoxLo + a]);
        sceneHi[a] = lbvhFromOrderedBits(state[kLbvhStateBoxHi + a]);
    }
    const float unit = plocAreaUnit(sceneLo, sceneHi);
    const uint chunks = (count + kHplocGroupSize - 1u) / kHplocGroupSize;
    uint made = 0u;  // by this workgroup, for the host's check that the tree is whole
    for (uint chunk = gl_WorkGroupID.x; chunk < chunks; chunk += gl_NumWorkGroups.x) {
        const uint k = chunk * kHplocGroupSize + lane;
        bool going = k < count;
        uint left = k, right = k, split = 0u;
        for (;;) {
            // Climb until every range stopped or needs merging (a loop the whole workgroup runs: see
            // the note on lavapipe above).
            bool climbing = going, merging = false;
            while (groupBallot(climbing) != 0u) {
                if (climbing) {
                    const bool isLeft = left == 0u || (right != count - 1u && prefixAfter(right) > prefixAfter(left - 1u));
                    // The first of two siblings leaves its far end in their parent's slot and stops;
                    // the second takes it and goes on with the union.
                    const uint other = atomicExchange(parents[isLeft ? right : left - 1u], isLeft ? left : right);
                    if (other == kHplocEmpty) {
                        climbing = false;
                        going = false;
                    } else {
                        memoryBarrierBuffer();  // the sibling's clusters, released before its exchange
                        if (isLeft) {
                            split = right + 1u;
                            right = other;
                        } else {
                            split = left;
                            left = other;
                        }
                        const uint size = right - left + 1u;
                        merging = size > kHplocThreshold || size == count;
                        climbing = !merging;
                    }
                }
            }
            const uint merges = groupBallot(merging);
            if (merges == 0u) break;
            for (uint m = merges; m != 0u; m &= m - 1u) {
                if (lane == uint(findLSB(m))) task = uvec4(left, right, split, 0u);
                barrier();
                const uvec4 range = task;
                barrier();
                made += mergeRange(range.x, range.y, range.z, unit);
            }
            if (merging && right - left + 1u == count) going = false;  // the root is made
        }
    }
    if (lane == 0u && made > 0u) atomicAdd(state[kLbvhStateNextMerged], made);
}

void main() {
    if (kPhase == kLbvhPhaseHplocInit)
        init();
    else
        build();
}
