// The GPU driver's own ray tracing (renderer/vk/rt_peer.h) as a tracer, "driver-rt": the peer a
// GPU user would pick instead of raypack. The peer is a function that builds the driver's
// acceleration structures, traces and destroys everything in one call (its build and upload times
// are part of its bench records), so prepare() only keeps the scene and each frame is one call.
// It does not use raypack's tree: the driver builds its own over the triangles in file order.
#include "renderer/error.h"
#include "renderer/measure/agreement.h"
#include "renderer/tracers/tracer_rows.h"
#include "renderer/vk/rt_peer.h"

namespace raypack {
namespace {

class DriverRtTracer final : public Tracer {
public:
    explicit DriverRtTracer(const vk::VulkanContext& context) : context_(context) {
        if (const std::string reason = rtPeerUnsupportedReason(context); !reason.empty())
            throw RtPeerUnsupported(reason);
    }

    std::string name() const override { return "driver-rt"; }
    std::string kernel() const override { return "vkCmdTraceRaysKHR"; }
    TracerDevice device() const override { return TracerDevice::Gpu; }
    std::string describe(const RenderSettings&) const override { return vk::describe(context_.info); }
    std::string driver() const override { return vk::describe(context_.info); }
    // Its own intersection, no accurate distance of raypack's.
    std::optional<std::string> hitDistance(const RenderSettings&) override { return std::nullopt; }
    TracerCapabilities capabilities() const override {
        TracerCapabilities c;
        c.hits = c.gpuTimestamps = true;
        return c;
    }
    Preparation prepare(const Scene& scene, const Bvh&) override {
        scene_ = &scene;
        return {};
    }
    // One warm-up launch (whose hits are the frame's) and one timed launch.
    Frame render(const RenderSettings& settings, const FrameRequest& request) override {
        if (!scene_) throw Error("driver-rt: no scene prepared");
        Frame frame = runRtPeer(context_, *scene_, settings, 1).frame;
        if (!request.hits) frame.hits.clear();
        return frame;
    }
    std::optional<nlohmann::json> peerRecords(const RenderSettings& settings, uint32_t repeats,
                                              const std::vector<HitRecord>& reference) override {
        if (!scene_) throw Error("driver-rt: no scene prepared");
        const RtPeerResult result = runRtPeer(context_, *scene_, settings, repeats);
        std::optional<HitAgreement> agreement;
        if (!reference.empty()) agreement = compareHits(result.frame.hits, reference);
        return rtPeerRecords(result, agreement ? &*agreement : nullptr);
    }

private:
    const vk::VulkanContext& context_;
    const Scene* scene_ = nullptr;
};

}  // namespace

std::unique_ptr<Tracer> makeDriverRtTracer(const vk::VulkanContext& context) {
    return std::make_unique<DriverRtTracer>(context);
}

}  // namespace raypack
