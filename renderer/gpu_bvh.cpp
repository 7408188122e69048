#include "renderer/gpu_bvh.h"

#include "renderer/bvh_build.h"  // validateOptions
#include "renderer/error.h"
#include "renderer/measure/spread.h"  // secondsSince
#include "shaders/lbvh.h"

#include "cluster_layout.spv.h"
#include "hploc.spv.h"
#include "lbvh.spv.h"
#include "lbvh_prepare.spv.h"
#include "ploc.spv.h"
#include "prefix_scan.spv.h"
#include "radix_sort.spv.h"
#include "top.spv.h"
#include "treelet.spv.h"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <string>
#include <utility>

namespace raypack {

static_assert(gpu::kLbvhMaxLeafPrimitives == kMaxLeafPrimitives, "one leaf bound for every builder");
static_assert(gpu::kTreeletLeaves == kTreeletLeaves, "one treelet size for the library and the shader");

// The most splits of one subset size of a treelet's leaves (shaders/treelet.comp's shared array).
constexpr uint32_t treeletMostSplits() {
    uint32_t most = 0, subsets = 1;  // subsets: C(kTreeletLeaves, size)
    for (uint32_t size = 1; size <= gpu::kTreeletLeaves; ++size) {
        subsets = subsets * (gpu::kTreeletLeaves - size + 1) / size;
        most = std::max(most, subsets * ((1u << (size - 1)) - 1));
    }
    return most;
}
static_assert(treeletMostSplits() == gpu::kTreeletMostSplits, "one size's splits fit the shared array");

namespace {

constexpr uint32_t kPhaseCount = gpu::kLbvhPhaseTopFinish + 1;
// gpu-ploc: clustering iterations per submission at most (those after the last merge cost a few
// empty dispatches each). The batch halves while a submission takes longer than
// kPlocSubmissionSeconds and doubles again below a quarter of it: on a CPU device (lavapipe) 16
// iterations over a million clusters take seconds, during which the build could neither be
// cancelled nor report its merges.
constexpr uint32_t kPlocIterationBatch = 16;
constexpr double kPlocSubmissionSeconds = 0.1;
// gpu-ploc, gpu-hploc: the deepest tree their layout lays out (an agglomerative tree has no depth
// bound of its own; the tracers' stacks need one): its pointer-jumping rounds finish every path of
// up to 2^rounds - 1 inner nodes below the root, so leaves are at most 2^rounds deep.
constexpr uint32_t kClusterPathRounds = 12;
constexpr uint32_t kPlocMaxDepth = 1u << kClusterPathRounds;
// The path records of cluster_layout.comp, two halves of n - 1 uvec4, fit in the output triangles.
static_assert(sizeof(gpu::GpuTriangle) >= 2 * 16, "the layout's path records fit the triangle array");
constexpr VkBufferUsageFlags kStorage = vk::StagedUpload::kUsage;
// The build's timestamps: its start, the end of the key sort, the start of the layout (after the
// hierarchy or the clustering), its end.
constexpr uint32_t kStampStart = 0, kStampSorted = 1, kStampLayout = 2, kStampEnd = 3, kTimestamps = 4;

uint32_t groupsFor(uint64_t invocations) {
    return uint32_t((invocations + gpu::kLbvhGroupSize - 1) / gpu::kLbvhGroupSize);
}

// The module holding each phase's kernel.
uint32_t moduleOf(uint32_t phase) {
    switch (phase) {
    case gpu::kLbvhPhaseBounds:
    case gpu::kLbvhPhaseMorton: return 0;
    case gpu::kLbvhPhaseHistogram:
    case gpu::kLbvhPhaseScatter: return 1;
    case gpu::kLbvhPhaseScanBlocks:
    case gpu::kLbvhPhaseAddBlockSums: return 2;
    case gpu::kLbvhPhasePlocInit:
    case gpu::kLbvhPhasePlocNearest:
    case gpu::kLbvhPhasePlocFlags:
    case gpu::kLbvhPhasePlocApply:
    case gpu::kLbvhPhasePlocReorder:
    case gpu::kLbvhPhasePlocSetup: return 4;
    case gpu::kLbvhPhaseHplocInit:
    case gpu::kLbvhPhaseHplocBuild: return 5;
    case gpu::kLbvhPhaseTreelet: return 6;
    case gpu::kLbvhPhaseClusterParents:
    case gpu::kLbvhPhaseClusterCosts:
    case gpu::kLbvhPhaseClusterPathStart:
    case gpu::kLbvhPhaseClusterPathJump:
    case gpu::kLbvhPhaseClusterEmit: return 7;
    case gpu::kLbvhPhaseTopStart:
    case gpu::kLbvhPhaseTopFinish: return 8;
    default: return 3;
    }
}

// The radix sort's prefix sums: the digit counts (256 per sort block) first, then the block sums
// of every level of the scan's recursion, one region after another.
struct ScanPlan {
    struct Level {
        uint32_t offset;  // in uints
        uint32_t count;
        uint32_t sums;  // where its block sums go
    };
    std::vector<Level> levels;  // levels[0] scans the digit counts
    uint64_t words = 0;
};
// `counts` entries from word `base` on; the block sums follow them.
ScanPlan planScan(uint64_t counts, uint64_t base = 0) {
    ScanPlan plan;
    uint64_t offset = base, count = counts, next = base + counts;
    for (;;) {
        const uint64_t blocks = (count + gpu::kLbvhScanBlock - 1) / gpu::kLbvhScanBlock;
        plan.levels.push_back({uint32_t(offset), uint32_t(count), uint32_t(next)});
        offset = next;
        next += blocks;
        if (blocks <= 1) break;
        count = blocks;
    }
    plan.words = next;
    return plan;
}

}  // namespace

GpuBvhSizes gpuBvhSizes(size_t triangles) {
    GpuBvhSizes sizes;
    sizes.nodes = triangles < 2 ? 1 : 2 * triangles - 1;
    sizes.triangles = triangles;
    return sizes;
}

struct GpuBvhBuilder::State {
    const vk::VulkanContext& ctx;
    VkCommandPool pool = VK_NULL_HANDLE;
    vk::StorageSetLayout layout;  // every build kernel's storage buffers and push constants
    std::array<VkShaderModule, 9> modules{};
    std::array<VkPipeline, kPhaseCount> pipelines{};  // created before the first build that runs them
    uint32_t plocRadius = kPlocRadius;                // the nearest-neighbour pipelines' r
    // Timestamps: the build's start, the end of the key sort, the start of the layout, the end.
    VkQueryPool queries = VK_NULL_HANDLE;
    uint32_t subgroupsPerGroup = 0;

    // The scene as it is in host memory: vertex arrays, vertex indices, triangle materials.
    vk::Buffer positions, indices, triangleMaterials, vertexNormals, vertexUvs, vertexColors, dummy;
    const Scene* scene = nullptr;
    size_t triangleCount = 0;
    bool hasScene = false, normals = false, uvs = false, colors = false, materials = false;
    // The last build's order (its sorted values), kept for downloadOrder.
    vk::Buffer order;
    size_t orderCount = 0;

