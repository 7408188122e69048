#pragma once
// The measurement protocol over any tracer (renderer/tracers/tracer.h), as raypack-cli render and
// bench run it: one warm-up run that also counts N_TR / N_IT and collects the hits, one untimed run
// of the timed configuration, on a GPU frames back to back so that its clocks are up, then N timed
// runs that do not count (so that the GPU's statistics variant of the kernel never inflates T_K).
#include "renderer/measure/statistics.h"
#include "renderer/measure/warm_up.h"
#include "renderer/tracers/tracer.h"

#include <cstdint>

namespace raypack {

struct MeasuredFrames {
    Frame frame;  // the warm-up run: image, hits (when asked for) and counters
    FrameStats stats;
};

// Renders once with counters and hits (plus the image when `wantImage`), once more untimed without
// counters (the warm-up of the timed configuration), then `repeats` (>= 1) timed times without
// counters; summarizes Table 2 with `preparation`'s T_CU. On a GPU, frames run back to back before
// the timed ones for at least `gpuWarmUpSeconds` and until their speed has settled
// (warmUpUntilSteady): less where the GPU has just been busy (the trade suite's cells that follow
// another GPU cell). Throws raypack::Error from the tracer.
MeasuredFrames measureFrames(Tracer& tracer, const Preparation& preparation, const RenderSettings& settings,
                             uint32_t repeats, bool wantImage, double gpuWarmUpSeconds = kGpuWarmUpSeconds);

}  // namespace raypack
