#include "app/cli/tracing.h"

#include "renderer/error.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <thread>

namespace raypack::cli {

std::string cpuModel() {
    std::ifstream in("/proc/cpuinfo");
    std::string line;
    while (std::getline(in, line)) {
        if (line.rfind("model name", 0) == 0) {
            const size_t colon = line.find(':');
            if (colon != std::string::npos) {
                const size_t start = line.find_first_not_of(" \t", colon + 1);
                if (start != std::string::npos) return line.substr(start);
            }
        }
    }
    return "unknown CPU";
}

uint32_t cpuThreads() { return std::max(1u, std::thread::hardware_concurrency()); }

std::string describeCpuDevice() {
    return "CPU reference, " + cpuModel() + " (" + std::to_string(cpuThreads()) + " threads)";
}

GpuSession::GpuSession(const std::string& device, bool validation, bool rayTracing) {
    vk::VulkanContextOptions options;
    options.device = device;
    options.validation = validation;
    options.enableRayTracing = rayTracing;
    options.applicationName = "raypack-cli";
    context = vk::createVulkanContext(options);
    try {
        tracer = std::make_unique<GpuTracer>(context);
    } catch (...) {
        vk::destroyVulkanContext(context);
        throw;
    }
}

GpuSession::~GpuSession() {
    tracer.reset();
    vk::destroyVulkanContext(context);
}

std::string describeCpuPacketDevice(PacketShape packet) {
    return "CPU packets " + std::to_string(packet.width) + "x" + std::to_string(packet.height) + " (" +
           toString(cpuSimdSelected()) + "), " + cpuModel() + " (" + std::to_string(cpuThreads()) + " threads)";
}

namespace {

// GPU time traced back to back right before the timed frames (at most so many frames).
constexpr double kGpuWarmUpSeconds = 0.3;
constexpr uint32_t kGpuWarmUpMaxFrames = 2000;

Frame renderWith(const FrameSource& source, const RenderSettings& settings, const FrameRequest& request) {
    RAYPACK_CHECK((source.cpu != nullptr) != (source.gpu != nullptr));
    if (source.cpu)
        return source.cpuPackets ? renderCpuPackets(*source.cpu, settings, request)
                                 : renderCpu(*source.cpu, settings, request);
    return source.gpu->render(settings, request);
}

}  // namespace

MeasuredFrames measureFrames(const FrameSource& source, const RenderSettings& settings, uint32_t repeats,
                             bool wantImage) {
    RAYPACK_CHECK(repeats >= 1);
    MeasuredFrames measured;
    // Warm-up: counts N_TR / N_IT, and collects the hits, which also tell which pixels cast a
    // shadow ray (N_Q of shadow rays). Not timed.
    RenderSettings counting = settings;
    counting.collectCounters = true;
    FrameRequest countingRequest;
    countingRequest.image = wantImage;
    countingRequest.hits = true;
    countingRequest.counters = true;
    measured.frame = renderWith(source, counting, countingRequest);
    const CounterSummary counters = summarizeCounters(measured.frame);

    RenderSettings timed = settings;
    // The heat views draw the counters, so they keep the counting kernel.
    timed.collectCounters = settings.view != ViewMode::Shaded;
    FrameRequest timedRequest;
    timedRequest.image = true;  // the frame as a user gets it
    // A second warm-up in the timed configuration: the counting run used another kernel variant
    // on the GPU, and a driver may compile a pipeline at its first dispatch (lavapipe's JIT).
    const Frame first = renderWith(source, timed, timedRequest);
    // On a GPU, then kGpuWarmUpSeconds of frames back to back: a GPU lowers its clocks when it
    // idles, and frames of a millisecond, each followed by a wait and a read-back, leave it mostly
    // idle. On the H100 the SM clock fell from 1980 to its idle 345 MHz a few seconds into a bench
    // run (nvidia-smi, 2026-11-22), and later cells measured up to 5.7x slower than the same cell
    // in a process of its own. The timed frames follow at once, before the clocks can fall again.
    if (source.gpu) {
        const double frameSeconds = std::max(first.timings.primarySeconds + first.timings.shadowSeconds, 1e-6);
        const double frames = std::ceil(kGpuWarmUpSeconds / frameSeconds);
        source.gpu->traceBackToBack(timed, uint32_t(std::clamp(frames, 1.0, double(kGpuWarmUpMaxFrames))));
    }
    std::vector<FrameTimings> timings;
    for (uint32_t i = 0; i < repeats; ++i) timings.push_back(renderWith(source, timed, timedRequest).timings);

    measured.stats = summarizeRuns(counters, timings, source.uploadSeconds);
    measured.stats.countersMeasured = true;
    measured.stats.gpu = source.gpu != nullptr;
    measured.stats.device = source.gpu          ? vk::describe(source.gpu->device())
                            : source.cpuPackets ? describeCpuPacketDevice(settings.packet)
                                                : describeCpuDevice();
    measured.stats.width = settings.width;
    measured.stats.height = settings.height;
    return measured;
}

}  // namespace raypack::cli
