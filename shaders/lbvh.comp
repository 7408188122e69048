#version 460
// gpu-lbvh, steps 4 to 8 (shaders/lbvh.h): the binary radix tree over the sorted Morton codes
// (Karras 2012), the triangles gathered into leaf order, the inner nodes listed by level, boxes and
// SAH costs bottom up with the collapse into leaves, and the top-down emission of the tracers' nodes
// (shaders/gpu_types.h).
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_basic : require

#include "gpu_types.h"
#include "lbvh.h"

layout(local_size_x = kLbvhGroupSize) in;
layout(constant_id = kLbvhSpecPhase) const uint kPhase = kLbvhPhaseHierarchy;
layout(push_constant) uniform Params { LbvhParams params; };

layout(std430, set = 0, binding = kLbvhBindPositions) readonly buffer Positions { float positions[]; };
layout(std430, set = 0, binding = kLbvhBindIndices) readonly buffer Indices { uint indices[]; };
layout(std430, set = 0, binding = kLbvhBindMaterials) readonly buffer Materials { uint triangleMaterials[]; };
layout(std430, set = 0, binding = kLbvhBindKeysA) readonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = kLbvhBindValuesA) readonly buffer Values { uint values[]; };
layout(std430, set = 0, binding = kLbvhBindState) coherent buffer State { uint state[]; };
layout(std430, set = 0, binding = kLbvhBindInner) buffer Inner { uvec4 inner[]; };
layout(std430, set = 0, binding = kLbvhBindLevels) buffer Levels { uvec2 levels[]; };
layout(std430, set = 0, binding = kLbvhBindBoxes) buffer Boxes { vec4 boxes[]; };
layout(std430, set = 0, binding = kLbvhBindCosts) buffer Costs { float costs[]; };
layout(std430, set = 0, binding = kLbvhBindFlags) buffer Flags { uint flags[]; };
layout(std430, set = 0, binding = kLbvhBindQueue) buffer Queue { uint queue[]; };
layout(std430, set = 0, binding = kLbvhBindIndirect) buffer Indirect { uvec4 indirect[]; };
layout(std430, set = 0, binding = kLbvhBindNodes) writeonly buffer Nodes { GpuNode nodes[]; };
layout(std430, set = 0, binding = kLbvhBindTriangles) buffer Triangles { GpuTriangle triangles[]; };
layout(std430, set = 0, binding = kLbvhBindVertexNormals) readonly buffer VertexNormals { float vertexNormals[]; };
layout(std430, set = 0, binding = kLbvhBindNormals) writeonly buffer Normals { GpuTriangleNormals normals[]; };
layout(std430, set = 0, binding = kLbvhBindVertexUvs) readonly buffer VertexUvs { float vertexUvs[]; };
layout(std430, set = 0, binding = kLbvhBindUvs) writeonly buffer Uvs { GpuTriangleUvs uvs[]; };
layout(std430, set = 0, binding = kLbvhBindVertexColors) readonly buffer VertexColors { uint vertexColors[]; };
layout(std430, set = 0, binding = kLbvhBindColors) writeonly buffer Colors { GpuTriangleColors colors[]; };

#include "emit.h"

uint triangleCount() { return params.counts.x; }
uint leafId(uint sorted) { return triangleCount() - 1u + sorted; }

// ---- Step 4: the hierarchy (Karras 2012, Figure 4).

// Length of the common prefix of the sorted keys i and j, extended by their positions where the
// keys are equal (so all keys are distinct); -1 outside the array.
int commonPrefix(int i, int j) {
    if (j < 0 || j >= int(triangleCount())) return -1;
    const uint a = keys[i], b = keys[j];
    if (a != b) return 31 - findMSB(a ^ b);
    return 32 + 31 - findMSB(uint(i ^ j));
}

