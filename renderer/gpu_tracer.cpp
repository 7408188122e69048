#include "renderer/gpu_tracer.h"

#include "renderer/camera.h"
#include "renderer/error.h"
#include "renderer/gpu_bvh.h"
#include "renderer/gpu_layout.h"
#include "renderer/gpu_wide.h"
#include "renderer/measure/spread.h"
#include "renderer/vk/float64_rate.h"
#include "shaders/bindings.h"
#include "shaders/gpu_types.h"

#include "trace.spv.h"
#include "trace_f64.spv.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <map>
#include <tuple>

namespace raypack {

namespace {

using Clock = SteadyClock;

// Timestamp slots: frames the viewer may have in flight before it reads one back.
constexpr uint32_t kQuerySlots = 4;
constexpr uint32_t kQueriesPerFrame = 4;  // primary begin/end, shadow begin/end
// Shared memory of the packet kernel besides its stack: four rotating uvec4 vote sums.
constexpr uint32_t kVoteBytes = 4 * 16;

// The node texels (NodeFetch::Texel): a GpuNode is two of them.
constexpr VkFormat kNodeTexelFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkBufferUsageFlags kNodeTexelUsage = VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT;
static_assert(sizeof(gpu::GpuNode) == 32, "a node is two RGBA32F texels");

// RAYPACK_NODE_FETCH: auto (or unset), storage or texel.
NodeFetch nodeFetchFromEnvironment() {
    const char* value = std::getenv("RAYPACK_NODE_FETCH");
    if (!value || !*value || std::strcmp(value, "auto") == 0) return NodeFetch::Auto;
    if (std::strcmp(value, "storage") == 0) return NodeFetch::Storage;
    if (std::strcmp(value, "texel") == 0) return NodeFetch::Texel;
    throw Error(std::string("RAYPACK_NODE_FETCH is '") + value + "': expected auto, storage or texel");
}

// One pipeline per combination, built on first use.
struct PipelineKey {
    KernelKind kernel;
    uint32_t packetWidth;
    uint32_t packetHeight;
    uint32_t pass;
    bool statistics;
    uint32_t view;
    uint32_t stackEntries;
    IntersectMode intersect;
    ShadowOrder shadowOrder;
    uint32_t hybridMinRays = 0;     // the hybrid kernel's split rules (0 for the other kernels)
    uint32_t hybridVisitRatio = 0;  // in 1/100
    uint32_t packetsPerGroup = 1;   // the hybrid kernel's packets per workgroup (packetHeight: all of them)
    bool wideBvh = false;           // the single-ray kernel over the compressed 8-wide tree
    bool float64 = false;           // trace_f64's module: the accurate hit distance in doubles
    bool texelNodes = false;        // binary nodes through the uniform texel buffer (NodeFetch::Texel)
    auto tie() const {
        return std::tie(kernel, packetWidth, packetHeight, pass, statistics, view, stackEntries, intersect, shadowOrder,
                        hybridMinRays, hybridVisitRatio, packetsPerGroup, wideBvh, float64, texelNodes);
    }
    bool operator<(const PipelineKey& o) const { return tie() < o.tie(); }
};

// Whether a packet of `width` x `height` rays runs as exactly one subgroup on `device`, so that
// its vote needs no shared memory and no barrier. A workgroup no larger than the subgroup is one
// subgroup on NVIDIA, AMD and Intel; lavapipe (llvmpipe) runs each row of a workgroup as its own
// SIMD-8 subgroup (a 4x2 workgroup is two subgroups of 4 although gl_NumSubgroups says 1), so
// there only single rows qualify. The kernel checks the promise (kStatusSubgroupMismatch).
bool subgroupsAreRows(const vk::DeviceInfo& device) { return device.name.find("llvmpipe") != std::string::npos; }

bool packetIsOneSubgroup(const vk::DeviceInfo& device, uint32_t width, uint32_t height) {
    if (uint64_t(width) * height > device.subgroupSize) return false;
    return height == 1 || !subgroupsAreRows(device);
}

// Whether `packets` packets of `width` x `height` rays, stacked in y in one workgroup, are each
// exactly one subgroup (the hybrid kernel's packets per workgroup). Where subgroups are runs of
// consecutive invocations (NVIDIA, AMD, Intel), a packet smaller than the subgroup would share one
// with the next packet, so it must fill its subgroup exactly; on lavapipe each row is one.
bool packetsAreOneSubgroupEach(const vk::DeviceInfo& device, uint32_t width, uint32_t height, uint32_t packets) {
    if (!packetIsOneSubgroup(device, width, height)) return false;
    return packets == 1 || subgroupsAreRows(device) || uint64_t(width) * height == device.subgroupSize;
}

// The workgroups that cover a width x height image in `shape`s, the last column and row padded.
struct WorkgroupCount {
    uint64_t x, y;
};
WorkgroupCount workgroupCount(uint32_t width, uint32_t height, PacketShape shape) {
    return {(uint64_t(width) + shape.width - 1) / shape.width, (uint64_t(height) + shape.height - 1) / shape.height};
}

uint32_t viewConstant(ViewMode view) {
    switch (view) {
    case ViewMode::HeatTraversal: return gpu::kViewHeatTraversal;
    case ViewMode::HeatIntersections: return gpu::kViewHeatIntersections;
    default: return gpu::kViewShaded;
    }
}

}  // namespace

struct GpuTracer::State {
    UploadTimings lastUpload;
    const vk::VulkanContext& ctx;
    VkCommandPool pool = VK_NULL_HANDLE;
    vk::StorageSetLayout layout;  // trace.comp's storage buffers, the node texels and push constants
    // The uploaded tree's nodes as RGBA32F texels (binding kBindNodeTexels), cut to what the device
    // can view where that is less than the whole buffer; nodeFetch says whether the kernels read it.
    VkBufferView nodeView = VK_NULL_HANDLE;
    NodeFetch requestedNodeFetch = NodeFetch::Auto;  // RAYPACK_NODE_FETCH
    NodeFetch nodeFetch = NodeFetch::Storage;        // what the uploaded tree's kernels read (installTree)
    std::string nodeFetchReason;                     // why, in words
    VkShaderModule module = VK_NULL_HANDLE;
    VkShaderModule moduleF64 = VK_NULL_HANDLE;  // trace.comp with RP_FLOAT64, where the device has doubles
    // HitDistanceMath::Auto's choice on this device, made on first use, and the measured rate of
    // doubles against floats behind it (0 where none was measured).
    std::optional<HitDistanceMath> autoHitDistance;
    double float64Rate = 0.0;
    VkPipelineCache pipelineCache = VK_NULL_HANDLE;
    std::map<PipelineKey, VkPipeline> pipelines;
    VkQueryPool queries = VK_NULL_HANDLE;
    uint32_t frameCounter = 0;                   // frames recorded, selects the timestamp slot
    std::array<bool, kQuerySlots> slotShadow{};  // whether the slot's frame had a shadow pass
    std::array<uint64_t, kQuerySlots> slotFrame{};
    VkCommandBuffer syncCommands = VK_NULL_HANDLE;
    VkFence syncFence = VK_NULL_HANDLE;

