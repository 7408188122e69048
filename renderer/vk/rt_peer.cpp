#include "renderer/vk/rt_peer.h"

#include "renderer/camera.h"
#include "renderer/measure/statistics.h"
#include "shaders/bindings.h"
#include "shaders/rt/rt_peer_params.glsl"

#include "rt_peer_primary_rmiss.spv.h"
#include "rt_peer_rchit.spv.h"
#include "rt_peer_rgen.spv.h"
#include "rt_peer_shadow_rmiss.spv.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace raypack {

namespace {

using Clock = SteadyClock;

uint64_t alignUp(uint64_t value, uint64_t alignment) {
    RAYPACK_CHECK(alignment != 0 && (alignment & (alignment - 1)) == 0);
    return (value + alignment - 1) & ~(alignment - 1);
}

// The KHR entry points, loaded from the device (they are not exported by the loader).
struct RtFunctions {
    PFN_vkGetAccelerationStructureBuildSizesKHR getBuildSizes = nullptr;
    PFN_vkCreateAccelerationStructureKHR createStructure = nullptr;
    PFN_vkDestroyAccelerationStructureKHR destroyStructure = nullptr;
    PFN_vkCmdBuildAccelerationStructuresKHR cmdBuild = nullptr;
    PFN_vkGetAccelerationStructureDeviceAddressKHR getStructureAddress = nullptr;
    PFN_vkCreateRayTracingPipelinesKHR createPipelines = nullptr;
    PFN_vkGetRayTracingShaderGroupHandlesKHR getGroupHandles = nullptr;
    PFN_vkCmdTraceRaysKHR cmdTraceRays = nullptr;
};

template <typename F>
void loadFunction(VkDevice device, const char* name, F& function) {
    function = reinterpret_cast<F>(vkGetDeviceProcAddr(device, name));
    // The extensions are enabled (rtPeerUnsupportedReason checked), so the driver must have them.
    RAYPACK_CHECK_MSG(function != nullptr, name);
}

RtFunctions loadRtFunctions(VkDevice device) {
    RtFunctions f;
    loadFunction(device, "vkGetAccelerationStructureBuildSizesKHR", f.getBuildSizes);
    loadFunction(device, "vkCreateAccelerationStructureKHR", f.createStructure);
    loadFunction(device, "vkDestroyAccelerationStructureKHR", f.destroyStructure);
    loadFunction(device, "vkCmdBuildAccelerationStructuresKHR", f.cmdBuild);
    loadFunction(device, "vkGetAccelerationStructureDeviceAddressKHR", f.getStructureAddress);
    loadFunction(device, "vkCreateRayTracingPipelinesKHR", f.createPipelines);
    loadFunction(device, "vkGetRayTracingShaderGroupHandlesKHR", f.getGroupHandles);
    loadFunction(device, "vkCmdTraceRaysKHR", f.cmdTraceRays);
    return f;
}

struct RtProperties {
    VkPhysicalDeviceRayTracingPipelinePropertiesKHR pipeline{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_PROPERTIES_KHR};
    VkPhysicalDeviceAccelerationStructurePropertiesKHR structure{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR};
    VkPhysicalDeviceLimits limits{};
};

RtProperties queryRtProperties(VkPhysicalDevice physical) {
    RtProperties p;
    p.pipeline.pNext = &p.structure;
    VkPhysicalDeviceProperties2 props{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    props.pNext = &p.pipeline;
    vkGetPhysicalDeviceProperties2(physical, &props);
    p.pipeline.pNext = nullptr;
    p.structure.pNext = nullptr;
    p.limits = props.properties.limits;
    return p;
}

VkDeviceAddress bufferAddress(const vk::VulkanContext& ctx, const vk::Buffer& buffer) {
    VkBufferDeviceAddressInfo info{VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO};
    info.buffer = buffer.buffer;
    return vkGetBufferDeviceAddress(ctx.device, &info);
}

// Every Vulkan object of one run, destroyed together when the run ends or throws (RAII at the
// level of their owner, ../shared/STYLE.md).
struct RtPeerObjects {
    const vk::VulkanContext& ctx;
    RtFunctions fn;
    VkCommandPool pool = VK_NULL_HANDLE;
    VkQueryPool queries = VK_NULL_HANDLE;
    vk::Buffer vertices, indices, instances, scratch, blasStorage, tlasStorage;
    vk::Buffer bindingTable, hits, readback;
    VkAccelerationStructureKHR blas = VK_NULL_HANDLE;
    VkAccelerationStructureKHR tlas = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
    VkDescriptorPool descriptorPool = VK_NULL_HANDLE;
    VkDescriptorSet descriptorSet = VK_NULL_HANDLE;
    VkPipelineLayout pipelineLayout = VK_NULL_HANDLE;
    VkPipeline pipeline = VK_NULL_HANDLE;
    std::vector<VkShaderModule> modules;

    RtPeerObjects(const vk::VulkanContext& context, const RtFunctions& functions) : ctx(context), fn(functions) {}
    RtPeerObjects(const RtPeerObjects&) = delete;
    RtPeerObjects& operator=(const RtPeerObjects&) = delete;
    ~RtPeerObjects() {
        const VkDevice d = ctx.device;
        if (pipeline) vkDestroyPipeline(d, pipeline, nullptr);
        if (pipelineLayout) vkDestroyPipelineLayout(d, pipelineLayout, nullptr);
        for (VkShaderModule m : modules) vkDestroyShaderModule(d, m, nullptr);
        if (descriptorPool) vkDestroyDescriptorPool(d, descriptorPool, nullptr);
        if (setLayout) vkDestroyDescriptorSetLayout(d, setLayout, nullptr);
        if (tlas) fn.destroyStructure(d, tlas, nullptr);
        if (blas) fn.destroyStructure(d, blas, nullptr);
        for (vk::Buffer* b :
             {&vertices, &indices, &instances, &scratch, &blasStorage, &tlasStorage, &bindingTable, &hits, &readback})
            vk::destroyBuffer(ctx, *b);
        if (queries) vkDestroyQueryPool(d, queries, nullptr);
        if (pool) vkDestroyCommandPool(d, pool, nullptr);
    }
};

// Timestamp queries: 0-2 around the two builds, 3-6 around the two trace passes.
constexpr uint32_t kQueryBuildStart = 0;
constexpr uint32_t kQueryTraceStart = 3;
constexpr uint32_t kQueryCount = 7;

std::vector<uint64_t> readQueries(const RtPeerObjects& o, uint32_t first, uint32_t count) {
    std::vector<uint64_t> ticks(count);
    vk::check(vkGetQueryPoolResults(o.ctx.device, o.queries, first, count, count * sizeof(uint64_t), ticks.data(),
                                    sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
              "vkGetQueryPoolResults");
    return ticks;
}

double tickSeconds(const vk::VulkanContext& ctx, uint64_t from, uint64_t to) {
    return double(to - from) * double(ctx.info.timestampPeriodNs) * 1e-9;
}

// A device-local buffer whose device address the builds or the shaders read.
vk::Buffer createAddressedBuffer(const vk::VulkanContext& ctx, VkDeviceSize size, VkBufferUsageFlags usage,
                                 const char* what) {
    return vk::createBuffer(ctx, size, usage | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT,
                            VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, what);
}

// Uploads the scene's positions and triangles as the BLAS's vertex and index buffers, unchanged:
// glm::vec3 is 12 tightly packed floats (VK_FORMAT_R32G32B32_SFLOAT, stride 12) and glm::uvec3
// three uint32 indices, so the BLAS's triangle i is the scene's triangle i.
void uploadGeometry(RtPeerObjects& o, const Scene& scene) {
    static_assert(sizeof(glm::vec3) == 12 && sizeof(glm::uvec3) == 12);
    const VkBufferUsageFlags usage =
        VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    const VkDeviceSize vertexBytes = scene.positions.size() * sizeof(glm::vec3);
    const VkDeviceSize indexBytes = scene.triangles.size() * sizeof(glm::uvec3);
    o.vertices = createAddressedBuffer(o.ctx, vertexBytes, usage, "the ray tracing peer's vertices");
    o.indices = createAddressedBuffer(o.ctx, indexBytes, usage, "the ray tracing peer's indices");
    vk::uploadToBuffer(o.ctx, o.pool, o.vertices, scene.positions.data(), vertexBytes);
    vk::uploadToBuffer(o.ctx, o.pool, o.indices, scene.triangles.data(), indexBytes);
}

// An acceleration structure at offset 0 of a buffer of its own (the offset must be a multiple of
// 256), sized by vkGetAccelerationStructureBuildSizesKHR.
VkAccelerationStructureKHR createStructure(RtPeerObjects& o, VkDeviceSize size, VkAccelerationStructureTypeKHR type,
                                           vk::Buffer& storage, const char* what) {
    storage = createAddressedBuffer(o.ctx, size, VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR, what);
    VkAccelerationStructureCreateInfoKHR create{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR};
    create.buffer = storage.buffer;
    create.offset = 0;
    create.size = size;
    create.type = type;
    VkAccelerationStructureKHR structure = VK_NULL_HANDLE;
    vk::check(o.fn.createStructure(o.ctx.device, &create, nullptr, &structure),
              (std::string("vkCreateAccelerationStructureKHR (") + what + ")").c_str());
    return structure;
}

struct BuildTimes {
    double blasSeconds = 0.0;
    double tlasSeconds = 0.0;
};

// One BLAS over all triangles (one geometry, opaque, PREFER_FAST_TRACE: the choice for a static
// scene traced many times) and one TLAS holding it once with the identity transform.
BuildTimes buildStructures(RtPeerObjects& o, const Scene& scene, const RtProperties& props, RtPeerResult& result) {
    const VkDevice device = o.ctx.device;

    VkAccelerationStructureGeometryKHR triangles{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR};
    triangles.geometryType = VK_GEOMETRY_TYPE_TRIANGLES_KHR;
    // Opaque: no any-hit shader is ever invoked, as for raypack's kernels.
    triangles.flags = VK_GEOMETRY_OPAQUE_BIT_KHR;
    VkAccelerationStructureGeometryTrianglesDataKHR& tri = triangles.geometry.triangles;
    tri.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR;
    tri.vertexFormat = VK_FORMAT_R32G32B32_SFLOAT;
    tri.vertexData.deviceAddress = bufferAddress(o.ctx, o.vertices);
    tri.vertexStride = sizeof(glm::vec3);
    tri.maxVertex = scene.positions.empty() ? 0u : uint32_t(scene.positions.size() - 1);
    tri.indexType = VK_INDEX_TYPE_UINT32;
    tri.indexData.deviceAddress = bufferAddress(o.ctx, o.indices);
    tri.transformData.deviceAddress = 0;  // no transform

    VkAccelerationStructureBuildGeometryInfoKHR blasInfo{
        VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR};
    blasInfo.type = VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR;
    blasInfo.flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR;
    blasInfo.mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR;
    blasInfo.geometryCount = 1;
    blasInfo.pGeometries = &triangles;
    const uint32_t triangleCount = uint32_t(scene.triangles.size());
    if (scene.triangles.size() > props.structure.maxPrimitiveCount)
        throw Error("driver ray tracing: " + o.ctx.info.name + " builds at most " +
                    std::to_string(props.structure.maxPrimitiveCount) + " triangles per structure, the scene has " +
                    std::to_string(scene.triangles.size()));
    VkAccelerationStructureBuildSizesInfoKHR blasSizes{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR};
    o.fn.getBuildSizes(device, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &blasInfo, &triangleCount, &blasSizes);

    o.blas = createStructure(o, blasSizes.accelerationStructureSize, VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR,
                             o.blasStorage, "the bottom-level acceleration structure");

    // The instance refers to the BLAS by its device address, known once it is created.
    VkAccelerationStructureDeviceAddressInfoKHR blasAddressInfo{
        VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR};
    blasAddressInfo.accelerationStructure = o.blas;
    VkAccelerationStructureInstanceKHR instance{};
    instance.transform.matrix[0][0] = 1.0f;  // 3x4 row-major identity
    instance.transform.matrix[1][1] = 1.0f;
    instance.transform.matrix[2][2] = 1.0f;
    instance.instanceCustomIndex = 0;
    instance.mask = 0xFF;
    instance.instanceShaderBindingTableRecordOffset = 0;
    // Both faces count, as in raypack's watertight test (no ray flag asks for culling anyway).
    instance.flags = VK_GEOMETRY_INSTANCE_TRIANGLE_FACING_CULL_DISABLE_BIT_KHR;
    instance.accelerationStructureReference = o.fn.getStructureAddress(device, &blasAddressInfo);
    o.instances = createAddressedBuffer(
        o.ctx, sizeof instance,
        VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
        "the ray tracing peer's instance");
    vk::uploadToBuffer(o.ctx, o.pool, o.instances, &instance, sizeof instance);
    const VkDeviceAddress instanceAddress = bufferAddress(o.ctx, o.instances);
    // VkAccelerationStructureGeometryInstancesDataKHR::data must be 16-byte aligned.
    RAYPACK_CHECK(instanceAddress % 16 == 0);

    VkAccelerationStructureGeometryKHR instances{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR};
    instances.geometryType = VK_GEOMETRY_TYPE_INSTANCES_KHR;
    instances.flags = 0;  // opacity is the BLAS geometry's (VK_GEOMETRY_OPAQUE_BIT_KHR above)
    instances.geometry.instances.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR;
    instances.geometry.instances.arrayOfPointers = VK_FALSE;
    instances.geometry.instances.data.deviceAddress = instanceAddress;
    VkAccelerationStructureBuildGeometryInfoKHR tlasInfo{
        VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR};
    tlasInfo.type = VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR;
    tlasInfo.flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR;
    tlasInfo.mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR;
    tlasInfo.geometryCount = 1;
    tlasInfo.pGeometries = &instances;
    const uint32_t instanceCount = 1;
    VkAccelerationStructureBuildSizesInfoKHR tlasSizes{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR};
    o.fn.getBuildSizes(device, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &tlasInfo, &instanceCount, &tlasSizes);
    o.tlas = createStructure(o, tlasSizes.accelerationStructureSize, VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR,
                             o.tlasStorage, "the top-level acceleration structure");

    // One scratch buffer for both builds (a barrier orders them), its address rounded up to
    // minAccelerationStructureScratchOffsetAlignment: the allocation is only as aligned as the
    // buffer's memory requirements say, which need not be that much.
    const VkDeviceSize scratchAlignment =
        std::max<VkDeviceSize>(props.structure.minAccelerationStructureScratchOffsetAlignment, 1);
    const VkDeviceSize scratchBytes = std::max(blasSizes.buildScratchSize, tlasSizes.buildScratchSize);
    o.scratch = createAddressedBuffer(o.ctx, scratchBytes + scratchAlignment, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                      "the acceleration structure build's scratch memory");
    const VkDeviceAddress scratchAddress = alignUp(bufferAddress(o.ctx, o.scratch), scratchAlignment);
    blasInfo.dstAccelerationStructure = o.blas;
    blasInfo.scratchData.deviceAddress = scratchAddress;
    tlasInfo.dstAccelerationStructure = o.tlas;
    tlasInfo.scratchData.deviceAddress = scratchAddress;

    VkAccelerationStructureBuildRangeInfoKHR blasRange{};
    blasRange.primitiveCount = triangleCount;
    VkAccelerationStructureBuildRangeInfoKHR tlasRange{};
    tlasRange.primitiveCount = instanceCount;
    const VkAccelerationStructureBuildRangeInfoKHR* blasRanges = &blasRange;
    const VkAccelerationStructureBuildRangeInfoKHR* tlasRanges = &tlasRange;

    vk::submitAndWait(o.ctx, o.pool, [&](VkCommandBuffer cmd) {
        vkCmdResetQueryPool(cmd, o.queries, kQueryBuildStart, 3);
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, o.queries, kQueryBuildStart);
        o.fn.cmdBuild(cmd, 1, &blasInfo, &blasRanges);
        // The TLAS build reads the BLAS and reuses the scratch memory.
        vk::memoryBarrier(
            cmd, VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR, VK_ACCESS_ACCELERATION_STRUCTURE_WRITE_BIT_KHR,
            VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR,
            VK_ACCESS_ACCELERATION_STRUCTURE_READ_BIT_KHR | VK_ACCESS_ACCELERATION_STRUCTURE_WRITE_BIT_KHR);
        // Bottom of pipe: written once every earlier command, the BLAS build, has completed.
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, o.queries, kQueryBuildStart + 1);
        o.fn.cmdBuild(cmd, 1, &tlasInfo, &tlasRanges);
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, o.queries, kQueryBuildStart + 2);
    });
    const std::vector<uint64_t> ticks = readQueries(o, kQueryBuildStart, 3);
    result.blasBytes = blasSizes.accelerationStructureSize;
    result.tlasBytes = tlasSizes.accelerationStructureSize;
    result.scratchBytes = scratchBytes;
    BuildTimes times;
    times.blasSeconds = tickSeconds(o.ctx, ticks[0], ticks[1]);
    times.tlasSeconds = tickSeconds(o.ctx, ticks[1], ticks[2]);
    return times;
}