void hierarchy() {
    const int i = int(gl_GlobalInvocationID.x);
    if (i >= int(triangleCount()) - 1) return;
    // Direction of the node's range, and its other end.
    const int d = commonPrefix(i, i + 1) - commonPrefix(i, i - 1) > 0 ? 1 : -1;
    const int minPrefix = commonPrefix(i, i - d);
    int maxLength = 2;
    while (commonPrefix(i, i + maxLength * d) > minPrefix) maxLength *= 2;
    int length = 0;
    for (int step = maxLength / 2; step >= 1; step /= 2)
        if (commonPrefix(i, i + (length + step) * d) > minPrefix) length += step;
    const int j = i + length * d;
    // The split: the last position whose prefix with i is longer than the node's.
    const int nodePrefix = commonPrefix(i, j);
    int split = 0;
    int step = length;
    do {
        step = (step + 1) / 2;
        if (commonPrefix(i, i + (split + step) * d) > nodePrefix) split += step;
    } while (step > 1);
    const int gamma = i + split * d + min(d, 0);
    const uint first = uint(min(i, j)), last = uint(max(i, j));
    const uint left = first == uint(gamma) ? leafId(uint(gamma)) : uint(gamma);
    const uint right = last == uint(gamma + 1) ? leafId(uint(gamma + 1)) : uint(gamma + 1);
    inner[i] = uvec4(left, right, first, last);
    flags[i] = 0u;
}

// ---- Step 5: the triangles and their attributes in sorted (leaf) order, in the tracers' layout
// (shaders/gpu_types.h; what writeGpuTriangles writes on the host for the CPU-built path).

vec3 position(uint v) { return vec3(positions[3u * v], positions[3u * v + 1u], positions[3u * v + 2u]); }
vec4 normal(uint v) { return vec4(vertexNormals[3u * v], vertexNormals[3u * v + 1u], vertexNormals[3u * v + 2u], 0.0f); }
vec2 uv(uint v) { return vec2(vertexUvs[2u * v], vertexUvs[2u * v + 1u]); }

void gather() {
    const uint k = gl_GlobalInvocationID.x;
    if (k >= triangleCount()) return;
    const uint t = values[k];
    const uvec3 v = uvec3(indices[3u * t], indices[3u * t + 1u], indices[3u * t + 2u]);
    const uint material = (params.counts.w & kLbvhHasMaterials) != 0u ? triangleMaterials[t] : 0u;
    GpuTriangle triangle;
    triangle.v0 = vec4(position(v.x), uintBitsToFloat(t));
    triangle.v1 = vec4(position(v.y), uintBitsToFloat(material));
    triangle.v2 = vec4(position(v.z), 0.0f);
    triangles[k] = triangle;
    if ((params.counts.w & kLbvhHasNormals) != 0u) {
        GpuTriangleNormals n;
        n.n0 = normal(v.x);
        n.n1 = normal(v.y);
        n.n2 = normal(v.z);
        normals[k] = n;
    }
    if ((params.counts.w & kLbvhHasUvs) != 0u) {
        GpuTriangleUvs u;
        u.uv01 = vec4(uv(v.x), uv(v.y));
        u.uv2 = vec4(uv(v.z), 0.0f, 0.0f);
        uvs[k] = u;
    }
    if ((params.counts.w & kLbvhHasColors) != 0u) {
        GpuTriangleColors c;
        c.rgba = uvec4(vertexColors[v.x], vertexColors[v.y], vertexColors[v.z], 0u);
        colors[k] = c;
    }
}

// ---- Step 6: the inner nodes, level by level.

// Level L's queue entries are levels[L] = (first, count); its dispatch is indirect[L].
void setLevel(uint level, uint begin, uint count) {
    levels[level] = uvec2(begin, count);
    indirect[level] = uvec4((count + kLbvhGroupSize - 1u) / kLbvhGroupSize, 1u, 1u, 0u);
}

// The queue's entry for this invocation on level params.counts.z, or false past the level's end.
bool levelNode(out uint node) {
    const uvec2 level = levels[params.counts.z];
    node = 0u;
    if (gl_GlobalInvocationID.x >= level.y) return false;
    node = queue[level.x + gl_GlobalInvocationID.x];
    return true;
}

void levelRoot() {
    queue[0] = 0u;
    state[kLbvhStateQueueTail] = 1u;
    setLevel(0u, 0u, 1u);
}