    explicit State(const vk::VulkanContext& context) : ctx(context) {}
};

namespace {

void destroyBuilder(GpuBvhBuilder::State& s) {
    const VkDevice device = s.ctx.device;
    if (!device) return;
    vk::deviceWaitIdle(s.ctx);
    for (VkPipeline& p : s.pipelines)
        if (p) vkDestroyPipeline(device, p, nullptr);
    for (VkShaderModule& m : s.modules)
        if (m) vkDestroyShaderModule(device, m, nullptr);
    for (vk::Buffer* b : {&s.positions, &s.indices, &s.triangleMaterials, &s.vertexNormals, &s.vertexUvs,
                          &s.vertexColors, &s.dummy, &s.order})
        vk::destroyBuffer(s.ctx, *b);
    if (s.queries) vkDestroyQueryPool(device, s.queries, nullptr);
    vk::destroyStorageSetLayout(s.ctx, s.layout);
    if (s.pool) vkDestroyCommandPool(device, s.pool, nullptr);
}

VkPipeline createPhasePipeline(GpuBvhBuilder::State& s, uint32_t phase, uint32_t plocRadius) {
    struct Constants {
        uint32_t phase;
        uint32_t subgroupsPerGroup;
        uint32_t plocRadius;
    } data{phase, s.subgroupsPerGroup, plocRadius};
    const std::array<VkSpecializationMapEntry, 3> entries{{
        {gpu::kLbvhSpecPhase, offsetof(Constants, phase), sizeof(uint32_t)},
        {gpu::kLbvhSpecSubgroupsPerGroup, offsetof(Constants, subgroupsPerGroup), sizeof(uint32_t)},
        {gpu::kLbvhSpecPlocRadius, offsetof(Constants, plocRadius), sizeof(uint32_t)},
    }};
    // The sort's shared memory is sized by the second constant; the other kernels do not declare it
    // (a map entry for a constant the module lacks is ignored).
    const VkSpecializationInfo specialization{uint32_t(entries.size()), entries.data(), sizeof data, &data};
    return vk::createComputePipeline(s.ctx, s.modules[moduleOf(phase)], specialization, s.layout.pipelineLayout,
                                     "gpu-lbvh: could not build kernel phase " + std::to_string(phase));
}

// The phases a build of `builder` over n triangles records (topRebuilt: top.comp's two; treelets:
// any treelet rounds). A builder creates their pipelines before it starts timing that build.
std::vector<uint32_t> phasesOfBuild(BvhBuilder builder, uint32_t n, bool topRebuilt, bool treelets) {
    using namespace gpu;
    std::vector<uint32_t> phases{kLbvhPhaseBounds,       kLbvhPhaseMorton,  kLbvhPhaseHistogram, kLbvhPhaseScanBlocks,
                                 kLbvhPhaseAddBlockSums, kLbvhPhaseScatter, kLbvhPhaseGather};
    const bool clustered = builder == BvhBuilder::GpuPloc || builder == BvhBuilder::GpuHploc;
    // gpu-lbvh's levels, and every builder's root below 2 triangles.
    if (!clustered || n < 2) {
        phases.insert(phases.end(), {kLbvhPhaseHierarchy, kLbvhPhaseLevelRoot, kLbvhPhaseEnumerate, kLbvhPhaseNextLevel,
                                     kLbvhPhaseBottomUp, kLbvhPhaseRoot, kLbvhPhaseEmit});
        return phases;
    }
    if (builder == BvhBuilder::GpuPloc)
        phases.insert(phases.end(), {kLbvhPhasePlocInit, kLbvhPhasePlocSetup, kLbvhPhasePlocNearest,
                                     kLbvhPhasePlocFlags, kLbvhPhasePlocApply});
    else
        phases.insert(phases.end(), {kLbvhPhaseHplocInit, kLbvhPhaseHplocBuild});
    phases.insert(phases.end(), {kLbvhPhaseClusterParents, kLbvhPhaseClusterCosts, kLbvhPhaseClusterPathStart,
                                 kLbvhPhaseClusterPathJump, kLbvhPhaseClusterEmit, kLbvhPhasePlocReorder});
    if (topRebuilt) phases.insert(phases.end(), {kLbvhPhaseTopStart, kLbvhPhaseTopFinish});
    if (treelets) phases.push_back(kLbvhPhaseTreelet);
    return phases;
}

}  // namespace

GpuBvhBuilder::GpuBvhBuilder(const vk::VulkanContext& context) : state_(std::make_unique<State>(context)) {
    State& s = *state_;
    const vk::DeviceInfo& info = context.info;
    if (info.subgroupSize == 0 || gpu::kLbvhGroupSize % info.subgroupSize != 0)
        throw Error("gpu-lbvh: " + info.name + " has subgroups of " + std::to_string(info.subgroupSize) +
                    " invocations, which do not divide the sort's workgroups of " +
                    std::to_string(gpu::kLbvhGroupSize));
    s.subgroupsPerGroup = gpu::kLbvhGroupSize / info.subgroupSize;
    const uint64_t sortShared = ((uint64_t(s.subgroupsPerGroup) + 1) / 2 + 1) * gpu::kLbvhRadixDigits * 4;
    if (sortShared > info.maxSharedMemoryBytes)
        throw Error("gpu-lbvh: the radix sort needs " + std::to_string(sortShared) + " bytes of shared memory, " +
                    info.name + " has " + std::to_string(info.maxSharedMemoryBytes));
    try {
        s.pool = vk::createCommandPool(context, VK_COMMAND_POOL_CREATE_TRANSIENT_BIT, "vkCreateCommandPool");
        s.layout = vk::createStorageSetLayout(context, gpu::kLbvhBindingCount, sizeof(gpu::LbvhParams));

        s.modules[0] = vk::createShaderModule(context, lbvh_prepare_spv, sizeof(lbvh_prepare_spv), "lbvh_prepare.comp");
        s.modules[1] = vk::createShaderModule(context, radix_sort_spv, sizeof(radix_sort_spv), "radix_sort.comp");
        s.modules[2] = vk::createShaderModule(context, prefix_scan_spv, sizeof(prefix_scan_spv), "prefix_scan.comp");
        s.modules[3] = vk::createShaderModule(context, lbvh_spv, sizeof(lbvh_spv), "lbvh.comp");
        s.modules[4] = vk::createShaderModule(context, ploc_spv, sizeof(ploc_spv), "ploc.comp");
        s.modules[5] = vk::createShaderModule(context, hploc_spv, sizeof(hploc_spv), "hploc.comp");
        s.modules[6] = vk::createShaderModule(context, treelet_spv, sizeof(treelet_spv), "treelet.comp");
        s.modules[7] =
            vk::createShaderModule(context, cluster_layout_spv, sizeof(cluster_layout_spv), "cluster_layout.comp");
        s.modules[8] = vk::createShaderModule(context, top_spv, sizeof(top_spv), "top.comp");

        if (info.timestamps) {
            VkQueryPoolCreateInfo queryInfo{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
            queryInfo.queryType = VK_QUERY_TYPE_TIMESTAMP;
            queryInfo.queryCount = kTimestamps;
            vk::check(vkCreateQueryPool(context.device, &queryInfo, nullptr, &s.queries), "vkCreateQueryPool");
        }
        s.dummy = vk::createBuffer(context, 16, kStorage, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, "an unused binding");
    } catch (...) {
        destroyBuilder(s);
        throw;
    }
}

GpuBvhBuilder::~GpuBvhBuilder() {
    if (state_) destroyBuilder(*state_);
}

bool GpuBvhBuilder::holds(const Scene& scene) const {
    return state_->hasScene && state_->scene == &scene && state_->triangleCount == scene.triangleCount();
}
const vk::VulkanContext& GpuBvhBuilder::context() const { return state_->ctx; }
bool GpuBvhBuilder::hasNormals() const { return state_->normals; }
bool GpuBvhBuilder::hasUvs() const { return state_->uvs; }
bool GpuBvhBuilder::hasColors() const { return state_->colors; }

GpuBvhBuilder::SceneUpload GpuBvhBuilder::setScene(const Scene& scene) {
    State& s = *state_;
    const auto start = SteadyClock::now();
    const size_t n = scene.triangleCount();
    // Ids reach 2n - 1 and every kernel's invocations fit one row of workgroups.
    const uint64_t groups = groupsFor(2 * uint64_t(n));
    if (2 * uint64_t(n) >= uint64_t(UINT32_MAX) || groups > s.ctx.info.maxWorkgroupCount[0])
        throw Error("gpu-lbvh: " + scene.source + " has " + std::to_string(n) + " triangles; " + s.ctx.info.name +
                    " dispatches at most " + std::to_string(s.ctx.info.maxWorkgroupCount[0]) +
                    " workgroups in a row, enough for " +
                    std::to_string(uint64_t(s.ctx.info.maxWorkgroupCount[0]) * gpu::kLbvhGroupSize / 2) +
                    " (use a CPU builder)");
    // The kernels' arithmetic assumes finite corners (loaders refuse others; a Scene made in code
    // might not).
    const size_t bad = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, scene.positions.size(), 65536), scene.positions.size(),
        [&](const tbb::blocked_range<size_t>& range, size_t found) {
            for (size_t i = range.begin(); i < range.end() && i < found; ++i) {
                const glm::vec3& p = scene.positions[i];
                if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return i;
            }
            return found;
        },
        [](size_t a, size_t b) { return std::min(a, b); });
    if (bad < scene.positions.size())
        throw Error("gpu-lbvh: " + scene.source + ": vertex " + std::to_string(bad) + " is not finite");
    const size_t vertices = scene.positions.size();
    const bool indicesInRange = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, n, 65536), true,
        [&](const tbb::blocked_range<size_t>& range, bool ok) {
            for (size_t i = range.begin(); i < range.end() && ok; ++i) {
                const glm::uvec3& t = scene.triangles[i];
                ok = t.x < vertices && t.y < vertices && t.z < vertices;
            }
            return ok;
        },
        [](bool a, bool b) { return a && b; });
    if (!indicesInRange) throw Error("gpu-lbvh: " + scene.source + ": vertex index out of range");

    vk::queueWaitIdle(s.ctx);
    for (vk::Buffer* b :
         {&s.positions, &s.indices, &s.triangleMaterials, &s.vertexNormals, &s.vertexUvs, &s.vertexColors, &s.order})
        vk::destroyBuffer(s.ctx, *b);
    s.hasScene = false;
    s.orderCount = 0;

    // The arrays as they are in host memory (vertices once, indices; 24 bytes a triangle on a
    // closed mesh instead of the 48 of the tracers' triangles), copied into mapped staging memory by
    // parallel workers and to the device in one submission; the gather kernel makes the tracers'
    // layout from them on the device.
    vk::StagedUpload staging(s.ctx, s.pool);
    const auto stage = [&](vk::Buffer& buffer, const void* data, size_t bytes, const char* what) {
        auto* target = static_cast<unsigned char*>(staging.add(buffer, bytes, what));
        if (!target) return;
        const auto* source = static_cast<const unsigned char*>(data);
        constexpr size_t kChunk = size_t(1) << 20;
        tbb::parallel_for(size_t(0), (bytes + kChunk - 1) / kChunk, [&](size_t chunk) {
            const size_t begin = chunk * kChunk;
            std::memcpy(target + begin, source + begin, std::min(kChunk, bytes - begin));
        });
    };
    static_assert(sizeof(glm::vec3) == 12 && sizeof(glm::uvec3) == 12 && sizeof(glm::vec2) == 8,
                  "the kernels read tightly packed float and uint arrays");
    stage(s.positions, scene.positions.data(), scene.positions.size() * sizeof(glm::vec3), "positions");
    stage(s.indices, scene.triangles.data(), n * sizeof(glm::uvec3), "vertex indices");
    s.materials = scene.hasMaterials();
    s.normals = scene.hasNormals();
    s.uvs = scene.hasUvs();
    s.colors = scene.hasVertexColors();
    if (s.materials)
        stage(s.triangleMaterials, scene.triangleMaterial.data(), n * sizeof(uint32_t), "triangle materials");
    if (s.normals) stage(s.vertexNormals, scene.normals.data(), scene.normals.size() * sizeof(glm::vec3), "normals");
    if (s.uvs) stage(s.vertexUvs, scene.uvs.data(), scene.uvs.size() * sizeof(glm::vec2), "UVs");
    if (s.colors)
        stage(s.vertexColors, scene.vertexColors.data(), scene.vertexColors.size() * sizeof(uint32_t), "colours");
    staging.submit();
    s.scene = &scene;
    s.triangleCount = n;
    s.hasScene = true;
    SceneUpload timings;
    timings.seconds = secondsSince(start);
    timings.allocationSeconds = staging.allocationSeconds();
    timings.transferSeconds = staging.transferSeconds();
    timings.conversionSeconds = timings.seconds - timings.allocationSeconds - timings.transferSeconds;
    return timings;
}

