// What the GPU kernels read, defined once for GLSL and C++ (../shared/STYLE.md, "One definition of
// what the GPU reads"). Built on the CPU by makeGpuLayout (renderer/gpu_layout.h) from the canonical
// Bvh and Scene: the BVH that is built is not the BVH that is traced.
#ifndef RAYPACK_SHADERS_GPU_TYPES_H
#define RAYPACK_SHADERS_GPU_TYPES_H
#include "camera.h"
#include "common.h"
#include "texture.h"  // GpuTexture

RP_BEGIN_NAMESPACE

// 32 bytes, the report's node size (2 x 16):
//   lo.xyz, hi.xyz: the box
//   lo.w (uint bits): inner node: index of the left child; the right child is index + 1, so the
//                     two children a packet tests are one 64-byte read
//                     leaf: index of its first triangle in GpuTriangle order (leaf order)
//   hi.w (uint bits): 0 for an inner node, the triangle count for a leaf
// Node 0 is the root. An empty scene has a root leaf with count 0 and an empty box (lo > hi),
// which no ray hits.
struct GpuNode {
    vec4 lo;
    vec4 hi;
};
RP_CHECK_SIZE(GpuNode, 32);
RP_CHECK_OFFSET(GpuNode, hi, 16);

// 80 bytes: a node of the compressed 8-wide tree (Ylitie, Karras and Laine 2017, "Efficient
// Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs"), which the single-ray kernel
// traces with RenderSettings::bvhWidth 8 (the tracer gpu-cwbvh; made from the binary tree at upload
// by makeGpuWideTree, renderer/gpu_wide.h; read by shaders/wide_node.h). Up to eight children, each
// box quantized to 8 bits per plane on a grid of the node's own: child i spans, on axis a,
//   [origin[a] + scale[a] * qlo[a][i], origin[a] + scale[a] * qhi[a][i]]
// with scale[a] = 2^(exponent[a] - 127); the host checked that these planes contain the child's box
// both as exact reals (the kernel's fused slab test) and as floats decoded with one exact product
// and one rounded sum (its decoded-box path; shaders/wide_node.h).
//   origin.xyz: the grid's origin (the node box's low corner)
//   origin.w (uint bits): byte 0, 1, 2 the biased exponents of x, y, z; byte 3 the inner-child mask
//             (bit i: child slot i is an inner node)
//   index.x: wide node index of the first inner child; the inner children are consecutive in slot
//            order (slot i's node is index.x + the number of inner slots below i)
//   index.y: leaf-order index of the node's first triangle: every leaf child's triangles lie within
//            the 24 after it
//   index.z, index.w: the slots' meta bytes (slot i in byte i % 4 of z for i < 4, else of w):
//            0 an empty slot; an inner child 0x20 | (24 + i); a leaf of n (1 to 3) triangles
//            ((1 << n) - 1) << 5 | k, its triangles index.y + k .. index.y + k + n - 1
//   quant[0]: qlo x of slots 0-3, 4-7 (x, y), qlo y of slots 0-3, 4-7 (z, w); a slot's byte as in index
//   quant[1]: qlo z (x, y), qhi x (z, w)
//   quant[2]: qhi y (x, y), qhi z (z, w)
// The slots are ordered by direction: slot s holds the child that a ray of octant s (bit a set:
// negative direction on axis a) meets first, so a ray of octant o that visits the slots in the
// order s ^ o for s = 0, 1, ..., 7 meets the children roughly front to back (rayOctant,
// shaders/wide_node.h). Node 0 is the root, which the kernel enters without a box test; an empty
// scene's root has no children.
struct GpuWideNode {
    vec4 origin;
    uvec4 index;
    uvec4 quant[3];
};
RP_CHECK_SIZE(GpuWideNode, 80);
RP_CHECK_OFFSET(GpuWideNode, index, 16);
RP_CHECK_OFFSET(GpuWideNode, quant, 32);
const uint kWideInnerMeta = 0x20u;  // an inner child's meta byte: kWideInnerMeta | (24 + slot)
const uint kWideMaxLeafTriangles = 3u;
const uint kWideNodeTriangles = 24u;  // triangles a node's leaf children hold at most

// 48 bytes: the three corners, gathered in leaf order so that a leaf's triangles are contiguous
// and the watertight test (Woop, Benthin, Wald 2013) reads its vertices without an index fetch.
//   v0.w (uint bits): the triangle's index in file order (HitRecord::prim)
//   v1.w (uint bits): material index (0 when the scene has no materials)
//   v2.w: 0
struct GpuTriangle {
    vec4 v0;
    vec4 v1;
    vec4 v2;
};
RP_CHECK_SIZE(GpuTriangle, 48);

