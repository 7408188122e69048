#version 460
// gpu-lbvh's exclusive prefix sum over a range of uints (the radix sort's digit counts), in place,
// by blocks (Blelloch 1990's scan-then-propagate, the host recursing over the block sums):
//   kLbvhPhaseScanBlocks    scan[in + i] becomes the sum of the block's entries before it, and
//                           scan[sums + block] the block's total;
//   kLbvhPhaseAddBlockSums  scan[in + i] += scan[sums + block], once the block sums are scanned.
// entryCount(): the entry count; params.offsets.x: in; params.offsets.y: sums (in uints).
#extension GL_GOOGLE_include_directive : require

#include "lbvh.h"

layout(local_size_x = kLbvhGroupSize) in;
layout(constant_id = kLbvhSpecPhase) const uint kPhase = kLbvhPhaseScanBlocks;
layout(push_constant) uniform Params { LbvhParams params; };

layout(std430, set = 0, binding = kLbvhBindScan) buffer Scan { uint scan[]; };
layout(std430, set = 0, binding = kLbvhBindState) readonly buffer State { uint state[]; };

// The entries of this scan: counts.z, or (gpu-ploc, offsets.z = 1 + L) level L of a scan over the
// clusters of this iteration, which only the device knows: ceil(clusters / kLbvhScanBlock^L). A level
// of one entry scans to 0, so the levels of the largest scan always all run.
uint entryCount() {
    if (params.offsets.z == 0u) return params.counts.z;
    uint count = state[kLbvhStateClusters];
    for (uint level = 1u; level < params.offsets.z; ++level) count = (count + kLbvhScanBlock - 1u) / kLbvhScanBlock;
    return count;
}

shared uint partial[kLbvhGroupSize];

void scanBlocks() {
    const uint local = gl_LocalInvocationIndex;
    const uint count = entryCount();
    const uint first = gl_WorkGroupID.x * kLbvhScanBlock + local * kLbvhScanItems;
    uint values[kLbvhScanItems];
    uint total = 0u;
    for (uint k = 0u; k < kLbvhScanItems; ++k) {
        values[k] = first + k < count ? scan[params.offsets.x + first + k] : 0u;
        total += values[k];
    }
    // Hillis and Steele's inclusive scan of the invocations' totals.
    partial[local] = total;
    barrier();
    for (uint step = 1u; step < kLbvhGroupSize; step <<= 1u) {
        const uint before = local >= step ? partial[local - step] : 0u;
        barrier();
        partial[local] += before;
        barrier();
    }
    uint running = partial[local] - total;
    for (uint k = 0u; k < kLbvhScanItems; ++k) {
        if (first + k < count) scan[params.offsets.x + first + k] = running;
        running += values[k];
    }
    if (local == kLbvhGroupSize - 1u) scan[params.offsets.y + gl_WorkGroupID.x] = partial[local];
}

void addBlockSums() {
    const uint count = entryCount();
    const uint add = scan[params.offsets.y + gl_WorkGroupID.x];
    const uint first = gl_WorkGroupID.x * kLbvhScanBlock + gl_LocalInvocationIndex * kLbvhScanItems;
    for (uint k = 0u; k < kLbvhScanItems; ++k)
        if (first + k < count) scan[params.offsets.x + first + k] += add;
}

void main() {
    if (kPhase == kLbvhPhaseScanBlocks)
        scanBlocks();
    else
        addBlockSums();
}