GpuBvhBuilder::Result GpuBvhBuilder::build(const BvhBuildOptions& options, const GpuBvhOutputs& outputs,
                                           BuildProgress* progress) {
    State& s = *state_;
    if (!isGpuBvhBuilder(options.builder))
        throw Error(std::string("gpu-lbvh: asked to build with ") + toString(options.builder) + ", a CPU builder");
    bvh_detail::validateOptions(options);
    if (!s.hasScene) throw Error("gpu-lbvh: no scene uploaded");
    RAYPACK_CHECK_MSG(outputs.nodes && outputs.triangles, "a device build writes nodes and triangles");
    const uint32_t n = uint32_t(s.triangleCount);
    const bool ploc = options.builder == BvhBuilder::GpuPloc, hploc = options.builder == BvhBuilder::GpuHploc;
    // Both cluster the Morton-sorted triangles into a tree of their own, laid out by cluster_layout.comp.
    const bool clustered = ploc || hploc;
    // gpu-ploc, gpu-hploc: the top rebuilt by the binned SAH from this many triangles (0: not at all).
    const uint32_t topThreshold = clustered ? topRebuildOf(options, n) : 0;
    const bool topRebuilt = topThreshold != 0 && n >= topThreshold;
    // What this build runs and the builder has not run before: compiled here, outside its time.
    const uint32_t radius = plocRadiusOf(options, n);
    if (clustered && radius != s.plocRadius) {
        // The search radius is a specialization constant (it sizes gpu-ploc's shared memory): the
        // pipelines that read it are made again.
        vk::queueWaitIdle(s.ctx);
        for (uint32_t phase : {gpu::kLbvhPhasePlocNearest, gpu::kLbvhPhaseHplocBuild}) {
            VkPipeline& pipeline = s.pipelines[phase];
            if (pipeline) vkDestroyPipeline(s.ctx.device, pipeline, nullptr);
            pipeline = VK_NULL_HANDLE;
        }
        s.plocRadius = radius;
    }
    for (uint32_t phase : phasesOfBuild(options.builder, n, topRebuilt, clustered && options.treeletRounds > 0))
        if (!s.pipelines[phase]) s.pipelines[phase] = createPhasePipeline(s, phase, s.plocRadius);
    const auto start = SteadyClock::now();
    const GpuBvhSizes sizes = gpuBvhSizes(n);
    const uint32_t inner = n < 2 ? 0u : n - 1u;
    const uint32_t sortBlocks = std::max(1u, (n + gpu::kLbvhSortBlock - 1) / gpu::kLbvhSortBlock);
    // gpu-hploc's clustering and the treelet rounds climb from groupSize sorted triangles per
    // workgroup, with fewer workgroups where the device's row of them is shorter (each then takes
    // several chunks in turn).
    const auto climbGroups = [&](uint32_t groupSize) {
        return std::max(1u, uint32_t(std::min<uint64_t>((uint64_t(n) + groupSize - 1) / groupSize,
                                                        s.ctx.info.maxWorkgroupCount[0])));
    };
    const uint32_t hplocGroups = climbGroups(gpu::kHplocGroupSize);
    // Its parent slots, one per inner node of the Morton order's radix tree.
    const uint64_t hplocParentWords = inner;
    const ScanPlan scan = planScan(uint64_t(sortBlocks) * gpu::kLbvhRadixDigits);
    // gpu-ploc scans two flags per cluster, from n clusters down.
    const ScanPlan keepScan = planScan(n, 0), mergeScan = planScan(n, keepScan.words);
    // gpu-lbvh's levels (the clustered trees' layout lists none).
    const uint32_t levels = clustered ? 0u : std::min(inner, gpu::kLbvhMaxDepth);

    // Scratch, sized from the triangle count and freed when the build returns.
    const VkMemoryPropertyFlags local = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
    struct Scratch {
        const vk::VulkanContext& ctx;
        vk::Buffer keysA, keysB, valuesB, scan, inner, levels, boxes, costs, flags, queue, indirect, state, readback;
        ~Scratch() {
            for (vk::Buffer* b : {&keysA, &keysB, &valuesB, &scan, &inner, &levels, &boxes, &costs, &flags, &queue,
                                  &indirect, &state, &readback})
                vk::destroyBuffer(ctx, *b);
        }
        uint64_t bytes() const {
            uint64_t total = 0;
            for (const vk::Buffer* b :
                 {&keysA, &keysB, &valuesB, &scan, &inner, &levels, &boxes, &costs, &flags, &queue, &indirect, &state})
                total += b->size;
            return total;
        }
    } x{s.ctx};
    const auto allocationStart = SteadyClock::now();
    vk::destroyBuffer(s.ctx, s.order);
    s.orderCount = 0;
    s.order = vk::createBuffer(s.ctx, uint64_t(n) * 4, kStorage, local, "the build's triangle order");
    x.keysA = vk::createBuffer(s.ctx, uint64_t(n) * 4, kStorage, local, "the build's Morton codes");
    x.keysB = vk::createBuffer(s.ctx, uint64_t(n) * 4, kStorage, local, "the radix sort's keys");
    x.valuesB = vk::createBuffer(s.ctx, uint64_t(n) * 4, kStorage, local, "the radix sort's values");
    x.scan =
        vk::createBuffer(s.ctx, std::max({scan.words, ploc ? mergeScan.words : 0, hploc ? hplocParentWords : 0}) * 4,
                         kStorage, local, "the build's prefix sums");
    x.inner = vk::createBuffer(s.ctx, uint64_t(inner) * 16, kStorage, local, "the build's inner nodes");
    x.levels = vk::createBuffer(s.ctx, uint64_t(levels + 1) * 8, kStorage, local, "the build's levels");
    // gpu-ploc and gpu-hploc keep a box per cluster id (triangles and inner nodes) while clustering.
    x.boxes =
        vk::createBuffer(s.ctx, uint64_t(clustered ? sizes.nodes : inner) * 32, kStorage, local, "the build's boxes");
    x.costs = vk::createBuffer(s.ctx, uint64_t(inner) * 4, kStorage, local, "the build's SAH costs");
    x.flags = vk::createBuffer(s.ctx, uint64_t(inner) * 4, kStorage, local, "the build's node flags");
    x.queue = vk::createBuffer(s.ctx, clustered ? 0 : uint64_t(inner) * 4, kStorage, local, "the build's level queue");
    // gpu-ploc also sizes its clustering there: one entry for the clusters and one per scan level.
    const uint64_t indirectEntries = std::max<uint64_t>(levels + 1, ploc ? 1 + keepScan.levels.size() : 0);
    x.indirect = vk::createBuffer(s.ctx, indirectEntries * 16, kStorage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, local,
                                  "the build's dispatch arguments");
    x.state = vk::createBuffer(s.ctx, gpu::kLbvhStateWords * 4, kStorage, local, "the build's state");
    x.readback = vk::createBuffer(s.ctx, gpu::kLbvhStateWords * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                  VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                  "the build's statistics");
    const double allocationSeconds = secondsSince(allocationStart);

    const uint32_t attributes =
        (s.normals && outputs.normals ? gpu::kLbvhHasNormals : 0u) | (s.uvs && outputs.uvs ? gpu::kLbvhHasUvs : 0u) |
        (s.colors && outputs.colors ? gpu::kLbvhHasColors : 0u) | (s.materials ? gpu::kLbvhHasMaterials : 0u);
    {
        std::array<VkBuffer, gpu::kLbvhBindingCount> buffers{};
        buffers[gpu::kLbvhBindPositions] = s.positions.buffer;
        buffers[gpu::kLbvhBindIndices] = s.indices.buffer;
        buffers[gpu::kLbvhBindMaterials] = s.materials ? s.triangleMaterials.buffer : s.dummy.buffer;
        buffers[gpu::kLbvhBindKeysA] = x.keysA.buffer;
        buffers[gpu::kLbvhBindValuesA] = s.order.buffer;
        buffers[gpu::kLbvhBindKeysB] = x.keysB.buffer;
        buffers[gpu::kLbvhBindValuesB] = x.valuesB.buffer;
        buffers[gpu::kLbvhBindScan] = x.scan.buffer;
        buffers[gpu::kLbvhBindState] = x.state.buffer;
        buffers[gpu::kLbvhBindInner] = x.inner.buffer;
        buffers[gpu::kLbvhBindLevels] = x.levels.buffer;
        buffers[gpu::kLbvhBindBoxes] = x.boxes.buffer;
        buffers[gpu::kLbvhBindCosts] = x.costs.buffer;
        buffers[gpu::kLbvhBindFlags] = x.flags.buffer;
        buffers[gpu::kLbvhBindQueue] = x.queue.buffer;
        buffers[gpu::kLbvhBindIndirect] = x.indirect.buffer;
        buffers[gpu::kLbvhBindNodes] = outputs.nodes;
        buffers[gpu::kLbvhBindTriangles] = outputs.triangles;
        const bool normals = attributes & gpu::kLbvhHasNormals, uvs = attributes & gpu::kLbvhHasUvs,
                   colors = attributes & gpu::kLbvhHasColors;
        buffers[gpu::kLbvhBindVertexNormals] = normals ? s.vertexNormals.buffer : s.dummy.buffer;
        buffers[gpu::kLbvhBindNormals] = normals ? outputs.normals : s.dummy.buffer;
        buffers[gpu::kLbvhBindVertexUvs] = uvs ? s.vertexUvs.buffer : s.dummy.buffer;
        buffers[gpu::kLbvhBindUvs] = uvs ? outputs.uvs : s.dummy.buffer;
        buffers[gpu::kLbvhBindVertexColors] = colors ? s.vertexColors.buffer : s.dummy.buffer;
        buffers[gpu::kLbvhBindColors] = colors ? outputs.colors : s.dummy.buffer;
        vk::writeStorageSet(s.ctx, s.layout.set, buffers);
    }

    gpu::LbvhParams base{};
    base.counts = {n, options.leafSize, 0u, attributes};
    base.costs = {options.traversalCost, options.intersectionCost, 0.0f, 0.0f};
    const auto readState = [&] {
        std::array<uint32_t, gpu::kLbvhStateWords> words{};
        std::memcpy(words.data(), x.readback.mapped, sizeof words);
        return words;
    };
    // Records into `cmd`: dispatches, each followed by one barrier that makes its writes visible to
    // the next dispatch, indirect dispatch or copy.
    struct Recorder {
        State& s;
        VkCommandBuffer cmd;
        VkBuffer indirectBuffer;
        void barrier() const {
            vk::memoryBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                              VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
                              VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT |
                                  VK_PIPELINE_STAGE_TRANSFER_BIT,
                              VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                                  VK_ACCESS_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT);
        }
        void bind(uint32_t phase, const gpu::LbvhParams& params) const {
            RAYPACK_CHECK_MSG(s.pipelines[phase],
                              "a build's phases are created before it records them (phasesOfBuild)");
            vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s.pipelines[phase]);
            vkCmdPushConstants(cmd, s.layout.pipelineLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof params, &params);
        }
        void dispatch(uint32_t phase, uint32_t groups, const gpu::LbvhParams& params) const {
            if (groups == 0) return;
            bind(phase, params);
            vkCmdDispatch(cmd, groups, 1, 1);
            barrier();
        }
        // One level of the listed levels: its dispatch size is indirect[level].
        void level(uint32_t phase, uint32_t level, gpu::LbvhParams params) const {
            params.counts.z = level;
            indirect(phase, level, params);
        }
        // A dispatch whose size the device wrote at indirect[entry].
        void indirect(uint32_t phase, uint32_t entry, const gpu::LbvhParams& params) const {
            bind(phase, params);
            vkCmdDispatchIndirect(cmd, indirectBuffer, VkDeviceSize(entry) * 16);
            barrier();
        }
        // gpu-ploc: the scan of `plan`'s largest layout over this iteration's clusters, every level
        // sized on the device (prefix_scan.comp's entryCount, kLbvhPhasePlocSetup's dispatches).
        void clusterScan(const ScanPlan& plan, const gpu::LbvhParams& base) const {
            for (uint32_t l = 0; l < plan.levels.size(); ++l) {
                gpu::LbvhParams p = base;
                p.offsets = {plan.levels[l].offset, plan.levels[l].sums, l + 1, 0u};
                indirect(gpu::kLbvhPhaseScanBlocks, gpu::kPlocIndirectScan + l, p);
            }
            for (uint32_t l = uint32_t(plan.levels.size()) - 1; l-- > 0;) {
                gpu::LbvhParams p = base;
                p.offsets = {plan.levels[l].offset, plan.levels[l].sums, l + 1, 0u};
                indirect(gpu::kLbvhPhaseAddBlockSums, gpu::kPlocIndirectScan + l, p);
            }
        }
        // The exclusive prefix sum of `plan` (prefix_scan.comp), block sums recursed.
        void scan(const ScanPlan& plan, const gpu::LbvhParams& base) const {
            const auto blocks = [](uint32_t count) { return (count + gpu::kLbvhScanBlock - 1) / gpu::kLbvhScanBlock; };
            for (const ScanPlan::Level& l : plan.levels) {
                gpu::LbvhParams p = base;
                p.counts.z = l.count;
                p.offsets = {l.offset, l.sums, 0u, 0u};
                dispatch(gpu::kLbvhPhaseScanBlocks, blocks(l.count), p);
            }
            for (size_t k = plan.levels.size() - 1; k-- > 0;) {  // every level with more than one block
                const ScanPlan::Level& l = plan.levels[k];
                gpu::LbvhParams p = base;
                p.counts.z = l.count;
                p.offsets = {l.offset, l.sums, 0u, 0u};
                dispatch(gpu::kLbvhPhaseAddBlockSums, blocks(l.count), p);
            }
        }
        // Timestamp k once every command recorded before it has finished.
        void stamp(uint32_t k) const {
            if (s.queries) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, s.queries, k);
        }
        void begin() const {
            vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s.layout.pipelineLayout, 0, 1, &s.layout.set,
                                    0, nullptr);
        }
    };
    const auto submit = [&](const std::function<void(const Recorder&)>& record) {
        bvh_detail::throwIfCancelled(progress);
        vk::submitAndWait(s.ctx, s.pool, [&](VkCommandBuffer cmd) {
            const Recorder r{s, cmd, x.indirect.buffer};
            r.begin();
            record(r);
            const VkBufferCopy region{0, 0, gpu::kLbvhStateWords * 4};
            vkCmdCopyBuffer(cmd, x.state.buffer, x.readback.buffer, 1, &region);
        });
    };
    // The last steps of gpu-lbvh (and of every builder below 2 triangles, depth 0): the levels top
    // down, boxes and costs bottom up, the root, the nodes top down.
    const auto finish = [&](const Recorder& r, uint32_t depth) {
        if (n >= 2) {
            r.dispatch(gpu::kLbvhPhaseLevelRoot, 1, base);
            for (uint32_t level = 0; level + 1 < depth; ++level) {
                r.level(gpu::kLbvhPhaseEnumerate, level, base);
                gpu::LbvhParams p = base;
                p.counts.z = level;
                r.dispatch(gpu::kLbvhPhaseNextLevel, 1, p);
            }
            for (uint32_t level = depth; level-- > 0;) r.level(gpu::kLbvhPhaseBottomUp, level, base);
        }
        r.dispatch(gpu::kLbvhPhaseRoot, 1, base);
        for (uint32_t level = 0; level < depth; ++level) r.level(gpu::kLbvhPhaseEmit, level, base);
        r.stamp(kStampEnd);
    };

    // gpu-ploc, gpu-hploc: the clustered tree's layout (cluster_layout.comp), then the triangles in
    // its leaf order; a fixed number of dispatches, whatever the tree's depth.
    const auto layOut = [&](const Recorder& r) {
        r.dispatch(gpu::kLbvhPhaseClusterParents, groupsFor(inner), base);
        r.dispatch(gpu::kLbvhPhaseClusterCosts, groupsFor(n), base);
        r.dispatch(gpu::kLbvhPhaseClusterPathStart, groupsFor(inner), base);
        for (uint32_t round = 0; round <= kClusterPathRounds; ++round) {
            gpu::LbvhParams p = base;
            p.counts.z = round;
            r.dispatch(round < kClusterPathRounds ? gpu::kLbvhPhaseClusterPathJump : gpu::kLbvhPhaseClusterEmit,
                       groupsFor(inner), p);
        }
        r.dispatch(gpu::kLbvhPhasePlocReorder, groupsFor(n), base);
        const VkBufferCopy region{0, 0, uint64_t(n) * 4};
        vkCmdCopyBuffer(r.cmd, x.keysB.buffer, s.order.buffer, 1, &region);
        r.barrier();
        r.dispatch(gpu::kLbvhPhaseGather, groupsFor(n), base);
        r.stamp(kStampEnd);
    };

    // gpu-ploc, gpu-hploc: the top rebuilt by the binned SAH (top.comp: one workgroup starts, one per
    // node it leaves finishes), then the treelet rounds over the clustered tree, each after listing
    // its parents.
    const uint32_t treeletGroups = climbGroups(gpu::kTreeletGroupSize);
    const auto restructure = [&](const Recorder& r) {
        if (topRebuilt) {
            gpu::LbvhParams p = base;
            p.counts.z = topThreshold;
            r.dispatch(gpu::kLbvhPhaseTopStart, 1, p);
            r.indirect(gpu::kLbvhPhaseTopFinish, 0, p);
        }
        for (uint32_t round = 0; round < options.treeletRounds; ++round) {
            gpu::LbvhParams p = base;
            p.counts.z = options.treeletGamma;
            r.dispatch(gpu::kLbvhPhaseClusterParents, groupsFor(inner), p);
            r.dispatch(gpu::kLbvhPhaseTreelet, treeletGroups, p);
        }
    };

    submit([&](const Recorder& r) {
        const VkCommandBuffer cmd = r.cmd;
        if (s.queries) {
            vkCmdResetQueryPool(cmd, s.queries, 0, kTimestamps);
            vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, s.queries, kStampStart);
        }
        // The state: zero, but the lower bounds start at the largest ordered value.
        vkCmdFillBuffer(cmd, x.state.buffer, 0, VK_WHOLE_SIZE, 0u);
        vkCmdFillBuffer(cmd, x.indirect.buffer, 0, VK_WHOLE_SIZE, 0u);
        vkCmdFillBuffer(cmd, x.flags.buffer, 0, VK_WHOLE_SIZE, 0u);
        r.barrier();
        vkCmdFillBuffer(cmd, x.state.buffer, gpu::kLbvhStateBoxLo * 4, 12, 0xFFFFFFFFu);
        vkCmdFillBuffer(cmd, x.state.buffer, gpu::kLbvhStateCentroidLo * 4, 12, 0xFFFFFFFFu);
        r.barrier();
        // 1, 2: bounds and Morton codes.
        r.dispatch(gpu::kLbvhPhaseBounds, groupsFor(n), base);
        r.dispatch(gpu::kLbvhPhaseMorton, groupsFor(n), base);
        if (n >= 2) {
            // 3: four passes of 8 bits, A -> B -> A -> B -> A.
            for (uint32_t pass = 0; pass < 4; ++pass) {
                gpu::LbvhParams sort = base;
                sort.counts.z = pass * gpu::kLbvhRadixBits;
                sort.offsets = {sortBlocks, 0u, pass % 2u, 0u};
                r.dispatch(gpu::kLbvhPhaseHistogram, sortBlocks, sort);
                r.scan(scan, base);
                r.dispatch(gpu::kLbvhPhaseScatter, sortBlocks, sort);
            }
        }
        r.stamp(kStampSorted);
        // 4: the hierarchy (gpu-ploc, gpu-hploc: their clusters start as the sorted triangles).
        if (!clustered && n >= 2) r.dispatch(gpu::kLbvhPhaseHierarchy, groupsFor(inner), base);
        if (!clustered) r.stamp(kStampLayout);
        // 5: leaf order (gpu-ploc: Morton order, for the clusters' boxes; again at the end; gpu-hploc
        // makes its boxes from the scene's arrays and gathers at the end only).
        if (!hploc || n < 2) r.dispatch(gpu::kLbvhPhaseGather, groupsFor(n), base);
        if (!clustered) finish(r, levels);
        if (hploc && n >= 2) {
            // The whole clustering in one dispatch, after its parent slots are emptied.
            vkCmdFillBuffer(cmd, x.scan.buffer, 0, hplocParentWords * 4, gpu::kHplocEmpty);
            r.barrier();
            r.dispatch(gpu::kLbvhPhaseHplocInit, hplocGroups, base);
            r.dispatch(gpu::kLbvhPhaseHplocBuild, hplocGroups, base);
            restructure(r);
            r.stamp(kStampLayout);
            layOut(r);
        }
    });
    if (hploc && n >= 2) {
        const uint32_t made = readState()[gpu::kLbvhStateNextMerged];
        if (made != n - 1)
            throw Error("gpu-hploc: the clustering made " + std::to_string(made) + " inner nodes where " +
                        std::to_string(n) + " triangles need " + std::to_string(n - 1) + " (device " + s.ctx.info.name +
                        ")");
        if (progress) progress->done.store(made);
    }
    if (clustered && n >= 2) {
        if (ploc) {
            // Clustering: kPlocIterationBatch iterations per submission, each sized on the device by
            // the clusters the last one left (kLbvhPhasePlocSetup); the host reads the count back
            // between submissions.
            uint32_t clusters = n, made = 0, iteration = 0;
            // On a CPU device the first iterations over all the triangles are the long ones; on a GPU
            // starting small cost 10-20% of the build's device time (H200, 2026-12-02).
            uint32_t batch = s.ctx.info.type == VK_PHYSICAL_DEVICE_TYPE_CPU ? 1u : kPlocIterationBatch;
            const uint32_t scanLevels = uint32_t(keepScan.levels.size());
            while (clusters > 1) {
                const auto submitted = SteadyClock::now();
                submit([&](const Recorder& r) {
                    if (iteration == 0) r.dispatch(gpu::kLbvhPhasePlocInit, groupsFor(n), base);
                    for (uint32_t k = 0; k < batch; ++k, ++iteration) {
                        gpu::LbvhParams p = base;
                        p.counts.z = scanLevels;
                        p.offsets = {keepScan.levels[0].offset, mergeScan.levels[0].offset, iteration % 2u, 0u};
                        r.dispatch(gpu::kLbvhPhasePlocSetup, 1, p);
                        r.indirect(gpu::kLbvhPhasePlocNearest, gpu::kPlocIndirectClusters, p);
                        r.indirect(gpu::kLbvhPhasePlocFlags, gpu::kPlocIndirectClusters, p);
                        r.clusterScan(keepScan, base);
                        r.clusterScan(mergeScan, base);
                        r.indirect(gpu::kLbvhPhasePlocApply, gpu::kPlocIndirectClusters, p);
                    }
                });
                const auto words = readState();
                if (words[gpu::kLbvhStateNextClusters] >= clusters)
                    throw Error("gpu-ploc: " + std::to_string(batch) + " iterations over " + std::to_string(clusters) +
                                " clusters merged none");
                clusters = words[gpu::kLbvhStateNextClusters];
                made = words[gpu::kLbvhStateNextMerged];
                if (progress) progress->done.store(made);
                const double took = secondsSince(submitted);
                if (took > kPlocSubmissionSeconds)
                    batch = std::max(1u, batch / 2);
                else if (took < kPlocSubmissionSeconds / 4)
                    batch = std::min(kPlocIterationBatch, batch * 2);
            }
            RAYPACK_CHECK_MSG(made == n - 1, "gpu-ploc made n - 1 inner nodes");
            submit([&](const Recorder& r) {
                restructure(r);
                r.stamp(kStampLayout);
                layOut(r);
            });
        }
    } else if (clustered) {
        submit([&](const Recorder& r) {
            r.stamp(kStampLayout);
            finish(r, 0);
        });
    }

    const std::array<uint32_t, gpu::kLbvhStateWords> state = readState();
    if (state[gpu::kLbvhStateStatus] & gpu::kLbvhStatusSubgroupLayout)
        throw Error("gpu-lbvh: the radix sort's subgroups on " + s.ctx.info.name + " are not consecutive runs of " +
                    std::to_string(s.ctx.info.subgroupSize) + " invocations as the device reports (use a CPU builder)");
    if (state[gpu::kLbvhStateStatus] & gpu::kLbvhStatusTooDeep)
        throw Error(std::string(toString(options.builder)) + ": the tree is deeper than " +
                    std::to_string(kPlocMaxDepth) + " levels");
    Result result;
    BvhStats& stats = result.stats;
    stats.leafCount = state[gpu::kLbvhStateLeafCount];
    const uint64_t depthSum = uint64_t(state[gpu::kLbvhStateDepthSum]) | uint64_t(state[gpu::kLbvhStateDepthSum + 1])
                                                                             << 32;
    stats.nodeCount = 1 + 2 * state[gpu::kLbvhStateInnerCount];
    stats.maxLeafDepth = state[gpu::kLbvhStateMaxDepth];
    stats.avgLeafDepth = stats.leafCount ? double(depthSum) / double(stats.leafCount) : 0.0;
    stats.avgPrimsPerLeaf = stats.leafCount ? double(n) / double(stats.leafCount) : 0.0;
    float rootCost, rootArea;
    std::memcpy(&rootCost, &state[gpu::kLbvhStateRootCost], 4);
    std::memcpy(&rootArea, &state[gpu::kLbvhStateRootArea], 4);
    stats.sahCost = rootArea > 0.0f ? double(rootCost) / double(rootArea) : 0.0;
    stats.bytes = sizes.nodes * sizeof(gpu::GpuNode) + uint64_t(n) * 4;
    stats.references = n;
    stats.primitives = n;
    if (s.queries) {
        std::array<uint64_t, kTimestamps> stamps{};
        if (vkGetQueryPoolResults(s.ctx.device, s.queries, 0, kTimestamps, sizeof stamps, stamps.data(),
                                  sizeof(uint64_t), VK_QUERY_RESULT_64_BIT) == VK_SUCCESS) {
            const auto between = [&](uint32_t a, uint32_t b) {
                return double(stamps[b] - stamps[a]) * double(s.ctx.info.timestampPeriodNs) * 1e-9;
            };
            result.deviceSeconds = between(kStampStart, kStampEnd);
            stats.deviceSortSeconds = between(kStampStart, kStampSorted);
            stats.deviceHierarchySeconds = between(kStampSorted, kStampLayout);
            stats.deviceLayoutSeconds = between(kStampLayout, kStampEnd);
        }
    }
    result.scratchBytes = x.bytes();
    stats.deviceBuildSeconds = result.deviceSeconds;
    stats.buildScratchBytes = result.scratchBytes;
    stats.topRebuildItems = topRebuilt ? state[gpu::kLbvhStateTopItems] : 0;
    stats.buildAllocationSeconds = allocationSeconds;
    s.orderCount = n;
    stats.buildSeconds = secondsSince(start);
    return result;
}

