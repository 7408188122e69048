// The CPU reference (renderer/cpu_tracer.h) as a tracer: the canonical tree traced where it lies,
// its nodes copied into cache-line pairs and each leaf's vertices gathered (CpuSceneView).
#include "renderer/cpu_tracer.h"
#include "renderer/error.h"
#include "renderer/measure/machine.h"
#include "renderer/measure/spread.h"
#include "renderer/tracers/tracer_rows.h"

#include <optional>

namespace raypack {
namespace {

class CpuReferenceTracer final : public Tracer {
public:
    std::string name() const override { return "cpu-reference"; }
    std::string kernel() const override { return "reference"; }
    TracerDevice device() const override { return TracerDevice::Cpu; }
    std::string describe(const RenderSettings&) const override { return describeCpuDevice("CPU reference"); }
    std::string driver() const override { return ""; }
    TracerCapabilities capabilities() const override {
        TracerCapabilities c;
        c.intersectModes = true;
        c.image = c.hits = c.counters = true;
        return c;
    }
    Preparation prepare(const Scene& scene, const Bvh& bvh) override { return prepareCpuSceneView(view_, scene, bvh); }
    Frame render(const RenderSettings& settings, const FrameRequest& request) override {
        if (!view_) throw Error("cpu-reference: no scene prepared");
        return renderCpu(*view_, settings, request);
    }

private:
    std::optional<CpuSceneView> view_;
};

}  // namespace

Preparation prepareCpuSceneView(std::optional<CpuSceneView>& view, const Scene& scene, const Bvh& bvh) {
    const auto start = SteadyClock::now();
    view.emplace(makeCpuSceneView(scene, bvh));
    Preparation p;
    p.seconds = secondsSince(start);
    p.bytes = view->leafVertices.size() * sizeof(glm::vec3) + view->nodeStorage.size() * sizeof(CpuNodePair);
    return p;
}

std::unique_ptr<Tracer> makeCpuReferenceTracer() { return std::make_unique<CpuReferenceTracer>(); }

}  // namespace raypack
