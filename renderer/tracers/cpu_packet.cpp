// The CPU packet tracer (renderer/cpu_packet_tracer.h) as a tracer: SIMD packets of
// RenderSettings::packet over the same CpuSceneView as the reference, with the reference's
// arithmetic, so its hits are the reference's to the bit.
#include "renderer/cpu_packet_tracer.h"
#include "renderer/error.h"
#include "renderer/measure/machine.h"
#include "renderer/tracers/tracer_rows.h"

#include <optional>

namespace raypack {
namespace {

class CpuPacketTracer final : public Tracer {
public:
    std::string name() const override { return "cpu-packet"; }
    std::string kernel() const override { return "packet"; }
    TracerDevice device() const override { return TracerDevice::Cpu; }
    std::string describe(const RenderSettings& settings) const override {
        return describeCpuDevice("CPU packets " + std::to_string(settings.packet.width) + "x" +
                                 std::to_string(settings.packet.height) + " (" + toString(cpuSimdSelected()) + ")");
    }
    std::string driver() const override { return ""; }
    TracerCapabilities capabilities() const override {
        TracerCapabilities c;
        c.intersectModes = true;
        c.image = c.hits = c.counters = true;
        c.packetShapes = true;
        c.bitExactWithReference = true;
        return c;
    }
    Preparation prepare(const Scene& scene, const Bvh& bvh) override { return prepareCpuSceneView(view_, scene, bvh); }
    Frame render(const RenderSettings& settings, const FrameRequest& request) override {
        if (!view_) throw Error("cpu-packet: no scene prepared");
        return renderCpuPackets(*view_, settings, request);
    }

private:
    std::optional<CpuSceneView> view_;
};

}  // namespace

std::unique_ptr<Tracer> makeCpuPacketTracer() { return std::make_unique<CpuPacketTracer>(); }

}  // namespace raypack
