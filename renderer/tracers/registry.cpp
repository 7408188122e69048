#include "renderer/tracers/registry.h"

#include "renderer/error.h"
#include "renderer/tracers/tracer_rows.h"
#include "renderer/vk/rt_peer.h"

#include <functional>

namespace raypack {
namespace {

struct Row {
    const char* name;
    TracerDevice device;
    const char* kernel;
    // "" when it can run in the environment, else why not.
    std::function<std::string(const TracerEnvironment&)> unavailable;
    std::function<std::unique_ptr<Tracer>(const TracerEnvironment&)> make;
};

std::string needsVulkan(const TracerEnvironment& e) { return e.vulkan ? "" : "no Vulkan device was opened"; }

const std::vector<Row>& rows() {
    static const std::vector<Row> table = {
        {"cpu-reference", TracerDevice::Cpu, "reference", [](const TracerEnvironment&) { return std::string(); },
         [](const TracerEnvironment&) { return makeCpuReferenceTracer(); }},
        {"cpu-packet", TracerDevice::Cpu, "packet", [](const TracerEnvironment&) { return std::string(); },
         [](const TracerEnvironment&) { return makeCpuPacketTracer(); }},
        {"embree", TracerDevice::Cpu, "embree",
         [](const TracerEnvironment&) {
             return embreeBuiltIn() ? std::string() : std::string("Embree: this raypack-cli was built without Embree");
         },
         [](const TracerEnvironment& environment) { return makeEmbreeTracer(environment.buildRepeats); }},
        {"gpu-packet", TracerDevice::Gpu, "packet", needsVulkan,
         [](const TracerEnvironment& e) { return makeGpuKernelTracer(*e.vulkan, KernelKind::Packet); }},
        {"gpu-single", TracerDevice::Gpu, "single", needsVulkan,
         [](const TracerEnvironment& e) { return makeGpuKernelTracer(*e.vulkan, KernelKind::Single); }},
        {"gpu-cwbvh", TracerDevice::Gpu, "single", needsVulkan,
         [](const TracerEnvironment& e) { return makeGpuKernelTracer(*e.vulkan, KernelKind::Single, 8); }},
        {"gpu-hybrid", TracerDevice::Gpu, "hybrid", needsVulkan,
         [](const TracerEnvironment& e) { return makeGpuKernelTracer(*e.vulkan, KernelKind::Hybrid); }},
        {"driver-rt", TracerDevice::Gpu, "vkCmdTraceRaysKHR",
         [](const TracerEnvironment& e) {
             return e.vulkan ? rtPeerUnsupportedReason(*e.vulkan)
                             : std::string("driver ray tracing unavailable: no Vulkan device was opened");
         },
         [](const TracerEnvironment& e) { return makeDriverRtTracer(*e.vulkan); }},
    };
    return table;
}

}  // namespace

std::vector<TracerInfo> listTracers(const TracerEnvironment& environment) {
    std::vector<TracerInfo> list;
    for (const Row& row : rows()) list.push_back({row.name, row.device, row.kernel, row.unavailable(environment)});
    return list;
}

std::vector<std::string> availableTracers(const TracerEnvironment& environment) {
    std::vector<std::string> names;
    for (const TracerInfo& info : listTracers(environment))
        if (info.unavailable.empty()) names.push_back(info.name);
    return names;
}

std::unique_ptr<Tracer> makeTracer(const std::string& name, const TracerEnvironment& environment) {
    std::string known;
    for (const Row& row : rows()) {
        if (name == row.name) {
            if (const std::string reason = row.unavailable(environment); !reason.empty())
                throw TracerUnavailable(reason);
            return row.make(environment);
        }
        known += known.empty() ? row.name : std::string(", ") + row.name;
    }
    throw Error("tracer \"" + name + "\" is not one of " + known);
}

bool embreeAvailable() { return embreeBuiltIn(); }
std::string embreeVersion() { return embreeBuildVersion(); }

}  // namespace raypack
