#version 460
// gpu-ploc (shaders/lbvh.h): Meister and Bittner 2018, "Parallel Locally-Ordered Clustering for
// Bounding Volume Hierarchy Construction", over the triangles sorted by Morton code. Every sorted
// triangle starts as a cluster; each iteration finds every cluster's nearest neighbour among the
// kPlocRadius clusters on either side (the smallest union surface area), merges the mutual pairs
// into new inner nodes (the lower position keeps the new cluster) and compacts the cluster array in
// order, until one cluster is left: the root. The cluster count lives on the device: each iteration
// starts with kLbvhPhasePlocSetup, which takes the count the last one left and sizes this one's
// dispatches (indirect), so the host records many iterations per submission and reads the count
// back only between submissions.
//
// The inner nodes are written as shaders/cluster_tree.h names them (children as lbvh.comp's records
// name them, the triangle count in z), numbered so that the root (the last one made) is inner node
// 0, children that are triangles as n - 1 + their position. A PLOC subtree's triangles are not
// contiguous in Morton order, so once cluster_layout.comp has given every triangle its slot in the
// depth-first leaf order, kLbvhPhasePlocReorder reorders the triangles by it and gpu-lbvh's gather
// writes them there.
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "lbvh.h"

layout(local_size_x = kLbvhGroupSize) in;
layout(constant_id = kLbvhSpecPhase) const uint kPhase = kLbvhPhasePlocInit;
// Clusters compared on each side: Meister and Bittner's r (BvhBuildOptions::plocRadius, 1..64;
// default 16, within a few percent of their best SAH at a fraction of the search).
layout(constant_id = kLbvhSpecPlocRadius) const uint kPlocRadius = 16u;
layout(push_constant) uniform Params { LbvhParams params; };

layout(std430, set = 0, binding = kLbvhBindKeysA) buffer ClustersA { uint clustersA[]; };
layout(std430, set = 0, binding = kLbvhBindValuesA) buffer Order { uint order[]; };
layout(std430, set = 0, binding = kLbvhBindKeysB) buffer ClustersB { uint clustersB[]; };
// The nearest neighbours while clustering, then each triangle's slot in the leaf order
// (cluster_layout.comp).
layout(std430, set = 0, binding = kLbvhBindValuesB) buffer Neighbours { uint neighbours[]; };
layout(std430, set = 0, binding = kLbvhBindScan) buffer Scan { uint scan[]; };
layout(std430, set = 0, binding = kLbvhBindState) buffer State { uint state[]; };
layout(std430, set = 0, binding = kLbvhBindInner) buffer Inner { uvec4 inner[]; };
layout(std430, set = 0, binding = kLbvhBindBoxes) buffer Boxes { vec4 boxes[]; };  // by cluster id
layout(std430, set = 0, binding = kLbvhBindTriangles) readonly buffer Triangles { GpuTriangle triangles[]; };
layout(std430, set = 0, binding = kLbvhBindIndirect) writeonly buffer Indirect { uvec4 indirect[]; };

uint clusters() { return state[kLbvhStateClusters]; }

// Cluster ids: sorted triangle k is id k, the j-th inner node made is id n + j. The inner node of
// id p is record 2n - 2 - p (the root, made last, is record 0).
uint n() { return params.counts.x; }
uint recordOf(uint id) { return 2u * n() - 2u - id; }
// The id as lbvh.comp's records name a child: an inner node by its record, a triangle as n - 1 + k.
uint childName(uint id) { return id >= n() ? recordOf(id) : n() - 1u + id; }
uint countOf(uint id) { return id >= n() ? inner[recordOf(id)].z : 1u; }

// Areas of union boxes compared in units of the scene's largest extent (plocAreaUnit).
float unitOfScene() {
    vec3 lo, hi;
    for (uint a = 0u; a < 3u; ++a) {
        lo[a] = lbvhFromOrderedBits(state[kLbvhStateBoxLo + a]);
        hi[a] = lbvhFromOrderedBits(state[kLbvhStateBoxHi + a]);
    }
    return plocAreaUnit(lo, hi);
}

bool readsB() { return params.offsets.z != 0u; }
uint clusterIn(uint i) { return readsB() ? clustersB[i] : clustersA[i]; }

void init() {
    const uint k = gl_GlobalInvocationID.x;
    if (k >= n()) return;
    const GpuTriangle t = triangles[k];
    boxes[2u * k] = vec4(min(min(t.v0.xyz, t.v1.xyz), t.v2.xyz), 0.0f);
    boxes[2u * k + 1u] = vec4(max(max(t.v0.xyz, t.v1.xyz), t.v2.xyz), 0.0f);
    clustersA[k] = k;
    if (k == 0u) {
        state[kLbvhStateNextClusters] = n();
        state[kLbvhStateNextMerged] = 0u;
    }
}

