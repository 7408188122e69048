#include "renderer/measure/warm_up.h"

#include <algorithm>
#include <cmath>

namespace raypack {
namespace {

// The frames of one warm-up batch at most.
constexpr uint32_t kGpuWarmUpMaxFrames = 2000;

}  // namespace

GpuWarmUp warmUpUntilSteady(const std::function<double(uint32_t frames)>& runBatch, double frameSeconds,
                            double minSeconds, double maxSeconds) {
    GpuWarmUp warmUp;
    const double batchSeconds = minSeconds / 3.0;
    double perFrame = std::max(frameSeconds, 1e-6);
    double before = 0.0;  // the previous batch's seconds per frame
    while (true) {
        const double wanted = minSeconds > 0.0 ? std::ceil(batchSeconds / perFrame) : 1.0;
        const uint32_t frames = uint32_t(std::clamp(wanted, 1.0, double(kGpuWarmUpMaxFrames)));
        const double seconds = runBatch(frames);
        warmUp.seconds += seconds;
        warmUp.frames += frames;
        ++warmUp.batches;
        perFrame = std::max(seconds / double(frames), 1e-9);
        if (minSeconds <= 0.0) break;
        const bool longEnough = warmUp.seconds >= minSeconds;
        if (longEnough && frames == 1 && seconds >= batchSeconds) {
            warmUp.steady = true;  // one frame outlasts a batch: it keeps the device busy by itself
            break;
        }
        if (longEnough && warmUp.batches >= 2 && perFrame >= before * (1.0 - kGpuWarmUpSteadyShare)) {
            warmUp.steady = true;
            break;
        }
        if (warmUp.seconds >= maxSeconds) break;
        before = perFrame;
    }
    return warmUp;
}

}  // namespace raypack
