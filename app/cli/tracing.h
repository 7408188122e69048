#pragma once
// The per-frame arrow of raypack's data flow as the CLI measures it: camera + settings -> tracer
// (CPU reference or Vulkan GPU tracer) -> Frame, one warm-up run that also counts N_TR / N_IT and
// collects the hits, one untimed run of the timed configuration, then N timed runs that do not count (so that the GPU's
// statistics variant of the kernel never inflates T_K).
#include "app/cli/statistics.h"
#include "renderer/cpu_packet_tracer.h"
#include "renderer/cpu_tracer.h"
#include "renderer/gpu_tracer.h"
#include "renderer/vk/context.h"

#include <memory>
#include <string>

namespace raypack::cli {

enum class DeviceKind { Cpu, Gpu };

// "CPU reference, AMD EPYC (2 threads)".
std::string describeCpuDevice();
// "CPU packets 16x16 (avx2), AMD EPYC (2 threads)".
std::string describeCpuPacketDevice(PacketShape packet);
// CPU model from /proc/cpuinfo ("unknown CPU" when it cannot be read).
std::string cpuModel();
uint32_t cpuThreads();

// A Vulkan context and the GPU tracer on it, destroyed in the right order.
struct GpuSession {
    vk::VulkanContext context;
    std::unique_ptr<GpuTracer> tracer;
    // `device`: "" automatic, an index or a name substring (vk::VulkanContextOptions::device).
    // Throws raypack::Error when there is no usable Vulkan device.
    // `rayTracing` also enables the driver's ray tracing where the device offers it (for the
    // bench's driver ray tracing peer); the device is chosen the same way either way.
    GpuSession(const std::string& device, bool validation, bool rayTracing = false);
    ~GpuSession();
    GpuSession(const GpuSession&) = delete;
    GpuSession& operator=(const GpuSession&) = delete;
};

// What traces the frames: the CPU reference (or, with cpuPackets, the CPU packet tracer) over a
// prepared view, or a GPU tracer with the scene uploaded (uploadSeconds = T_CU).
struct FrameSource {
    const CpuSceneView* cpu = nullptr;
    bool cpuPackets = false;  // renderCpuPackets with settings.packet instead of renderCpu
    GpuTracer* gpu = nullptr;
    double uploadSeconds = 0.0;
};

struct MeasuredFrames {
    Frame frame;  // the warm-up run: image, hits (when asked for) and counters
    FrameStats stats;
};

// Renders once with counters and hits (plus the image when `wantImage`), once more untimed without
// counters (the warm-up of the timed configuration), then `repeats` (>= 1) timed times without
// counters; summarizes Table 2. Throws raypack::Error from the tracer.
MeasuredFrames measureFrames(const FrameSource& source, const RenderSettings& settings, uint32_t repeats,
                             bool wantImage);

}  // namespace raypack::cli
