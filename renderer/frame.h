#pragma once
// What a tracer (CPU reference or GPU) hands back for one frame. Both fill the same value so that
// images, hits and counters compare directly.
#include "shaders/frame_types.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace raypack {

using gpu::HitRecord;
using gpu::RayCounters;

struct FrameRequest {
    bool image = true;      // shaded (or heat-map) RGBA8 image
    bool hits = false;      // one HitRecord per pixel
    bool counters = false;  // one RayCounters per pixel (N_TR, N_IT for primary and shadow rays)
};

// Seconds. For the GPU, kernel times come from timestamp queries; for the CPU, wall clock.
struct FrameTimings {
    double primarySeconds = 0.0;  // tracing primary rays
    double shadowSeconds = 0.0;   // tracing shadow rays (0 when shadows are off)
    double shadeSeconds = 0.0;    // shading / writing the image, when it is a pass of its own
    double totalSeconds = 0.0;    // the whole frame as the caller saw it (T_F)
};

struct Frame {
    uint32_t width = 0;
    uint32_t height = 0;
    glm::vec3 light{0.0f};
    std::vector<uint32_t> rgba;  // R in the low byte (RGBA8 in memory), row-major, top row first
    std::vector<HitRecord> hits;
    std::vector<RayCounters> counters;
    FrameTimings timings;
};

// Averages over a frame's counters, as the report's Table 2 gives them.
struct CounterSummary {
    uint64_t primaryRays = 0;   // N_Q of primary rays (one per pixel)
    uint64_t shadowRays = 0;    // N_Q of shadow rays (pixels whose primary ray hit, shadows on)
    double primaryNodes = 0.0;  // average N_TR per primary ray
    double primaryTests = 0.0;  // average N_IT per primary ray
    double shadowNodes = 0.0;   // average N_TR per shadow ray
    double shadowTests = 0.0;   // average N_IT per shadow ray
};

// shadowRays counts pixels whose HitRecord::shadow is lit or occluded when hits are given,
// otherwise pixels with a non-zero shadow counter.
CounterSummary summarizeCounters(const Frame& frame);

}  // namespace raypack
