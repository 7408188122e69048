// raypack: the interactive viewer. Parses the command line into ui::ViewerOptions and runs the
// session (ui/viewer.h); a raypack::Error that stops it from starting (no display, no device)
// becomes one line on stderr and exit code 2.
#include "renderer/error.h"
#include "renderer/settings_json.h"
#include "renderer/settings_text.h"
#include "ui/viewer.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <sstream>

int main(int argc, char** argv) {
    using namespace raypack;
    CLI::App app{
        "raypack: fly or orbit through a triangle scene, traced interactively on any device (a frame\n"
        "budget with reduced resolution while moving, refinement when still), by the Vulkan packet,\n"
        "single-ray or hybrid kernel or the CPU packet or reference tracer; change the packet shape,\n"
        "kernel and BVH live, compare with the CPU reference. F1 in the window lists the controls.\n"
        "With --frames N it runs N frames and exits (scripted runs, tests). Needs a display (xvfb-run\n"
        "without one), except with --offscreen."};
    ui::ViewerOptions options;
    std::string packet, kernel, view, intersect, builder, eye, at, up, present = "fifo", tracer, heatScale;
    std::vector<std::string> script;
    float fov = 0.0f;
    bool noShadows = false, noCounters = false;
    // Named or as the one positional argument (`raypack model.glb`), as raypack-cli render takes it.
    app.add_option("scene,--scene", options.scene, "scene file (OBJ, PLY, glTF, GLB) or generator spec")
        ->capture_default_str();
    app.add_option("--width", options.width, "window width in pixels")->capture_default_str();
    app.add_option("--height", options.height, "window height in pixels")->capture_default_str();
    app.add_option("--frames", options.frames, "run this many frames and exit (0: until closed)")
        ->capture_default_str();
    app.add_option("--screenshot", options.screenshot,
                   "after the last frame: the image as shown (without the panel) as PNG + JSON sidecar");
    app.add_option("--window-screenshot", options.windowScreenshot, "after the last frame: the whole window as PNG");
    app.add_option("--packet", packet,
                   "packet shape WxH of the packet tracer drawing first (default 8x4 for the Vulkan kernel, 16x16 for "
                   "the CPU packet tracer)");
    app.add_option("--leaf-size", options.bvh.leafSize, "BVH leaf size")->capture_default_str();
    std::string builders;
    for (BvhBuilder b : kAllBvhBuilders) builders += std::string(builders.empty() ? "" : ", ") + toString(b);
    app.add_option("--builder", builder,
                   "BVH builder: " + builders + " (the gpu-* builders build on the Vulkan device)");
    app.add_flag("--no-shadows", noShadows, "no shadow rays");
    app.add_option("--kernel", kernel,
                   "Vulkan kernel: packet, single or hybrid (without --tracer, its tracer draws first)");
    app.add_option("--view", view, "shaded, nodes (N_TR heat map) or tests (N_IT heat map)");
    app.add_option("--intersect", intersect,
                   "robust (watertight triangles, conservative slabs, accurate hit distances) or fast "
                   "(Moller-Trumbore, plain slabs; may leak through shared edges); docs/trade.md");
    app.add_option("--heat-scale", heatScale,
                   "count shown as full red in the heat maps, a number above 0 (default: the frame's 99th "
                   "percentile)");
    app.add_option("--light-height", options.settings.lightHeight, "light above the camera, times the scene's height")
        ->capture_default_str();
    app.add_option("--eye", eye,
                   "camera position x,y,z (default: raypack-cli's start view of the scene; each of --eye, --at, "
                   "--up and --fov replaces its part of it)");
    app.add_option("--at", at, "point looked at x,y,z");
    app.add_option("--up", up, "up vector x,y,z");
    app.add_option("--fov", fov, "vertical field of view in degrees")->check(CLI::Range(0.001f, 179.999f));
    app.add_option("--device", options.device, "Vulkan device: index or part of its name");
    app.add_flag("--validation", options.validation, "Vulkan validation layer on; exit code 3 on any message");
    app.add_option("--present", present, "fifo, mailbox or immediate (falls back to fifo)")->capture_default_str();
    app.add_flag("--no-counters", noCounters, "no live N_TR / N_IT in the panel");
    app.add_option(
        "--tracer", tracer,
        "who draws: vulkan-packet, vulkan-single, vulkan-hybrid, cpu-reference or cpu-packet (default: cpu-packet on "
        "a CPU Vulkan device such as lavapipe, vulkan-packet on a GPU)");
    app.add_option("--frame-budget", options.frameLoop.frameBudgetMs,
                   "frame-time budget in ms: while moving, the resolution is reduced to keep it")
        ->check(CLI::Range(1.0f, 10000.0f))
        ->capture_default_str();
    app.add_option("--samples", options.frameLoop.samples,
                   "samples per pixel accumulated when still (1: no refinement)")
        ->check(CLI::Range(1u, 4096u))
        ->capture_default_str();
    std::string sideBySide;
    app.add_option(
        "--side-by-side", sideBySide,
        "trace the right half of the image with this tracer too (vulkan-packet, vulkan-single, vulkan-hybrid, "
        "cpu-reference, cpu-packet), both halves labelled with their kernel times");
    bool fullResolution = false;
    app.add_flag("--no-adaptive", fullResolution, "trace every frame at full resolution, also while moving");
    app.add_option("--record-path", options.recordPath,
                   "write the camera of every frame with its time to this JSON file on exit");
    app.add_option("--play-path", options.playPath, "fly the camera path of this JSON file (from --record-path)");
    app.add_flag("--play-frames", options.playFrames,
                 "with --play-path: one recorded camera per frame, not the recorded timing");
    app.add_flag("--offscreen", options.offscreen,
                 "no window and no display: the same frame loop (budget, refinement, camera paths) into an offscreen "
                 "image, without the panel or input; without --frames it runs until --play-path is played and the "
                 "image has converged (for measuring on machines without a display)");
    app.add_flag("--exit-when-converged", options.exitWhenConverged,
                 "exit once the --play-path is over (or at once without one) and the image has converged");
    app.add_option("--summary", options.summaryPath,
                   "on exit, write a JSON summary: frames, frames/s while moving and still, resolution scales, "
                   "input-to-photon latency, idle CPU share, time to full resolution and to convergence");
    app.add_flag("--hide-panel", options.hidePanel, "draw no panel");
    app.add_option(
        "--script", script,
        "scripted step FRAME:ACTION[:VALUE], repeatable; ACTION: resize WxH, packet WxH, leaf-size N, "
        "builder NAME, shadows on|off, kernel packet|single|hybrid, intersect robust|fast, tracer NAME, view "
        "shaded|nodes|tests, "
        "open SCENE, wait, screenshot FILE, window-screenshot FILE, move RIGHT,UP,FORWARD (seconds of "
        "flight), look DX,DY (pixels), bookmark N, save-bookmark N, frame-all, scale S, samples N, "
        "budget MS, side-by-side TRACER|off");
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        // A usage error exits with the viewer's own code for bad arguments, not CLI11's.
        std::fprintf(stderr, "raypack: %s (see raypack --help)\n", e.what());
        return ui::kViewerExitError;
    }

    try {
        if (!packet.empty()) options.settings.packet = parsePacketShape("--packet", packet);
        options.packetGiven = !packet.empty();
        if (!builder.empty()) options.bvh.builder = parseBvhBuilder(builder);
        options.settings.shadows = !noShadows;
        options.liveCounters = !noCounters;
        options.frameLoop.adaptiveResolution = !fullResolution;
        if (!tracer.empty()) options.tracer = ui::requireTracerChoice("--tracer", tracer);
        if (options.playFrames && options.playPath.empty()) throw Error("--play-frames needs --play-path");
        if (!sideBySide.empty()) options.sideBySide = ui::requireTracerChoice("--side-by-side", sideBySide);
        if (!kernel.empty()) options.settings.kernel = requireKernelKind("--kernel", kernel);
        options.kernelGiven = !kernel.empty();
        if (!intersect.empty()) options.settings.intersect = requireIntersectMode("--intersect", intersect);
        if (!view.empty()) options.settings.view = requireViewMode("--view", view);
        if (!heatScale.empty()) options.settings.heatFullScale = parsePositiveFloat("--heat-scale", heatScale);
        // Each camera flag replaces its part of the start view.
        Camera& camera = options.settings.camera;
        if (!eye.empty()) camera.eye = parseVec3("--eye", eye);
        if (!at.empty()) camera.at = parseVec3("--at", at);
        if (!up.empty()) camera.up = parseVec3("--up", up);
        if (fov > 0.0f) camera.fovYDegrees = fov;
        options.cameraGiven = {!eye.empty(), !at.empty(), !up.empty(), fov > 0.0f};
        if (present == "fifo")
            options.presentMode = VK_PRESENT_MODE_FIFO_KHR;
        else if (present == "mailbox")
            options.presentMode = VK_PRESENT_MODE_MAILBOX_KHR;
        else if (present == "immediate")
            options.presentMode = VK_PRESENT_MODE_IMMEDIATE_KHR;
        else
            throw Error("--present: \"" + present + "\" is not fifo, mailbox or immediate");
        for (const std::string& step : script) options.script.push_back(ui::parseScriptStep(step));
        return ui::runViewer(options);
    } catch (const Error& e) {
        std::fprintf(stderr, "raypack: %s\n", e.what());
        return ui::kViewerExitError;
    }
}