    // Scene: the tables that depend on the scene alone (materials, textures), uploaded for
    // `tablesScene`, and the tree's arrays (nodes, leaf-order triangles and their attributes),
    // uploaded from a host tree or built on the device.
    vk::Buffer materials, textures, texels, dummy;
    const Scene* tablesScene = nullptr;
    std::unique_ptr<GpuTree> tree;
    std::function<void(std::unique_ptr<GpuTree>)> retiredTreeSink;  // setRetiredTreeSink
    bool hasScene = false, hasNormals = false, hasMaterials = false, hasUvs = false, hasColors = false;
    bool hostTimedPasses = false;  // setHostTimedPasses
    uint32_t stackEntries = 1;
    Aabb sceneBounds;
    // buildOnDevice's builder (made on first use); it keeps the scene's vertex arrays while only
    // the tree changes.
    std::unique_ptr<GpuBvhBuilder> builder;

    // Frame.
    uint32_t width = 0, height = 0;
    vk::Buffer primaryHits, output, hits, counters, status;
    vk::Buffer readback;  // host-visible copy target of render()

    explicit State(const vk::VulkanContext& context) : ctx(context) {}
};

namespace {
void destroyState(GpuTracer::State& s);
}  // namespace

GpuTracer::GpuTracer(const vk::VulkanContext& context) : state_(std::make_unique<State>(context)) {
    State& s = *state_;
    const VkDevice device = context.device;
    try {
        s.pool = vk::createCommandPool(context, VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT, "vkCreateCommandPool");

        s.requestedNodeFetch = nodeFetchFromEnvironment();
        static_assert(gpu::kBindNodeTexels == gpu::kBindingCount, "the texel binding follows the storage buffers");
        s.layout = vk::createStorageSetLayout(context, gpu::kBindingCount, sizeof(gpu::GpuFrameParams), 1);

        s.module = vk::createShaderModule(context, trace_spv, sizeof(trace_spv), "trace.comp");
        if (context.float64)
            s.moduleF64 = vk::createShaderModule(context, trace_f64_spv, sizeof(trace_f64_spv), "trace.comp (fp64)");
        VkPipelineCacheCreateInfo cacheInfo{VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO};
        vk::check(vkCreatePipelineCache(device, &cacheInfo, nullptr, &s.pipelineCache), "vkCreatePipelineCache");

        if (context.info.timestamps) {
            VkQueryPoolCreateInfo queryInfo{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
            queryInfo.queryType = VK_QUERY_TYPE_TIMESTAMP;
            queryInfo.queryCount = kQuerySlots * kQueriesPerFrame;
            vk::check(vkCreateQueryPool(device, &queryInfo, nullptr, &s.queries), "vkCreateQueryPool");
        }

        VkCommandBufferAllocateInfo commandInfo{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
        commandInfo.commandPool = s.pool;
        commandInfo.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        commandInfo.commandBufferCount = 1;
        vk::check(vkAllocateCommandBuffers(device, &commandInfo, &s.syncCommands), "vkAllocateCommandBuffers");
        VkFenceCreateInfo fenceInfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
        vk::check(vkCreateFence(device, &fenceInfo, nullptr, &s.syncFence), "vkCreateFence");

        // Bound where the scene has no normals, materials, UVs or colours: the kernels never read
        // it then.
        s.dummy = vk::createBuffer(context, 16, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT,
                                   "an unused binding");
        s.status = vk::createBuffer(context, 16, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                    VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                    "the status word");
    } catch (...) {
        destroyState(s);
        throw;
    }
}

GpuTracer::~GpuTracer() {
    if (state_) destroyState(*state_);
}

namespace {
void destroyState(GpuTracer::State& s) {
    const VkDevice device = s.ctx.device;
    if (device) vk::deviceWaitIdle(s.ctx);
    for (auto& [key, pipeline] : s.pipelines) vkDestroyPipeline(device, pipeline, nullptr);
    s.pipelines.clear();
    if (s.nodeView) vkDestroyBufferView(device, s.nodeView, nullptr);
    s.nodeView = VK_NULL_HANDLE;
    s.tree.reset();
    s.builder.reset();
    for (vk::Buffer* b : {&s.materials, &s.textures, &s.texels, &s.dummy, &s.primaryHits, &s.output, &s.hits,
                          &s.counters, &s.status, &s.readback})
        vk::destroyBuffer(s.ctx, *b);
    if (s.syncFence) vkDestroyFence(device, s.syncFence, nullptr);
    if (s.queries) vkDestroyQueryPool(device, s.queries, nullptr);
    if (s.pipelineCache) vkDestroyPipelineCache(device, s.pipelineCache, nullptr);
    if (s.module) vkDestroyShaderModule(device, s.module, nullptr);
    if (s.moduleF64) vkDestroyShaderModule(device, s.moduleF64, nullptr);
    if (device) vk::destroyStorageSetLayout(s.ctx, s.layout);
    if (s.pool) vkDestroyCommandPool(device, s.pool, nullptr);
    s.pool = VK_NULL_HANDLE;
}
}  // namespace

namespace {

void writeDescriptors(GpuTracer::State& s);

// What every way of setting a scene shares: the scene's attribute flags (gpuTreeAttributes, the
// arrays a device build makes), and staging for the tables that do not depend on the tree
// (materials, texture table, texels). Returns `counts` (gpuLayoutCounts of `scene`) as the layout
// is written: UVs come with textures (Scene::uvs), and without texels the kernels never read UVs,
// so neither the UVs nor the texture tables are converted or uploaded then.
GpuLayoutCounts stageSceneTables(GpuTracer::State& s, vk::StagedUpload& staging, const Scene& scene,
                                 GpuLayoutCounts counts, GpuLayoutTargets& targets);

// The stack entries a tree of depth `maxDepth` needs (a leaf at depth D has at most D pending
// siblings; one more for the root leaf); throws when the packet stack does not fit shared memory.
uint32_t stackEntriesFor(const GpuTracer::State& s, uint32_t maxDepth);

// Drops the current scene after the queue has gone idle; the tables too unless `keepTables`.
void dropScene(GpuTracer::State& s, bool keepTables) {
    vk::queueWaitIdle(s.ctx);
    if (s.tree && s.retiredTreeSink)
        s.retiredTreeSink(std::move(s.tree));
    else
        s.tree.reset();
    s.hasScene = false;
    if (keepTables) return;
    for (vk::Buffer* b : {&s.materials, &s.textures, &s.texels}) vk::destroyBuffer(s.ctx, *b);
    s.tablesScene = nullptr;
}

// Uploads `scene`'s tables (materials, textures) and sets the attribute flags: T_CU's share of a
// device-built tree, whose own arrays the device fills.
GpuTracer::UploadTimings uploadTables(GpuTracer::State& s, const Scene& scene) {
    const auto start = Clock::now();
    Bvh none;  // counts of the scene alone: no tree yet
    none.nodes.assign(1, BvhNode{});
    vk::StagedUpload staging(s.ctx, s.pool);
    GpuLayoutTargets targets;
    writeGpuMaterials(scene, stageSceneTables(s, staging, scene, gpuLayoutCounts(scene, none), targets), targets);
    staging.submit();
    s.tablesScene = &scene;
    GpuTracer::UploadTimings timings;
    timings.allocationSeconds = staging.allocationSeconds();
    timings.transferSeconds = staging.transferSeconds();
    timings.conversionSeconds = secondsSince(start) - timings.allocationSeconds - timings.transferSeconds;
    return timings;
}

// What `tree`'s kernels read nodes through on this device (NodeFetch), and why.
void chooseNodeFetch(GpuTracer::State& s, const GpuTree& tree) {
    const vk::DeviceInfo& device = s.ctx.info;
    const bool cpuDevice = device.type == VK_PHYSICAL_DEVICE_TYPE_CPU;
    const NodeFetch wanted = s.requestedNodeFetch != NodeFetch::Auto ? s.requestedNodeFetch
                             : cpuDevice                             ? NodeFetch::Texel
                                                                     : NodeFetch::Storage;
    const std::string asked = s.requestedNodeFetch != NodeFetch::Auto ? "RAYPACK_NODE_FETCH"
                              : cpuDevice                             ? "auto: a CPU device"
                                                                      : "auto: not a CPU device";
    s.nodeFetch = NodeFetch::Storage;
    if (wanted == NodeFetch::Storage) {
        s.nodeFetchReason = asked;
    } else if (tree.bvhWidth != 2) {
        s.nodeFetchReason = asked + "; the 8-wide tree reads storage";
    } else if (!device.rgba32fTexelBuffers) {
        s.nodeFetchReason = asked + "; the device has no RGBA32F uniform texel buffers";
    } else if (tree.nodes.size / 16 > device.maxTexelBufferElements) {
        s.nodeFetchReason = asked + "; " + std::to_string(tree.nodes.size / 16) + " node texels exceed the device's " +
                            std::to_string(device.maxTexelBufferElements);
    } else {
        s.nodeFetch = NodeFetch::Texel;
        s.nodeFetchReason = asked;
    }
}

// Makes `tree` the traced one (the queue idle, the previous tree dropped, the tables in place),
// with the kernels' stack sized for `stackEntries`. The scene's bounds (for the light) are computed
// unless `sameScene` (a gather over every vertex of every triangle: 0.1 s at 13M triangles).
void installTree(GpuTracer::State& s, std::unique_ptr<GpuTree> tree, uint32_t stackEntries, bool sameScene) {
    const Scene& scene = *tree->scene;
    s.stackEntries = stackEntries;
    if (s.nodeView) vkDestroyBufferView(s.ctx.device, s.nodeView, nullptr);
    s.nodeView = VK_NULL_HANDLE;  // writeDescriptors makes the new tree's
    chooseNodeFetch(s, *tree);
    s.tree = std::move(tree);
    if (!sameScene) s.sceneBounds = scene.bounds();
    s.hasScene = true;
    if (s.width > 0) writeDescriptors(s);
}

}  // namespace

double GpuTracer::upload(const Scene& scene, const Bvh& bvh, uint32_t bvhWidth) {
    State& s = *state_;
    const auto start = Clock::now();
    if (bvhWidth != 2 && bvhWidth != 8)
        throw Error("GPU: a BVH of width " + std::to_string(bvhWidth) + " is not traced (2 or 8)");
    const GpuLayoutCounts counts = gpuLayoutCounts(scene, bvh);
    // The compressed 8-wide tree is made here from the binary one (part of T_CU's conversion); its
    // rays push at most one node group per wide level.
    const auto collapseStart = Clock::now();
    const GpuWideTree wide = bvhWidth == 8 ? makeGpuWideTree(scene, bvh) : GpuWideTree{};
    const double collapseSeconds = secondsSince(collapseStart);
    const uint32_t entries = stackEntriesFor(s, bvhWidth == 8 ? wide.maxDepth : gpuTreeDepth(bvh));

    dropScene(s, /*keepTables=*/false);
    auto tree = std::make_unique<GpuTree>(s.ctx);
    tree->scene = &scene;
    tree->options = bvh.options;
    tree->stats = bvh.stats;
    tree->bvhWidth = bvhWidth;

    // Each array gets its device-local buffer and a mapped staging buffer of the same size; the
    // layout is written straight into the staging memory by parallel workers (writeGpuLayout: no
    // host-side copy of the layout, no zero-filled temporaries), then one submission copies every
    // array.
    vk::StagedUpload staging(s.ctx, s.pool);
    GpuLayoutTargets targets;
    const GpuLayoutCounts written = stageSceneTables(s, staging, scene, counts, targets);
    // Texel usage: the kernels may read the nodes through a texel view (NodeFetch).
    void* nodes = bvhWidth == 8
                      ? staging.add(tree->nodes, wide.nodes.size() * sizeof(gpu::GpuWideNode), "8-wide BVH nodes",
                                    kNodeTexelUsage)
                      : staging.add(tree->nodes, counts.nodes * sizeof(gpu::GpuNode), "BVH nodes", kNodeTexelUsage);
    if (bvhWidth == 2) targets.nodes = static_cast<gpu::GpuNode*>(nodes);
    targets.triangles = static_cast<gpu::GpuTriangle*>(
        staging.add(tree->triangles, counts.triangles * sizeof(gpu::GpuTriangle), "triangles"));
    if (s.hasNormals)
        targets.normals = static_cast<gpu::GpuTriangleNormals*>(
            staging.add(tree->normals, counts.triangles * sizeof(gpu::GpuTriangleNormals), "vertex normals"));
    if (s.hasUvs)
        targets.uvs = static_cast<gpu::GpuTriangleUvs*>(
            staging.add(tree->uvs, counts.triangles * sizeof(gpu::GpuTriangleUvs), "UVs"));
    if (s.hasColors)
        targets.colors = static_cast<gpu::GpuTriangleColors*>(
            staging.add(tree->colors, counts.triangles * sizeof(gpu::GpuTriangleColors), "vertex colours"));
    const auto converted = Clock::now();
    if (bvhWidth == 8) {
        std::memcpy(nodes, wide.nodes.data(), wide.nodes.size() * sizeof(gpu::GpuWideNode));
        writeGpuTriangles(scene, wide.order, written, targets);
        writeGpuMaterials(scene, written, targets);
    } else {
        writeGpuLayout(scene, bvh, written, targets);
    }
    const auto transferStart = Clock::now();
    // The collapse to the 8-wide tree is conversion, though it runs before the buffers are made.
    s.lastUpload.allocationSeconds = std::chrono::duration<double>(converted - start).count() - collapseSeconds;
    s.lastUpload.conversionSeconds = std::chrono::duration<double>(transferStart - converted).count() + collapseSeconds;
    staging.submit();
    s.lastUpload.transferSeconds = secondsSince(transferStart);
    s.tablesScene = &scene;
    installTree(s, std::move(tree), entries, /*sameScene=*/false);
    return secondsSince(start);
}

GpuTracer::DeviceBuild GpuTracer::buildOnDevice(const Scene& scene, const BvhBuildOptions& options) {
    State& s = *state_;
    const auto start = Clock::now();
    if (!isGpuBvhBuilder(options.builder))
        throw Error(std::string("GPU: ") + toString(options.builder) + " is not a device builder");
    if (!s.builder) s.builder = std::make_unique<GpuBvhBuilder>(s.ctx);
    // What does not depend on the tree is uploaded once per scene: the builder's vertex arrays
    // and indices, the materials and the textures. The previous tree is dropped first, so that a
    // large scene never holds two trees.
    const bool sameScene = s.tablesScene == &scene && s.builder->holds(scene);
    dropScene(s, /*keepTables=*/sameScene);
    DeviceBuild result;
    if (!sameScene) {
        const UploadTimings tables = uploadTables(s, scene);
        const GpuBvhBuilder::SceneUpload arrays = s.builder->setScene(scene);
        result.uploadSeconds = secondsSince(start);
        result.upload.allocationSeconds = tables.allocationSeconds + arrays.allocationSeconds;
        result.upload.transferSeconds = tables.transferSeconds + arrays.transferSeconds;
        result.upload.conversionSeconds =
            result.uploadSeconds - result.upload.allocationSeconds - result.upload.transferSeconds;
    }
    std::unique_ptr<GpuTree> tree = buildGpuTree(*s.builder, scene, options, /*keepOrder=*/false);
    result.stats = tree->stats;
    installTree(s, std::move(tree), stackEntriesFor(s, result.stats.maxLeafDepth), sameScene);
    s.lastUpload = result.upload;
    result.seconds = secondsSince(start);
    return result;
}

double GpuTracer::adopt(std::unique_ptr<GpuTree> tree) {
    State& s = *state_;
    RAYPACK_CHECK_MSG(tree && tree->scene && &tree->ctx == &s.ctx, "a tree built on the tracer's device");
    const auto start = Clock::now();
    const Scene& scene = *tree->scene;
    const uint32_t entries = stackEntriesFor(s, tree->stats.maxLeafDepth);  // throws before anything is dropped
    const bool sameScene = s.tablesScene == &scene;
    dropScene(s, /*keepTables=*/sameScene);
    s.lastUpload = sameScene ? UploadTimings{} : uploadTables(s, scene);
    installTree(s, std::move(tree), entries, sameScene);
    return sameScene ? 0.0 : secondsSince(start);
}

void GpuTracer::setRetiredTreeSink(std::function<void(std::unique_ptr<GpuTree>)> sink) {
    state_->retiredTreeSink = std::move(sink);
}

Bvh GpuTracer::downloadBvh() const {
    const State& s = *state_;
    if (!s.hasScene) throw Error("GPU: no scene uploaded");
    if (s.tree->bvhWidth != 2)
        throw Error("GPU: the traced tree is the 8-wide one made at upload; its binary tree is the host's");
    return downloadGpuTree(*s.tree);
}

GpuTracer::UploadTimings GpuTracer::lastUploadTimings() const { return state_->lastUpload; }

bool GpuTracer::hasScene() const { return state_->hasScene; }
uint32_t GpuTracer::stackEntries() const { return state_->stackEntries; }
const vk::DeviceInfo& GpuTracer::device() const { return state_->ctx.info; }
VkBuffer GpuTracer::outputBuffer() const { return state_->output.buffer; }
VkDeviceSize GpuTracer::outputBytes() const { return VkDeviceSize(state_->width) * state_->height * 4u; }

uint64_t GpuTracer::sceneBytes() const {
    const State& s = *state_;
    uint64_t bytes = 0;
    if (!s.hasScene) return 0;
    const GpuTree& tree = *s.tree;
    for (const vk::Buffer* b :
         {&tree.nodes, &tree.triangles, &tree.normals, &s.materials, &tree.uvs, &tree.colors, &s.textures, &s.texels})
        bytes += b->size;
    return bytes;
}

namespace {

GpuLayoutCounts stageSceneTables(GpuTracer::State& s, vk::StagedUpload& staging, const Scene& scene,
                                 GpuLayoutCounts counts, GpuLayoutTargets& targets) {
    const GpuTreeAttributes attributes = gpuTreeAttributes(scene);
    s.hasNormals = attributes.normals;
    s.hasMaterials = counts.materials > 0;
    s.hasUvs = attributes.uvs;
    s.hasColors = attributes.colors;
    if (!s.hasUvs) {
        counts.uvs = false;
        counts.textures = 0;
        counts.texels = 0;
    }
    if (s.hasMaterials)
        targets.materials = static_cast<gpu::GpuMaterial*>(
            staging.add(s.materials, counts.materials * sizeof(gpu::GpuMaterial), "materials"));
    if (s.hasUvs) {
        targets.textures = static_cast<gpu::GpuTexture*>(
            staging.add(s.textures, counts.textures * sizeof(gpu::GpuTexture), "the texture table"));
        targets.texels = static_cast<uint32_t*>(staging.add(s.texels, counts.texels * sizeof(uint32_t), "texels"));
    }
    return counts;
}

uint32_t stackEntriesFor(const GpuTracer::State& s, uint32_t maxDepth) {
    const uint32_t entries = maxDepth + 1;
    const uint64_t packetStackBytes = uint64_t(entries) * 8u;
    if (packetStackBytes + kVoteBytes > s.ctx.info.maxSharedMemoryBytes)
        throw Error("GPU: the BVH is " + std::to_string(maxDepth) + " levels deep; its packet stack needs " +
                    std::to_string(packetStackBytes) + " bytes of shared memory but " + s.ctx.info.name + " has " +
                    std::to_string(s.ctx.info.maxSharedMemoryBytes) +
                    " (build with a larger leaf size or use the CPU tracer)");
    return entries;
}

void writeDescriptors(GpuTracer::State& s) {
    std::array<VkBuffer, gpu::kBindingCount> buffers{};
    const GpuTree& tree = *s.tree;
    buffers[gpu::kBindNodes] = tree.nodes.buffer;
    buffers[gpu::kBindTriangles] = tree.triangles.buffer;
    buffers[gpu::kBindNormals] = (s.hasNormals ? tree.normals : s.dummy).buffer;
    buffers[gpu::kBindMaterials] = (s.hasMaterials ? s.materials : s.dummy).buffer;
    buffers[gpu::kBindPrimaryHits] = s.primaryHits.buffer;
    buffers[gpu::kBindOutput] = s.output.buffer;
    buffers[gpu::kBindHits] = s.hits.buffer;
    buffers[gpu::kBindCounters] = s.counters.buffer;
    buffers[gpu::kBindStatus] = s.status.buffer;
    buffers[gpu::kBindUvs] = (s.hasUvs ? tree.uvs : s.dummy).buffer;
    buffers[gpu::kBindColors] = (s.hasColors ? tree.colors : s.dummy).buffer;
    buffers[gpu::kBindTextures] = (s.hasUvs ? s.textures : s.dummy).buffer;
    buffers[gpu::kBindTexels] = (s.hasUvs ? s.texels : s.dummy).buffer;
    vk::writeStorageSet(s.ctx, s.layout.set, buffers);
    if (!s.nodeView) {
        // Every pipeline declares the binding, so it always holds a valid view: the whole node
        // buffer where the kernels read it (chooseNodeFetch checked that it fits), else its first
        // texels.
        VkBufferViewCreateInfo viewInfo{VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO};
        viewInfo.buffer = tree.nodes.buffer;
        viewInfo.format = kNodeTexelFormat;
        viewInfo.range =
            std::min<VkDeviceSize>(tree.nodes.size, VkDeviceSize(s.ctx.info.maxTexelBufferElements) * 16) / 16 * 16;
        vk::check(vkCreateBufferView(s.ctx.device, &viewInfo, nullptr, &s.nodeView), "vkCreateBufferView");
    }
    vk::writeTexelBuffer(s.ctx, s.layout.set, gpu::kBindNodeTexels, s.nodeView);
}

// (Re-)creates the per-pixel buffers for a width x height frame.
void ensureFrameBuffers(GpuTracer::State& s, uint32_t width, uint32_t height) {
    if (s.width == width && s.height == height) return;
    vk::queueWaitIdle(s.ctx);
    for (vk::Buffer* b : {&s.primaryHits, &s.output, &s.hits, &s.counters, &s.readback}) vk::destroyBuffer(s.ctx, *b);
    s.width = s.height = 0;
    const VkDeviceSize pixels = VkDeviceSize(width) * height;
    const VkBufferUsageFlags usage =
        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    const VkMemoryPropertyFlags local = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
    s.primaryHits =
        vk::createBuffer(s.ctx, pixels * sizeof(gpu::GpuPrimaryHit), usage, local, "the primary hits of a frame");
    s.output = vk::createBuffer(s.ctx, pixels * 4u, usage, local, "the output image");
    s.hits = vk::createBuffer(s.ctx, pixels * sizeof(HitRecord), usage, local, "the hit records");
    s.counters = vk::createBuffer(s.ctx, pixels * sizeof(RayCounters), usage, local, "the ray counters");
    s.width = width;
    s.height = height;
    if (s.hasScene) writeDescriptors(s);
}

void ensureReadback(GpuTracer::State& s, VkDeviceSize bytes) {
    if (s.readback.buffer && s.readback.size >= bytes) return;
    vk::destroyBuffer(s.ctx, s.readback);
    // Cached host memory reads back fast; fall back to plain host-visible memory.
    const VkMemoryPropertyFlags coherent = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    try {
        s.readback = vk::createBuffer(s.ctx, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                      coherent | VK_MEMORY_PROPERTY_HOST_CACHED_BIT, "the read-back buffer");
    } catch (const Error&) {
        s.readback = vk::createBuffer(s.ctx, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, coherent, "the read-back buffer");
    }
}

// The arithmetic `requested` comes to on this tracer's device. Auto: doubles on a CPU device (which
// runs them at half the float rate, as its SIMD lanes are twice as wide), float pairs where the
// device has no doubles, else as measured once (vk::measureFloat64Rate against
// vk::kFloat64RateForDoubles).
HitDistanceMath resolveHitDistance(GpuTracer::State& s, HitDistanceMath requested) {
    if (requested == HitDistanceMath::Float64 && !s.moduleF64)
        throw Error("hit distance fp64: " + s.ctx.info.name +
                    " has no 64-bit floats (shaderFloat64); choose float-pair or auto");
    if (requested != HitDistanceMath::Auto) return requested;
    if (!s.autoHitDistance) {
        if (!s.moduleF64) {
            s.autoHitDistance = HitDistanceMath::FloatPair;
        } else if (s.ctx.info.type == VK_PHYSICAL_DEVICE_TYPE_CPU) {
            s.autoHitDistance = HitDistanceMath::Float64;
        } else {
            s.float64Rate = vk::measureFloat64Rate(s.ctx);
            s.autoHitDistance =
                s.float64Rate >= vk::kFloat64RateForDoubles ? HitDistanceMath::Float64 : HitDistanceMath::FloatPair;
        }
    }
    return *s.autoHitDistance;
}

bool usesFloat64(GpuTracer::State& s, const RenderSettings& settings) {
    return settings.intersect == IntersectMode::Robust &&
           resolveHitDistance(s, settings.hitDistance) == HitDistanceMath::Float64;
}

// The pipeline that traces `settings`' pass `pass` (kPass*): everything of the settings a
// specialization constant takes, the hybrid kernel's split rules included (the other kernels keep
// 0, one pipeline), and what the uploaded tree and the device decide: the stack's entries, the
// module (doubles where the robust hit distance resolves to them, usesFloat64; only the primary
// pass computes the distance, so only it takes the doubles' module) and the node path
// (State::nodeFetch; only the binary tree's kernels read texels). One place for the frame's
// dispatches and for pipelineStatistics.
PipelineKey pipelineKeyFor(GpuTracer::State& s, const RenderSettings& settings, uint32_t pass, bool statistics) {
    const PacketShape group = gpuWorkgroup(settings, pass == gpu::kPassShadowShade);
    PipelineKey key{
        settings.kernel, group.width,        group.height,        pass, statistics, viewConstant(settings.view),
        s.stackEntries,  settings.intersect, settings.shadowOrder};
    if (settings.kernel == KernelKind::Hybrid) {
        key.hybridMinRays = settings.hybrid.minRays;
        key.hybridVisitRatio = uint32_t(std::lround(double(settings.hybrid.visitRatio) * 100.0));
        key.packetsPerGroup = settings.hybrid.packetsPerGroup;
    }
    key.wideBvh = settings.kernel == KernelKind::Single && settings.bvhWidth == 8;
    key.float64 = usesFloat64(s, settings) && pass != gpu::kPassShadowShade;
    key.texelNodes = s.nodeFetch == NodeFetch::Texel && !key.wideBvh;
    return key;
}

VkPipeline pipelineFor(GpuTracer::State& s, const PipelineKey& key) {
    if (auto found = s.pipelines.find(key); found != s.pipelines.end()) return found->second;
    // The packet and hybrid kernels trace packets with the shared stack; the single-ray and hybrid
    // kernels give each ray its own stack. After the hybrid kernel's split a ray's stack holds the
    // packet's pending entries it wanted (at most the packet stack's entries) and its own pushes
    // below the split node (at most the single kernel's entries), so it gets both.
    const bool packet = key.kernel == KernelKind::Packet;
    const bool hybrid = key.kernel == KernelKind::Hybrid;
    const bool sharedStack = packet || hybrid;
    gpu::TraceSpecialization data{};
    data.packetWidth = key.packetWidth;
    data.packetHeight = key.packetHeight;
    data.kernel = packet ? gpu::kKernelPacket : hybrid ? gpu::kKernelHybrid : gpu::kKernelSingle;
    data.pass = key.pass;
    data.statistics = key.statistics ? VK_TRUE : VK_FALSE;
    data.view = key.view;
    data.packetStackEntries = sharedStack ? key.stackEntries : 1u;
    data.rayStackEntries = packet ? 1u : hybrid ? 2u * key.stackEntries : key.stackEntries;
    data.packetIsOneSubgroup =
        sharedStack && packetIsOneSubgroup(s.ctx.info, key.packetWidth, key.packetHeight / key.packetsPerGroup)
            ? VK_TRUE
            : VK_FALSE;
    data.packetsPerGroup = key.packetsPerGroup;
    data.wideBvh = key.wideBvh ? VK_TRUE : VK_FALSE;
    data.texelNodes = key.texelNodes ? VK_TRUE : VK_FALSE;
    data.fastIntersect = key.intersect == IntersectMode::Fast ? VK_TRUE : VK_FALSE;
    data.shadowOrder = key.shadowOrder == ShadowOrder::Tree     ? gpu::kShadowOrderTree
                       : key.shadowOrder == ShadowOrder::Larger ? gpu::kShadowOrderLarger
                                                                : gpu::kShadowOrderNearest;
    data.hybridMinRays = key.hybridMinRays;
    data.hybridVisitRatio = key.hybridVisitRatio;
    static_assert(sizeof(VkBool32) == sizeof(data.statistics), "a bool specialization constant is a VkBool32");
    std::array<VkSpecializationMapEntry, gpu::kTraceSpecializationEntries.size()> entries{};
    for (size_t i = 0; i < entries.size(); ++i) {
        const gpu::SpecializationEntry& e = gpu::kTraceSpecializationEntries[i];
        entries[i] = {e.constantId, e.offset, e.size};
    }
    const VkSpecializationInfo specialization{uint32_t(entries.size()), entries.data(), sizeof data, &data};
    const VkPipeline pipeline = vk::createComputePipeline(
        s.ctx, key.float64 ? s.moduleF64 : s.module, specialization, s.layout.pipelineLayout,
        std::string("GPU: could not build the ") + toString(key.kernel) + " kernel for packet " +
            std::to_string(key.packetWidth) + "x" + std::to_string(key.packetHeight),
        s.pipelineCache, s.ctx.pipelineStatistics ? VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR : 0);
    s.pipelines.emplace(key, pipeline);
    return pipeline;
}

void checkWorkgroup(const GpuTracer::State& s, const RenderSettings& settings, bool shadowPass) {
    const vk::DeviceInfo& d = s.ctx.info;
    const PacketShape shape = gpuWorkgroup(settings, shadowPass);
    const std::string name = std::string(settings.kernel != KernelKind::Single ? "packet "
                                         : shadowPass                          ? "shadow-pass workgroup "
                                                                               : "workgroup ") +
                             std::to_string(shape.width) + "x" + std::to_string(shape.height);
    if (shape.width == 0 || shape.height == 0) throw Error("GPU: " + name + " is empty");
    if (shape.rays() > d.maxWorkgroupInvocations || shape.width > d.maxWorkgroupSize[0] ||
        shape.height > d.maxWorkgroupSize[1])
        throw Error("GPU: " + name + " exceeds " + d.name + "'s workgroup limit (" +
                    std::to_string(d.maxWorkgroupInvocations) + " invocations, " +
                    std::to_string(d.maxWorkgroupSize[0]) + "x" + std::to_string(d.maxWorkgroupSize[1]) + ")");
    const uint32_t packets = settings.kernel == KernelKind::Hybrid ? settings.hybrid.packetsPerGroup : 1u;
    if (packets > 1 && !packetsAreOneSubgroupEach(d, settings.packet.width, settings.packet.height, packets))
        throw Error("GPU: " + std::to_string(packets) + " hybrid packets of " + std::to_string(settings.packet.width) +
                    "x" + std::to_string(settings.packet.height) +
                    " per workgroup need packets that are each exactly one subgroup (" +
                    std::to_string(d.subgroupSize) + " rays on " + d.name + ")");
    const uint64_t shared = uint64_t(s.stackEntries) * 8u * packets + kVoteBytes;
    if (settings.kernel != KernelKind::Single && shared > d.maxSharedMemoryBytes)
        throw Error("GPU: " + name + " with a stack of " + std::to_string(s.stackEntries) + " entries needs " +
                    std::to_string(shared) + " bytes of shared memory; " + d.name + " has " +
                    std::to_string(d.maxSharedMemoryBytes));
    const WorkgroupCount groups = workgroupCount(settings.width, settings.height, shape);
    if (groups.x > d.maxWorkgroupCount[0] || groups.y > d.maxWorkgroupCount[1])
        throw Error("GPU: " + std::to_string(settings.width) + "x" + std::to_string(settings.height) + " in " + name +
                    "s needs " + std::to_string(groups.x) + "x" + std::to_string(groups.y) + " workgroups, more than " +
                    d.name + " dispatches");
}

// HybridParams' automatic packets per workgroup (kAutoPacketsPerGroup) on this device: four where
// each packet fills exactly one subgroup (8x4 on NVIDIA, an 8x1 row on lavapipe) and four fit the
// device's workgroup and shared memory, otherwise one. Four measured 0.98-1.09x one on an H100 and
// 0.98-3.4x on lavapipe (docs/gpu.md, "The hybrid kernel's packets per workgroup").
constexpr uint32_t kAutoHybridPackets = 4;
uint32_t autoPacketsPerGroup(const GpuTracer::State& s, PacketShape packet) {
    const vk::DeviceInfo& d = s.ctx.info;
    const uint64_t rays = uint64_t(packet.width) * packet.height;
    const bool fillsSubgroup =
        rays == d.subgroupSize && packetsAreOneSubgroupEach(d, packet.width, packet.height, kAutoHybridPackets);
    const bool fits = rays * kAutoHybridPackets <= d.maxWorkgroupInvocations &&
                      uint64_t(packet.height) * kAutoHybridPackets <= d.maxWorkgroupSize[1] &&
                      uint64_t(s.stackEntries) * 8u * kAutoHybridPackets + kVoteBytes <= d.maxSharedMemoryBytes;
    return fillsSubgroup && fits ? kAutoHybridPackets : 1u;
}

RenderSettings deviceSettingsFor(const GpuTracer::State& s, RenderSettings settings) {
    if (settings.kernel == KernelKind::Hybrid && settings.hybrid.packetsPerGroup == kAutoPacketsPerGroup)
        settings.hybrid.packetsPerGroup = autoPacketsPerGroup(s, settings.packet);
    return settings;
}

void checkSettings(const GpuTracer::State& s, const RenderSettings& settings) {
    if (!s.hasScene) throw Error("GPU: no scene uploaded");
    if (settings.width == 0 || settings.height == 0)
        throw Error("GPU: the image is empty (" + std::to_string(settings.width) + "x" +
                    std::to_string(settings.height) + ")");
    checkWorkgroup(s, settings, false);
    if (settings.shadows) checkWorkgroup(s, settings, true);
    if (settings.bvhWidth != s.tree->bvhWidth)
        throw Error("GPU: the uploaded BVH is " + std::to_string(s.tree->bvhWidth) +
                    "-wide, the settings ask for width " + std::to_string(settings.bvhWidth) +
                    " (upload with that width)");
    if (settings.bvhWidth == 8 && settings.kernel != KernelKind::Single)
        throw Error(std::string("GPU: the 8-wide BVH is traced by the single-ray kernel only, not by the ") +
                    toString(settings.kernel) + " kernel");
    if (settings.bvhWidth == 8 && settings.shadowOrder != ShadowOrder::Nearest)
        throw Error("GPU: the 8-wide BVH orders every ray's children by its octant; --shadow-order " +
                    std::string(toString(settings.shadowOrder)) + " applies to the binary tree");
    if (!(settings.hybrid.visitRatio >= 0.0f && settings.hybrid.visitRatio <= kMaxHybridVisitRatio))
        throw Error("GPU: the hybrid kernel's visit ratio " + std::to_string(settings.hybrid.visitRatio) +
                    " is not 0 (off) or a ratio up to " + std::to_string(int(kMaxHybridVisitRatio)));
}

gpu::GpuFrameParams frameParams(const GpuTracer::State& s, const RenderSettings& settings,
                                const GpuRecordOptions& options, bool writeHits, glm::vec3* light) {
    gpu::GpuFrameParams p{};
    p.camera = makeGpuCamera(settings.camera, settings.width, settings.height, settings.pixelJitter);
    *light = lightPosition(settings.camera, s.sceneBounds, settings.lightHeight);
    p.light = glm::vec4(*light, 0.0f);
    p.background = glm::vec4(settings.background, settings.heatFullScale);
    p.phong =
        glm::vec4(settings.phong.ambient, settings.phong.diffuse, settings.phong.specular, settings.phong.shininess);
    const uint32_t packetsPerRow = uint32_t(workgroupCount(settings.width, settings.height, gpuWorkgroup(settings)).x);
    p.frame =
        glm::uvec4(settings.width, settings.height,
                   (writeHits ? gpu::kFrameWriteHits : 0u) | (options.bgra ? gpu::kFrameBgra : 0u) |
                       (s.hasNormals ? gpu::kFrameHasNormals : 0u) | (s.hasMaterials ? gpu::kFrameHasMaterials : 0u) |
                       (s.hasUvs ? gpu::kFrameHasUvs : 0u) | (s.hasColors ? gpu::kFrameHasColors : 0u),
                   packetsPerRow);
    return p;
}

// Records both passes; returns the light position.
// The synchronous command buffer: begin it anew, and end + submit + wait for it.
void beginSyncCommands(GpuTracer::State& s) {
    vk::check(vkResetCommandBuffer(s.syncCommands, 0), "vkResetCommandBuffer");
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vk::check(vkBeginCommandBuffer(s.syncCommands, &begin), "vkBeginCommandBuffer");
}

void submitSyncCommandsAndWait(GpuTracer::State& s) {
    vk::check(vkEndCommandBuffer(s.syncCommands), "vkEndCommandBuffer");
    vk::check(vkResetFences(s.ctx.device, 1, &s.syncFence), "vkResetFences");
    VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &s.syncCommands;
    vk::queueSubmit(s.ctx, submit, s.syncFence, "vkQueueSubmit");
    vk::check(vkWaitForFences(s.ctx.device, 1, &s.syncFence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
}

// Host timing of the passes (GpuTracer::setHostTimedPasses): `split` submits what was recorded so
// far, waits for it, re-opens the command buffer and returns the time; recordPasses calls it around
// each dispatch.
struct HostPassClock {
    std::function<Clock::time_point()> split;
    double primarySeconds = 0.0;
    double shadowSeconds = 0.0;
};

// `settings` as deviceSettingsFor resolved them (the public entry points do).
glm::vec3 recordPasses(GpuTracer::State& s, VkCommandBuffer cmd, const RenderSettings& settings,
                       const GpuRecordOptions& options, bool writeHits, bool statistics,
                       HostPassClock* hostClock = nullptr) {
    checkSettings(s, settings);
    ensureFrameBuffers(s, settings.width, settings.height);
    glm::vec3 light;
    const gpu::GpuFrameParams params = frameParams(s, settings, options, writeHits, &light);
    const uint32_t view = viewConstant(settings.view);
    statistics = statistics || settings.collectCounters || view != gpu::kViewShaded;
    const uint32_t slot = s.frameCounter % kQuerySlots;
    const uint32_t firstQuery = slot * kQueriesPerFrame;
    s.slotShadow[slot] = settings.shadows;
    s.slotFrame[slot] = ++s.frameCounter;

    // Earlier frames on this queue read or wrote the same buffers (copies of the output, the
    // shaders): finish them first.
    vkCmdFillBuffer(cmd, s.status.buffer, 0, VK_WHOLE_SIZE, 0u);
    if (s.queries) vkCmdResetQueryPool(cmd, s.queries, firstQuery, kQueriesPerFrame);
    vk::memoryBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                      VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                      VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);

    // checkSettings has held each pass's workgroup count to the device's limit.
    const WorkgroupCount groups = workgroupCount(settings.width, settings.height, gpuWorkgroup(settings));
    PipelineKey key =
        pipelineKeyFor(s, settings, settings.shadows ? gpu::kPassPrimary : gpu::kPassPrimaryShade, statistics);
    // What the dispatches use: bound here, and again after a host split, which re-opens the
    // command buffer.
    auto bindState = [&] {
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s.layout.pipelineLayout, 0, 1, &s.layout.set, 0,
                                nullptr);
        vkCmdPushConstants(cmd, s.layout.pipelineLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof params, &params);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelineFor(s, key));
    };
    bindState();
    if (s.queries) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, s.queries, firstQuery);
    const Clock::time_point primaryStart = hostClock ? hostClock->split() : Clock::time_point{};
    if (hostClock) bindState();
    vkCmdDispatch(cmd, uint32_t(groups.x), uint32_t(groups.y), 1);
    if (s.queries) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, s.queries, firstQuery + 1);
    Clock::time_point shadowStart{};
    if (hostClock) {
        shadowStart = hostClock->split();
        hostClock->primarySeconds = std::chrono::duration<double>(shadowStart - primaryStart).count();
    }

    if (settings.shadows) {
        vk::memoryBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                          VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
        // The shadow pass's workgroup may differ from the primary pass's (the single-ray kernel).
        key = pipelineKeyFor(s, settings, gpu::kPassShadowShade, statistics);
        const WorkgroupCount shadowGroups =
            workgroupCount(settings.width, settings.height, gpuWorkgroup(settings, true));
        if (hostClock) bindState();
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelineFor(s, key));
        if (s.queries) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, s.queries, firstQuery + 2);
        vkCmdDispatch(cmd, uint32_t(shadowGroups.x), uint32_t(shadowGroups.y), 1);
        if (s.queries) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, s.queries, firstQuery + 3);
        if (hostClock)
            hostClock->shadowSeconds = std::chrono::duration<double>(hostClock->split() - shadowStart).count();
    } else if (s.queries) {
        // Keep the slot's four queries written so that availability reads stay simple.
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, s.queries, firstQuery + 2);
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, s.queries, firstQuery + 3);
    }
    vk::memoryBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                      VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_HOST_BIT,
                      VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_HOST_READ_BIT);
    return light;
}

