#include "app/cli/tracing.h"

#include "renderer/error.h"

#include <chrono>
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

// Untimed frames right before the timed ones on a GPU: at least this long, at most this many.
constexpr double kGpuWarmUpSeconds = 0.5;
constexpr uint32_t kGpuWarmUpMaxFrames = 10000;

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
    // On a GPU it lasts kGpuWarmUpSeconds rather than one frame: a GPU lowers its clocks when it
    // idles, and frames of a millisecond with a read-back after each leave it mostly idle. On the
    // H100 the SM clock fell from 1980 to 345 MHz about 3 s into such a bench run (nvidia-smi,
    // 2026-11-22) and the cells after that measured up to 5.7x slower than in a process of their
    // own; with a timed warm-up right before them the timed frames run at the clock a sustained
    // load gets.
    const auto warmUpStart = std::chrono::steady_clock::now();
    for (uint32_t frames = 0;; ++frames) {
        renderWith(source, timed, timedRequest);
        const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - warmUpStart;
        if (!source.gpu || elapsed.count() >= kGpuWarmUpSeconds || frames >= kGpuWarmUpMaxFrames)
            break;
    }
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
