#pragma once
// The ImGui panel. It edits values (RenderSettings, BvhBuildOptions, PanelLayout: nothing reads
// toggles from globals) and says what the user asked for as PanelActions; it shows what PanelInfo
// holds. It never calls the tracer or the builder, and touches the file system only through its
// file browser's directory listing (ui/file_browser.h).
//
// Layout: the panel is a full-height side bar at the left edge of the window, resizable by its
// right edge (kept between PanelLayout::kMinWidth and the window's width less a margin, so a
// window resize never leaves it off screen) and collapsible to its title bar, which keeps showing
// frames per second. With PanelLayout::overlay it lies over the image, transparent; otherwise it
// reports the part of the window it covers (PanelState::coveredWidthPixels) so that the image can
// be framed in the rest. Errors appear in a box of their own at the bottom of the free part of the
// window, so they never move the panel's buttons. PanelLayout::uiScale scales fonts and sizes
// (ImGui's FontGlobalScale and ScaleAllSizes) for HiDPI screens.
//
// drawPanel draws one section per function (statistics, scene, tracer, light, camera, screenshot,
// presentation, panel); a new section is one more such function and one call in drawPanel.
#include "renderer/async_build.h"
#include "renderer/bvh.h"
#include "renderer/frame.h"
#include "renderer/settings.h"
#include "ui/file_browser.h"
#include "ui/frame_loop.h"
#include "ui/viewer_config.h"

#include <vulkan/vulkan.h>

#include <optional>
#include <string>
#include <vector>

namespace raypack::ui {

// Live numbers of the newest frames.
struct LiveStatistics {
    double frameSeconds = 0.0;     // wall clock between frames, smoothed
    double nonTracingShare = 0.0;  // share of the frame not spent in the kernels
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
    // Heat maps: the full scale follows the frame's 99th percentile (else settings.heatFullScale).
    bool heatAuto = true;
    // Side by side: the right half of the image traced by another tracer (or packet shape).
    bool sideBySide = false;
    TracerChoice sideBySideTracer = TracerChoice::VulkanSingle;
    PacketShape sideBySidePacket;
    PanelLayout layout;       // width, collapsed, UI scale, overlay: kept in viewer.json
    FileBrowser fileBrowser;  // Browse...: its choice becomes openPath and the open action

    // Written by drawPanel each frame: the width in framebuffer pixels of the window's left part
    // that the panel covers (0 when collapsed or overlaying), for framing the image in the rest.
    float coveredWidthPixels = 0.0f;

    // drawPanel's own bookkeeping.
    bool windowPlaced = false;        // the first frame sets the remembered width and collapsed state
    float appliedUiScale = 0.0f;      // the scale the ImGui style and font carry now
    bool widthChangePending = false;  // a resize drag not yet reported as layoutChanged
    float lastDisplayWidth = 0.0f;    // the window's width in the previous frame
};

// Kernel times (primary + shadow) of the two halves of a side-by-side frame.
struct SideBySideTimes {
    double left = 0.0, right = 0.0;
    uint32_t width = 0, height = 0;
};

// What the panel shows.
struct PanelInfo {
    std::string device;
    std::string scene;        // the traced scene's spec; shown only once a tree has been traced
    std::string failedScene;  // the newest scene that failed to load (empty after a success)
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
    std::string cameraArguments;    // the view as raypack-cli render arguments
    std::vector<bool> bookmarkSet;  // 9 entries
    std::vector<VkPresentModeKHR> presentModes;
    VkPresentModeKHR presentMode = VK_PRESENT_MODE_FIFO_KHR;
    uint32_t maxPacketRays = 1024;  // the device's maxComputeWorkGroupInvocations
    float flySpeed = 0.0f;          // scene units per second
    // Interactivity: what the frame loop did with the newest frame, and why this tracer draws.
    FrameLoopStatus frameLoop;
    SideBySideTimes sideBySideTimes;
    std::string tracerReason;
    std::vector<TracerChoice> tracers;     // the tracers this device offers
    bool orbitCamera = false;              // the orbit camera moves the view (else the fly camera)
    std::vector<std::string> recentFiles;  // RecentFiles::entries() after pruneMissing()
};

struct PanelActions {
    bool rebuild = false;  // leaf size or builder changed
    bool open = false;     // load PanelState::openPath
    bool screenshot = false;
    bool compare = false;
    bool frameAll = false;
    bool dismissError = false;
    bool copyCameraArguments = false;
    bool toggleCameraMode = false;  // fly <-> orbit (the panel's radio buttons; Tab in the viewer)
    // PanelState::layout changed (a resize drag ended, collapsed or expanded, UI scale or overlay
    // changed): the caller saves it to viewer.json.
    bool layoutChanged = false;
    int saveBookmark = 0;  // 1..9, 0 for none
    int recallBookmark = 0;
    std::optional<VkPresentModeKHR> presentMode;
    bool tracerChanged = false;  // PanelState::tracer was changed
};

// The panel's "Interactivity" section: tracer, frame budget, resolution scale, samples.
void drawInteractivitySection(PanelState& state, const PanelInfo& info, PanelActions& actions);

PanelActions drawPanel(PanelState& state, const PanelInfo& info);

// The panel's scene line: "Scene: NAME (N triangles)" once a tree is traced, with what is loading
// or what failed; "Scene: none ..." before any scene loaded, "failed", never "(loading)", after a
// failed load.
std::string sceneLine(const PanelInfo& info);
// The shadow rays of the timed frame, for the panel's shadow Mrays/s: the counting frame's shadow
// N_Q where that frame is the one timed (same N_Q of primary rays), else its share of pixels that
// cast a shadow ray applied to the timed frame's pixels (a GPU device counts at a reduced size);
// `estimated` tells which. 0 without counters.
double timedShadowRays(const LiveStatistics& stats, bool* estimated);
// The panel's title, also visible when it is collapsed: "raypack  12.5 fps" (ImGui ID kept apart).
std::string panelTitle(const LiveStatistics& stats);

}  // namespace raypack::ui
