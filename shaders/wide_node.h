// Reading a compressed 8-wide node (GpuWideNode, shaders/gpu_types.h): the one definition of how a
// child's quantized box decodes, compiled by the single-ray kernel (shaders/trace.comp) and by the
// host, which quantizes each box so that this very decoding contains the child's box
// (renderer/gpu_wide.cpp) and whose tests check it.
#ifndef RAYPACK_SHADERS_WIDE_NODE_H
#define RAYPACK_SHADERS_WIDE_NODE_H
#include "common.h"
#include "gpu_types.h"
#include "intersect.h"  // RP_PRECISE

RP_BEGIN_NAMESPACE

// Byte `slot % 4` of `word`: a slot's byte in a pair of words that holds slots 0-3 and 4-7.
RP_FUNC uint wideSlotByte(uint word, uint slot) { return (word >> (8u * (slot & 3u))) & 255u; }

// The slot's byte in the pair (first, second) of a quant or index vector: slots 0-3 in `first`.
RP_FUNC uint wideSlotValue(uint first, uint second, uint slot) {
    return wideSlotByte(slot < 4u ? first : second, slot);
}

// The slot's meta byte (0: empty; see GpuWideNode).
RP_FUNC uint wideMeta(GpuWideNode n, uint slot) { return wideSlotValue(n.index.z, n.index.w, slot); }

// 2^(biased - 127) from its biased exponent (1 to 254: a normal float, exact).
RP_FUNC float wideScale(uint biased) { return uintBitsToFloat(biased << 23u); }

// The grid's scales on x, y, z.
RP_FUNC vec3 wideScales(GpuWideNode n) {
    const uint e = floatBitsToUint(n.origin.w);
    return vec3(wideScale(e & 255u), wideScale((e >> 8u) & 255u), wideScale((e >> 16u) & 255u));
}

// One plane of a child box: origin + scale * q, the product exact (q has 8 bits, scale is a power
// of two in the normal range) and the sum rounded once, never fused.
RP_FUNC float wideDecode(float origin, float scale, uint q) {
    RP_PRECISE const float offset = scale * float(q);
    RP_PRECISE const float plane = origin + offset;
    return plane;
}

// The box of child `slot`, as the kernel tests it.
RP_FUNC void wideChildBox(GpuWideNode n, vec3 scale, uint slot, RP_OUT(vec3) lo, RP_OUT(vec3) hi) {
    lo.x = wideDecode(n.origin.x, scale.x, wideSlotValue(n.quant[0].x, n.quant[0].y, slot));
    lo.y = wideDecode(n.origin.y, scale.y, wideSlotValue(n.quant[0].z, n.quant[0].w, slot));
    lo.z = wideDecode(n.origin.z, scale.z, wideSlotValue(n.quant[1].x, n.quant[1].y, slot));
    hi.x = wideDecode(n.origin.x, scale.x, wideSlotValue(n.quant[1].z, n.quant[1].w, slot));
    hi.y = wideDecode(n.origin.y, scale.y, wideSlotValue(n.quant[2].x, n.quant[2].y, slot));
    hi.z = wideDecode(n.origin.z, scale.z, wideSlotValue(n.quant[2].z, n.quant[2].w, slot));
}

// The slab test of a node's children in the grid's own terms (Ylitie et al. 2017's form): per node
// and axis a = scale * invDir (exact: scale is a power of two) and b = (origin - org) * invDir, per
// child plane t = q * a + b, one fused multiply-add instead of a decode, a subtraction and a
// product. It is made conservative by an absolute bound on its rounding, per node and axis:
//   E = (|b| + 255 |a|) * kWideSlabError,
// subtracted from the near planes' distances and added to the far planes'. The exact distance of a
// plane is (origin + scale * q - org) / dir; the computed one carries the rounding of origin - org,
// of its product with invDir, of the fused multiply-add and of b - E, and invDir's own error (a
// GPU's division may be off by 2.5 ulp, Vulkan's bound): about 11 u (|b| + 255 |a|) in all, u =
// 2^-24. kWideSlabError is 2^-19 = 32 u. The host quantized every box so that the exact real
// planes origin + scale * q contain the child's box (renderer/gpu_wide.cpp), so a ray that meets the
// child meets the widened slabs. Rays parallel to an axis (invDir 0) and nodes whose distances
// reach kWideFastLimit (where 255 |a| could overflow) take the decoded box and the slab test of
// shaders/intersect.h instead (the kernel's wideChildBox path).
const float kWideSlabError = 1.9073486328125e-06f;  // 2^-19
const float kWideFastLimit = 1.0e30f;

// A ray's octant: bit a set when its direction is negative on axis a. The kernel visits the slots
// of a node in the order s ^ octant, s = 0, 1, ..., 7 (GpuWideNode: roughly front to back).
RP_FUNC uint rayOctant(vec3 dir) {
    return (dir.x < 0.0f ? 1u : 0u) | (dir.y < 0.0f ? 2u : 0u) | (dir.z < 0.0f ? 4u : 0u);
}

RP_END_NAMESPACE

#endif  // RAYPACK_SHADERS_WIDE_NODE_H