// Descriptor set (the TLAS, the hit records), push constants and the pipeline: raygen, the two miss
// shaders and one triangle hit group with a closest-hit shader, in the order of shaders/rt/
// rt_peer_params.glsl's kRtPeerGroup*.
void createPipeline(RtPeerObjects& o) {
    const VkDevice device = o.ctx.device;
    VkDescriptorSetLayoutBinding bindings[gpu::kRtBindingCount] = {};
    bindings[gpu::kRtBindTlas].binding = gpu::kRtBindTlas;
    bindings[gpu::kRtBindTlas].descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR;
    bindings[gpu::kRtBindTlas].descriptorCount = 1;
    bindings[gpu::kRtBindTlas].stageFlags = VK_SHADER_STAGE_RAYGEN_BIT_KHR;
    bindings[gpu::kRtBindHits].binding = gpu::kRtBindHits;
    bindings[gpu::kRtBindHits].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    bindings[gpu::kRtBindHits].descriptorCount = 1;
    bindings[gpu::kRtBindHits].stageFlags = VK_SHADER_STAGE_RAYGEN_BIT_KHR;
    VkDescriptorSetLayoutCreateInfo setInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    setInfo.bindingCount = gpu::kRtBindingCount;
    setInfo.pBindings = bindings;
    vk::check(vkCreateDescriptorSetLayout(device, &setInfo, nullptr, &o.setLayout), "vkCreateDescriptorSetLayout");

    VkPushConstantRange pushRange{};
    pushRange.stageFlags = VK_SHADER_STAGE_RAYGEN_BIT_KHR;
    pushRange.offset = 0;
    pushRange.size = sizeof(gpu::RtPeerParams);
    VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    layoutInfo.setLayoutCount = 1;
    layoutInfo.pSetLayouts = &o.setLayout;
    layoutInfo.pushConstantRangeCount = 1;
    layoutInfo.pPushConstantRanges = &pushRange;
    vk::check(vkCreatePipelineLayout(device, &layoutInfo, nullptr, &o.pipelineLayout), "vkCreatePipelineLayout");

    struct StageSource {
        VkShaderStageFlagBits stage;
        const uint32_t* code;
        size_t bytes;
        const char* name;
    };
    const StageSource sources[] = {
        {VK_SHADER_STAGE_RAYGEN_BIT_KHR, rt_peer_rgen_spv, sizeof rt_peer_rgen_spv, "rt_peer.rgen"},
        {VK_SHADER_STAGE_MISS_BIT_KHR, rt_peer_primary_rmiss_spv, sizeof rt_peer_primary_rmiss_spv,
         "rt_peer_primary.rmiss"},
        {VK_SHADER_STAGE_MISS_BIT_KHR, rt_peer_shadow_rmiss_spv, sizeof rt_peer_shadow_rmiss_spv,
         "rt_peer_shadow.rmiss"},
        {VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR, rt_peer_rchit_spv, sizeof rt_peer_rchit_spv, "rt_peer.rchit"},
    };
    std::vector<VkPipelineShaderStageCreateInfo> stages;
    for (const StageSource& s : sources) {
        o.modules.push_back(vk::createShaderModule(o.ctx, s.code, s.bytes, s.name));
        VkPipelineShaderStageCreateInfo stage{VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
        stage.stage = s.stage;
        stage.module = o.modules.back();
        stage.pName = "main";
        stages.push_back(stage);
    }

    // Group g uses stage g: three general groups, then the triangle hit group.
    std::vector<VkRayTracingShaderGroupCreateInfoKHR> groups(gpu::kRtPeerGroupCount);
    for (uint32_t g = 0; g < gpu::kRtPeerGroupCount; ++g) {
        VkRayTracingShaderGroupCreateInfoKHR& group = groups[g];
        group = {VK_STRUCTURE_TYPE_RAY_TRACING_SHADER_GROUP_CREATE_INFO_KHR};
        group.generalShader = VK_SHADER_UNUSED_KHR;
        group.closestHitShader = VK_SHADER_UNUSED_KHR;
        group.anyHitShader = VK_SHADER_UNUSED_KHR;
        group.intersectionShader = VK_SHADER_UNUSED_KHR;
        if (g == gpu::kRtPeerGroupHit) {
            group.type = VK_RAY_TRACING_SHADER_GROUP_TYPE_TRIANGLES_HIT_GROUP_KHR;
            group.closestHitShader = g;
        } else {
            group.type = VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR;
            group.generalShader = g;
        }
    }
    VkRayTracingPipelineCreateInfoKHR pipelineInfo{VK_STRUCTURE_TYPE_RAY_TRACING_PIPELINE_CREATE_INFO_KHR};
    pipelineInfo.stageCount = uint32_t(stages.size());
    pipelineInfo.pStages = stages.data();
    pipelineInfo.groupCount = uint32_t(groups.size());
    pipelineInfo.pGroups = groups.data();
    // Only the raygen shader traces rays: one level, within the guaranteed maxRayRecursionDepth.
    pipelineInfo.maxPipelineRayRecursionDepth = 1;
    pipelineInfo.layout = o.pipelineLayout;
    vk::check(o.fn.createPipelines(device, VK_NULL_HANDLE, VK_NULL_HANDLE, 1, &pipelineInfo, nullptr, &o.pipeline),
              "vkCreateRayTracingPipelinesKHR");
}

struct BindingTableRegions {
    VkStridedDeviceAddressRegionKHR raygen{}, miss{}, hit{}, callable{};
};

// Writes the group handles into a device-local table laid out by layoutShaderBindingTable, at a
// base address rounded up to shaderGroupBaseAlignment.
BindingTableRegions createBindingTable(RtPeerObjects& o, const RtProperties& props) {
    const VkPhysicalDeviceRayTracingPipelinePropertiesKHR& p = props.pipeline;
    const ShaderBindingTableLayout layout =
        layoutShaderBindingTable(p.shaderGroupHandleSize, p.shaderGroupHandleAlignment, p.shaderGroupBaseAlignment,
                                 p.maxShaderGroupStride, 2, 1);
    std::vector<uint8_t> handles(size_t(gpu::kRtPeerGroupCount) * p.shaderGroupHandleSize);
    vk::check(o.fn.getGroupHandles(o.ctx.device, o.pipeline, 0, gpu::kRtPeerGroupCount, handles.size(), handles.data()),
              "vkGetRayTracingShaderGroupHandlesKHR");

    o.bindingTable = createAddressedBuffer(
        o.ctx, layout.bytes + p.shaderGroupBaseAlignment,
        VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR | VK_BUFFER_USAGE_TRANSFER_DST_BIT, "the shader binding table");
    const VkDeviceAddress start = bufferAddress(o.ctx, o.bindingTable);
    const VkDeviceAddress base = alignUp(start, p.shaderGroupBaseAlignment);
    const uint64_t shift = base - start;
    std::vector<uint8_t> image(shift + layout.bytes, 0);
    auto put = [&](uint32_t group, uint64_t offset) {
        std::memcpy(image.data() + shift + offset, handles.data() + size_t(group) * p.shaderGroupHandleSize,
                    p.shaderGroupHandleSize);
    };
    put(gpu::kRtPeerGroupRaygen, layout.raygen.offset);
    put(gpu::kRtPeerGroupMissPrimary, layout.miss.offset + gpu::kRtPeerMissPrimary * layout.miss.stride);
    put(gpu::kRtPeerGroupMissShadow, layout.miss.offset + gpu::kRtPeerMissShadow * layout.miss.stride);
    put(gpu::kRtPeerGroupHit, layout.hit.offset);
    vk::uploadToBuffer(o.ctx, o.pool, o.bindingTable, image.data(), image.size());

    BindingTableRegions r;
    r.raygen = {base + layout.raygen.offset, layout.raygen.stride, layout.raygen.size};
    r.miss = {base + layout.miss.offset, layout.miss.stride, layout.miss.size};
    r.hit = {base + layout.hit.offset, layout.hit.stride, layout.hit.size};
    // No callable shaders: an empty region.
    return r;
}

void createDescriptorSet(RtPeerObjects& o) {
    const VkDevice device = o.ctx.device;
    VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR, 1},
                                     {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1}};
    VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    poolInfo.maxSets = 1;
    poolInfo.poolSizeCount = 2;
    poolInfo.pPoolSizes = sizes;
    vk::check(vkCreateDescriptorPool(device, &poolInfo, nullptr, &o.descriptorPool), "vkCreateDescriptorPool");
    VkDescriptorSetAllocateInfo allocate{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    allocate.descriptorPool = o.descriptorPool;
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &o.setLayout;
    vk::check(vkAllocateDescriptorSets(device, &allocate, &o.descriptorSet), "vkAllocateDescriptorSets");

    VkWriteDescriptorSetAccelerationStructureKHR tlasWrite{
        VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_ACCELERATION_STRUCTURE_KHR};
    tlasWrite.accelerationStructureCount = 1;
    tlasWrite.pAccelerationStructures = &o.tlas;
    VkDescriptorBufferInfo hitsInfo{o.hits.buffer, 0, VK_WHOLE_SIZE};
    VkWriteDescriptorSet writes[2] = {{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET},
                                      {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET}};
    writes[0].pNext = &tlasWrite;
    writes[0].dstSet = o.descriptorSet;
    writes[0].dstBinding = gpu::kRtBindTlas;
    writes[0].descriptorCount = 1;
    writes[0].descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR;
    writes[1].dstSet = o.descriptorSet;
    writes[1].dstBinding = gpu::kRtBindHits;
    writes[1].descriptorCount = 1;
    writes[1].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[1].pBufferInfo = &hitsInfo;
    vkUpdateDescriptorSets(device, 2, writes, 0, nullptr);
}