std::vector<uint32_t> GpuBvhBuilder::downloadOrder() {
    State& s = *state_;
    std::vector<uint32_t> order(s.orderCount);
    if (order.empty()) return order;
    vk::Buffer staging = vk::createBuffer(s.ctx, order.size() * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                          VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                          "the order's read-back");
    try {
        vk::submitAndWait(s.ctx, s.pool, [&](VkCommandBuffer cmd) {
            const VkBufferCopy region{0, 0, order.size() * 4};
            vkCmdCopyBuffer(cmd, s.order.buffer, staging.buffer, 1, &region);
        });
    } catch (...) {
        vk::destroyBuffer(s.ctx, staging);
        throw;
    }
    std::memcpy(order.data(), staging.mapped, order.size() * 4);
    vk::destroyBuffer(s.ctx, staging);
    return order;
}

vk::Buffer GpuBvhBuilder::takeOrder() {
    State& s = *state_;
    s.orderCount = 0;
    return std::exchange(s.order, vk::Buffer{});
}

Bvh bvhFromGpuNodes(std::span<const gpu::GpuNode> nodes, PrimIndices order) {
    RAYPACK_CHECK_MSG(!nodes.empty(), "a device build has a root");
    const auto bits = [](float f) {
        uint32_t u;
        std::memcpy(&u, &f, 4);
        return u;
    };
    Bvh bvh;
    bvh.primIndices = std::move(order);
    bvh.nodes.resize(1);
    struct Pending {
        uint32_t slot;  // in `nodes`
        uint32_t node;  // in bvh.nodes
    };
    std::vector<Pending> stack{{0, 0}};
    while (!stack.empty()) {
        const Pending item = stack.back();
        stack.pop_back();
        const gpu::GpuNode& g = nodes[item.slot];
        const uint32_t index = bits(g.lo.w), count = bits(g.hi.w);
        BvhNode& node = bvh.nodes[item.node];
        node.lo = glm::vec3(g.lo);
        node.hi = glm::vec3(g.hi);
        if (count != 0 || index == 0) {
            if (count == 0) {  // the empty scene's root
                node.lo = Aabb{}.lo;
                node.hi = Aabb{}.hi;
            }
            if (uint64_t(index) + count > bvh.primIndices.size())
                throw Error("gpu-lbvh: a downloaded leaf lies outside the triangles");
            node.index = index;
            node.count = count;
            continue;
        }
        if (uint64_t(index) + 1 >= nodes.size() || bvh.nodes.size() + 2 > nodes.size())
            throw Error("gpu-lbvh: a downloaded node points outside the node array");
        const uint32_t pair = uint32_t(bvh.nodes.size());
        node.index = pair;
        node.count = 0;
        bvh.nodes.resize(bvh.nodes.size() + 2);
        stack.push_back({index + 1, pair + 1});
        stack.push_back({index, pair});
    }
    return bvh;
}

