#version 460
// gpu-lbvh, step 3 (shaders/lbvh.h): one pass of a stable least-significant-digit radix sort of
// (key, value) pairs by an 8-bit digit of the key. Three dispatches a pass:
//   kLbvhPhaseHistogram  each workgroup counts the digits of its block of kLbvhSortBlock keys into
//                        scan[digit * blocks + block] (digit-major, so that one exclusive scan of
//                        the whole array gives every block's first slot for every digit);
//   (prefix_scan.comp over those counts)
//   kLbvhPhaseScatter    each workgroup walks its block again in chunks of one key per invocation
//                        and writes every pair to its digit's next slot. A key's rank among the
//                        equal digits before it in the chunk comes from the subgroup's ballots of
//                        the digit's 8 bits (the peers with the same digit: Adinets and Merrill
//                        2022, "Onesweep", warp-level multi-split) plus the counts of the subgroups
//                        before it, so equal keys keep their order: the sort is stable.
// Passes alternate between the A and B buffers (offsets.z = 1: read B, write A).
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require

#include "lbvh.h"

layout(local_size_x = kLbvhGroupSize) in;
layout(constant_id = kLbvhSpecPhase) const uint kPhase = kLbvhPhaseHistogram;
// kLbvhGroupSize / the device's subgroup size (the host's value; checked here).
layout(constant_id = kLbvhSpecSubgroupsPerGroup) const uint kSubgroups = 8u;
layout(push_constant) uniform Params { LbvhParams params; };

layout(std430, set = 0, binding = kLbvhBindKeysA) buffer KeysA { uint keysA[]; };
layout(std430, set = 0, binding = kLbvhBindValuesA) buffer ValuesA { uint valuesA[]; };
layout(std430, set = 0, binding = kLbvhBindKeysB) buffer KeysB { uint keysB[]; };
layout(std430, set = 0, binding = kLbvhBindValuesB) buffer ValuesB { uint valuesB[]; };
layout(std430, set = 0, binding = kLbvhBindScan) buffer Scan { uint scan[]; };
layout(std430, set = 0, binding = kLbvhBindState) buffer State { uint state[]; };

shared uint digitCounts[kLbvhRadixDigits];  // histogram; the scatter's next slot per digit
// Per subgroup and digit, the count (then the offset) in a chunk: at most kLbvhGroupSize, so two
// subgroups share a word in 16-bit halves (subgroup s: word s / 2, bits 16 (s % 2) up), which keeps
// the sort within 32 KiB of shared memory for subgroups as small as 4.
shared uint subgroupCounts[(kSubgroups + 1u) / 2u * kLbvhRadixDigits];

uint countWord(uint s, uint digit) { return (s >> 1u) * kLbvhRadixDigits + digit; }
uint countShift(uint s) { return (s & 1u) * 16u; }

uint sourceKey(uint i) { return params.offsets.z == 0u ? keysA[i] : keysB[i]; }
uint sourceValue(uint i) { return params.offsets.z == 0u ? valuesA[i] : valuesB[i]; }
uint digitOf(uint key) { return (key >> params.counts.z) & (kLbvhRadixDigits - 1u); }

void histogram() {
    const uint local = gl_LocalInvocationIndex;
    const uint n = params.counts.x;
    const uint block = gl_WorkGroupID.x;
    digitCounts[local] = 0u;
    barrier();
    for (uint item = 0u; item < kLbvhSortItems; ++item) {
        const uint i = block * kLbvhSortBlock + item * kLbvhGroupSize + local;
        if (i < n) atomicAdd(digitCounts[digitOf(sourceKey(i))], 1u);
    }
    barrier();
    scan[local * params.offsets.x + block] = digitCounts[local];
}

void scatter() {
    const uint local = gl_LocalInvocationIndex;
    const uint n = params.counts.x;
    const uint block = gl_WorkGroupID.x;
    const uint lane = gl_SubgroupInvocationID;
    const uint subgroup = local / gl_SubgroupSize;
    // The ranks below assume that subgroups are consecutive runs of the workgroup's invocations
    // and that the host knew their size; a device that breaks either is reported, not mis-sorted
    // silently (the host throws on the status).
    if (lane != local % gl_SubgroupSize || gl_SubgroupSize * kSubgroups != kLbvhGroupSize) {
        atomicOr(state[kLbvhStateStatus], kLbvhStatusSubgroupLayout);
        return;
    }
    digitCounts[local] = scan[local * params.offsets.x + block];
    for (uint item = 0u; item < kLbvhSortItems; ++item) {
        for (uint w = 0u; w < (kSubgroups + 1u) / 2u; ++w) subgroupCounts[w * kLbvhRadixDigits + local] = 0u;
        barrier();
        const uint i = block * kLbvhSortBlock + item * kLbvhGroupSize + local;
        const bool valid = i < n;
        const uint key = valid ? sourceKey(i) : 0u;
        const uint digit = digitOf(key);
        uvec4 peers = subgroupBallot(valid);
        for (uint bit = 0u; bit < kLbvhRadixBits; ++bit) {
            const bool set = ((digit >> bit) & 1u) != 0u;
            const uvec4 ballot = subgroupBallot(set);
            peers &= set ? ballot : ~ballot;
        }
        const uint rank = subgroupBallotExclusiveBitCount(peers);
        if (valid && subgroupBallotFindLSB(peers) == lane)
            atomicOr(subgroupCounts[countWord(subgroup, digit)], subgroupBallotBitCount(peers) << countShift(subgroup));
        barrier();
        // Invocation `local` turns digit `local`'s counts per subgroup into exclusive offsets.
        uint running = 0u;
        for (uint w = 0u; w < (kSubgroups + 1u) / 2u; ++w) {
            const uint pair = subgroupCounts[w * kLbvhRadixDigits + local];
            const uint low = pair & 0xFFFFu, high = pair >> 16u;
            subgroupCounts[w * kLbvhRadixDigits + local] = running | ((running + low) << 16u);
            running += low + high;
        }
        barrier();
        if (valid) {
            const uint offset = (subgroupCounts[countWord(subgroup, digit)] >> countShift(subgroup)) & 0xFFFFu;
            const uint slot = digitCounts[digit] + offset + rank;
            const uint value = sourceValue(i);
            if (params.offsets.z == 0u) {
                keysB[slot] = key;
                valuesB[slot] = value;
            } else {
                keysA[slot] = key;
                valuesA[slot] = value;
            }
        }
        barrier();
        digitCounts[local] += running;
    }
}

void main() {
    if (kPhase == kLbvhPhaseHistogram)
        histogram();
    else
        scatter();
}
