#include "ui/frame_loop.h"

#include "renderer/error.h"
#include "renderer/progressive.h"

#include <algorithm>
#include <iterator>

namespace raypack::ui {

const char* toString(TracerChoice tracer) {
    switch (tracer) {
    case TracerChoice::VulkanPacket: return "Vulkan packet kernel";
    case TracerChoice::VulkanSingle: return "Vulkan single-ray kernel";
    case TracerChoice::VulkanHybrid: return "Vulkan hybrid kernel";
    case TracerChoice::CpuReference: return "CPU reference tracer";
    case TracerChoice::CpuPacket: return "CPU packet tracer";
    }
    return "?";
}

const char* cliName(TracerChoice tracer) {
    switch (tracer) {
    case TracerChoice::VulkanPacket: return "vulkan-packet";
    case TracerChoice::VulkanSingle: return "vulkan-single";
    case TracerChoice::VulkanHybrid: return "vulkan-hybrid";
    case TracerChoice::CpuReference: return "cpu-reference";
    case TracerChoice::CpuPacket: return "cpu-packet";
    }
    return "?";
}

std::optional<TracerChoice> parseTracerChoice(const std::string& name) {
    for (const TracerChoice t : kAllTracerChoices)
        if (name == cliName(t)) return t;
    return std::nullopt;
}

TracerChoice requireTracerChoice(const std::string& what, const std::string& text) {
    if (const std::optional<TracerChoice> tracer = parseTracerChoice(text)) return *tracer;
    std::string names;
    for (size_t i = 0; i < std::size(kAllTracerChoices); ++i) {
        if (i > 0) names += i + 1 == std::size(kAllTracerChoices) ? " or " : ", ";
        names += cliName(kAllTracerChoices[i]);
    }
    throw Error(what + ": \"" + text + "\" is not " + names);
}

TracerChoice vulkanTracerFor(KernelKind kernel) {
    switch (kernel) {
    case KernelKind::Single: return TracerChoice::VulkanSingle;
    case KernelKind::Hybrid: return TracerChoice::VulkanHybrid;
    default: return TracerChoice::VulkanPacket;
    }
}

KernelKind kernelOf(TracerChoice tracer) {
    switch (tracer) {
    case TracerChoice::VulkanSingle: return KernelKind::Single;
    case TracerChoice::VulkanHybrid: return KernelKind::Hybrid;
    default: return KernelKind::Packet;
    }
}

bool tracesPackets(TracerChoice tracer) {
    return tracer == TracerChoice::VulkanPacket || tracer == TracerChoice::VulkanHybrid ||
           tracer == TracerChoice::CpuPacket;
}

bool isCpuTracer(TracerChoice tracer) {
    return tracer == TracerChoice::CpuReference || tracer == TracerChoice::CpuPacket;
}

const char* toString(FrameKind kind) {
    switch (kind) {
    case FrameKind::Idle: return "idle";
    case FrameKind::Moving: return "moving";
    case FrameKind::Full: return "full resolution";
    case FrameKind::Refine: return "refining";
    }
    return "?";
}

FramePlan FrameLoop::plan(const FrameLoopSettings& settings, uint32_t width, uint32_t height, bool changed,
                          std::optional<uint32_t> forcedScale, bool refine) {
    FramePlan plan;
    if (changed || forcedScale) {
        fullDone_ = false;
        samplesDone_ = 0;
        plan.kind = FrameKind::Moving;
        if (forcedScale)
            plan.scale = std::max(1u, *forcedScale);
        else if (settings.adaptiveResolution)
            plan.scale = chooseResolutionScale(cost_, width, height, settings.frameBudgetMs * 1e-3);
        return plan;
    }
    if (!fullDone_) {
        plan.kind = FrameKind::Full;
        return plan;
    }
    const uint32_t samples = refine ? std::clamp(settings.samples, 1u, kMaxSamplesPerPixel) : 1u;
    if (samples > 1 && samplesDone_ < samples) {
        plan.kind = FrameKind::Refine;
        plan.samples = samples;
        plan.sampleIndex = samplesDone_;
        plan.jitter = samplePatternOffset(samplesDone_, samples);
        return plan;
    }
    return plan;  // Idle
}

void FrameLoop::traced(const FramePlan& plan, uint64_t pixels, double traceSeconds, double frameSeconds) {
    cost_.addFrame(pixels, traceSeconds, frameSeconds);
    switch (plan.kind) {
    case FrameKind::Moving:
        fullDone_ = plan.scale == 1;  // a full-resolution frame while moving needs no second one
        samplesDone_ = 0;
        break;
    case FrameKind::Full:
        fullDone_ = true;
        samplesDone_ = 0;
        break;
    case FrameKind::Refine: ++samplesDone_; break;
    case FrameKind::Idle: break;
    }
}

}  // namespace raypack::ui
