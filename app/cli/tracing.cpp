#include "app/cli/tracing.h"

#include "renderer/error.h"

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

namespace {

Frame renderWith(const FrameSource& source, const RenderSettings& settings,
                 const FrameRequest& request) {
    RAYPACK_CHECK((source.cpu != nullptr) != (source.gpu != nullptr));
    if (source.cpu) return renderCpu(*source.cpu, settings, request);
    return source.gpu->render(settings, request);
}

}  // namespace

MeasuredFrames measureFrames(const FrameSource& source, const RenderSettings& settings,
                             uint32_t repeats, bool wantImage) {
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
    renderWith(source, timed, timedRequest);
    std::vector<FrameTimings> timings;
    for (uint32_t i = 0; i < repeats; ++i)
        timings.push_back(renderWith(source, timed, timedRequest).timings);

    measured.stats = summarizeRuns(counters, timings, source.uploadSeconds);
    measured.stats.countersMeasured = true;
    measured.stats.gpu = source.gpu != nullptr;
    measured.stats.device = source.gpu ? vk::describe(source.gpu->device()) : describeCpuDevice();
    measured.stats.width = settings.width;
    measured.stats.height = settings.height;
    return measured;
}

}  // namespace raypack::cli
