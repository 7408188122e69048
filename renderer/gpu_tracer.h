#pragma once
// The Vulkan compute tracer: the report's packet traversal with a stack in shared memory
// (Gunther, Popov, Seidel 2007, "Realtime Ray Tracing on GPU with BVH-based Packet Traversal";
// ../shared/reference/gpu-packet-traversal-report.txt 2.2, 2.3, 3.3-3.5) and, beside it, the
// single-ray while-while kernel (Aila and Laine 2009) on the same node layout.
//
// Data flow: Scene + Bvh --makeGpuLayout--> GpuLayout --upload--> device buffers; per frame
// RenderSettings --render / recordFrame--> two dispatches (primary rays, then shadow rays that
// also shade) --> RGBA8 buffer (+ hits, counters).
//
// The tracer owns its pipelines (one per kernel x packet shape x statistics x view x pass, built on
// first use from specialization constants and cached), the scene buffers and the frame buffers.
// It does not own the VulkanContext, which must outlive it.
#include "renderer/bvh.h"
#include "renderer/frame.h"
#include "renderer/gpu_bvh.h"
#include "renderer/scene.h"
#include "renderer/settings.h"
#include "renderer/vk/context.h"

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace raypack {

// How the binary tree's kernels read nodes: through the node storage buffer, or through a uniform
// texel buffer over the same memory (RGBA32F, two texels a node). On lavapipe texels are
// 1.14-1.59x the storage loads (medians), on an H100 0.97-1.03x (docs/gpu.md, "Nodes through a texel
// buffer"), so Auto takes texels on CPU devices. The environment variable RAYPACK_NODE_FETCH
// (auto, storage or texel) overrides it. A tree with more texels than the device's
// maxTexelBufferElements, the 8-wide tree and a device without RGBA32F texel buffers read storage.
enum class NodeFetch { Auto, Storage, Texel };
const char* toString(NodeFetch fetch);

// Options of a recorded frame that concern only how the output is consumed.
struct GpuRecordOptions {
    // Write the output as B8G8R8A8 instead of R8G8B8A8, for copying into a BGRA swapchain image.
    bool bgra = false;
};

class GpuTracer {
public:
    explicit GpuTracer(const vk::VulkanContext& context);
    ~GpuTracer();
    GpuTracer(const GpuTracer&) = delete;
    GpuTracer& operator=(const GpuTracer&) = delete;

    // Converts `bvh` over `scene` to the GPU layout (renderer/gpu_layout.h), creates the device
    // buffers and uploads them, replacing the previous scene (after waiting for the queue to go
    // idle). Returns T_CU: seconds for conversion, creation and upload, measured on the host.
    // Throws raypack::Error when the device is out of memory or the tree is too deep for the
    // stack the device's shared memory can hold.
    // `bvhWidth` 8 uploads the compressed 8-wide tree made from `bvh` (makeGpuWideTree,
    // renderer/gpu_wide.h), which the single-ray kernel traces with RenderSettings::bvhWidth 8; 2
    // the binary tree itself. The device builds (buildOnDevice, adopt) are binary trees.
    double upload(const Scene& scene, const Bvh& bvh, uint32_t bvhWidth = 2);
    // Where the last upload's T_CU went (issue 13): creating the device and staging buffers, writing
    // the layout into the staging memory (writeGpuLayout, page faults of fresh memory included; or
    // straight into mapped device memory, vk::StagedUpload), and the copies to the device. After a
    // device build, its scene upload's split (0 when the scene was kept).
    struct UploadTimings {
        double allocationSeconds = 0.0;
        double conversionSeconds = 0.0;
        double transferSeconds = 0.0;
    };
    // Builds the BVH on this device with a device builder (options.builder gpu-lbvh,
    // renderer/gpu_bvh.h) straight into the tracer's buffers, replacing the previous scene: no tree
    // on the host and no round trip (issue 13). The materials, textures and the builder's vertex arrays and
    // indices are uploaded only when `scene` is not the one of the last device build (it must stay
    // unchanged while it is used). Throws raypack::Error as upload() and GpuBvhBuilder do.
    struct DeviceBuild {
        BvhStats stats;            // of the built tree (device-side statistics), T_B included
        double uploadSeconds = 0;  // T_CU of this call: the scene's upload, 0 when it was kept
        UploadTimings upload;      // uploadSeconds split (allocation, conversion, transfer)
        double seconds = 0;        // the whole call: upload, allocation, build
    };
    DeviceBuild buildOnDevice(const Scene& scene, const BvhBuildOptions& options);
    // Takes over `tree`, built on this tracer's device by another GpuBvhBuilder (buildGpuTree, on
    // any thread: the viewer's worker), in place of the current tree once the queue has gone idle;
    // the previous tree is traced until this call. The scene's materials and textures are uploaded
    // when tree->scene is not the current scene (it must stay unchanged while it is used). Returns
    // that upload's seconds (T_CU; 0 when the scene was kept). Throws raypack::Error as upload().
    double adopt(std::unique_ptr<GpuTree> tree);
    // The canonical tree of the current scene read back from the device (for a CPU consumer of a
    // tree built on the device). Throws raypack::Error without a scene, or when the tree's leaf
    // order was not kept (buildOnDevice keeps none; adopt keeps what buildGpuTree kept).
    Bvh downloadBvh() const;
    // Where a replaced tree goes once the queue is idle and nothing refers to it any more (upload,
    // buildOnDevice, adopt): to `sink`, which frees it where it likes (the viewer: on its worker
    // thread; freeing the 13M dragon's tree took 0.15 s on the H200). Without a sink the tracer
    // frees it at once.
    void setRetiredTreeSink(std::function<void(std::unique_ptr<GpuTree>)> sink);
    bool hasScene() const;
    UploadTimings lastUploadTimings() const;

    // The compiler's statistics of the pipeline that traces `settings`' primary (or shadow) pass
    // (VK_KHR_pipeline_executable_properties: register count, spills, ... as the driver names
    // them), building the pipeline if needed. Empty where the context was made without
    // VulkanContextOptions::enablePipelineStatistics or the device does not offer them.
    struct PipelineStatistic {
        std::string name;
        double value = 0.0;
    };
    std::vector<PipelineStatistic> pipelineStatistics(const RenderSettings& settings, bool shadowPass);
    // The arithmetic of the robust path's accurate hit distance that `requested` comes to on this
    // device (RenderSettings::hitDistance): Auto takes doubles on a CPU device, float pairs where
    // the device has no shaderFloat64, and otherwise measures the device's doubles against its
    // floats once, on first use (vk::measureFloat64Rate). Throws raypack::Error for Float64 on a
    // device without shaderFloat64.
    HitDistanceMath hitDistanceMath(HitDistanceMath requested);
    // The rate of doubles against floats behind Auto's choice (0 before it, or where it chose
    // without measuring).
    double float64Rate() const;
    // What the uploaded tree's binary kernels read nodes through (Storage or Texel, never Auto;
    // Storage before an upload), and why, in words ("auto: a CPU device", ...).
    NodeFetch nodeFetch() const;
    const std::string& nodeFetchReason() const;
    // `settings` as this device traces them, with the scene uploaded now: the hybrid kernel's
    // automatic packets per workgroup (kAutoPacketsPerGroup, renderer/settings.h) resolved to a
    // count. render, recordFrame, traceBackToBack and pipelineStatistics resolve it themselves.
    RenderSettings deviceSettings(const RenderSettings& settings) const;

    // Everything synchronously: records both passes, submits, waits and reads back what `request`
    // asks for. Frame::timings.primarySeconds / shadowSeconds are kernel times (T_K) from
    // timestamp queries, totalSeconds the host's wall time for the call (T_F).
    // Throws raypack::Error for a packet shape the device cannot run (more rays than
    // maxComputeWorkGroupInvocations) or when no scene is uploaded.
    Frame render(const RenderSettings& settings, const FrameRequest& request = {});

    // Traces `frames` frames back to back in one submission and waits, reading nothing back: keeps
    // the GPU busy so that its clocks are up before frames are timed (a GPU lowers its clocks when
    // it idles, as it mostly does between short frames that each wait for a read-back).
    void traceBackToBack(const RenderSettings& settings, uint32_t frames);

    // For the viewer: records the frame into `cmd`, a command buffer the caller owns, begun and not
    // yet ended, on the context's queue. Starts with a barrier against earlier frames on the queue
    // (so one tracer's frames may be in flight back to back) and ends with a barrier making
    // outputBuffer() readable by transfer (VK_PIPELINE_STAGE_TRANSFER_BIT,
    // VK_ACCESS_TRANSFER_READ_BIT): copy it into the swapchain image with
    // vkCmdCopyBufferToImage (tightly packed, width x height texels, row 0 at the top).
    // A change of image size re-creates the frame buffers after vkQueueWaitIdle.
    void recordFrame(VkCommandBuffer cmd, const RenderSettings& settings, const GpuRecordOptions& options = {});
    VkBuffer outputBuffer() const;
    VkDeviceSize outputBytes() const;

    // Kernel times of the newest recorded frame whose timestamps are available (not waiting for
    // the GPU); nullopt before the first one completes or when the queue has no timestamps.
    std::optional<FrameTimings> lastKernelTimes();

    // Stack entries the kernels are compiled with: the uploaded tree's maximal depth + 1.
    uint32_t stackEntries() const;

    // render() times each pass on the host (the wall time of a submission holding only that pass)
    // instead of by timestamp queries. For lavapipe in the viewer: once graphics work has run on
    // its queue, lavapipe's timestamps no longer bracket the dispatches (a 57 ms pass read 17 us),
    // while on a CPU device the host's clock sees exactly the work. Off by default.
    void setHostTimedPasses(bool on);
    // Bytes of the uploaded scene's device buffers (nodes, triangles, normals, materials, UVs,
    // colours, textures, texels); 0 before upload.
    uint64_t sceneBytes() const;
    const vk::DeviceInfo& device() const;

    // Opaque: pipelines, buffers and queries, defined in gpu_tracer.cpp.
    struct State;

private:
    std::unique_ptr<State> state_;
};

}  // namespace raypack