// Records the primary pass and, when `shadows`, the shadow pass, each between two timestamps;
// with `readBack`, then copies the hit records to the host-visible buffer.
void recordTrace(const RtPeerObjects& o, VkCommandBuffer cmd, const BindingTableRegions& table,
                 gpu::RtPeerParams params, bool shadows, bool readBack) {
    const uint32_t width = params.frame.x, height = params.frame.y;
    vkCmdResetQueryPool(cmd, o.queries, kQueryTraceStart, 4);
    // Earlier submissions built the structures, uploaded the table and read the hits: finish them.
    vk::memoryBarrier(
        cmd,
        VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR | VK_PIPELINE_STAGE_TRANSFER_BIT |
            VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR,
        VK_ACCESS_ACCELERATION_STRUCTURE_WRITE_BIT_KHR | VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
            VK_ACCESS_SHADER_WRITE_BIT,
        VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR,
        VK_ACCESS_ACCELERATION_STRUCTURE_READ_BIT_KHR | VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, o.pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, o.pipelineLayout, 0, 1, &o.descriptorSet, 0,
                            nullptr);

    // Timestamps at the ray tracing stage around each launch, as raypack's kernels are timed at
    // the compute stage around each dispatch (renderer/gpu_tracer.cpp).
    const VkPipelineStageFlagBits stage = VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR;
    params.frame.z = gpu::kRtPeerPassPrimary;
    vkCmdPushConstants(cmd, o.pipelineLayout, VK_SHADER_STAGE_RAYGEN_BIT_KHR, 0, sizeof params, &params);
    vkCmdWriteTimestamp(cmd, stage, o.queries, kQueryTraceStart);
    o.fn.cmdTraceRays(cmd, &table.raygen, &table.miss, &table.hit, &table.callable, width, height, 1);
    vkCmdWriteTimestamp(cmd, stage, o.queries, kQueryTraceStart + 1);
    if (shadows) {
        // The shadow pass reads the primary pass's hit records.
        vk::memoryBarrier(cmd, VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR, VK_ACCESS_SHADER_WRITE_BIT,
                          VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR,
                          VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
        params.frame.z = gpu::kRtPeerPassShadow;
        vkCmdPushConstants(cmd, o.pipelineLayout, VK_SHADER_STAGE_RAYGEN_BIT_KHR, 0, sizeof params, &params);
        vkCmdWriteTimestamp(cmd, stage, o.queries, kQueryTraceStart + 2);
        o.fn.cmdTraceRays(cmd, &table.raygen, &table.miss, &table.hit, &table.callable, width, height, 1);
        vkCmdWriteTimestamp(cmd, stage, o.queries, kQueryTraceStart + 3);
    } else {
        // Keep all four queries written so that one read covers every run.
        vkCmdWriteTimestamp(cmd, stage, o.queries, kQueryTraceStart + 2);
        vkCmdWriteTimestamp(cmd, stage, o.queries, kQueryTraceStart + 3);
    }
    if (readBack) {
        vk::memoryBarrier(cmd, VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR, VK_ACCESS_SHADER_WRITE_BIT,
                          VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT);
        const VkBufferCopy region{0, 0, VkDeviceSize(width) * height * sizeof(HitRecord)};
        vkCmdCopyBuffer(cmd, o.hits.buffer, o.readback.buffer, 1, &region);
        vk::memoryBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
                          VK_ACCESS_HOST_READ_BIT);
    }
}

