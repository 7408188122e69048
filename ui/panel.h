#pragma once
// The ImGui panel. It edits values (RenderSettings, BvhBuildOptions: nothing reads toggles from
// globals) and says what the user asked for as PanelActions; it shows what PanelInfo holds. It
// never calls the tracer, the builder or the file system itself.
#include "renderer/async_build.h"
#include "renderer/bvh.h"
#include "renderer/frame.h"
#include "renderer/settings.h"
#include "ui/frame_loop.h"

#include <vulkan/vulkan.h>

#include <optional>
#include <string>
#include <vector>

namespace raypack::ui {

// Live numbers of the newest frames.
struct LiveStatistics {
    double frameSeconds = 0.0;          // wall clock between frames, smoothed
    double nonTracingShare = 0.0;       // share of the frame not spent in the kernels
    bool kernelTimesValid = false;
    std::string kernelTimesNote;        // where T_K comes from (which frame, which clock)
    double primaryKernelSeconds = 0.0;  // T_K of primary rays
    double shadowKernelSeconds = 0.0;   // T_K of shadow rays
    uint64_t primaryRays = 0;           // N_Q: one per pixel
    bool countersValid = false;         // from the newest counting frame
    CounterSummary counters;            // N_TR, N_IT averages and the shadow N_Q
    std::string countersNote;           // which frame the counters are from, and how old
};

struct CompareResult {
    bool valid = false;
    uint64_t differingPixels = 0;
    uint64_t pixels = 0;
    double differingShare = 0.0;
    uint32_t maxChannelDifference = 0;
    double cpuSeconds = 0.0;
};

enum class Showing { Traced, Reference, Difference };

// What the panel edits.
struct PanelState {
    RenderSettings settings;
    BvhBuildOptions bvh;
    std::string openPath;
    bool liveCounters = true;  // one counting frame per second for N_TR / N_IT
    Showing showing = Showing::Traced;
    // Interactivity (issue 8): which tracer draws, the frame budget, refinement when still.
    TracerChoice tracer = TracerChoice::VulkanPacket;
    FrameLoopSettings frameLoop;
};

// What the panel shows.
struct PanelInfo {
    std::string device;
    std::string scene;
    uint64_t triangles = 0;
    bool hasBvh = false;
    BvhStats bvhStats;
    BvhBuildOptions builtWith;  // the options of the tree being traced
    double loadSeconds = 0.0;
    BuildStatus build;
    std::string error;  // the newest error (bad file, bad packet shape), empty when none
    LiveStatistics stats;
    CompareResult compare;
    std::string lastScreenshot;
    std::string cameraArguments;  // the view as raypack-cli render arguments
    std::vector<bool> bookmarkSet;  // 9 entries
    std::vector<VkPresentModeKHR> presentModes;
    VkPresentModeKHR presentMode = VK_PRESENT_MODE_FIFO_KHR;
    uint32_t maxPacketRays = 1024;  // the device's maxComputeWorkGroupInvocations
    float flySpeed = 0.0f;          // scene units per second
    // Interactivity: what the frame loop did with the newest frame, and why this tracer draws.
    FrameLoopStatus frameLoop;
    std::string tracerReason;
    std::vector<TracerChoice> tracers;  // the tracers this device offers
};

struct PanelActions {
    bool rebuild = false;     // leaf size or builder changed
    bool open = false;        // load PanelState::openPath
    bool screenshot = false;
    bool compare = false;
    bool frameAll = false;
    bool dismissError = false;
    bool copyCameraArguments = false;
    int saveBookmark = 0;     // 1..9, 0 for none
    int recallBookmark = 0;
    std::optional<VkPresentModeKHR> presentMode;
    bool tracerChanged = false;  // PanelState::tracer was changed
};

// The panel's "Interactivity" section: tracer, frame budget, resolution scale, samples.
void drawInteractivitySection(PanelState& state, const PanelInfo& info, PanelActions& actions);

PanelActions drawPanel(PanelState& state, const PanelInfo& info);

}  // namespace raypack::ui
