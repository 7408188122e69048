#pragma once
// What renderer/cpu_packet_tracer.cpp hands the SIMD translation units (cpu_packet_sse41.cpp,
// cpu_packet_avx2.cpp): one frame's data, and one function per pass and width that traces the
// packet whose top-left pixel is (x0, y0). Those units compile cpu_packet_simd.inl under
// `#pragma GCC target("sse4.1")` or `("avx2")` (never "fma": the triangle test's products must
// round as shaders/intersect.h rounds them), so the rest of the program stays baseline x86-64 and
// runs on any CPU; cpu_packet_tracer.cpp calls them only where CPUID says the CPU has the width.
#include "renderer/bvh.h"
#include "renderer/cpu_tracer.h"
#include "renderer/frame.h"
#include "renderer/settings.h"
#include "shaders/camera.h"

#include <glm/glm.hpp>

#include <cstdint>

namespace raypack::packet_detail {

struct PacketFrame {
    const BvhNode* nodes = nullptr;           // CpuSceneView::nodes()
    const glm::vec3* leafVertices = nullptr;  // CpuSceneView::leafVertices
    const uint32_t* primIndices = nullptr;    // Bvh::primIndices
    const Scene* scene = nullptr;             // the triangles by file index, for the hit's final t
    uint32_t stackEntries = 1;                // CpuSceneView::stackEntries
    gpu::GpuCamera camera{};
    glm::vec3 eye{0.0f};
    glm::vec3 light{0.0f};
    uint32_t width = 0;  // image
    uint32_t height = 0;
    PacketShape packet;               // W x H rays per packet
    ClosestHit* hits = nullptr;       // one per pixel: written by the primary pass, read by shadow
    uint32_t* shadowState = nullptr;  // one per pixel: written by the shadow pass
    RayCounters* counters = nullptr;  // one per pixel; null: do not count (the faster kernel)
    IntersectMode intersect = IntersectMode::Robust;
};

void tracePrimaryPacketSse41(const PacketFrame& frame, uint32_t x0, uint32_t y0);
void traceShadowPacketSse41(const PacketFrame& frame, uint32_t x0, uint32_t y0);
void tracePrimaryPacketAvx2(const PacketFrame& frame, uint32_t x0, uint32_t y0);
void traceShadowPacketAvx2(const PacketFrame& frame, uint32_t x0, uint32_t y0);

}  // namespace raypack::packet_detail