GpuTreeAttributes gpuTreeAttributes(const Scene& scene) {
    GpuTreeAttributes attributes;
    attributes.normals = scene.hasNormals();
    attributes.colors = scene.hasVertexColors();
    attributes.uvs = scene.hasUvs() && std::any_of(scene.textures.begin(), scene.textures.end(),
                                                   [](const Texture& t) { return !t.texels.empty(); });
    return attributes;
}

GpuTree::~GpuTree() {
    for (vk::Buffer* b : {&nodes, &triangles, &normals, &uvs, &colors, &order}) vk::destroyBuffer(ctx, *b);
}

std::unique_ptr<GpuTree> buildGpuTree(GpuBvhBuilder& builder, const Scene& scene, const BvhBuildOptions& options,
                                      bool keepOrder, BuildProgress* progress) {
    const vk::VulkanContext& ctx = builder.context();
    if (!builder.holds(scene)) builder.setScene(scene);
    auto tree = std::make_unique<GpuTree>(ctx);
    tree->scene = &scene;
    tree->options = options;
    // The arrays the build fills on the device: device-local, never written by the host.
    const auto allocationStart = SteadyClock::now();
    const GpuBvhSizes sizes = gpuBvhSizes(scene.triangleCount());
    const auto create = [&](vk::Buffer& buffer, size_t count, size_t entryBytes, const char* what,
                            VkBufferUsageFlags extraUsage = 0) {
        vk::checkBindable(ctx, count * entryBytes, what);
        buffer =
            vk::createBuffer(ctx, count * entryBytes, kStorage | extraUsage, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, what);
        return buffer.buffer;
    };
    GpuBvhOutputs outputs;
    // The tracer may read the nodes through a texel view (NodeFetch, renderer/gpu_tracer.h).
    outputs.nodes =
        create(tree->nodes, sizes.nodes, sizeof(gpu::GpuNode), "BVH nodes", VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT);
    outputs.triangles = create(tree->triangles, sizes.triangles, sizeof(gpu::GpuTriangle), "triangles");
    const GpuTreeAttributes attributes = gpuTreeAttributes(scene);
    if (attributes.normals)
        outputs.normals = create(tree->normals, sizes.triangles, sizeof(gpu::GpuTriangleNormals), "vertex normals");
    if (attributes.uvs) outputs.uvs = create(tree->uvs, sizes.triangles, sizeof(gpu::GpuTriangleUvs), "UVs");
    if (attributes.colors)
        outputs.colors = create(tree->colors, sizes.triangles, sizeof(gpu::GpuTriangleColors), "vertex colours");
    const double arraysSeconds = secondsSince(allocationStart);
    tree->stats = builder.build(options, outputs, progress).stats;
    // Creating the tree's arrays is part of building it (T_B); it was counted nowhere before
    // 2026-12-02 (t_scene_to_frame_s left it out).
    tree->stats.buildSeconds += arraysSeconds;
    tree->stats.buildAllocationSeconds += arraysSeconds;
    if (keepOrder) tree->order = builder.takeOrder();
    return tree;
}