// Appends `count` queue entries for this invocation, one atomic for the whole subgroup (lavapipe,
// Mesa 22.3, returned the same old value to two invocations of one subgroup adding to one word; one
// atomic per subgroup also spares the device most of them), and returns the first of them.
uint reserve(uint count) {
    uint base = 0u;
    const uint total = subgroupAdd(count);
    if (subgroupElect()) base = atomicAdd(state[kLbvhStateQueueTail], total);
    return subgroupBroadcastFirst(base) + subgroupExclusiveAdd(count);
}

void enumerate() {
    uint node;
    const bool valid = levelNode(node);
    const uint n = triangleCount();
    const uvec4 record = valid ? inner[node] : uvec4(n - 1u);
    const bool leftInner = valid && record.x < n - 1u, rightInner = valid && record.y < n - 1u;
    const uint count = (leftInner ? 1u : 0u) + (rightInner ? 1u : 0u);
    const uint slot = reserve(count);
    // Within the n - 1 entries a whole tree fills (a clustering that failed, which the host reports,
    // must not write past them).
    if (leftInner && slot < n - 1u) queue[slot] = record.x;
    if (rightInner && slot + (leftInner ? 1u : 0u) < n - 1u) queue[slot + (leftInner ? 1u : 0u)] = record.y;
}

// After level params.counts.z: the next level is what it pushed.
void nextLevel() {
    const uvec2 level = levels[params.counts.z];
    const uint begin = level.x + level.y;
    const uint count = state[kLbvhStateQueueTail] - begin;
    setLevel(params.counts.z + 1u, begin, count);
}

// ---- Step 7: boxes and SAH costs, bottom up.

// The SAH's area: the half surface area of the box measured in units of the scene's largest
// extent, so that neither huge nor tiny coordinates overflow or underflow in float. Extents are
// halved first (no overflow near FLT_MAX), which scales every area alike.
float sceneUnit() {
    vec3 sceneLo, sceneHi;
    for (uint a = 0u; a < 3u; ++a) {
        sceneLo[a] = lbvhFromOrderedBits(state[kLbvhStateBoxLo + a]);
        sceneHi[a] = lbvhFromOrderedBits(state[kLbvhStateBoxHi + a]);
    }
    const vec3 extent = 0.5f * sceneHi - 0.5f * sceneLo;
    const float largest = max(max(extent.x, extent.y), extent.z);
    return largest > 0.0f ? 1.0f / largest : 0.0f;
}
float sahArea(vec3 lo, vec3 hi, float unit) {
    const vec3 e = (0.5f * hi - 0.5f * lo) * unit;
    return e.x * e.y + e.y * e.z + e.z * e.x;
}

void triangleBox(GpuTriangle t, out vec3 lo, out vec3 hi) {
    lo = min(min(t.v0.xyz, t.v1.xyz), t.v2.xyz);
    hi = max(max(t.v0.xyz, t.v1.xyz), t.v2.xyz);
}

// A child's box and S: an inner node's from this pass's deeper level, a triangle's computed here.
void childOf(uint id, float unit, out vec3 lo, out vec3 hi, out float cost) {
    const uint n = triangleCount();
    if (id >= n - 1u) {
        triangleBox(triangles[id - (n - 1u)], lo, hi);
        cost = sahArea(lo, hi, unit) * params.costs.y;
    } else {
        lo = boxes[2u * id].xyz;
        hi = boxes[2u * id + 1u].xyz;
        cost = costs[id];
    }
}

void bottomUp() {
    uint node;
    if (!levelNode(node)) return;
    const float unit = sceneUnit();
    const uvec4 record = inner[node];
    vec3 leftLo, leftHi, rightLo, rightHi;
    float leftCost, rightCost;
    childOf(record.x, unit, leftLo, leftHi, leftCost);
    childOf(record.y, unit, rightLo, rightHi, rightCost);
    const vec3 lo = min(leftLo, rightLo), hi = max(leftHi, rightHi);
    const uint count = record.w - record.z + 1u;
    const float area = sahArea(lo, hi, unit);
    const float leafCost = area * float(count) * params.costs.y;
    const float splitCost = area * params.costs.x + leftCost + rightCost;
    const bool collapse = count <= params.counts.y || (count <= kLbvhMaxLeafPrimitives && leafCost <= splitCost);
    boxes[2u * node] = vec4(lo, 0.0f);
    boxes[2u * node + 1u] = vec4(hi, 0.0f);
    costs[node] = collapse ? leafCost : splitCost;
    flags[node] = collapse ? kLbvhCollapsed : 0u;
    if (node == 0u) {
        state[kLbvhStateRootCost] = floatBitsToUint(costs[node]);
        state[kLbvhStateRootArea] = floatBitsToUint(area);
    }
}

