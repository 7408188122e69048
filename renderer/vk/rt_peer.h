#pragma once
// The GPU driver's own ray tracing as a benchmark peer (issue 5, "Peers"): what a GPU user would
// pick instead of raypack. On a device with VK_KHR_ray_tracing_pipeline and
// VK_KHR_acceleration_structure it builds the driver's acceleration structure over the scene's
// triangles (one BLAS, opaque, PREFER_FAST_TRACE, in file order; one TLAS with one instance) and
// traces raypack's own rays through a minimal ray tracing pipeline (shaders/rt/): one primary ray
// per pixel from shaders/camera.h, then one shadow ray per hit by shaders/intersect.h's shadow-ray
// rule, each pass timed with timestamp queries. docs/rt-peer.md says what is measured and how.
//
// Data flow: Scene --upload--> vertex/index buffers --build--> BLAS, TLAS (timestamps);
// RenderSettings --one warm-up launch, launches back to back until their speed settles, `repeats` timed
// launches--> hits (Frame) + kernel times.
// Everything is created and destroyed inside one call: the peer is a function, not an object.
#include "renderer/error.h"
#include "renderer/frame.h"
#include "renderer/measure/agreement.h"
#include "renderer/measure/spread.h"
#include "renderer/measure/warm_up.h"
#include "renderer/scene.h"
#include "renderer/settings.h"
#include "renderer/vk/context.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace raypack {

// The device or the context cannot run the peer. what() is one line naming the device and what it
// lacks, for the bench to print as its "skipped" line.
class RtPeerUnsupported : public Error {
public:
    using Error::Error;
};

// "" when runRtPeer can run on `context`; otherwise the line RtPeerUnsupported would carry. The
// context must have been created with VulkanContextOptions::enableRayTracing on a device that
// offers the extensions and features (vk::rayTracingMissing), and its queue must write timestamps.
std::string rtPeerUnsupportedReason(const vk::VulkanContext& context);

struct RtPeerResult {
    std::string device;  // vk::describe() of the device
    uint64_t triangles = 0;
    uint32_t width = 0;
    uint32_t height = 0;
    uint32_t repeats = 0;  // timed launches of each pass (after the warm-up)
    // Launches back to back before the timed ones, until their speed settled (as raypack's GPU
    // cells do, renderer/measure/protocol.h).
    GpuWarmUp warmUp;

    // Building (the driver's T_B and T_CU):
    double uploadSeconds = 0.0;     // host wall time: vertex and index buffers created and filled
    double blasBuildSeconds = 0.0;  // timestamps around vkCmdBuildAccelerationStructuresKHR (BLAS)
    double tlasBuildSeconds = 0.0;  // the same for the TLAS of one instance
    // Host wall time from the size query to the finished builds: allocation of the structures and
    // the scratch buffer, the instance upload, the builds and the wait.
    double buildHostSeconds = 0.0;
    uint64_t blasBytes = 0;  // VkAccelerationStructureBuildSizesInfoKHR::accelerationStructureSize
    uint64_t tlasBytes = 0;
    uint64_t scratchBytes = 0;  // the one scratch buffer both builds share

    // Tracing: kernel times from timestamps around each vkCmdTraceRaysKHR.
    uint64_t primaryRays = 0;    // one per pixel
    bool shadowsTraced = false;  // settings.shadows: the shadow pass ran
    uint64_t shadowRays = 0;     // one per primary hit (0 when settings.shadows is off)
    Spread primarySeconds;       // median, minimum and maximum of the timed launches
    Spread shadowSeconds;

    // The warm-up launch's hits: one HitRecord per pixel (t, the file-order triangle, the shadow
    // state), and the light. No image, no counters: the driver does not report its traversal.
    Frame frame;

    double buildSeconds() const { return blasBuildSeconds + tlasBuildSeconds; }
    double primaryMraysPerSecond() const {
        return primarySeconds.median > 0.0 ? double(primaryRays) / primarySeconds.median / 1e6 : 0.0;
    }
    double shadowMraysPerSecond() const {
        return shadowSeconds.median > 0.0 ? double(shadowRays) / shadowSeconds.median / 1e6 : 0.0;
    }
};

// Builds the acceleration structures for `scene`, traces settings.width x settings.height primary
// rays from settings.camera and, when settings.shadows, a shadow ray per hit towards the light at
// settings.lightHeight (renderer/camera.h lightPosition over scene.bounds()): one warm-up launch
// whose hits are read back, then `repeats` timed launches. Only the camera, image size, light and
// shadows of `settings` matter (no shading, kernels or packets: the driver chooses).
// Throws RtPeerUnsupported (see rtPeerUnsupportedReason) and raypack::Error for repeats == 0, an
// image the device cannot launch, or too little device memory.
RtPeerResult runRtPeer(const vk::VulkanContext& context, const Scene& scene, const RenderSettings& settings,
                       uint32_t repeats);

// The bench records of a run (issue 5's field names, as the Embree peer writes them): one for
// primary rays and, when shadow rays were traced, one for shadow rays, with tracer "driver-rt",
// kernel "vkCmdTraceRaysKHR", t_b_s (BLAS + TLAS build), t_cu_s (upload), n_q_rays, t_k_s (+ min,
// max), t_r_us_per_ray, perf_mrays_s, the structure sizes and, when `agreement` is given, the hit
// comparison (renderer/measure/agreement.h, the bar the Embree comparison uses). The caller adds
// the scene fields.
nlohmann::json rtPeerRecords(const RtPeerResult& result, const HitAgreement* agreement);

// Two lines for the terminal: build and tracing figures.
std::string describeRtPeer(const RtPeerResult& result);

// ---- The shader binding table layout (exposed for tests): one raygen record, then the miss and
// the hit records, each region starting at a multiple of shaderGroupBaseAlignment and each record
// a multiple of shaderGroupHandleAlignment apart (VK_KHR_ray_tracing_pipeline, vkCmdTraceRaysKHR:
// the raygen region's size equals its stride; strides at most maxShaderGroupStride).
struct ShaderBindingTableRegion {
    uint64_t offset = 0;  // from the table's base, which must itself be base-aligned
    uint64_t stride = 0;
    uint64_t size = 0;
};
struct ShaderBindingTableLayout {
    ShaderBindingTableRegion raygen, miss, hit;
    uint64_t bytes = 0;
};
// Throws raypack::Error when a stride would exceed maxShaderGroupStride. Alignments must be powers
// of two (the spec promises it).
ShaderBindingTableLayout layoutShaderBindingTable(uint32_t handleSize, uint32_t handleAlignment, uint32_t baseAlignment,
                                                  uint32_t maxStride, uint32_t missCount, uint32_t hitCount);

}  // namespace raypack
