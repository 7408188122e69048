#include "renderer/frame.h"

#include "renderer/error.h"

namespace raypack {

CounterSummary summarizeCounters(const Frame& frame) {
    CounterSummary summary;
    const size_t pixels = size_t(frame.width) * frame.height;
    summary.primaryRays = pixels;
    if (frame.counters.empty()) return summary;
    RAYPACK_CHECK_MSG(frame.counters.size() == pixels, "one RayCounters per pixel");
    const bool haveHits = !frame.hits.empty();
    RAYPACK_CHECK_MSG(!haveHits || frame.hits.size() == pixels, "one HitRecord per pixel");

    uint64_t primaryNodes = 0, primaryTests = 0, shadowNodes = 0, shadowTests = 0;
    uint64_t shadowRays = 0;
    for (size_t i = 0; i < pixels; ++i) {
        const RayCounters& c = frame.counters[i];
        primaryNodes += c.primaryNodes;
        primaryTests += c.primaryTests;
        shadowNodes += c.shadowNodes;
        shadowTests += c.shadowTests;
        const bool traced =
            haveHits ? frame.hits[i].shadow != gpu::kShadowNone : (c.shadowNodes != 0 || c.shadowTests != 0);
        if (traced) ++shadowRays;
    }
    summary.shadowRays = shadowRays;
    if (pixels > 0) {
        summary.primaryNodes = double(primaryNodes) / double(pixels);
        summary.primaryTests = double(primaryTests) / double(pixels);
    }
    if (shadowRays > 0) {
        summary.shadowNodes = double(shadowNodes) / double(shadowRays);
        summary.shadowTests = double(shadowTests) / double(shadowRays);
    }
    return summary;
}

}  // namespace raypack
