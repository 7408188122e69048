#pragma once
// The tracers this machine has, and one made by name. Every tracer is one file under
// renderer/tracers/ and one row of registry.cpp's table; the bench, raypack-cli render and the
// tests find them here.
//
//   cpu-reference  the CPU reference (renderer/cpu_tracer.h)             always
//   cpu-packet     the CPU packet tracer (renderer/cpu_packet_tracer.h)  always
//   embree         Embree 3 (Wald et al. 2014), a CPU peer               built with RAYPACK_WITH_EMBREE
//   gpu-packet     the Vulkan packet kernel (renderer/gpu_tracer.h)      with a Vulkan context
//   gpu-single     the Vulkan single-ray kernel                          with a Vulkan context
//   gpu-cwbvh      the single-ray kernel over the compressed 8-wide tree with a Vulkan context
//   gpu-hybrid     the Vulkan hybrid packet / single-ray kernel          with a Vulkan context
//   driver-rt      the driver's ray tracing (renderer/vk/rt_peer.h)      where the GPU offers it
#include "renderer/error.h"
#include "renderer/tracers/tracer.h"
#include "renderer/vk/context.h"

#include <memory>
#include <string>
#include <vector>

namespace raypack {

// What tracers may run on.
struct TracerEnvironment {
    // The GPU tracers' device, owned by the caller, outliving the tracers; nullptr: none. The
    // driver's ray tracing needs it created with VulkanContextOptions::enableRayTracing.
    const vk::VulkanContext* vulkan = nullptr;
    // Peers that build their own tree (Embree) build it this many times, back to back, and report
    // the median build time (bench --build-repeat).
    uint32_t buildRepeats = 1;
};

struct TracerInfo {
    std::string name;
    TracerDevice device = TracerDevice::Cpu;
    std::string kernel;       // Tracer::kernel(): "packet", "single", "hybrid": --kernel
    std::string unavailable;  // "" when makeTracer can make it here; else one line saying why not
};

// Every known tracer in the bench's order (CPU tracers, then GPU tracers), available or not.
std::vector<TracerInfo> listTracers(const TracerEnvironment& environment);
// The names of those makeTracer can make in `environment`.
std::vector<std::string> availableTracers(const TracerEnvironment& environment);
// A tracer this environment lacks; what() is TracerInfo::unavailable.
class TracerUnavailable : public Error {
public:
    using Error::Error;
};
// Throws TracerUnavailable for one this environment lacks, raypack::Error for an unknown name.
std::unique_ptr<Tracer> makeTracer(const std::string& name, const TracerEnvironment& environment);

// Whether this build has Embree, and its version ("" without).
bool embreeAvailable();
std::string embreeVersion();

}  // namespace raypack
