#pragma once
// The report's Table 1 (the BVH) and Table 2 (tracing) as text and JSON, for every program that
// measures (raypack-cli render and bench, the viewer). Every JSON key carries its unit ("_s" seconds, "_us_per_ray",
// "_mrays_s", "_bytes", ...).
//
// Table 2 quantities, per ray kind (primary, shadow), as the reference report defines them:
//   N_Q   number of rays (queries) of that kind: one primary ray per pixel; one shadow ray per pixel
//         whose primary ray hit, when shadows are on
//   N_TR  average nodes visited per ray;  N_IT  average ray/triangle tests per ray
//   T_K   time tracing the rays of that kind: GPU timestamp queries around the kernel, or the CPU
//         tracer's wall clock for that pass (median over the timed repeats, with min and max)
//   T_CU  time to create and upload the GPU data (BVH, triangles) once per scene; 0 on the CPU
//   T_F   full time of traversal = T_CU + T_K (the report's City GPU row: 0.350 = 0.301 + 0.049)
//   T_R   T_K / N_Q, in microseconds per ray
//   PERF  N_Q / T_K in Mrays/s (the report's PERF), and N_Q / (T_CU + T_K) "with upload"
#include "renderer/bvh.h"
#include "renderer/frame.h"
#include "renderer/measure/spread.h"
#include "renderer/measure/warm_up.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace raypack {

// What loading the scene cost and what it holds (the columns of Table 1 beside the BVH's).
struct SceneInfo {
    std::string spec;  // file path or generator spec
    uint64_t triangles = 0;
    uint64_t degenerateTriangles = 0;
    double loadSeconds = 0.0;
    // Bytes read: every file the loader read (a glTF's buffers and texture images and an OBJ's
    // textures included), the scene's in-memory size for a generator spec (so that MB/s is
    // defined for both).
    uint64_t inputBytes = 0;
    // Decoded textures (Scene::textureBytes), which the GPU holds beside the BVH.
    uint64_t textureCount = 0;
    uint64_t textureBytes = 0;
    double loadMegabytesPerSecond() const { return loadSeconds > 0.0 ? double(inputBytes) / 1e6 / loadSeconds : 0.0; }
};

// Table 1 row: N_L, D_AVG, D_MAX, O_AVG, T_B, nodes, SAH cost, bytes, triangles, degenerate
// triangles, load time and MB/s.
nlohmann::json table1Json(const SceneInfo& scene, const BvhStats& bvh, const BvhBuildOptions& options);
void printTable1(std::FILE* out, const SceneInfo& scene, const BvhStats& bvh, const BvhBuildOptions& options);

// Table 2 quantities of one ray kind.
struct RayKindStats {
    uint64_t rays = 0;           // N_Q
    double nodesPerRay = 0.0;    // N_TR
    double testsPerRay = 0.0;    // N_IT
    Spread kernelSeconds;        // T_K
    double uploadSeconds = 0.0;  // T_CU

    double traversalSeconds() const { return uploadSeconds + kernelSeconds.median; }  // T_F
    double microsecondsPerRay() const {                                               // T_R
        return rays ? kernelSeconds.median / double(rays) * 1e6 : 0.0;
    }
    double mraysPerSecond() const {  // PERF without T_CU
        return kernelSeconds.median > 0.0 ? double(rays) / kernelSeconds.median / 1e6 : 0.0;
    }
    double mraysPerSecondWithUpload() const {  // PERF with T_CU
        const double t = traversalSeconds();
        return t > 0.0 ? double(rays) / t / 1e6 : 0.0;
    }
};

// One frame configuration measured over repeats.
struct FrameStats {
    std::string device;  // what traced it, as printed ("cpu: 2 threads", "gpu: llvmpipe ...")
    bool gpu = false;
    uint32_t width = 0, height = 0;
    uint32_t repeats = 0;  // timed runs (after two warm-up runs that are not timed)
    RayKindStats primary;
    RayKindStats shadow;            // rays == 0 when shadows are off
    Spread frameSeconds;            // the whole frame as the caller saw it (trace, shade, read back)
    bool countersMeasured = false;  // N_TR / N_IT come from a counting run
    // T_CU split (Preparation): buffer creation, layout conversion into staging memory, transfer.
    double uploadAllocationSeconds = 0.0;
    double uploadConversionSeconds = 0.0;
    double uploadTransferSeconds = 0.0;
    uint64_t preparedBytes = 0;  // what the tracer holds for the scene (Preparation::bytes)
    GpuWarmUp warmUp;            // on a GPU: the frames traced back to back before the timed ones
};

// Fills N_Q / N_TR / N_IT from a counting run's summary and the timings from the timed runs.
FrameStats summarizeRuns(const CounterSummary& counters, const std::vector<FrameTimings>& timedRuns,
                         double uploadSeconds);

nlohmann::json toJson(const RayKindStats& stats);
// {"gpu_warm_up_s", "gpu_warm_up_frames", "gpu_warm_up_steady"}: the bench's GPU records and the
// driver's ray tracing peer's.
nlohmann::json toJson(const GpuWarmUp& warmUp);
// {"device", "width_px", "height_px", "repeats", "frame_s", "frame_min_s", "frame_max_s",
//  "primary": {...}, "shadow": {...}}
nlohmann::json toJson(const FrameStats& stats);
void printTable2(std::FILE* out, const FrameStats& stats);

}  // namespace raypack
