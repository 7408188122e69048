#pragma once
// The CPU packet tracer (issue 9; Wald, Boulos, Shirley 2007; Overbeck, Ramamoorthi, Mark 2008):
// image tiles of W x H primary rays traced together through the canonical BVH, SIMD over rays
// (8 lanes with AVX2, 4 with SSE4.1, chosen at run time from CPUID), then shadow packets from the
// point light with per-lane termination. It gives the same hits as the CPU reference
// (renderer/cpu_tracer.h): the same camera rays, the same watertight triangle test and
// conservative slab test (shaders/intersect.h), vectorised operation for operation, and closest
// hits ordered by (t, triangle index), which does not depend on the order nodes are visited in.
//
// Traversal of one packet (cpu_packet_kernel.h):
//  - the packet's rays are cut into groups of one SIMD width (2x2 pixels with SSE, 4x2 with AVX2);
//  - at a node, an interval test of the whole packet's rays (common origin, the bounds of their
//    inverse directions: Wald 2007, Reshetov 2005) culls boxes no ray can touch; then the groups
//    are tested from the first active one on until one hits ("first hit ray", Overbeck 2008's
//    ranged traversal): the groups before it miss the node and hence every node below it, so the
//    subtree is traversed from that group on;
//  - inner nodes: the child on the packet's side of the children's split is visited first, the
//    other pushed with the first active group; a leaf is tested by every group of the range whose
//    box test passes, its triangles by the lanes that passed;
//  - the packet ends when the stack is empty or, for shadow packets, when every ray is occluded.
// The stack holds the tree's depth + 1 entries (CpuSceneView::stackEntries), never a fixed cap.
//
// Counters (as the GPU packet kernel counts them, per ray):
//  N_TR (nodes): nodes the packet visits while the ray is active and its group lies in the
//               packet's active range (a shadow ray stops counting once occluded);
//  N_IT (tests): triangle tests whose result the ray uses: leaf triangles, for the rays whose box
//               test of that leaf passed (a shadow ray does not test the triangle it starts from).
#include "renderer/cpu_tracer.h"

#include <string>

namespace raypack {

// Which code traces the packets. Scalar: the packet's rays one by one through the CPU reference's
// traversal (any x86-64); Sse41: 4 lanes; Avx2: 8 lanes (no FMA: watertightness needs the exact
// products of shaders/intersect.h).
enum class CpuSimd { Scalar, Sse41, Avx2 };

const char* toString(CpuSimd simd);
// The widest this CPU runs (CPUID).
CpuSimd cpuSimdSupported();
// What renderCpuPackets uses: RAYPACK_CPU_SIMD=scalar|sse|avx2 when set, else cpuSimdSupported().
// Throws raypack::Error when the variable names another value or a width this CPU lacks.
CpuSimd cpuSimdSelected();

// The packet shape the viewer uses on CPU devices (docs/cpu-packet.md: of 4x4, 8x8, 16x16 and 32x32
// the fastest or within 13% of the fastest on every report scene, primary and shadow rays, on
// the 2-core development machine).
inline constexpr PacketShape kDefaultCpuPacket{16, 16};

// One frame like renderCpu (same primary rays, shadow rays, shading through shadeCpuFrame, the
// same timings), traced in packets of settings.packet (any W x H: tiles at the image border are
// cut, their missing rays are padding lanes). Packets are image tiles handed out dynamically to
// the threads of the caller's TBB arena. Throws raypack::Error for a degenerate camera or an
// empty image.
Frame renderCpuPackets(const CpuSceneView& view, const RenderSettings& settings, const FrameRequest& request = {});
// The same with the SIMD width given (tests force each width; throws raypack::Error when this CPU
// lacks it).
Frame renderCpuPackets(const CpuSceneView& view, const RenderSettings& settings, const FrameRequest& request,
                       CpuSimd simd);

}  // namespace raypack