// Kernel times of a slot, when its queries are available (or waiting for them).
std::optional<FrameTimings> slotTimings(GpuTracer::State& s, uint32_t slot, bool wait) {
    if (!s.queries) return std::nullopt;
    uint64_t values[kQueriesPerFrame * 2] = {};
    VkQueryResultFlags flags = VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WITH_AVAILABILITY_BIT;
    if (wait) flags |= VK_QUERY_RESULT_WAIT_BIT;
    const VkResult result = vkGetQueryPoolResults(s.ctx.device, s.queries, slot * kQueriesPerFrame, kQueriesPerFrame,
                                                  sizeof values, values, 2 * sizeof(uint64_t), flags);
    if (result != VK_SUCCESS) return std::nullopt;
    for (uint32_t q = 0; q < kQueriesPerFrame; ++q)
        if (values[2 * q + 1] == 0) return std::nullopt;
    const double tick = double(s.ctx.info.timestampPeriodNs) * 1e-9;
    FrameTimings t;
    t.primarySeconds = double(values[2] - values[0]) * tick;
    if (s.slotShadow[slot]) t.shadowSeconds = double(values[6] - values[4]) * tick;
    return t;
}

}  // namespace

void GpuTracer::recordFrame(VkCommandBuffer cmd, const RenderSettings& settings, const GpuRecordOptions& options) {
    recordPasses(*state_, cmd, deviceSettingsFor(*state_, settings), options, false, false);
}