// ---- Step 8: the tracers' nodes, top down.

void root() {
    const uint n = triangleCount();
    if (n == 0u) {
        // An empty scene: a root leaf of no triangles whose box no ray hits.
        nodes[0] = leafNode(vec3(3.402823466e38f), vec3(-3.402823466e38f), 0u, 0u);
        state[kLbvhStateLeafCount] = 1u;
        return;
    }
    vec3 lo, hi;
    if (n == 1u) {
        triangleBox(triangles[0], lo, hi);
        nodes[0] = leafNode(lo, hi, 0u, 1u);
        const float area = sahArea(lo, hi, sceneUnit());
        state[kLbvhStateRootCost] = floatBitsToUint(area * params.costs.y);
        state[kLbvhStateRootArea] = floatBitsToUint(area);
        state[kLbvhStateLeafCount] = 1u;
        return;
    }
    lo = boxes[0].xyz;
    hi = boxes[1].xyz;
    if ((flags[0] & kLbvhCollapsed) != 0u) {
        nodes[0] = leafNode(lo, hi, 0u, n);
        state[kLbvhStateLeafCount] = 1u;
        return;
    }
    nodes[0] = innerNode(lo, hi, 1u);
    flags[0] |= kLbvhLive;
    state[kLbvhStateInnerCount] = 1u;
}

// The live, not collapsed inner nodes of depth params.counts.z write their children into slots
// 1 + 2i and 2 + 2i; children that stay inner nodes become live.
void emit() {
    uint node;
    const bool valid = levelNode(node);
    const uint n = triangleCount();
    const uint level = params.counts.z;
    const bool splits = valid && flags[node] == kLbvhLive;
    uint leaves = 0u, inners = 0u;
    if (splits) {
        const uvec4 record = inner[node];
        for (uint side = 0u; side < 2u; ++side) {
            const uint child = side == 0u ? record.x : record.y;
            const uint slot = 1u + 2u * node + side;
            vec3 lo, hi;
            uint first, count;
            bool leaf;
            if (child >= n - 1u) {
                triangleBox(triangles[child - (n - 1u)], lo, hi);
                first = child - (n - 1u);
                count = 1u;
                leaf = true;
            } else {
                const uvec4 range = inner[child];
                lo = boxes[2u * child].xyz;
                hi = boxes[2u * child + 1u].xyz;
                first = range.z;
                count = range.w - range.z + 1u;
                leaf = (flags[child] & kLbvhCollapsed) != 0u;
            }
            if (leaf) {
                nodes[slot] = leafNode(lo, hi, first, count);
                ++leaves;
            } else {
                nodes[slot] = innerNode(lo, hi, 1u + 2u * child);
                flags[child] |= kLbvhLive;
                ++inners;
            }
        }
    }
    // The statistics: one atomic per workgroup and counter.
    addStatistics(leaves, level + 1u, inners);
}

void main() {
    if (kPhase == kLbvhPhaseHierarchy)
        hierarchy();
    else if (kPhase == kLbvhPhaseGather)
        gather();
    else if (kPhase == kLbvhPhaseEnumerate)
        enumerate();
    else if (kPhase == kLbvhPhaseBottomUp)
        bottomUp();
    else if (kPhase == kLbvhPhaseEmit)
        emit();
    else if (gl_GlobalInvocationID.x == 0u) {
        if (kPhase == kLbvhPhaseLevelRoot)
            levelRoot();
        else if (kPhase == kLbvhPhaseNextLevel)
            nextLevel();
        else
            root();
    }
}