// The launch must fit the device's limits (vkCmdTraceRaysKHR: width and height at most
// maxComputeWorkGroupCount x maxComputeWorkGroupSize, their product at most
// maxRayDispatchInvocationCount).
void checkLaunch(const vk::VulkanContext& ctx, const RtProperties& props, uint32_t width, uint32_t height) {
    const uint64_t maxWidth =
        uint64_t(props.limits.maxComputeWorkGroupCount[0]) * props.limits.maxComputeWorkGroupSize[0];
    const uint64_t maxHeight =
        uint64_t(props.limits.maxComputeWorkGroupCount[1]) * props.limits.maxComputeWorkGroupSize[1];
    const uint64_t invocations = uint64_t(width) * height;
    if (width > maxWidth || height > maxHeight || invocations > props.pipeline.maxRayDispatchInvocationCount)
        throw Error("driver ray tracing: " + ctx.info.name + " cannot launch " + std::to_string(width) + "x" +
                    std::to_string(height) + " rays at once (at most " + std::to_string(maxWidth) + "x" +
                    std::to_string(maxHeight) + ", " + std::to_string(props.pipeline.maxRayDispatchInvocationCount) +
                    " in all)");
}

}  // namespace

ShaderBindingTableLayout layoutShaderBindingTable(uint32_t handleSize, uint32_t handleAlignment, uint32_t baseAlignment,
                                                  uint32_t maxStride, uint32_t missCount, uint32_t hitCount) {
    RAYPACK_CHECK(handleSize > 0);
    const uint64_t recordStride = alignUp(handleSize, handleAlignment);
    if (recordStride > maxStride)
        throw Error("driver ray tracing: a shader binding table record of " + std::to_string(recordStride) +
                    " bytes exceeds maxShaderGroupStride (" + std::to_string(maxStride) + ")");
    ShaderBindingTableLayout l;
    // vkCmdTraceRaysKHR: the raygen region's size must equal its stride.
    l.raygen = {0, recordStride, recordStride};
    l.miss.offset = alignUp(l.raygen.offset + l.raygen.size, baseAlignment);
    l.miss.stride = recordStride;
    l.miss.size = missCount * recordStride;
    l.hit.offset = alignUp(l.miss.offset + l.miss.size, baseAlignment);
    l.hit.stride = recordStride;
    l.hit.size = hitCount * recordStride;
    l.bytes = l.hit.offset + l.hit.size;
    return l;
}