// 48 bytes, leaf order, present only when the scene has vertex normals: the normals at v0, v1, v2.
struct GpuTriangleNormals {
    vec4 n0;
    vec4 n1;
    vec4 n2;
};
RP_CHECK_SIZE(GpuTriangleNormals, 48);

// 32 bytes, leaf order, present only when the scene has UVs (a material has a texture): the UVs
// at v0, v1, v2 as uv01 = (u0, v0, u1, v1), uv2 = (u2, v2, 0, 0).
struct GpuTriangleUvs {
    vec4 uv01;
    vec4 uv2;
};
RP_CHECK_SIZE(GpuTriangleUvs, 32);

// 16 bytes, leaf order, present only when the scene has vertex colours: RGBA8 (texture.h's
// packing) at v0, v1, v2 in x, y, z; w: 0.
struct GpuTriangleColors {
    uvec4 rgba;
};
RP_CHECK_SIZE(GpuTriangleColors, 16);

// 16 bytes per material: diffuse.xyz the colour, diffuse.w (uint bits) the index of its texture in
// the texture table (GpuTexture), or kNoTextureIndex.
struct GpuMaterial {
    vec4 diffuse;
};
RP_CHECK_SIZE(GpuMaterial, 16);

// Bits of GpuFrameParams::frame.z.
const uint kFrameWriteHits = 1u;     // write HitRecords
const uint kFrameBgra = 2u;          // output bytes in B, G, R, A order
const uint kFrameHasNormals = 4u;    // the normals buffer holds real data
const uint kFrameHasMaterials = 8u;  // the materials buffer holds real data
const uint kFrameHasUvs = 16u;       // the UV, texture table and texel buffers hold real data
const uint kFrameHasColors = 32u;    // the vertex colour buffer holds real data

// 128 bytes: the push constants of every pass (the guaranteed minimum of maxPushConstantsSize).
struct GpuFrameParams {
    GpuCamera camera;  // 64 bytes, shaders/camera.h
    vec4 light;        // xyz: point light position, w: 0
    vec4 background;   // rgb: colour of a miss, w: heat-map scale (value shown as full red)
    vec4 phong;        // ambient, diffuse, specular, shininess
    uvec4 frame;       // x: width, y: height, z: kFrame* bits, w: packets per image row
};
RP_CHECK_SIZE(GpuFrameParams, 128);
RP_CHECK_OFFSET(GpuFrameParams, light, 64);
RP_CHECK_OFFSET(GpuFrameParams, frame, 112);

// 16 bytes per pixel: what the primary pass hands the shadow pass.
//   x: t (+inf on a miss), y (uint bits): triangle in leaf order or kNoHit, z, w: barycentrics u, v
struct GpuPrimaryHit {
    vec4 data;
};
RP_CHECK_SIZE(GpuPrimaryHit, 16);

// Values of the kernel specialization constants (constant_id in shaders/trace.comp).
const uint kKernelPacket = 0u;
const uint kKernelSingle = 1u;
const uint kKernelHybrid = 2u;      // packet while coherent, then each ray alone (docs/gpu.md)
const uint kPassPrimary = 0u;       // trace primary rays, keep the hits for the shadow pass
const uint kPassPrimaryShade = 1u;  // trace primary rays and shade (shadows off)
const uint kPassShadowShade = 2u;   // trace shadow rays for the kept hits and shade
const uint kViewShaded = 0u;
const uint kViewHeatTraversal = 1u;
const uint kViewHeatIntersections = 2u;

// The most steps (inner nodes visited plus triangles tested) one ray, or one packet, may take in a
// pass. Lavapipe (llvmpipe) ends any shader loop silently after 65,535 iterations in all, which
// made rays through huge leaves miss (issue 11); the kernels stop at this bound instead and say so
// (kStatusTraversalTruncated), and the BVH builders never make a leaf of more than
// kMaxLeafPrimitives (renderer/bvh.h) triangles, so a ray can test dozens of full leaves within it.
const uint kMaxTraversalSteps = 60000u;

// Status word written by the kernels (should stay 0): set when a stack would overflow, which the
// host's sizing from the tree's depth rules out; checked after every synchronous frame.
const uint kStatusStackOverflow = 1u;
// Set when the host compiled a packet as one subgroup (kPacketIsOneSubgroup) but the device split
// it across subgroups; the packet then traces nothing and render() throws.
const uint kStatusSubgroupMismatch = 2u;
// Set when a ray or packet reached kMaxTraversalSteps and stopped: its answer may be wrong, so
// render() throws instead of returning it.
const uint kStatusTraversalTruncated = 4u;

RP_END_NAMESPACE

#endif  // RAYPACK_SHADERS_GPU_TYPES_H
