#version 460
// gpu-lbvh, steps 1 and 2 (shaders/lbvh.h): the bounds of the triangles and of their centroids,
// then one 30-bit Morton code per triangle (Morton 1966; Karras 2012, section 4), its bits shared
// among the axes by their extents (Vinkler et al. 2017).
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

// The axis that takes the Morton code's next bit (Vinkler, Bittner and Havran 2017, "Extended
// Morton Codes for High Performance Bounding Volume Hierarchy Construction", section 4.1): the one
// whose cells are widest after the bits it has, its cell width being extent · 2^-bits, compared as
// bits + log2(largest extent / extent) so that no product underflows; ties go to the lower axis, and
// an axis of no extent never takes a bit. A cube's extents give x, y, z in turn: Karras' code.
uint nextAxis(vec3 deficit, uvec3 bits) {
    uint best = 0u;
    for (uint a = 1u; a < 3u; ++a)
        if (float(bits[a]) + deficit[a] < float(bits[best]) + deficit[best]) best = a;
    return best;
}

// The code bits of each axis (a mask per axis), the same for every triangle: worked out once per
// workgroup into shared memory, since the choice of 30 bits costs more than a triangle's code.
shared uint axisMasks[3];

// `value`'s low bits, the least significant first, into the set bits of `mask` from the lowest up.
uint depositBits(uint value, uint mask) {
    uint result = 0u;
    while (mask != 0u) {
        result |= (value & 1u) << uint(findLSB(mask));
        value >>= 1u;
        mask &= mask - 1u;
    }
    return result;
}

// The code's 30 bits over the three axes in proportion to their extents: a flat terrain's height
// axis, which a per-axis cube (Karras 2012) gives as many bits as the others, takes few, so that
// neighbours in the code are neighbours on the ground.
void morton() {
    vec3 boundLo, extent;
    for (uint a = 0u; a < 3u; ++a) {
        boundLo[a] = lbvhFromOrderedBits(state[kLbvhStateCentroidLo + a]);
        // Halves, so that extents near FLT_MAX do not overflow.
        extent[a] = 0.5f * lbvhFromOrderedBits(state[kLbvhStateCentroidHi + a]) - 0.5f * boundLo[a];
    }
    if (gl_LocalInvocationIndex == 0u) {
        // From the code's most significant bit down; no bits at all when every centroid is one point.
        const float largest = max(max(extent.x, extent.y), extent.z);
        uvec3 bits = uvec3(0u), masks = uvec3(0u);
        if (largest > 0.0f) {
            vec3 deficit;
            for (uint a = 0u; a < 3u; ++a) deficit[a] = extent[a] > 0.0f ? log2(largest / extent[a]) : 1e30f;
            for (uint b = 0u; b < kLbvhMortonBits; ++b) {
                const uint a = nextAxis(deficit, bits);
                ++bits[a];
                masks[a] |= 1u << (kLbvhMortonBits - 1u - b);
            }
        }
        for (uint a = 0u; a < 3u; ++a) axisMasks[a] = masks[a];
    }
    barrier();
    const uint t = gl_GlobalInvocationID.x;
    if (t >= params.counts.x) return;
    vec3 lo, hi;
    const vec3 c = centroidOf(t, lo, hi);
    uint code = 0u;
    for (uint a = 0u; a < 3u; ++a) {
        const uint mask = axisMasks[a];
        const uint bits = uint(bitCount(mask));
        const float unit = extent[a] > 0.0f ? (0.5f * c[a] - 0.5f * boundLo[a]) / extent[a] : 0.0f;
        // The last cell clamped as an integer: 2^bits - 1 has no float above 24 bits.
        const uint cell = min(uint(clamp(unit, 0.0f, 1.0f) * float(1u << bits)), (1u << bits) - 1u);
        code |= depositBits(cell, mask);
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
