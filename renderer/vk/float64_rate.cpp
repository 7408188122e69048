#include "renderer/vk/float64_rate.h"

#include "renderer/error.h"
#include "renderer/measure/spread.h"  // secondsSince

#include "float64_rate.spv.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <limits>

namespace raypack::vk {
namespace {

constexpr uint32_t kGroupSize = 256;  // shaders/float64_rate.comp's local_size_x

// Sized so that a large GPU runs each dispatch for tens of microseconds (far above its launch
// cost; 2^29 double multiply-adds, 1/64 of the float rate, take a few milliseconds) and a CPU
// device for tens of milliseconds.
struct ProbeSize {
    uint32_t groups;
    uint32_t iterations;
};
ProbeSize probeSize(const DeviceInfo& info) {
    if (info.type == VK_PHYSICAL_DEVICE_TYPE_CPU) return {16, 2048};
    return {1024, 2048};
}

struct Push {
    float multiplier;
    float addend;
};

// What a probe creates, destroyed in one place whether it finished or threw.
struct Probe {
    const VulkanContext& ctx;
    VkCommandPool pool = VK_NULL_HANDLE;
    StorageSetLayout layout;
    VkShaderModule module = VK_NULL_HANDLE;
    std::array<VkPipeline, 2> pipelines{};
    VkQueryPool queries = VK_NULL_HANDLE;
    Buffer result;
    explicit Probe(const VulkanContext& context) : ctx(context) {}
    ~Probe() {
        for (VkPipeline p : pipelines)
            if (p) vkDestroyPipeline(ctx.device, p, nullptr);
        if (module) vkDestroyShaderModule(ctx.device, module, nullptr);
        if (queries) vkDestroyQueryPool(ctx.device, queries, nullptr);
        destroyBuffer(ctx, result);
        destroyStorageSetLayout(ctx, layout);
        if (pool) vkDestroyCommandPool(ctx.device, pool, nullptr);
    }
};

VkPipeline createProbePipeline(const Probe& probe, bool doubles, uint32_t iterations) {
    struct Constants {
        VkBool32 doubles;
        uint32_t iterations;
    } data{doubles ? VK_TRUE : VK_FALSE, iterations};
    const std::array<VkSpecializationMapEntry, 2> entries{{
        {0, offsetof(Constants, doubles), sizeof(VkBool32)},
        {1, offsetof(Constants, iterations), sizeof(uint32_t)},
    }};
    const VkSpecializationInfo specialization{uint32_t(entries.size()), entries.data(), sizeof data, &data};
    return createComputePipeline(probe.ctx, probe.module, specialization, probe.layout.pipelineLayout,
                                 "GPU: could not build the 64-bit float rate probe");
}

// Seconds one dispatch of `pipeline` takes: from timestamps where the queue writes them, else the
// host's clock around the submission.
double timeDispatch(const Probe& probe, VkPipeline pipeline, uint32_t groups) {
    const bool timestamps = probe.queries != VK_NULL_HANDLE;
    const Push push{0.999f, 0.001f};
    const auto start = std::chrono::steady_clock::now();
    submitAndWait(probe.ctx, probe.pool, [&](VkCommandBuffer cmd) {
        if (timestamps) {
            vkCmdResetQueryPool(cmd, probe.queries, 0, 2);
            vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, probe.queries, 0);
        }
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, probe.layout.pipelineLayout, 0, 1,
                                &probe.layout.set, 0, nullptr);
        vkCmdPushConstants(cmd, probe.layout.pipelineLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, &push);
        vkCmdDispatch(cmd, groups, 1, 1);
        if (timestamps) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, probe.queries, 1);
    });
    if (!timestamps) return secondsSince(start);
    std::array<uint64_t, 2> ticks{};
    check(vkGetQueryPoolResults(probe.ctx.device, probe.queries, 0, 2, sizeof ticks, ticks.data(), sizeof(uint64_t),
                                VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
          "vkGetQueryPoolResults");
    return double(ticks[1] - ticks[0]) * double(probe.ctx.info.timestampPeriodNs) * 1e-9;
}

}  // namespace

double measureFloat64Rate(const VulkanContext& context) {
    if (!context.float64)
        throw Error("GPU: " + context.info.name + " has no 64-bit floats (shaderFloat64), nothing to measure");
    const ProbeSize size = probeSize(context.info);
    Probe probe(context);
    probe.pool = createCommandPool(context, VK_COMMAND_POOL_CREATE_TRANSIENT_BIT, "vkCreateCommandPool");
    probe.layout = createStorageSetLayout(context, 1, sizeof(Push));
    probe.module = createShaderModule(context, float64_rate_spv, sizeof(float64_rate_spv), "float64_rate.comp");
    probe.result = createBuffer(context, VkDeviceSize(size.groups) * kGroupSize * sizeof(float),
                                VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT,
                                "the 64-bit float rate probe's results");
    const std::array<VkBuffer, 1> buffers{probe.result.buffer};
    writeStorageSet(context, probe.layout.set, buffers);
    if (context.info.timestamps) {
        VkQueryPoolCreateInfo queryInfo{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
        queryInfo.queryType = VK_QUERY_TYPE_TIMESTAMP;
        queryInfo.queryCount = 2;
        check(vkCreateQueryPool(context.device, &queryInfo, nullptr, &probe.queries), "vkCreateQueryPool");
    }
    std::array<double, 2> best{};  // floats, doubles
    for (int kind = 0; kind < 2; ++kind) {
        probe.pipelines[kind] = createProbePipeline(probe, kind == 1, size.iterations);
        timeDispatch(probe, probe.pipelines[kind], size.groups);  // untimed: clocks up, caches warm
        best[kind] = std::numeric_limits<double>::infinity();
        for (int run = 0; run < 3; ++run)
            best[kind] = std::min(best[kind], timeDispatch(probe, probe.pipelines[kind], size.groups));
    }
    // Both kinds run the same chains, so the ratio of their times is the ratio of their rates.
    if (!(best[1] > 0.0)) return 1.0;
    return best[0] / best[1];
}

}  // namespace raypack::vk
