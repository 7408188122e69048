#pragma once
// BVH construction on the Vulkan device that traces (issue 13): the builders gpu-lbvh (Karras 2012),
// gpu-ploc (Meister and Bittner 2018) and gpu-hploc (Benthin et al. 2024), each with the leaves
// collapsed by the SAH (shaders/lbvh.h has the algorithm). It writes the tracers'
// node layout and the leaf-order triangles straight into device buffers: no host round trip and no
// tree on the CPU. Its Table 1 statistics come from a reduction on the device, a few hundred bytes
// read back. A CPU consumer (the CPU tracers, `stats`, a test) asks for the canonical tree with
// buildBvhOnDevice, which builds the same tree and downloads it.
//
// Data flow: Scene --setScene--> its vertex arrays and vertex indices on the device, as they are in
// host memory (kept while only the tree changes) --build(options)--> nodes + leaf-order triangles in the caller's
// buffers + BvhStats.
#include "renderer/bvh.h"
#include "renderer/scene.h"
#include "renderer/vk/context.h"
#include "shaders/gpu_types.h"

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace raypack {

// True for the builders that run on a Vulkan device (gpu-lbvh, gpu-ploc, gpu-hploc).
constexpr bool isGpuBvhBuilder(BvhBuilder builder) {
    return builder == BvhBuilder::GpuLbvh || builder == BvhBuilder::GpuPloc || builder == BvhBuilder::GpuHploc;
}

// Entries of each output array a device build of `triangles` triangles writes: 2n - 1 node slots
// (Karras' inner node i's children at 1 + 2i and 2 + 2i; slots below a collapsed node stay unused)
// and n triangles. At least one node (the root leaf of an empty scene).
struct GpuBvhSizes {
    size_t nodes = 1;
    size_t triangles = 0;
};
GpuBvhSizes gpuBvhSizes(size_t triangles);

// Where a build writes: device buffers of at least gpuBvhSizes' entries each (storage buffers).
// The attribute buffers are needed where the scene has the attribute (null otherwise).
struct GpuBvhOutputs {
    VkBuffer nodes = VK_NULL_HANDLE;      // gpu::GpuNode
    VkBuffer triangles = VK_NULL_HANDLE;  // gpu::GpuTriangle, leaf order
    VkBuffer normals = VK_NULL_HANDLE;    // gpu::GpuTriangleNormals, leaf order
    VkBuffer uvs = VK_NULL_HANDLE;        // gpu::GpuTriangleUvs, leaf order
    VkBuffer colors = VK_NULL_HANDLE;     // gpu::GpuTriangleColors, leaf order
};

class GpuBvhBuilder {
public:
    // Loads the build kernels' modules on `context`, which must outlive the builder. The pipelines of
    // a build's phases are created by the first build that runs them, before its time starts (so a
    // builder compiles only what its builders and options need: all 30 take about 0.4 s on
    // lavapipe). Throws raypack::Error when the device cannot run them (a subgroup size that does
    // not divide 256).
    explicit GpuBvhBuilder(const vk::VulkanContext& context);
    ~GpuBvhBuilder();
    GpuBvhBuilder(const GpuBvhBuilder&) = delete;
    GpuBvhBuilder& operator=(const GpuBvhBuilder&) = delete;

    // Uploads the scene's positions, vertex indices and triangle materials (with its vertex normals,
    // UVs and colours where it has them) as they are in host memory; every build reads them until the
    // next setScene, and its gather makes the tracers' leaf-order triangles from them. Returns the
    // host's wall time, split into creating the buffers, checking and copying the arrays into them
    // (conversion) and the transfer (vk::StagedUpload). Throws raypack::Error for a vertex that is
    // not finite, an index out of range or when the device is out of memory.
    struct SceneUpload {
        double seconds = 0;
        double allocationSeconds = 0;
        double conversionSeconds = 0;
        double transferSeconds = 0;
    };
    SceneUpload setScene(const Scene& scene);
    // Whether `scene` is the one uploaded (the same object with the same triangle count).
    bool holds(const Scene& scene) const;
    // Whether the uploaded scene has each attribute (the outputs it needs).
    bool hasNormals() const;
    bool hasUvs() const;
    bool hasColors() const;

    struct Result {
        BvhStats stats;             // of the built tree; buildSeconds is the host's wall time
        double deviceSeconds = 0;   // the build's commands by the device's timestamps (0 without)
        uint64_t scratchBytes = 0;  // temporary device memory of the build, freed before it returns
    };
    // Builds with `options` (a device builder; leafSize, traversalCost, intersectionCost and, for the
    // clustering builders, plocRadius are honoured, the bin and split settings do not apply) into `outputs`, and waits
    // for it. Throws raypack::Error for options out of range, without a scene, or when the device is out of memory.
    // `progress` (optional): total is the triangle count, done counts gpu-ploc's merges as they are
    // read back, and cancel is polled before each of the build's submissions, throwing
    // BuildCancelled (the outputs are then undefined).
    Result build(const BvhBuildOptions& options, const GpuBvhOutputs& outputs, BuildProgress* progress = nullptr);
    // The last build's leaf order: slot k holds triangle order[k] (Bvh::primIndices).
    std::vector<uint32_t> downloadOrder();
    // Hands over the device buffer holding the last build's order (n uint32); downloadOrder is empty
    // after it until the next build.
    vk::Buffer takeOrder();
    const vk::VulkanContext& context() const;

    struct State;

private:
    std::unique_ptr<State> state_;
};

// The per-triangle attributes the tracers read of `scene`: UVs only where textures have texels.
struct GpuTreeAttributes {
    bool normals = false;
    bool uvs = false;
    bool colors = false;
};
GpuTreeAttributes gpuTreeAttributes(const Scene& scene);

// A device build's arrays in buffers of its own: what the tracers trace (nodes, leaf-order
// triangles and their attributes) and, where kept, the leaf order, from which the canonical tree
// can be read back later (downloadGpuTree). The viewer's worker builds one on the tracer's device
// (through its own GpuBvhBuilder, submitting under vk::lockQueue) while the render thread still
// draws the previous tree, and the render thread swaps it in (GpuTracer::adopt): no host round trip.
struct GpuTree {
    explicit GpuTree(const vk::VulkanContext& context) : ctx(context) {}
    ~GpuTree();
    GpuTree(const GpuTree&) = delete;
    GpuTree& operator=(const GpuTree&) = delete;

    const vk::VulkanContext& ctx;
    const Scene* scene = nullptr;  // what it was built over; must outlive the tree's use
    vk::Buffer nodes, triangles, normals, uvs, colors;
    // 2: nodes holds GpuNodes (every device build); 8: GpuWideNodes, the compressed 8-wide tree that
    // GpuTracer::upload makes from a host tree (renderer/gpu_wide.h).
    uint32_t bvhWidth = 2;
    vk::Buffer order;  // empty unless kept
    BvhBuildOptions options;
    BvhStats stats;  // the device's statistics; buildSeconds includes creating the arrays
};

// Builds `scene` with `builder` (uploading it first unless the builder holds it) into a new
// GpuTree, keeping the order when asked. Throws as GpuBvhBuilder does.
std::unique_ptr<GpuTree> buildGpuTree(GpuBvhBuilder& builder, const Scene& scene, const BvhBuildOptions& options,
                                      bool keepOrder, BuildProgress* progress = nullptr);

// The canonical tree of `tree` (which kept its order): its node slots and order read back and
// renumbered (bvhFromGpuNodes), statistics by computeBvhStats, the build's times from tree.stats.
Bvh downloadGpuTree(const GpuTree& tree);

// The canonical tree of a device build, from its node slots and its order: nodes renumbered depth
// first from the root (children after their parents, the unused slots dropped), leaves indexing
// `order` as Bvh::primIndices. Statistics are left for the caller.
Bvh bvhFromGpuNodes(std::span<const gpu::GpuNode> nodes, PrimIndices order);

// Builds on `context`'s device and downloads the canonical tree (for the CPU tracers and tools).
// Its stats are computeBvhStats of the downloaded tree, buildSeconds the device build's wall time.
// Throws as GpuBvhBuilder does; BuildCancelled when progress->cancel is set before the build starts.
Bvh buildBvhOnDevice(const vk::VulkanContext& context, const Scene& scene, const BvhBuildOptions& options,
                     BuildProgress* progress = nullptr);

}  // namespace raypack
