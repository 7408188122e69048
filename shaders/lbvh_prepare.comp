#version 460
// gpu-lbvh, steps 1 and 2 (shaders/lbvh.h): the bounds of the triangles and of their centroids,
// then one 30-bit Morton code per triangle (Morton 1966; Karras 2012, section 4).
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "lbvh.h"

layout(local_size_x = kLbvhGroupSize) in;
layout(constant_id = kLbvhSpecPhase) const uint kPhase = kLbvhPhaseBounds;
layout(push_constant) uniform Params { LbvhParams params; };

layout(std430, set = 0, binding = kLbvhBindPositions) readonly buffer Positions { float positions[]; };
layout(std430, set = 0, binding = kLbvhBindIndices) readonly buffer Indices { uint indices[]; };
layout(std430, set = 0, binding = kLbvhBindKeysA) writeonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = kLbvhBindValuesA) writeonly buffer Values { uint values[]; };
layout(std430, set = 0, binding = kLbvhBindState) coherent buffer State { uint state[]; };

shared uint groupBounds[12];

// Centroids as the CPU builders compute them (renderer/bvh_build.h, centroidOf): no overflow near
// FLT_MAX.
vec3 vertex(uint v) { return vec3(positions[3u * v], positions[3u * v + 1u], positions[3u * v + 2u]); }
vec3 centroidOf(uint t, out vec3 lo, out vec3 hi) {
    const vec3 a = vertex(indices[3u * t]), b = vertex(indices[3u * t + 1u]), c = vertex(indices[3u * t + 2u]);
    lo = min(min(a, b), c);
    hi = max(max(a, b), c);
    return 0.5f * lo + 0.5f * hi;
}

void bounds() {
    const uint local = gl_LocalInvocationIndex;
    if (local < 12u) groupBounds[local] = local % 6u < 3u ? 0xFFFFFFFFu : 0u;
    barrier();
    const uint t = gl_GlobalInvocationID.x;
    if (t < params.counts.x) {
        vec3 lo, hi;
        const vec3 c = centroidOf(t, lo, hi);
        for (uint a = 0u; a < 3u; ++a) {
            atomicMin(groupBounds[kLbvhStateBoxLo + a], lbvhOrderedBits(lo[a]));
            atomicMax(groupBounds[kLbvhStateBoxHi + a], lbvhOrderedBits(hi[a]));
            atomicMin(groupBounds[kLbvhStateCentroidLo + a], lbvhOrderedBits(c[a]));
            atomicMax(groupBounds[kLbvhStateCentroidHi + a], lbvhOrderedBits(c[a]));
        }
    }
    barrier();
    if (local < 12u) {
        if (local % 6u < 3u)
            atomicMin(state[local], groupBounds[local]);
        else
            atomicMax(state[local], groupBounds[local]);
    }
}

// 10 bits spread to every third bit (Karras 2012's expandBits).
uint spreadBits(uint v) {
    v = (v * 0x00010001u) & 0xFF0000FFu;
    v = (v * 0x00000101u) & 0x0F00F00Fu;
    v = (v * 0x00000011u) & 0xC30C30C3u;
    v = (v * 0x00000005u) & 0x49249249u;
    return v;
}

void morton() {
    const uint t = gl_GlobalInvocationID.x;
    if (t >= params.counts.x) return;
    vec3 lo, hi;
    const vec3 c = centroidOf(t, lo, hi);
    uint code = 0u;
    for (uint a = 0u; a < 3u; ++a) {
        const float boundLo = lbvhFromOrderedBits(state[kLbvhStateCentroidLo + a]);
        const float boundHi = lbvhFromOrderedBits(state[kLbvhStateCentroidHi + a]);
        // Halves, so that extents near FLT_MAX do not overflow; a flat axis gives every centroid 0.
        const float extent = 0.5f * boundHi - 0.5f * boundLo;
        const float unit = extent > 0.0f ? (0.5f * c[a] - 0.5f * boundLo) / extent : 0.0f;
        const uint cell = uint(clamp(unit * 1024.0f, 0.0f, 1023.0f));
        code |= spreadBits(cell) << (2u - a);
    }
    keys[t] = code;
    values[t] = t;
}

void main() {
    if (kPhase == kLbvhPhaseBounds)
        bounds();
    else
        morton();
}
