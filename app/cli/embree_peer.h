#pragma once
// Embree 3, the tracer a CPU user would pick, measured on the same triangles and the same rays as
// raypack (issue 5, "Peers"): the same camera (shaders/camera.h's primaryRayDirection), the same
// light (lightPosition) and the same shadow-ray convention (from the light towards the hit point,
// ignoring intersections at or beyond it). Built only when CMake finds Embree
// (RAYPACK_HAVE_EMBREE); otherwise embreeAvailable() is false and runEmbreePeer throws.
#include "app/cli/statistics.h"
#include "renderer/frame.h"
#include "renderer/scene.h"
#include "renderer/settings.h"

#include <string>
#include <vector>

namespace raypack::cli {

bool embreeAvailable();

// Throughput of one way of tracing: rays per pass and the seconds of each timed pass.
struct EmbreeRate {
    uint64_t rays = 0;
    Spread seconds;
    double mraysPerSecond() const { return seconds.median > 0.0 ? double(rays) / seconds.median / 1e6 : 0.0; }
};

// One build quality: its build time and the three tracing modes on that tree.
struct EmbreeQualityResults {
    std::string quality;  // "medium" or "high" (RTC_BUILD_QUALITY_*)
    double buildSeconds = 0.0;
    EmbreeRate intersect1;  // primary rays, rtcIntersect1
    EmbreeRate intersect8;  // primary rays, rtcIntersect8 packets of 4x2 pixels
    // Primary rays, rtcIntersect16 packets of 4x4 pixels; rays = 0 where this Embree build has no
    // 16-ray packets (RTC_DEVICE_PROPERTY_RAY16_SUPPORTED).
    EmbreeRate intersect16;
    bool intersect16Native = false;  // RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED
    EmbreeRate occluded1;            // shadow rays, rtcOccluded1
    EmbreeRate occluded8;            // shadow rays, rtcOccluded8 packets of 4x2 pixels
};

struct EmbreeResults {
    std::string version;   // "3.13.5"
    uint32_t threads = 0;  // TBB worker threads tracing the tiles
    std::vector<EmbreeQualityResults> qualities;
    // Embree's primary hits against the given reference hits (same pixel, same ray): a ray agrees
    // when both miss, or both hit with |t_embree - t_ref| <= 1e-4 * t_ref.
    uint64_t comparedRays = 0;
    uint64_t agreeingRays = 0;
    double maxRelativeTError = 0.0;  // over rays that both hit
    // Shadow state (lit/occluded) of pixels where both primary rays hit and the reference cast a
    // shadow ray.
    uint64_t comparedShadows = 0;
    uint64_t agreeingShadows = 0;
    double agreementShare() const { return comparedRays ? double(agreeingRays) / double(comparedRays) : 0.0; }
};

// Builds Embree scenes at build qualities medium and high over `scene`'s triangles and traces
// settings.width x settings.height primary rays from settings.camera (and shadow rays from the
// light at settings.lightHeight when settings.shadows), one warm-up pass then `repeats` timed
// passes of each mode, multithreaded with TBB over 8x8-pixel tiles. `referenceHits` (one
// HitRecord per pixel, or empty) is compared with Embree's primary hits on the medium tree.
EmbreeResults runEmbreePeer(const Scene& scene, const RenderSettings& settings,
                            const std::vector<HitRecord>& referenceHits, uint32_t repeats);

}  // namespace raypack::cli
