#include "renderer/cpu_packet_tracer.h"

#include "renderer/camera.h"
#include "renderer/cpu_packet_kernel.h"
#include "renderer/error.h"
#include "renderer/measure/spread.h"
#include "shaders/camera.h"
#include "shaders/intersect.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string>

namespace raypack {
namespace {

using Clock = SteadyClock;

bool cpuHas(CpuSimd simd) {
    switch (simd) {
    case CpuSimd::Scalar: return true;
#if defined(__x86_64__) || defined(__i386__)
    case CpuSimd::Sse41: return __builtin_cpu_supports("sse4.1");
    // libgcc's check includes the OS saving the AVX state (XGETBV).
    case CpuSimd::Avx2: return __builtin_cpu_supports("avx2");
#else
    case CpuSimd::Sse41:
    case CpuSimd::Avx2: return false;
#endif
    }
    return false;
}

using PacketFunction = void (*)(const packet_detail::PacketFrame&, uint32_t, uint32_t);

// The scalar fallback: the packet's pixels one by one through the CPU reference's traversal.
void tracePrimaryScalar(const CpuSceneView& view, const packet_detail::PacketFrame& frame, uint32_t x0, uint32_t y0) {
    const uint32_t x1 = std::min(frame.width, x0 + frame.packet.width);
    const uint32_t y1 = std::min(frame.height, y0 + frame.packet.height);
    for (uint32_t y = y0; y < y1; ++y) {
        for (uint32_t x = x0; x < x1; ++x) {
            const size_t pixel = size_t(y) * frame.width + x;
            const glm::vec3 dir = gpu::primaryRayDirection(frame.camera, x, y);
            TraversalCounts counts;
            frame.hits[pixel] = traceClosestHit(view, frame.eye, dir, kRayTmaxInfinite, &counts, frame.intersect);
            if (frame.counters) {
                frame.counters[pixel].primaryNodes = counts.nodes;
                frame.counters[pixel].primaryTests = counts.tests;
            }
        }
    }
}

void traceShadowScalar(const CpuSceneView& view, const packet_detail::PacketFrame& frame, uint32_t x0, uint32_t y0) {
    const uint32_t x1 = std::min(frame.width, x0 + frame.packet.width);
    const uint32_t y1 = std::min(frame.height, y0 + frame.packet.height);
    for (uint32_t y = y0; y < y1; ++y) {
        for (uint32_t x = x0; x < x1; ++x) {
            const size_t pixel = size_t(y) * frame.width + x;
            const ClosestHit& hit = frame.hits[pixel];
            if (!hit.hit()) continue;
            const glm::vec3 dir = gpu::primaryRayDirection(frame.camera, x, y);
            const glm::vec3 point = gpu::hitPosition(frame.eye, dir, hit.t);
            TraversalCounts counts;
            const bool occluded = traceShadowOccluded(view, frame.light, point, hit.prim, &counts, frame.intersect);
            frame.shadowState[pixel] = occluded ? gpu::kShadowOccluded : gpu::kShadowLit;
            if (frame.counters) {
                frame.counters[pixel].shadowNodes = counts.nodes;
                frame.counters[pixel].shadowTests = counts.tests;
            }
        }
    }
}

}  // namespace

const char* toString(CpuSimd simd) {
    switch (simd) {
    case CpuSimd::Scalar: return "scalar";
    case CpuSimd::Sse41: return "sse";
    case CpuSimd::Avx2: return "avx2";
    }
    return "?";
}

CpuSimd cpuSimdSupported() {
    if (cpuHas(CpuSimd::Avx2)) return CpuSimd::Avx2;
    if (cpuHas(CpuSimd::Sse41)) return CpuSimd::Sse41;
    return CpuSimd::Scalar;
}

CpuSimd cpuSimdSelected() {
    const char* value = std::getenv("RAYPACK_CPU_SIMD");
    if (!value || !*value) return cpuSimdSupported();
    CpuSimd simd;
    if (std::strcmp(value, "scalar") == 0)
        simd = CpuSimd::Scalar;
    else if (std::strcmp(value, "sse") == 0)
        simd = CpuSimd::Sse41;
    else if (std::strcmp(value, "avx2") == 0)
        simd = CpuSimd::Avx2;
    else
        throw Error(std::string("RAYPACK_CPU_SIMD: \"") + value + "\" is not scalar, sse or avx2");
    if (!cpuHas(simd))
        throw Error(std::string("RAYPACK_CPU_SIMD=") + value + ": this CPU lacks " +
                    (simd == CpuSimd::Avx2 ? "AVX2" : "SSE4.1"));
    return simd;
}

Frame renderCpuPackets(const CpuSceneView& view, const RenderSettings& settings, const FrameRequest& request) {
    return renderCpuPackets(view, settings, request, cpuSimdSelected());
}

Frame renderCpuPackets(const CpuSceneView& view, const RenderSettings& settings, const FrameRequest& request,
                       CpuSimd simd) {
    const Clock::time_point frameStart = Clock::now();
    RAYPACK_CHECK_MSG(view.scene && view.bvh, "a CpuSceneView made by makeCpuSceneView");
    if (!cpuHas(simd)) throw Error(std::string("CPU packet tracer: this CPU lacks ") + toString(simd));
    if (settings.packet.width == 0 || settings.packet.height == 0)
        throw Error("CPU packet tracer: the packet shape must be at least 1x1");
    const uint32_t width = settings.width;
    const uint32_t height = settings.height;
    const gpu::GpuCamera camera = makeGpuCamera(settings.camera, width, height, settings.pixelJitter);
    const size_t pixels = size_t(width) * height;

    Frame frame;
    frame.width = width;
    frame.height = height;
    frame.light = lightPosition(settings.camera, view.bounds, settings.lightHeight);

    std::vector<ClosestHit> hits(pixels);
    std::vector<RayCounters> counters(pixels, RayCounters{0, 0, 0, 0});
    std::vector<uint32_t> shadowState(pixels, gpu::kShadowNone);
    // Counting costs a pass over the packet's groups per node, so the kernel counts only when
    // asked to (the reference always counts).
    const bool count = request.counters || settings.collectCounters || settings.view != ViewMode::Shaded;

    packet_detail::PacketFrame packetFrame;
    packetFrame.nodes = view.nodes();
    packetFrame.leafVertices = view.leafVertices.data();
    packetFrame.primIndices = view.bvh->primIndices.data();
    packetFrame.scene = view.scene;
    packetFrame.stackEntries = view.stackEntries;
    packetFrame.camera = camera;
    packetFrame.eye = gpu::cameraEye(camera);
    packetFrame.light = frame.light;
    packetFrame.width = width;
    packetFrame.height = height;
    packetFrame.packet = settings.packet;
    packetFrame.hits = hits.data();
    packetFrame.shadowState = shadowState.data();
    packetFrame.counters = count ? counters.data() : nullptr;
    packetFrame.intersect = settings.intersect;

    PacketFunction primary = nullptr;
    PacketFunction shadow = nullptr;
    if (simd == CpuSimd::Avx2) {
        primary = packet_detail::tracePrimaryPacketAvx2;
        shadow = packet_detail::traceShadowPacketAvx2;
    } else if (simd == CpuSimd::Sse41) {
        primary = packet_detail::tracePrimaryPacketSse41;
        shadow = packet_detail::traceShadowPacketSse41;
    }

    const uint32_t packetsX = (width + settings.packet.width - 1) / settings.packet.width;
    const uint32_t packetsY = (height + settings.packet.height - 1) / settings.packet.height;
    const uint32_t packetCount = packetsX * packetsY;
    // One packet per task, handed out dynamically (TBB's work stealing, no fixed split): packets
    // of a busy part of the image take longer, and no core idles while others still have some.
    const auto forEachPacket =
        [&](PacketFunction kernel,
            void (*scalar)(const CpuSceneView&, const packet_detail::PacketFrame&, uint32_t, uint32_t)) {
            tbb::parallel_for(
                tbb::blocked_range<uint32_t>(0, packetCount, 1),
                [&](const tbb::blocked_range<uint32_t>& range) {
                    for (uint32_t p = range.begin(); p != range.end(); ++p) {
                        const uint32_t x0 = (p % packetsX) * settings.packet.width;
                        const uint32_t y0 = (p / packetsX) * settings.packet.height;
                        if (kernel)
                            kernel(packetFrame, x0, y0);
                        else
                            scalar(view, packetFrame, x0, y0);
                    }
                },
                tbb::simple_partitioner());
        };

    Clock::time_point passStart = Clock::now();
    forEachPacket(primary, tracePrimaryScalar);
    frame.timings.primarySeconds = secondsSince(passStart);

    if (settings.shadows) {
        passStart = Clock::now();
        forEachPacket(shadow, traceShadowScalar);
        frame.timings.shadowSeconds = secondsSince(passStart);
    }

    passStart = Clock::now();
    shadeCpuFrame(*view.scene, settings, camera, hits, shadowState, counters, request, frame);
    frame.timings.shadeSeconds = secondsSince(passStart);
    if (request.counters) frame.counters = std::move(counters);
    frame.timings.totalSeconds = secondsSince(frameStart);
    return frame;
}

}  // namespace raypack
