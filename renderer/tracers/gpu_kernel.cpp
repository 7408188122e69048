// raypack's three Vulkan compute kernels (renderer/gpu_tracer.h) as tracers: "gpu-packet", the
// shared-stack packet traversal (Gunther, Popov, Seidel 2007) of RenderSettings::packet,
// "gpu-single", one ray per invocation (Aila and Laine 2009), and "gpu-hybrid", the packet until
// it is incoherent and then single rays (Benthin et al. 2012; RenderSettings::hybrid), on the same
// node layout; and "gpu-cwbvh", the single-ray kernel over the compressed 8-wide tree made at upload
// (Ylitie et al. 2017; RenderSettings::bvhWidth 8). One file for all: they differ in the kernel the
// GpuTracer is told to dispatch and the tree it uploads.
#include "renderer/error.h"
#include "renderer/gpu_tracer.h"
#include "renderer/tracers/tracer_rows.h"

namespace raypack {
namespace {

class GpuKernelTracer final : public Tracer {
public:
    GpuKernelTracer(const vk::VulkanContext& context, KernelKind kernel, uint32_t bvhWidth)
        : tracer_(std::make_unique<GpuTracer>(context)), kernel_(kernel), bvhWidth_(bvhWidth) {}

    std::string name() const override { return bvhWidth_ == 8 ? "gpu-cwbvh" : std::string("gpu-") + toString(kernel_); }
    std::string kernel() const override { return toString(kernel_); }
    TracerDevice device() const override { return TracerDevice::Gpu; }
    std::string describe(const RenderSettings&) const override { return vk::describe(tracer_->device()); }
    std::string driver() const override { return tracer_->device().driver; }
    TracerCapabilities capabilities() const override {
        TracerCapabilities c;
        c.intersectModes = true;
        c.image = c.hits = c.counters = c.gpuTimestamps = true;
        c.packetShapes = kernel_ != KernelKind::Single;
        return c;
    }
    Preparation prepare(const Scene& scene, const Bvh& bvh) override {
        Preparation p;
        p.seconds = tracer_->upload(scene, bvh, bvhWidth_);
        p.bytes = tracer_->sceneBytes();
        p.isUpload = true;
        const GpuTracer::UploadTimings split = tracer_->lastUploadTimings();
        p.allocationSeconds = split.allocationSeconds;
        p.conversionSeconds = split.conversionSeconds;
        p.transferSeconds = split.transferSeconds;
        return p;
    }
    std::optional<DeviceBuildPreparation> prepareWithDeviceBuild(const Scene& scene,
                                                                 const BvhBuildOptions& options) override {
        // The device builders write the binary tree; the 8-wide one is made from a host tree.
        if (bvhWidth_ != 2) return std::nullopt;
        const GpuTracer::DeviceBuild built = tracer_->buildOnDevice(scene, options);
        DeviceBuildPreparation p;
        p.preparation.seconds = built.uploadSeconds;
        p.preparation.bytes = tracer_->sceneBytes();
        p.preparation.isUpload = true;
        p.preparation.allocationSeconds = built.upload.allocationSeconds;
        p.preparation.conversionSeconds = built.upload.conversionSeconds;
        p.preparation.transferSeconds = built.upload.transferSeconds;
        p.stats = built.stats;
        return p;
    }
    Frame render(const RenderSettings& settings, const FrameRequest& request) override {
        return tracer_->render(withKernel(settings), request);
    }
    void warmUp(const RenderSettings& settings, uint32_t frames) override {
        tracer_->traceBackToBack(withKernel(settings), frames);
    }
    nlohmann::json pipelineStatistics(const RenderSettings& settings) override {
        nlohmann::json j = nullptr;
        for (const bool shadow : {false, true}) {
            if (shadow && !settings.shadows) continue;
            const auto stats = tracer_->pipelineStatistics(withKernel(settings), shadow);
            if (stats.empty()) return nullptr;
            nlohmann::json pass = nlohmann::json::object();
            for (const GpuTracer::PipelineStatistic& s : stats) pass[s.name] = s.value;
            j[shadow ? "shadow" : "primary"] = pass;
        }
        return j;
    }

    std::optional<std::string> hitDistance(const RenderSettings& settings) override {
        if (settings.intersect != IntersectMode::Robust) return std::nullopt;
        return std::string(toString(tracer_->hitDistanceMath(settings.hitDistance)));
    }
    double float64Rate() const override { return tracer_->float64Rate(); }
    std::optional<std::pair<std::string, std::string>> nodeFetch() const override {
        return std::make_pair(std::string(toString(tracer_->nodeFetch())), tracer_->nodeFetchReason());
    }
    RenderSettings deviceSettings(const RenderSettings& settings) const override {
        return tracer_->deviceSettings(withKernel(settings));
    }

private:
    RenderSettings withKernel(RenderSettings settings) const {
        settings.kernel = kernel_;
        settings.bvhWidth = bvhWidth_;
        return settings;
    }
    std::unique_ptr<GpuTracer> tracer_;
    KernelKind kernel_;
    uint32_t bvhWidth_;
};

}  // namespace

std::unique_ptr<Tracer> makeGpuKernelTracer(const vk::VulkanContext& context, KernelKind kernel, uint32_t bvhWidth) {
    return std::make_unique<GpuKernelTracer>(context, kernel, bvhWidth);
}

}  // namespace raypack