std::optional<FrameTimings> GpuTracer::lastKernelTimes() {
    State& s = *state_;
    // Newest slot first.
    for (uint32_t back = 0; back < kQuerySlots && back < s.frameCounter; ++back) {
        const uint32_t slot = (s.frameCounter - 1 - back) % kQuerySlots;
        if (auto t = slotTimings(s, slot, false)) return t;
    }
    return std::nullopt;
}

void GpuTracer::setHostTimedPasses(bool on) { state_->hostTimedPasses = on; }

void GpuTracer::traceBackToBack(const RenderSettings& requested, uint32_t frames) {
    State& s = *state_;
    const RenderSettings settings = deviceSettingsFor(s, requested);
    beginSyncCommands(s);
    for (uint32_t i = 0; i < frames; ++i) recordPasses(s, s.syncCommands, settings, {}, false, false);
    submitSyncCommandsAndWait(s);
}

Frame GpuTracer::render(const RenderSettings& requested, const FrameRequest& request) {
    State& s = *state_;
    const auto start = Clock::now();
    const RenderSettings settings = deviceSettingsFor(s, requested);
    checkSettings(s, settings);
    ensureFrameBuffers(s, settings.width, settings.height);
    const VkDeviceSize pixels = VkDeviceSize(settings.width) * settings.height;
    const VkDeviceSize imageBytes = request.image ? pixels * 4u : 0u;
    const VkDeviceSize hitBytes = request.hits ? pixels * sizeof(HitRecord) : 0u;
    const VkDeviceSize counterBytes = request.counters ? pixels * sizeof(RayCounters) : 0u;
    ensureReadback(s, std::max<VkDeviceSize>(imageBytes + hitBytes + counterBytes, 16));

    beginSyncCommands(s);
    HostPassClock hostClock;
    if (s.hostTimedPasses) {
        hostClock.split = [&] {
            submitSyncCommandsAndWait(s);
            const Clock::time_point now = Clock::now();
            beginSyncCommands(s);
            return now;
        };
    }
    const glm::vec3 light = recordPasses(s, s.syncCommands, settings, {}, request.hits, request.counters,
                                         s.hostTimedPasses ? &hostClock : nullptr);
    const uint32_t slot = (s.frameCounter - 1) % kQuerySlots;
    VkDeviceSize offset = 0;
    auto copy = [&](const vk::Buffer& from, VkDeviceSize bytes) {
        if (bytes == 0) return;
        VkBufferCopy region{0, offset, bytes};
        vkCmdCopyBuffer(s.syncCommands, from.buffer, s.readback.buffer, 1, &region);
        offset += bytes;
    };
    copy(s.output, imageBytes);
    copy(s.hits, hitBytes);
    copy(s.counters, counterBytes);
    vk::memoryBarrier(s.syncCommands, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
    submitSyncCommandsAndWait(s);

    const uint32_t status = *static_cast<const uint32_t*>(s.status.mapped);
    if (status & gpu::kStatusSubgroupMismatch)
        throw Error("GPU: " + s.ctx.info.name + " split a packet of " + std::to_string(settings.packet.width) + "x" +
                    std::to_string(settings.packet.height) +
                    " rays across subgroups although it fits one subgroup of " +
                    std::to_string(s.ctx.info.subgroupSize) + "; use another packet shape");
    if (status & gpu::kStatusTraversalTruncated)
        throw Error("GPU: a ray needed more than " + std::to_string(gpu::kMaxTraversalSteps) +
                    " traversal steps (nodes plus triangle tests) and was stopped, so the frame would be "
                    "wrong; render this scene on the CPU (--device cpu)");
    RAYPACK_CHECK_MSG(status == 0, "a GPU traversal stack overflowed despite its sizing");

    Frame frame;
    frame.width = settings.width;
    frame.height = settings.height;
    frame.light = light;
    const auto* bytes = static_cast<const uint8_t*>(s.readback.mapped);
    if (request.image) {
        frame.rgba.resize(pixels);
        std::memcpy(frame.rgba.data(), bytes, imageBytes);
    }
    if (request.hits) {
        frame.hits.resize(pixels);
        std::memcpy(frame.hits.data(), bytes + imageBytes, hitBytes);
    }
    if (request.counters) {
        frame.counters.resize(pixels);
        std::memcpy(frame.counters.data(), bytes + imageBytes + hitBytes, counterBytes);
    }
    if (s.hostTimedPasses) {
        frame.timings.primarySeconds = hostClock.primarySeconds;
        frame.timings.shadowSeconds = hostClock.shadowSeconds;
    } else if (auto t = slotTimings(s, slot, true)) {
        frame.timings.primarySeconds = t->primarySeconds;
        frame.timings.shadowSeconds = t->shadowSeconds;
    }
    frame.timings.totalSeconds = secondsSince(start);
    return frame;
}

HitDistanceMath GpuTracer::hitDistanceMath(HitDistanceMath requested) { return resolveHitDistance(*state_, requested); }

RenderSettings GpuTracer::deviceSettings(const RenderSettings& settings) const {
    return deviceSettingsFor(*state_, settings);
}

double GpuTracer::float64Rate() const { return state_->float64Rate; }

NodeFetch GpuTracer::nodeFetch() const { return state_->nodeFetch; }

const std::string& GpuTracer::nodeFetchReason() const { return state_->nodeFetchReason; }

const char* toString(NodeFetch fetch) {
    switch (fetch) {
    case NodeFetch::Storage: return "storage";
    case NodeFetch::Texel: return "texel";
    default: return "auto";
    }
}

std::vector<GpuTracer::PipelineStatistic> GpuTracer::pipelineStatistics(const RenderSettings& requested,
                                                                        bool shadowPass) {
    State& s = *state_;
    const RenderSettings settings = deviceSettingsFor(s, requested);
    std::vector<PipelineStatistic> out;
    if (!s.ctx.pipelineStatistics) return out;
    const auto getProperties = reinterpret_cast<PFN_vkGetPipelineExecutablePropertiesKHR>(
        vkGetDeviceProcAddr(s.ctx.device, "vkGetPipelineExecutablePropertiesKHR"));
    const auto getStatistics = reinterpret_cast<PFN_vkGetPipelineExecutableStatisticsKHR>(
        vkGetDeviceProcAddr(s.ctx.device, "vkGetPipelineExecutableStatisticsKHR"));
    if (!getProperties || !getStatistics) return out;
    const bool statistics = settings.collectCounters || settings.view != ViewMode::Shaded;
    const uint32_t pass = shadowPass         ? gpu::kPassShadowShade
                          : settings.shadows ? gpu::kPassPrimary
                                             : gpu::kPassPrimaryShade;
    const PipelineKey key = pipelineKeyFor(s, settings, pass, statistics);
    VkPipelineInfoKHR pipelineInfo{VK_STRUCTURE_TYPE_PIPELINE_INFO_KHR};
    pipelineInfo.pipeline = pipelineFor(s, key);
    uint32_t executables = 0;
    vk::check(getProperties(s.ctx.device, &pipelineInfo, &executables, nullptr),
              "vkGetPipelineExecutablePropertiesKHR");
    std::vector<VkPipelineExecutablePropertiesKHR> properties(executables,
                                                              {VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_PROPERTIES_KHR});
    vk::check(getProperties(s.ctx.device, &pipelineInfo, &executables, properties.data()),
              "vkGetPipelineExecutablePropertiesKHR");
    for (uint32_t e = 0; e < executables; ++e) {
        VkPipelineExecutableInfoKHR executable{VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_INFO_KHR};
        executable.pipeline = pipelineInfo.pipeline;
        executable.executableIndex = e;
        uint32_t count = 0;
        vk::check(getStatistics(s.ctx.device, &executable, &count, nullptr), "vkGetPipelineExecutableStatisticsKHR");
        std::vector<VkPipelineExecutableStatisticKHR> stats(count,
                                                            {VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_STATISTIC_KHR});
        vk::check(getStatistics(s.ctx.device, &executable, &count, stats.data()),
                  "vkGetPipelineExecutableStatisticsKHR");
        const std::string prefix = executables > 1 ? std::string(properties[e].name) + ": " : std::string();
        for (const VkPipelineExecutableStatisticKHR& stat : stats) {
            PipelineStatistic p;
            p.name = prefix + stat.name;
            switch (stat.format) {
            case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_BOOL32_KHR: p.value = stat.value.b32 ? 1.0 : 0.0; break;
            case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_INT64_KHR: p.value = double(stat.value.i64); break;
            case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_UINT64_KHR: p.value = double(stat.value.u64); break;
            case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_FLOAT64_KHR: p.value = stat.value.f64; break;
            default: continue;
            }
            out.push_back(p);
        }
    }
    return out;
}

}  // namespace raypack