std::string rtPeerUnsupportedReason(const vk::VulkanContext& context) {
    const std::string device = context.info.name;
    if (!context.rayTracing) {
        const std::string missing = vk::rayTracingMissing(context.physicalDevice);
        if (!missing.empty()) return "driver ray tracing unavailable: " + device + " lacks " + missing;
        return "driver ray tracing unavailable: " + device +
               " offers it, but the Vulkan context was created without enableRayTracing";
    }
    if (!context.info.timestamps)
        return "driver ray tracing unavailable: the queue of " + device + " writes no timestamps to time it with";
    return "";
}

RtPeerResult runRtPeer(const vk::VulkanContext& context, const Scene& scene, const RenderSettings& settings,
                       uint32_t repeats) {
    if (const std::string reason = rtPeerUnsupportedReason(context); !reason.empty()) throw RtPeerUnsupported(reason);
    if (repeats == 0) throw Error("driver ray tracing: at least one timed repetition is needed");
    const RtProperties props = queryRtProperties(context.physicalDevice);
    gpu::RtPeerParams params{};
    params.camera = makeGpuCamera(settings.camera, settings.width, settings.height, settings.pixelJitter);
    checkLaunch(context, props, settings.width, settings.height);
    const glm::vec3 light = lightPosition(settings.camera, scene.bounds(), settings.lightHeight);
    params.light = glm::vec4(light, 0.0f);
    params.frame = glm::uvec4(settings.width, settings.height, gpu::kRtPeerPassPrimary, 0u);

    RtPeerResult result;
    result.device = vk::describe(context.info);
    result.triangles = scene.triangles.size();
    result.width = settings.width;
    result.height = settings.height;
    result.repeats = repeats;

    RtPeerObjects o(context, loadRtFunctions(context.device));
    o.pool = vk::createCommandPool(context, VK_COMMAND_POOL_CREATE_TRANSIENT_BIT, "vkCreateCommandPool");
    VkQueryPoolCreateInfo queryInfo{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    queryInfo.queryType = VK_QUERY_TYPE_TIMESTAMP;
    queryInfo.queryCount = kQueryCount;
    vk::check(vkCreateQueryPool(context.device, &queryInfo, nullptr, &o.queries), "vkCreateQueryPool");

    const auto uploadStart = Clock::now();
    uploadGeometry(o, scene);
    result.uploadSeconds = secondsSince(uploadStart);

    const auto buildStart = Clock::now();
    const BuildTimes build = buildStructures(o, scene, props, result);
    result.buildHostSeconds = secondsSince(buildStart);
    result.blasBuildSeconds = build.blasSeconds;
    result.tlasBuildSeconds = build.tlasSeconds;

    createPipeline(o);
    const BindingTableRegions table = createBindingTable(o, props);
    const VkDeviceSize pixels = VkDeviceSize(settings.width) * settings.height;
    const VkDeviceSize hitBytes = pixels * sizeof(HitRecord);
    o.hits = vk::createBuffer(context, hitBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                              VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, "the peer's hit records");
    o.readback = vk::createBuffer(context, hitBytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                  VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                  "the peer's hit records on the host");
    createDescriptorSet(o);

    // Warm-up launch (first-use costs out of the timings); its hits are the result's.
    vk::submitAndWait(context, o.pool,
                      [&](VkCommandBuffer cmd) { recordTrace(o, cmd, table, params, settings.shadows, true); });
    Frame& frame = result.frame;
    frame.width = settings.width;
    frame.height = settings.height;
    frame.light = light;
    frame.hits.resize(pixels);
    std::memcpy(frame.hits.data(), o.readback.mapped, hitBytes);
    result.primaryRays = pixels;
    result.shadowsTraced = settings.shadows;
    if (settings.shadows)
        result.shadowRays = uint64_t(std::count_if(frame.hits.begin(), frame.hits.end(), [](const HitRecord& h) {
            return h.shadow == gpu::kShadowLit || h.shadow == gpu::kShadowOccluded;
        }));

    // Then launches back to back until their speed has settled, so that the timed launches run at
    // the clocks raypack's kernels are timed at (measureFrames, renderer/measure/protocol.cpp).
    const std::vector<uint64_t> firstTicks = readQueries(o, kQueryTraceStart, 4);
    const double launchSeconds = tickSeconds(context, firstTicks[0], firstTicks[1]) +
                                 (settings.shadows ? tickSeconds(context, firstTicks[2], firstTicks[3]) : 0.0);
    result.warmUp = warmUpUntilSteady(
        [&](uint32_t launches) {
            const SteadyClock::time_point start = SteadyClock::now();
            vk::submitAndWait(context, o.pool, [&](VkCommandBuffer cmd) {
                for (uint32_t i = 0; i < launches; ++i) recordTrace(o, cmd, table, params, settings.shadows, false);
            });
            return secondsSince(start);
        },
        launchSeconds, kGpuWarmUpSeconds);

    std::vector<double> primary, shadow;
    for (uint32_t r = 0; r < repeats; ++r) {
        vk::submitAndWait(context, o.pool,
                          [&](VkCommandBuffer cmd) { recordTrace(o, cmd, table, params, settings.shadows, false); });
        const std::vector<uint64_t> ticks = readQueries(o, kQueryTraceStart, 4);
        primary.push_back(tickSeconds(context, ticks[0], ticks[1]));
        if (settings.shadows) shadow.push_back(tickSeconds(context, ticks[2], ticks[3]));
    }
    result.primarySeconds = spreadOf(primary);
    result.shadowSeconds = spreadOf(shadow);
    frame.timings.primarySeconds = result.primarySeconds.median;
    frame.timings.shadowSeconds = result.shadowSeconds.median;
    frame.timings.totalSeconds = frame.timings.primarySeconds + frame.timings.shadowSeconds;
    return result;
}

nlohmann::json rtPeerRecords(const RtPeerResult& result, const HitAgreement* agreement) {
    nlohmann::json records = nlohmann::json::array();
    const std::pair<const char*, bool> kinds[] = {{"primary", true}, {"shadow", result.shadowsTraced}};
    for (const auto& [kind, traced] : kinds) {
        if (!traced) continue;
        const bool isPrimary = std::string(kind) == "primary";
        const uint64_t rays = isPrimary ? result.primaryRays : result.shadowRays;
        const Spread& seconds = isPrimary ? result.primarySeconds : result.shadowSeconds;
        nlohmann::json r;
        r["tracer"] = "driver-rt";
        r["device"] = result.device;
        r["driver"] = result.device;
        r["kernel"] = "vkCmdTraceRaysKHR";
        r["packet"] = nullptr;
        r["ray_kind"] = kind;
        r["width_px"] = result.width;
        r["height_px"] = result.height;
        r["repeats"] = result.repeats;
        r["triangles"] = result.triangles;
        r["t_b_s"] = result.buildSeconds();
        r["t_b_blas_s"] = result.blasBuildSeconds;
        r["t_b_tlas_s"] = result.tlasBuildSeconds;
        r["t_b_host_s"] = result.buildHostSeconds;
        r["t_cu_s"] = result.uploadSeconds;
        r["blas_bytes"] = result.blasBytes;
        r["tlas_bytes"] = result.tlasBytes;
        r["scratch_bytes"] = result.scratchBytes;
        r["bytes_per_triangle"] = result.triangles ? double(result.blasBytes) / double(result.triangles) : 0.0;
        r["n_q_rays"] = rays;
        r["t_k_s"] = seconds.median;
        r["t_k_min_s"] = seconds.min;
        r["t_k_max_s"] = seconds.max;
        r["t_r_us_per_ray"] = rays ? seconds.median / double(rays) * 1e6 : 0.0;
        r["perf_mrays_s"] = isPrimary ? result.primaryMraysPerSecond() : result.shadowMraysPerSecond();
        r.update(toJson(result.warmUp));
        if (agreement) {
            r["hits_compared"] = agreement->comparedRays;
            r["hits_agree_share"] = agreement->rayShare();
            r["hits_same_prim"] = agreement->samePrim;
            r["hits_max_rel_t_error"] = agreement->maxRelativeTError;
            r["shadows_compared"] = agreement->comparedShadows;
            r["shadows_agree_share"] = agreement->shadowShare();
        }
        records.push_back(r);
    }
    return records;
}

std::string describeRtPeer(const RtPeerResult& r) {
    char text[1024];
    std::snprintf(text, sizeof text,
                  "driver ray tracing on %s: %llu triangles, upload %.3f ms, build %.3f ms (BLAS "
                  "%.3f + TLAS %.3f; host %.3f ms), BLAS %.1f MiB\n"
                  "driver ray tracing %ux%u: primary %.3f ms median (%.3f-%.3f) = %.1f Mrays/s, "
                  "shadow %.3f ms median (%.3f-%.3f) = %.1f Mrays/s, %u repeats",
                  r.device.c_str(), static_cast<unsigned long long>(r.triangles), r.uploadSeconds * 1e3,
                  r.buildSeconds() * 1e3, r.blasBuildSeconds * 1e3, r.tlasBuildSeconds * 1e3, r.buildHostSeconds * 1e3,
                  double(r.blasBytes) / (1024.0 * 1024.0), r.width, r.height, r.primarySeconds.median * 1e3,
                  r.primarySeconds.min * 1e3, r.primarySeconds.max * 1e3, r.primaryMraysPerSecond(),
                  r.shadowSeconds.median * 1e3, r.shadowSeconds.min * 1e3, r.shadowSeconds.max * 1e3,
                  r.shadowMraysPerSecond(), r.repeats);
    return text;
}

}  // namespace raypack
