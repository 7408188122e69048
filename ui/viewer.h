#pragma once
// The viewer session: window, tracer, worker thread and panel wired into one frame loop, for
// `raypack` (app/viewer/main.cpp). Each piece lives in its own module (ui/viewer_window.h,
// renderer/gpu_tracer.h, renderer/async_build.h, ui/panel.h, ui/fly_camera.h, ui/bookmarks.h,
// ui/screenshot.h); this file only passes values between them once per frame.
#include "renderer/bvh.h"
#include "renderer/settings.h"
#include "renderer/start_view.h"
#include "ui/frame_loop.h"
#include "ui/script.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace raypack::ui {

struct ViewerOptions {
    std::string scene = "gen:default";  // a file or a generator spec (scenes/load.h)
    uint32_t width = 1280;              // window size; the traced image is the framebuffer's size
    uint32_t height = 800;
    uint32_t frames = 0;           // 0: interactive until the window closes
    std::string screenshot;        // after the last frame: traced image + JSON sidecar
    std::string windowScreenshot;  // after the last frame: the whole window, panel included
    RenderSettings settings;       // width/height are taken from the window
    // The parts of settings.camera that --eye, --at, --up and --fov gave for the first scene; the
    // others are its start view's (withStartView), as raypack-cli render takes them.
    CameraParts cameraGiven;
    BvhBuildOptions bvh;
    std::string device;       // as raypack-cli --device
    bool validation = false;  // VK_LAYER_KHRONOS_validation; exit code 3 on any message
    VkPresentModeKHR presentMode = VK_PRESENT_MODE_FIFO_KHR;
    bool liveCounters = true;  // N_TR / N_IT in the panel
    bool hidePanel = false;
    std::vector<ScriptStep> script;
    std::optional<TracerChoice> tracer;      // default: by device (see runViewer)
    std::optional<TracerChoice> sideBySide;  // the right half's tracer
    bool packetGiven = false;                // settings.packet is --packet, for the tracer that draws first
    bool kernelGiven = false;                // settings.kernel is --kernel: without --tracer, its Vulkan tracer draws
    FrameLoopSettings frameLoop;
    std::string recordPath;          // write the camera of every frame here on exit
    std::string playPath;            // fly this recorded path
    bool playFrames = false;         // one recorded key per frame instead of the recorded timing
    std::string summaryPath;         // a JSON summary of the run on exit
    bool offscreen = false;          // no window: the same frame loop into an offscreen image
    bool exitWhenConverged = false;  // exit once the played path is over and the image converged
};

// Exit codes of `raypack`.
constexpr int kViewerExitOk = 0;
constexpr int kViewerExitError = 2;       // no display, no device, bad arguments
constexpr int kViewerExitValidation = 3;  // --validation and the layer reported something

// Opens the window and runs the frame loop. Throws raypack::Error for what stops the viewer from
// starting (no display, no device that can present); errors after that (a bad file, a packet
// shape the device cannot run) are shown in the panel, printed in scripted runs, and the viewer
// goes on with what it had.
int runViewer(const ViewerOptions& options);

}  // namespace raypack::ui
