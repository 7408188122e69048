#include "renderer/measure/protocol.h"

#include "renderer/error.h"
#include "renderer/measure/spread.h"
#include "renderer/measure/warm_up.h"

namespace raypack {

MeasuredFrames measureFrames(Tracer& tracer, const Preparation& preparation, const RenderSettings& settings,
                             uint32_t repeats, bool wantImage, double gpuWarmUpSeconds) {
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
    measured.frame = tracer.render(counting, countingRequest);
    const CounterSummary counters = summarizeCounters(measured.frame);

    RenderSettings timed = settings;
    // The heat views draw the counters, so they keep the counting kernel.
    timed.collectCounters = settings.view != ViewMode::Shaded;
    FrameRequest timedRequest;
    timedRequest.image = true;  // the frame as a user gets it
    // A second warm-up in the timed configuration: the counting run used another kernel variant
    // on the GPU, and a driver may compile a pipeline at its first dispatch (lavapipe's JIT).
    const Frame first = tracer.render(timed, timedRequest);
    // On a GPU, then frames back to back until their speed has settled (warmUpUntilSteady), for at
    // least gpuWarmUpSeconds (by default kGpuWarmUpSeconds, 0.5 s): a GPU lowers its clocks when it idles,
    // and frames of a millisecond, each followed by a wait and a read-back, leave it mostly idle. On
    // the H100 the SM clock fell from 1980 to its idle 345 MHz a few seconds into a bench run
    // (nvidia-smi, 2026-11-22), and later cells measured up to 5.7x slower than the same cell in a
    // process of its own. A fixed 0.3 s of frames (until 2026-12-07) left some cells of the largest
    // scenes, which follow seconds of loading and building on the host, 3x slower from their first
    // timed frame to their last, the SM clock at 480-615 MHz (docs/gpu.md, "The slow mode of the
    // large scans"). The timed frames follow at once, before the clocks can fall again.
    const bool gpu = tracer.device() == TracerDevice::Gpu;
    GpuWarmUp warmUp;
    if (gpu) {
        const double frameSeconds = first.timings.primarySeconds + first.timings.shadowSeconds;
        warmUp = warmUpUntilSteady(
            [&](uint32_t frames) {
                const SteadyClock::time_point start = SteadyClock::now();
                tracer.warmUp(timed, frames);
                return secondsSince(start);
            },
            frameSeconds, gpuWarmUpSeconds);
    }
    std::vector<FrameTimings> timings;
    for (uint32_t i = 0; i < repeats; ++i) timings.push_back(tracer.render(timed, timedRequest).timings);

    measured.stats = summarizeRuns(counters, timings, preparation.isUpload ? preparation.seconds : 0.0);
    measured.stats.countersMeasured = true;
    measured.stats.uploadAllocationSeconds = preparation.allocationSeconds;
    measured.stats.uploadConversionSeconds = preparation.conversionSeconds;
    measured.stats.uploadTransferSeconds = preparation.transferSeconds;
    measured.stats.preparedBytes = preparation.bytes;
    measured.stats.gpu = gpu;
    measured.stats.warmUp = warmUp;
    measured.stats.device = tracer.describe(settings);
    measured.stats.width = settings.width;
    measured.stats.height = settings.height;
    return measured;
}

}  // namespace raypack
