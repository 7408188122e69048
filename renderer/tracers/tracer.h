#pragma once
// One shape for every way raypack traces rays, so that programs, the bench and the tests handle
// them alike: the CPU reference, the CPU packet tracer, the Vulkan packet and single-ray kernels,
// the driver's own ray tracing and Embree. A tracer is made by the registry
// (renderer/tracers/registry.h), prepared once per scene (its own layout of the canonical BVH,
// uploaded where it runs on a GPU), then renders frames of RenderSettings into a Frame.
//
// Data flow: Scene + Bvh --prepare--> the tracer's layout (Preparation: time, bytes);
// RenderSettings + FrameRequest --render--> Frame (image, hits, counters, pass timings).
// The measurement protocol over any tracer (warm-ups, timed runs, medians) is
// renderer/measure/protocol.h.
#include "renderer/bvh.h"
#include "renderer/frame.h"
#include "renderer/scene.h"
#include "renderer/settings.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace raypack {

enum class TracerDevice { Cpu, Gpu };

// What a tracer's frames can hold and how they are timed.
struct TracerCapabilities {
    bool image = false;     // shaded / heat-map RGBA8 (FrameRequest::image)
    bool hits = false;      // one HitRecord per pixel (FrameRequest::hits)
    bool counters = false;  // N_TR / N_IT per pixel (FrameRequest::counters)
    // Pass times (FrameTimings::primarySeconds / shadowSeconds) come from GPU timestamp queries,
    // not the host's clock.
    bool gpuTimestamps = false;
    // RenderSettings::packet chooses the packet shape it traces (the packet kernels).
    bool packetShapes = false;
    // Traces with the CPU reference's arithmetic, so its hits must be the reference's to the bit
    // (the bench records the share that is).
    bool bitExactWithReference = false;
    // Honours RenderSettings::intersect: IntersectMode::Fast runs raypack's fast tests. The peers
    // (Embree, the driver's ray tracing) have their own intersection and ignore it.
    bool intersectModes = false;
};

// What prepare() cost.
struct Preparation {
    double seconds = 0.0;  // host wall time converting to the tracer's layout (and uploading it)
    uint64_t bytes = 0;    // what the tracer holds for the scene beside the Scene itself
    // `seconds` is the report's T_CU, creating and uploading device data (a GPU tracer). The CPU
    // tracers read the tree in host memory, and the report's CPU rows have T_CU = 0.
    bool isUpload = false;
    // A GPU tracer's T_CU split (issue 13): buffer creation, writing the layout into staging
    // memory, and the copies to the device; all 0 where not measured.
    double allocationSeconds = 0.0;
    double conversionSeconds = 0.0;
    double transferSeconds = 0.0;
};

class Tracer {
public:
    virtual ~Tracer() = default;

    // The registry's name and the bench's "tracer" field: "cpu-reference", "gpu-packet", ...
    virtual std::string name() const = 0;
    // The bench's "kernel" field: "reference", "packet", "single", or a peer's own.
    virtual std::string kernel() const = 0;
    virtual TracerDevice device() const = 0;
    // What traced a frame of `settings`, as printed and recorded ("CPU reference, AMD EPYC (2
    // threads)", vk::describe() of a GPU).
    virtual std::string describe(const RenderSettings& settings) const = 0;
    // The bench's "driver" field: the Vulkan driver, Embree's version, "" for raypack's CPU code.
    virtual std::string driver() const = 0;
    virtual TracerCapabilities capabilities() const = 0;

    // Converts `bvh` over `scene` to the tracer's layout, replacing the previous scene. Both must
    // outlive the frames rendered from them. Throws raypack::Error (out of memory, a tree too deep).
    virtual Preparation prepare(const Scene& scene, const Bvh& bvh) = 0;
    // Builds the BVH with a device builder (gpu-lbvh) where the tracer runs, straight into its own
    // layout, replacing the previous scene (issue 13: no tree on the host, no round trip). Returns
    // the Preparation (T_CU: the scene's upload, 0 when the scene was already there) and the built
    // tree's statistics (T_B); nullopt for tracers that cannot (the CPU tracers and the peers take
    // the downloaded tree through prepare()).
    struct DeviceBuildPreparation {
        Preparation preparation;
        BvhStats stats;
    };
    virtual std::optional<DeviceBuildPreparation> prepareWithDeviceBuild(const Scene& scene,
                                                                         const BvhBuildOptions& options) {
        (void)scene;
        (void)options;
        return std::nullopt;
    }
    // One frame, synchronously. Throws raypack::Error before prepare() or for settings the tracer
    // cannot run (a packet shape the device cannot hold).
    virtual Frame render(const RenderSettings& settings, const FrameRequest& request) = 0;
    // Traces `frames` frames back to back without reading them back, untimed: a GPU lowers its
    // clocks when it idles, and timed frames follow at once (renderer/measure/protocol.cpp). A CPU
    // tracer has nothing to warm.
    virtual void warmUp(const RenderSettings& settings, uint32_t frames) {
        (void)settings;
        (void)frames;
    }

    // The compiler's statistics of the kernels that trace `settings` (a GPU tracer on a context made
    // with pipeline statistics: {"primary": {name: value, ...}, "shadow": {...}}); null elsewhere.
    virtual nlohmann::json pipelineStatistics(const RenderSettings& settings) {
        (void)settings;
        return nullptr;
    }

    // The arithmetic of the robust path's accurate hit distance when tracing `settings` ("fp64",
    // "float-pair"; the bench's "hit_distance" field), resolved for this tracer's device; nullopt
    // where none is computed (the fast path, the peers). Throws raypack::Error as render() does for
    // an arithmetic the device lacks.
    virtual std::optional<std::string> hitDistance(const RenderSettings& settings) {
        if (settings.intersect != IntersectMode::Robust) return std::nullopt;
        return std::string(toString(HitDistanceMath::Float64));  // raypack's CPU tracers
    }
    // The rate of doubles against floats that the device was measured at for that choice
    // (GpuTracer::float64Rate); 0 where none was measured.
    virtual double float64Rate() const { return 0.0; }
    // What the prepared scene's kernels read their nodes through ("storage", "texel"; the bench's
    // "node_fetch" field) and why (GpuTracer::nodeFetch); nullopt for tracers without that choice.
    virtual std::optional<std::pair<std::string, std::string>> nodeFetch() const { return std::nullopt; }
    // `settings` as this tracer runs them on its device after prepare(): what an automatic choice
    // comes to (the hybrid kernel's packets per workgroup, GpuTracer::deviceSettings).
    virtual RenderSettings deviceSettings(const RenderSettings& settings) const { return settings; }

    // Tracers whose measurement is not a frame write their own bench records: Embree's five ray
    // modes at two build qualities, the driver's acceleration structure build and launch figures.
    // `reference` holds the reference tracer's hits of the same rays (or is empty). nullopt for
    // the frame tracers, which the protocol of renderer/measure/protocol.h measures.
    virtual std::optional<nlohmann::json> peerRecords(const RenderSettings& settings, uint32_t repeats,
                                                      const std::vector<HitRecord>& reference) {
        (void)settings;
        (void)repeats;
        (void)reference;
        return std::nullopt;
    }
};

}  // namespace raypack
