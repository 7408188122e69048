#pragma once
// What the viewer traces next (issue 8: interactive on every device). Each frame the viewer says
// whether anything that changes the image happened since the last traced frame (camera, a
// setting, the tree, the window size); the frame loop answers with a plan:
//   Moving  - something changed: trace at the resolution scale that fits the frame budget;
//   Full    - nothing changed since a reduced frame: trace at full resolution (pixel centres);
//   Refine  - still at full resolution: trace sample k of the fixed pattern (renderer/progressive.h)
//             into the accumulation, until the wanted samples are in;
//   Idle    - nothing to trace: the viewer presents nothing new and waits for events.
// Pure logic, testable headless; the viewer owns the images.
#include "renderer/settings.h"
#include "ui/frame_budget.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace raypack::ui {

// Who draws the viewer's image.
enum class TracerChoice {
    VulkanPacket,  // the report's packet kernel (renderer/gpu_tracer.h)
    VulkanSingle,  // the single-ray kernel on the same layout
    VulkanHybrid,  // the hybrid kernel: packets splitting into single rays (docs/gpu.md)
    CpuReference,  // the CPU reference tracer (renderer/cpu_tracer.h) on the host's cores
    CpuPacket,     // the CPU packet tracer (renderer/cpu_packet_tracer.h), SIMD over rays
};
constexpr TracerChoice kAllTracerChoices[] = {TracerChoice::VulkanPacket, TracerChoice::VulkanSingle,
                                              TracerChoice::VulkanHybrid, TracerChoice::CpuReference,
                                              TracerChoice::CpuPacket};
const char* toString(TracerChoice tracer);  // "Vulkan packet kernel"
const char* cliName(TracerChoice tracer);   // "vulkan-packet", "vulkan-single", "cpu-reference", "cpu-packet"
std::optional<TracerChoice> parseTracerChoice(const std::string& name);
// The cliName, or raypack::Error `WHAT: "TEXT" is not vulkan-packet, ... or cpu-packet`.
TracerChoice requireTracerChoice(const std::string& what, const std::string& text);
bool isCpuTracer(TracerChoice tracer);
// The Vulkan tracer of a kernel, and a Vulkan tracer's kernel (the packet kernel for CPU tracers).
TracerChoice vulkanTracerFor(KernelKind kernel);
KernelKind kernelOf(TracerChoice tracer);
// Whether the tracer traces RenderSettings::packet-shaped packets.
bool tracesPackets(TracerChoice tracer);

struct FrameLoopSettings {
    float frameBudgetMs = float(kDefaultFrameBudgetSeconds * 1e3);
    bool adaptiveResolution = true;  // off: every frame at full resolution
    uint32_t samples = 16;           // per pixel when still; 1: no refinement
};

enum class FrameKind { Idle, Moving, Full, Refine };
const char* toString(FrameKind kind);

struct FramePlan {
    FrameKind kind = FrameKind::Idle;
    uint32_t scale = 1;        // resolution divisor in each axis
    uint32_t sampleIndex = 0;  // Refine: the sample of the pattern
    uint32_t samples = 1;      // Refine: the pattern's size
    glm::vec2 jitter{0.0f};    // RenderSettings::pixelJitter for this frame
};

// What the panel shows of the frame loop.
struct FrameLoopStatus {
    FrameKind lastKind = FrameKind::Idle;  // of the newest traced frame
    uint32_t scale = 1;                    // of the image shown
    uint32_t samplesShown = 0;             // samples in the image shown (0: a reduced or plain frame)
    uint32_t samplesWanted = 1;
    bool costMeasured = false;
    double secondsPerMegapixel = 0.0;  // tracing cost, smoothed
    double fixedSeconds = 0.0;         // the rest of a frame, smoothed
    uint64_t framesTraced = 0;
    uint64_t framesPresented = 0;
};

class FrameLoop {
public:
    // `changed`: something that changes the image happened since the last traced frame.
    // `forcedScale`: a scripted resolution scale for this frame (a Moving frame at that scale).
    // `refine`: whether this image may be refined by samples (not for heat maps).
    FramePlan plan(const FrameLoopSettings& settings, uint32_t width, uint32_t height, bool changed,
                   std::optional<uint32_t> forcedScale = std::nullopt, bool refine = true);
    // After tracing `plan`: `pixels` traced in `traceSeconds`, the frame took `frameSeconds`.
    void traced(const FramePlan& plan, uint64_t pixels, double traceSeconds, double frameSeconds);
    // The image is no longer what was traced (the traced frame failed, or the caller dropped it).
    void invalidate() {
        fullDone_ = false;
        samplesDone_ = 0;
    }
    uint32_t samplesDone() const { return samplesDone_; }
    bool fullDone() const { return fullDone_; }
    const FrameCostModel& cost() const { return cost_; }

private:
    FrameCostModel cost_;
    bool fullDone_ = false;     // the image shown is at full resolution, nothing changed since
    uint32_t samplesDone_ = 0;  // pattern samples accumulated since then
};

}  // namespace raypack::ui