Bvh downloadGpuTree(const GpuTree& tree) {
    const vk::VulkanContext& ctx = tree.ctx;
    RAYPACK_CHECK_MSG(tree.scene, "a device tree knows its scene");
    const size_t n = tree.scene->triangleCount();
    const GpuBvhSizes sizes = gpuBvhSizes(n);
    if (n > 0 && tree.order.size < n * 4) throw Error("gpu-lbvh: the tree's leaf order was not kept; rebuild it");
    const uint64_t nodeBytes = sizes.nodes * sizeof(gpu::GpuNode), orderBytes = uint64_t(n) * 4;
    struct ReadBack {
        const vk::VulkanContext& ctx;
        vk::Buffer buffer;
        VkCommandPool pool = VK_NULL_HANDLE;
        ~ReadBack() {
            vk::destroyBuffer(ctx, buffer);
            if (pool) vkDestroyCommandPool(ctx.device, pool, nullptr);
        }
    } back{ctx};
    back.buffer = vk::createBuffer(ctx, nodeBytes + orderBytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                   VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                   "the tree's read-back");
    back.pool = vk::createCommandPool(ctx, VK_COMMAND_POOL_CREATE_TRANSIENT_BIT, "vkCreateCommandPool");
    vk::submitAndWait(ctx, back.pool, [&](VkCommandBuffer cmd) {
        const VkBufferCopy nodes{0, 0, nodeBytes};
        vkCmdCopyBuffer(cmd, tree.nodes.buffer, back.buffer.buffer, 1, &nodes);
        if (orderBytes > 0) {
            const VkBufferCopy order{0, nodeBytes, orderBytes};
            vkCmdCopyBuffer(cmd, tree.order.buffer, back.buffer.buffer, 1, &order);
        }
    });
    const auto* bytes = static_cast<const unsigned char*>(back.buffer.mapped);
    PrimIndices order(n);  // not zeroed first: the copy writes every entry
    if (n > 0) std::memcpy(order.data(), bytes + nodeBytes, orderBytes);
    Bvh bvh = bvhFromGpuNodes({reinterpret_cast<const gpu::GpuNode*>(bytes), sizes.nodes}, std::move(order));
    bvh.options = tree.options;
    bvh.stats = computeBvhStats(bvh, tree.options);
    bvh.stats.buildSeconds = tree.stats.buildSeconds;
    bvh.stats.deviceBuildSeconds = tree.stats.deviceBuildSeconds;
    bvh.stats.deviceSortSeconds = tree.stats.deviceSortSeconds;
    bvh.stats.deviceHierarchySeconds = tree.stats.deviceHierarchySeconds;
    bvh.stats.deviceLayoutSeconds = tree.stats.deviceLayoutSeconds;
    bvh.stats.buildScratchBytes = tree.stats.buildScratchBytes;
    bvh.stats.topRebuildItems = tree.stats.topRebuildItems;
    bvh.stats.buildAllocationSeconds = tree.stats.buildAllocationSeconds;
    return bvh;
}

Bvh buildBvhOnDevice(const vk::VulkanContext& context, const Scene& scene, const BvhBuildOptions& options,
                     BuildProgress* progress) {
    if (progress) {
        progress->total.store(scene.triangleCount());
        progress->done.store(0);
    }
    bvh_detail::throwIfCancelled(progress);
    GpuBvhBuilder builder(context);
    const std::unique_ptr<GpuTree> tree = buildGpuTree(builder, scene, options, /*keepOrder=*/true, progress);
    Bvh bvh = downloadGpuTree(*tree);
    if (progress) progress->done.store(scene.triangleCount());
    return bvh;
}

}  // namespace raypack