// The iteration's clusters (what the last one left) and its dispatches: the clusters' and those of
// the scan's params.counts.z levels; none once one cluster is left.
void setup() {
    const uint m = state[kLbvhStateNextClusters];
    state[kLbvhStateClusters] = m;
    state[kLbvhStateMerged] = state[kLbvhStateNextMerged];
    const uint running = m > 1u ? 1u : 0u;
    indirect[kPlocIndirectClusters] = uvec4(running * ((m + kLbvhGroupSize - 1u) / kLbvhGroupSize), 1u, 1u, 0u);
    uint count = m;
    for (uint level = 0u; level < params.counts.z; ++level) {
        indirect[kPlocIndirectScan + level] = uvec4(running * ((count + kLbvhScanBlock - 1u) / kLbvhScanBlock), 1u, 1u, 0u);
        count = (count + kLbvhScanBlock - 1u) / kLbvhScanBlock;
    }
}

// The boxes of this workgroup's clusters and kPlocRadius on either side.
shared vec3 windowLo[kLbvhGroupSize + 2u * kPlocRadius];
shared vec3 windowHi[kLbvhGroupSize + 2u * kPlocRadius];

void nearest() {
    const uint m = clusters();
    const int first = int(gl_WorkGroupID.x * kLbvhGroupSize) - int(kPlocRadius);
    for (uint w = gl_LocalInvocationIndex; w < kLbvhGroupSize + 2u * kPlocRadius; w += kLbvhGroupSize) {
        const int i = first + int(w);
        if (i >= 0 && i < int(m)) {
            const uint id = clusterIn(uint(i));
            windowLo[w] = boxes[2u * id].xyz;
            windowHi[w] = boxes[2u * id + 1u].xyz;
        }
    }
    barrier();
    const uint i = gl_GlobalInvocationID.x;
    if (i >= m) return;
    const float unit = unitOfScene();
    const uint self = gl_LocalInvocationIndex + kPlocRadius;
    const vec3 lo = windowLo[self], hi = windowHi[self];
    float best = 3.402823466e38f;
    uint bestIndex = i;
    const uint begin = i >= kPlocRadius ? i - kPlocRadius : 0u;
    const uint end = min(m - 1u, i + kPlocRadius);
    for (uint j = begin; j <= end; ++j) {
        if (j == i) continue;
        const uint w = j + kPlocRadius - gl_WorkGroupID.x * kLbvhGroupSize;
        const float d = plocArea(min(lo, windowLo[w]), max(hi, windowHi[w]), unit);
        if (d < best || (d == best && plocCloserTie(i, j, bestIndex))) {
            best = d;
            bestIndex = j;
        }
    }
    neighbours[i] = bestIndex;
}

// The keep flags (offsets.x) and merge flags (offsets.y) of the clusters, for two scans.
void flags() {
    const uint i = gl_GlobalInvocationID.x;
    if (i >= clusters()) return;
    const uint j = neighbours[i];
    const bool mutual = j != i && neighbours[j] == i;
    scan[params.offsets.x + i] = mutual && i > j ? 0u : 1u;
    scan[params.offsets.y + i] = mutual && i < j ? 1u : 0u;
}

void apply() {
    const uint i = gl_GlobalInvocationID.x;
    const uint m = clusters();
    if (i >= m) return;
    const uint j = neighbours[i];
    const bool mutual = j != i && neighbours[j] == i;
    const bool keep = !(mutual && i > j), merge = mutual && i < j;
    const uint keepSlot = scan[params.offsets.x + i], mergeRank = scan[params.offsets.y + i];
    const uint made = state[kLbvhStateMerged];
    uint id = clusterIn(i);
    if (merge) {
        const uint left = id, right = clusterIn(j);
        id = n() + made + mergeRank;
        boxes[2u * id] = min(boxes[2u * left], boxes[2u * right]);
        boxes[2u * id + 1u] = max(boxes[2u * left + 1u], boxes[2u * right + 1u]);
        inner[recordOf(id)] = uvec4(childName(left), childName(right), countOf(left) + countOf(right), 0u);
    }
    if (keep) {
        if (readsB())
            clustersA[keepSlot] = id;
        else
            clustersB[keepSlot] = id;
    }
    if (i == m - 1u) {
        state[kLbvhStateNextClusters] = keepSlot + (keep ? 1u : 0u);
        state[kLbvhStateNextMerged] = made + mergeRank + (merge ? 1u : 0u);
    }
}

// The triangles in depth-first leaf order: the sorted triangle k goes to the slot cluster_layout.comp
// gave it.
void reorder() {
    const uint k = gl_GlobalInvocationID.x;
    if (k >= n()) return;
    clustersB[neighbours[k]] = order[k];
}

void main() {
    if (kPhase == kLbvhPhasePlocInit)
        init();
    else if (kPhase == kLbvhPhasePlocNearest)
        nearest();
    else if (kPhase == kLbvhPhasePlocFlags)
        flags();
    else if (kPhase == kLbvhPhasePlocApply)
        apply();
    else if (kPhase == kLbvhPhasePlocReorder)
        reorder();
    else if (gl_GlobalInvocationID.x == 0u)
        setup();
}
