#include "ui/viewer.h"

#include "renderer/async_build.h"
#include "renderer/cpu_packet_tracer.h"
#include "renderer/cpu_tracer.h"
#include "renderer/error.h"
#include "renderer/gpu_tracer.h"
#include "renderer/image.h"
#include "renderer/measure/spread.h"
#include "renderer/measure/statistics.h"
#include "renderer/pick.h"
#include "renderer/progressive.h"
#include "renderer/settings_json.h"
#include "renderer/start_view.h"
#include "renderer/vk/context.h"
#include "scenes/load.h"
#include "ui/bookmarks.h"
#include "ui/camera_path.h"
#include "ui/fly_camera.h"
#include "ui/frame_loop.h"
#include "ui/input.h"
#include "ui/orbit_camera.h"
#include "ui/panel.h"
#include "ui/pointer.h"
#include "ui/readback.h"
#include "ui/run_statistics.h"
#include "ui/screenshot.h"
#include "ui/viewer_config.h"
#include "ui/viewer_window.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_vulkan.h>
#include <imgui.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <thread>

#include <sys/resource.h>

namespace raypack::ui {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

// A scene spec as the sidecar and the bookmarks keep it: an existing file becomes absolute, so
// `raypack-cli render --from` works from any folder; a generator spec stays as it is.
std::string canonicalSpec(const std::string& spec) {
    std::error_code error;
    if (fs::is_regular_file(spec, error)) return fs::absolute(spec).lexically_normal().string();
    return spec;
}

std::string bookmarksFile() { return (fs::path(configDirectory()) / "bookmarks.json").string(); }

// Where the image on screen came from, so that it can be presented again without tracing.
enum class ShownSource { Nothing, TracerOutput, Host };

// A key pressed since the last frame that acts once (F, F1, F12, bookmarks), from the callback.
struct KeyPress {
    int key = 0;
    int mods = 0;
};

// Everything the frame loop passes between the modules. Destroyed in the reverse order of use:
// the worker first (it may still be building), then the tracer, the window and the context.
struct Session {
    const ViewerOptions& options;
    vk::VulkanContext context;
    ViewerWindow window;
    // --offscreen: no window; frames that stay on the GPU are recorded from this pool and waited for.
    bool offscreen = false;
    VkCommandPool offscreenPool = VK_NULL_HANDLE;
    std::unique_ptr<GpuTracer> tracer;
    std::unique_ptr<AsyncSceneBuilder> builder;
    bool cpuDevice = false;
    PacketShape otherPacket = kDefaultCpuPacket;  // the packet shape of the tracers not drawing

    std::shared_ptr<const Scene> scene;
    // The host tree: a CPU build's, or a device build's read back when a CPU consumer first asks
    // (hostBvh); null until then.
    std::shared_ptr<const Bvh> bvh;
    uint64_t treeGeneration = 0;  // counts the trees taken from the worker
    // Frames drawn while the worker loaded or built, since the last tree was taken, and the
    // longest of them; each tree taken, kept only for --summary ("trees").
    uint32_t framesWhileBuilding = 0;
    double longestFrameWhileBuilding = 0.0;
    nlohmann::json treesTaken = nlohmann::json::array();
    std::optional<CpuSceneView> cpuView;  // made when a CPU tracer first draws this tree
    std::string sceneSpec;
    bool firstScene = true;
    bool firstLoadFailed = false;
    double uploadSeconds = 0.0;

    PanelState panel;
    PanelInfo info;
    FlyCamera fly;
    OrbitCamera orbit;
    bool orbitMode = false;
    ViewerConfig config;
    std::string configFile = viewerConfigFile();
    std::optional<BookmarkStore> bookmarks;
    std::vector<std::string> droppedFiles;

    // Input, filled by the GLFW callbacks between frames (ui/input.h).
    HeldKeys keys;
    std::vector<KeyPress> pressed;
    bool looking = false;
    glm::dvec2 lastCursor{0.0};
    glm::vec2 lookPixels{0.0f};
    bool orbiting = false, panning = false;  // left / middle drags that started over the image
    glm::vec2 orbitPixels{0.0f}, panPixels{0.0f};
    DoubleClickDetector clicks;
    std::optional<glm::dvec2> pivotPick;  // a double-click's cursor position, picked next frame
    float imageOffsetX = 0.0f;            // framebuffer pixels left of the image (the panel beside it)
    double firstInputSeconds = -1.0;      // time of the first input event since the last frame
    int uiFramesPending = 2;              // frames to draw for the panel after an event
    bool showHelp = false;
    GLFWkeyfun previousKey = nullptr;
    GLFWcharfun previousChar = nullptr;
    GLFWmousebuttonfun previousMouseButton = nullptr;
    GLFWcursorposfun previousCursor = nullptr;
    GLFWscrollfun previousScroll = nullptr;
    GLFWwindowfocusfun previousFocus = nullptr;

    // The frame loop (ui/frame_loop.h) and what is on screen.
    FrameLoop loop;
    SampleAccumulator accumulator;
    std::string tracedViewKey;  // the view of the image on screen
    std::optional<uint32_t> forcedScale;
    ShownSource shown = ShownSource::Nothing;
    Image shownHost;        // the image on screen when it came from the host, RGBA8, window-sized
    vk::Buffer shownImage;  // host-visible copy of it, in the swapchain's byte order
    vk::Buffer screenshotReadback;
    Image referenceImage, differenceImage;  // the compare view

    // Counters of the Vulkan kernels: a counting frame within budget (measureCounters).
    Clock::time_point lastCounting{};
    bool lastFrameCounted = false;
    double countingSeconds = 0.0;
    std::string countedViewKey;
    Clock::time_point countersTime{};
    float heatPercentile = 0.0f;  // of the newest counted frame, for the heat maps' full scale
    ViewMode heatPercentileView = ViewMode::Shaded;
    std::string countersSource;

    // Camera paths.
    std::optional<CameraPath> playing;
    Clock::time_point playStart{};
    uint32_t playFrame = 0;
    bool playbackOver = false;
    CameraPath recording;

    // Timing and the run's summary.
    const Clock::time_point runStart = Clock::now();
    Clock::time_point lastFrame = Clock::now();
    Clock::time_point lastTitle{};
    double smoothedFrameSeconds = 0.0;
    uint32_t frameIndex = 0;
    std::vector<double> frameTimes, primaryKernelTimes, shadowKernelTimes;
    RunStatistics run;  // every frame, for --summary

    explicit Session(const ViewerOptions& o) : options(o) {}
    ~Session() {
        builder.reset();
        if (context.device) vk::deviceWaitIdle(context);
        tracer.reset();
        vk::destroyBuffer(context, shownImage);
        vk::destroyBuffer(context, screenshotReadback);
        if (offscreenPool) vkDestroyCommandPool(context.device, offscreenPool, nullptr);
        if (!offscreen) destroyViewerWindow(context, window);
        destroyVulkanContext(context);
        if (!offscreen) glfwTerminate();
    }

    double secondsSinceStart(Clock::time_point t = Clock::now()) const {
        return std::chrono::duration<double>(t - runStart).count();
    }
    void report(const std::string& message) {
        info.error = message;
        if (options.frames) std::fprintf(stderr, "raypack: %s\n", message.c_str());
    }
    void noteInput() {
        if (firstInputSeconds < 0.0) firstInputSeconds = secondsSinceStart();
        uiFramesPending = std::max(uiFramesPending, 3);
    }
};

Session& sessionOf(GLFWwindow* window) { return *static_cast<Session*>(glfwGetWindowUserPointer(window)); }

std::optional<FlyKey> flyKeyOf(int key) {
    switch (key) {
    case GLFW_KEY_W: return FlyKey::Forward;
    case GLFW_KEY_S: return FlyKey::Back;
    case GLFW_KEY_A: return FlyKey::Left;
    case GLFW_KEY_D: return FlyKey::Right;
    case GLFW_KEY_Q: return FlyKey::Down;
    case GLFW_KEY_E: return FlyKey::Up;
    default: return std::nullopt;
    }
}

// GLFW callbacks: each first calls the one it replaced (ImGui's backend), then records the event.
void onKey(GLFWwindow* window, int key, int scancode, int action, int mods) {
    Session& s = sessionOf(window);
    if (s.previousKey) s.previousKey(window, key, scancode, action, mods);
    s.noteInput();
    const double now = s.secondsSinceStart();
    const std::optional<FlyKey> fly = flyKeyOf(key);
    if (action == GLFW_RELEASE) {
        if (fly) s.keys.release(*fly, now);  // always, so no key sticks
        return;
    }
    if (ImGui::GetIO().WantCaptureKeyboard) return;  // typing into the panel
    if (action == GLFW_PRESS) {
        if (fly && !(mods & GLFW_MOD_CONTROL))
            s.keys.press(*fly, now);  // Ctrl+Q quits
        else
            s.pressed.push_back({key, mods});
    }
}

void onChar(GLFWwindow* window, unsigned int codepoint) {
    Session& s = sessionOf(window);
    if (s.previousChar) s.previousChar(window, codepoint);
    s.noteInput();
    if (codepoint == '?' && !ImGui::GetIO().WantCaptureKeyboard) s.showHelp = !s.showHelp;
}

void onMouseButton(GLFWwindow* window, int button, int action, int mods) {
    Session& s = sessionOf(window);
    if (s.previousMouseButton) s.previousMouseButton(window, button, action, mods);
    s.noteInput();
    // A drag acts only when it started over the image, not over the panel.
    const bool overImage = !ImGui::GetIO().WantCaptureMouse;
    bool* drag = button == GLFW_MOUSE_BUTTON_RIGHT    ? &s.looking
                 : button == GLFW_MOUSE_BUTTON_LEFT   ? &s.orbiting
                 : button == GLFW_MOUSE_BUTTON_MIDDLE ? &s.panning
                                                      : nullptr;
    if (!drag) return;
    if (action == GLFW_PRESS) {
        *drag = overImage;
        glfwGetCursorPos(window, &s.lastCursor.x, &s.lastCursor.y);
        // A double-click on the image sets the orbit pivot (event times: ImGui's double-click
        // counts frames, which on a CPU device can be seconds apart).
        if (button == GLFW_MOUSE_BUTTON_LEFT && overImage && s.clicks.press(glfwGetTime(), s.lastCursor))
            s.pivotPick = s.lastCursor;
    } else if (action == GLFW_RELEASE) {
        *drag = false;
    }
}

void onCursor(GLFWwindow* window, double x, double y) {
    Session& s = sessionOf(window);
    if (s.previousCursor) s.previousCursor(window, x, y);
    s.noteInput();
    const glm::vec2 delta(glm::dvec2(x, y) - s.lastCursor);
    if (s.looking) s.lookPixels += delta;
    if (s.orbiting) s.orbitPixels += delta;
    if (s.panning) s.panPixels += delta;
    s.lastCursor = glm::dvec2(x, y);
}

void onScroll(GLFWwindow* window, double dx, double dy) {
    Session& s = sessionOf(window);
    if (s.previousScroll) s.previousScroll(window, dx, dy);
    s.noteInput();
}

void onFocus(GLFWwindow* window, int focused) {
    Session& s = sessionOf(window);
    if (s.previousFocus) s.previousFocus(window, focused);
    s.noteInput();
    if (!focused) {  // no release events will come for keys held now
        s.keys.releaseAll(s.secondsSinceStart());
        s.looking = s.orbiting = s.panning = false;
    }
}

void onDrop(GLFWwindow* window, int count, const char** paths) {
    Session& s = sessionOf(window);
    s.noteInput();
    for (int i = 0; i < count; ++i) s.droppedFiles.emplace_back(paths[i]);
}

void onRefresh(GLFWwindow* window) { sessionOf(window).noteInput(); }
void onFramebufferSize(GLFWwindow* window, int, int) { sessionOf(window).noteInput(); }

void installCallbacks(Session& s) {
    GLFWwindow* w = s.window.window;
    glfwSetWindowUserPointer(w, &s);
    s.previousKey = glfwSetKeyCallback(w, onKey);
    s.previousChar = glfwSetCharCallback(w, onChar);
    s.previousMouseButton = glfwSetMouseButtonCallback(w, onMouseButton);
    s.previousCursor = glfwSetCursorPosCallback(w, onCursor);
    s.previousScroll = glfwSetScrollCallback(w, onScroll);
    s.previousFocus = glfwSetWindowFocusCallback(w, onFocus);
    glfwSetDropCallback(w, onDrop);
    glfwSetWindowRefreshCallback(w, onRefresh);
    glfwSetFramebufferSizeCallback(w, onFramebufferSize);
}

void saveConfig(Session& s) {
    try {
        saveViewerConfig(s.configFile, s.config);
    } catch (const Error& e) {
        s.report(e.what());
    }
}

void requestLoad(Session& s, const std::string& spec) {
    s.builder->requestLoad(spec, s.panel.bvh);
    if (s.options.frames) std::printf("raypack: frame %u: open %s\n", s.frameIndex, spec.c_str());
}

// The right half traced by `tracer` (its own default packet shape).
void setSideBySide(Session& s, TracerChoice tracer) {
    s.panel.sideBySide = true;
    s.panel.sideBySideTracer = tracer;
    s.panel.sideBySidePacket = tracer == TracerChoice::CpuPacket ? kDefaultCpuPacket : PacketShape{};
}

// The packet shape belongs to the tracer: the CPU packet tracer's (16x16 by default) and the
// Vulkan packet kernel's (8x4) are kept apart, and the panel's shape controls edit the one drawing.
void setTracer(Session& s, TracerChoice tracer, const std::string& reason) {
    const bool wasCpuPacket = s.panel.tracer == TracerChoice::CpuPacket;
    const bool isCpuPacket = tracer == TracerChoice::CpuPacket;
    if (wasCpuPacket != isCpuPacket) std::swap(s.panel.settings.packet, s.otherPacket);
    s.panel.tracer = tracer;
    if (!isCpuTracer(tracer)) s.panel.settings.kernel = kernelOf(tracer);
    s.info.tracerReason = reason;
}

// The host tree of the scene shown (the CPU tracers, picking, the CPU reference): a device build's
// is read back from the tracer the first time a CPU consumer asks for it.
const Bvh& hostBvh(Session& s) {
    if (!s.bvh) s.bvh = std::make_shared<const Bvh>(s.tracer->downloadBvh());
    return *s.bvh;
}

// Whether a CPU tracer draws (either half): a device build then reads its tree back on the worker.
bool needsHostTree(const Session& s) {
    return isCpuTracer(s.panel.tracer) || (s.panel.sideBySide && isCpuTracer(s.panel.sideBySideTracer));
}

// At the frame boundary: swap in what the worker finished (upload, then trace it from this frame
// on), and show what failed.
void takeWorkerResults(Session& s) {
    if (std::optional<BuildFailure> failure = s.builder->takeFailure()) {
        // Loaders name the file in their messages; add it only where the message does not.
        const std::string& path = failure->scenePath;
        const bool named = path.empty() || failure->message.find(path) != std::string::npos;
        s.report(path.empty() ? "rebuild: " + failure->message
                              : (named ? failure->message : path + ": " + failure->message));
        if (!path.empty()) s.info.failedScene = path;
        if (!path.empty() && !s.scene) s.firstLoadFailed = true;
    }
    std::optional<SceneBuild> build = s.builder->takeFinished();
    if (!build) return;
    const auto takeStart = Clock::now();
    const bool adopted = build->deviceTree != nullptr;
    try {
        // A device build is already in the tracer's device memory: it is swapped in, not uploaded.
        s.uploadSeconds =
            adopted ? s.tracer->adopt(std::move(build->deviceTree)) : s.tracer->upload(*build->scene, *build->bvh);
    } catch (const Error& e) {
        s.report(e.what());
        return;
    }
    // What the render thread spent taking the tree (the frame it delays), against the worker's build.
    const double takeSeconds = std::chrono::duration<double>(Clock::now() - takeStart).count();
    if (!s.options.summaryPath.empty())
        s.treesTaken.push_back({{"frame", s.frameIndex},
                                {"builder", toString(build->options.builder)},
                                {"leaf_size", build->options.leafSize},
                                {"triangles", build->scene->triangleCount()},
                                {"taken_by", adopted ? "adopt" : "upload"},
                                {"take_s", takeSeconds},
                                {"build_s", build->buildSeconds},
                                {"frames_while_building", s.framesWhileBuilding},
                                {"longest_frame_while_building_s", s.longestFrameWhileBuilding}});
    if (s.options.frames)
        std::printf(
            "raypack: frame %u: tree of %s (leaf size %u) built in %.3f s on the worker, taken by %s in %.4f "
            "s on the render thread; %u frames drawn meanwhile, the longest %.1f ms\n",
            s.frameIndex, toString(build->options.builder), build->options.leafSize, build->buildSeconds,
            adopted ? "adopt" : "upload", takeSeconds, s.framesWhileBuilding, s.longestFrameWhileBuilding * 1e3);
    s.framesWhileBuilding = 0;
    s.longestFrameWhileBuilding = 0.0;
    const bool newScene = build->scene != s.scene;
    s.scene = build->scene;
    s.bvh = build->bvh;
    ++s.treeGeneration;
    s.cpuView.reset();
    s.info.bvhStats = build->stats;
    s.info.builtWith = build->options;
    s.info.hasBvh = true;
    s.info.compare.valid = false;
    s.panel.showing = Showing::Traced;
    if (!newScene) return;
    s.firstLoadFailed = false;
    s.info.failedScene.clear();
    if (s.config.recent.add(build->scenePath)) saveConfig(s);
    s.config.recent.pruneMissing();
    s.info.recentFiles = s.config.recent.entries();
    s.sceneSpec = canonicalSpec(build->scenePath);
    s.info.scene = s.sceneSpec;
    // The path field names the scene shown, however it was opened (typed, Browse..., Recent files,
    // a dropped file, a script's `open`).
    s.panel.openPath = build->scenePath;
    s.info.triangles = s.scene->triangleCount();
    s.info.loadSeconds = build->loadSeconds;
    const Aabb bounds = s.scene->bounds();
    // The start camera is the CLI's start view (the file's camera, the framing, or inside a room),
    // so the viewer and raypack-cli render agree.
    // Parts given on the command line replace the start view's for the first scene; with both
    // points given the start view is not needed (nor, after a device build, the host's tree).
    const CameraParts given = s.firstScene ? s.options.cameraGiven : CameraParts{};
    const Camera camera = given.bothPoints()
                              ? s.options.settings.camera
                              : withStartView(s.options.settings.camera, given, startCamera(*s.scene, hostBvh(s)));
    s.firstScene = false;
    s.panel.settings.camera = camera;
    s.fly.reset(camera, bounds);
    s.orbit.reset(camera, bounds);
    try {
        s.bookmarks.emplace(bookmarksFile(), s.sceneSpec);
    } catch (const Error& e) {
        s.bookmarks.reset();
        s.report(std::string("bookmarks: ") + e.what());
    }
}

nlohmann::json statisticsJson(const Session& s) {
    const LiveStatistics& st = s.info.stats;
    // N_Q and T_K as Table 2 holds them (renderer/measure/statistics.h): the sidecar's Mrays/s is
    // the bench's formula.
    RayKindStats primary;
    primary.rays = st.primaryRays;
    primary.kernelSeconds.median = st.primaryKernelSeconds;
    nlohmann::json stats = {
        {"device", s.info.device},
        {"tracer", cliName(s.panel.tracer)},
        {"frame_s", st.frameSeconds},
        {"primary_rays", st.primaryRays},
        {"primary_kernel_s", st.primaryKernelSeconds},
        {"shadow_kernel_s", st.shadowKernelSeconds},
        {"primary_mrays_s", primary.mraysPerSecond()},
        {"upload_s", s.uploadSeconds},
    };
    if (s.panel.sideBySide)  // the sidecar's settings are the left half's; the right half's tracer:
        stats["side_by_side"] = {{"right_tracer", cliName(s.panel.sideBySideTracer)},
                                 {"right_packet", {s.panel.sideBySidePacket.width, s.panel.sideBySidePacket.height}},
                                 {"left_kernel_s", s.info.sideBySideTimes.left},
                                 {"right_kernel_s", s.info.sideBySideTimes.right}};
    if (st.countersValid) {
        stats["primary_nodes_per_ray"] = st.counters.primaryNodes;
        stats["primary_tests_per_ray"] = st.counters.primaryTests;
        stats["shadow_rays"] = st.counters.shadowRays;
        stats["shadow_nodes_per_ray"] = st.counters.shadowNodes;
        stats["shadow_tests_per_ray"] = st.counters.shadowTests;
        stats["counters_from"] = s.countersSource;
    }
    if (s.info.hasBvh) {
        const BvhStats& b = s.info.bvhStats;
        stats["bvh"] = {{"leaves", b.leafCount},
                        {"avg_leaf_depth", b.avgLeafDepth},
                        {"max_leaf_depth", b.maxLeafDepth},
                        {"avg_prims_per_leaf", b.avgPrimsPerLeaf},
                        {"build_s", b.buildSeconds},
                        {"sah_cost", b.sahCost},
                        {"nodes", b.nodeCount},
                        {"bytes", b.bytes},
                        {"triangles", s.scene->triangleCount()}};
    }
    return stats;
}

const CpuSceneView& cpuViewOf(Session& s) {
    if (!s.cpuView) s.cpuView.emplace(makeCpuSceneView(*s.scene, hostBvh(s)));
    return *s.cpuView;
}

// One frame traced synchronously on the host's side: the CPU tracers, or a Vulkan kernel through
// GpuTracer::render (which reads the image back).
Frame traceOnHost(Session& s, TracerChoice tracer, const RenderSettings& settings, const FrameRequest& request) {
    if (tracer == TracerChoice::CpuPacket) return renderCpuPackets(cpuViewOf(s), settings, request);
    if (tracer == TracerChoice::CpuReference) return renderCpu(cpuViewOf(s), settings, request);
    return s.tracer->render(settings, request);
}

// The CPU reference of the same view and the difference, shown in the panel (raypack-cli diff's
// numbers) and, on request, in place of the traced image.
void compareWithReference(Session& s) {
    if (!s.scene || !s.info.hasBvh) return;
    RenderSettings settings = s.panel.settings;
    settings.collectCounters = false;
    settings.pixelJitter = glm::vec2(0.0f);
    const Frame gpuFrame = s.tracer->render(settings);
    const Frame cpuFrame = renderCpu(cpuViewOf(s), settings);
    const Image gpuImage{gpuFrame.width, gpuFrame.height, gpuFrame.rgba};
    s.referenceImage = Image{cpuFrame.width, cpuFrame.height, cpuFrame.rgba};
    const ImageDiff diff = diffImages(s.referenceImage, gpuImage, 0, "CPU reference", "GPU image");
    s.differenceImage = diff.difference;
    s.info.compare = CompareResult{true,
                                   diff.differingPixels,
                                   diff.pixels,
                                   diff.differingShare,
                                   diff.maxChannelDifference,
                                   cpuFrame.timings.totalSeconds};
    if (s.options.frames)
        std::printf("raypack: compare: %llu of %llu pixels differ\n", (unsigned long long)diff.differingPixels,
                    (unsigned long long)diff.pixels);
}

// The image on screen, RGBA8, as the user sees it (reduced, refined or plain).
Image shownImageNow(Session& s) {
    if (s.shown == ShownSource::Host) return s.shownHost;
    if (s.shown != ShownSource::TracerOutput) throw Error("screenshot: no image shown yet");
    const uint32_t width = s.panel.settings.width, height = s.panel.settings.height;
    RAYPACK_CHECK(s.tracer->outputBytes() == VkDeviceSize(width) * height * 4);
    return readBackImage(s.context, s.offscreen ? s.offscreenPool : s.window.commandPool, s.tracer->outputBuffer(),
                         width, height, !s.offscreen && s.window.swapchain.format.format == VK_FORMAT_B8G8R8A8_UNORM,
                         s.screenshotReadback);
}

void saveScreenshot(Session& s, const std::string& path) {
    try {
        Image image = shownImageNow(s);
        RenderSetup setup{s.sceneSpec, s.panel.settings, s.info.hasBvh ? s.info.builtWith : s.panel.bvh};
        setup.settings.width = image.width;
        setup.settings.height = image.height;
        setup.settings.pixelJitter = glm::vec2(0.0f);
        const FrameLoopStatus& st = s.info.frameLoop;
        setup.samples = std::max(1u, st.samplesShown);
        setup.resolutionScale = st.scale;
        // The kernel the sidecar names is the one that drew: the CPU reference traces single rays.
        if (s.panel.tracer == TracerChoice::CpuReference) setup.settings.kernel = KernelKind::Single;
        if (s.panel.tracer == TracerChoice::CpuPacket) setup.settings.kernel = KernelKind::Packet;
        writeScreenshot(path, image, setup, statisticsJson(s), isCpuTracer(s.panel.tracer) ? "cpu" : "gpu");
        s.info.lastScreenshot = path;
        std::printf("raypack: screenshot %s (%ux%u, %u samples, 1/%u resolution) and %s\n", path.c_str(), image.width,
                    image.height, setup.samples, setup.resolutionScale, sidecarPath(path).c_str());
    } catch (const Error& e) {
        s.report(e.what());
    }
}

void recallBookmark(Session& s, int slot) {
    if (!s.bookmarks || !s.bookmarks->slot(slot)) return;
    s.panel.settings.camera = *s.bookmarks->slot(slot);
    s.fly.setCamera(s.panel.settings.camera);
    s.orbit.setCamera(s.panel.settings.camera);
}

void saveBookmark(Session& s, int slot) {
    if (!s.bookmarks) return;
    try {
        s.bookmarks->save(slot, s.panel.settings.camera);
    } catch (const Error& e) {
        s.report(e.what());
    }
}

void handleActions(Session& s, const PanelActions& a, const RenderSettings& before);

// This frame's script steps, applied through the panel's own path (handleActions) and the
// session's effects, in a fixed order: the panel's edits, then loads and rebuilds, then a wait.
void applyScriptSteps(Session& s, std::string& screenshot, std::string& windowShot, FlyInput& input) {
    const RenderSettings before = s.panel.settings;
    PanelActions actions;
    ScriptEffects effects;
    bool any = false;
    for (const ScriptStep& step : s.options.script) {
        if (step.frame != s.frameIndex) continue;
        any = true;
        std::printf("raypack: frame %u: %s %s\n", s.frameIndex, toString(step.action), step.value.c_str());
        applyScriptStep(step, s.panel, actions, effects);
    }
    if (!any) return;
    if (effects.resize) {
        if (s.offscreen) throw Error("resize: an offscreen run has a fixed size (--width, --height)");
        glfwSetWindowSize(s.window.window, int(effects.resize->width), int(effects.resize->height));
    }
    if (effects.tracer) setTracer(s, *effects.tracer, "chosen by the script");
    if (effects.sideBySide) setSideBySide(s, *effects.sideBySide);
    if (!effects.open.empty()) {
        const BuildStatus status = s.builder->status();
        std::printf("raypack: frame %u: worker %s when the load was requested\n", s.frameIndex, toString(status.phase));
        s.builder->requestLoad(effects.open, s.panel.bvh);  // the step itself was logged above
    }
    handleActions(s, actions, before);
    if (effects.wait) {
        s.builder->waitIdle();
        takeWorkerResults(s);
    }
    if (effects.scale) s.forcedScale = *effects.scale;
    input.heldSeconds += effects.input.heldSeconds;
    input.lookPixels += effects.input.lookPixels;
    if (!effects.screenshot.empty()) screenshot = effects.screenshot;
    if (!effects.windowScreenshot.empty()) windowShot = effects.windowScreenshot;
}

// The scene point under the cursor: the primary ray of that pixel of the image (at full
// resolution) through the CPU reference; nullopt over the background, the panel or no scene.
std::optional<PickHit> pickUnderCursor(Session& s, glm::dvec2 cursor) {
    if (!s.scene || !s.info.hasBvh) return std::nullopt;
    int windowW = 0, windowH = 0, fbW = 0, fbH = 0;
    glfwGetWindowSize(s.window.window, &windowW, &windowH);
    glfwGetFramebufferSize(s.window.window, &fbW, &fbH);
    const RenderSettings& settings = s.panel.settings;
    ShownImage image;
    image.origin = glm::vec2(s.imageOffsetX, 0.0f);
    image.size = glm::vec2(float(settings.width), float(settings.height));
    image.traced = glm::uvec2(settings.width, settings.height);
    const std::optional<glm::uvec2> pixel =
        imagePixelUnderCursor(cursor, glm::ivec2(windowW, windowH), glm::ivec2(fbW, fbH), image);
    if (!pixel) return std::nullopt;
    return pickPixel(*s.scene, hostBvh(s), settings.camera, settings.width, settings.height, pixel->x, pixel->y);
}

// The camera for this frame from the keys held, the mouse, the wheel, or the path being played.
void moveCamera(Session& s, FlyInput& input, double frameSeconds) {
    if (!s.scene) return;
    const std::array<double, kFlyKeyCount> held = s.keys.take(s.secondsSinceStart());
    const auto seconds = [&](FlyKey k) { return float(held[uint32_t(k)]); };
    input.heldSeconds +=
        glm::vec3(seconds(FlyKey::Right) - seconds(FlyKey::Left), seconds(FlyKey::Up) - seconds(FlyKey::Down),
                  seconds(FlyKey::Forward) - seconds(FlyKey::Back));
    input.lookPixels += s.lookPixels;
    s.lookPixels = glm::vec2(0.0f);
    if (!s.offscreen) {
        const ImGuiIO& io = ImGui::GetIO();
        if (!io.WantCaptureMouse) input.wheel += io.MouseWheel;
        GLFWwindow* w = s.window.window;
        input.fast =
            glfwGetKey(w, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS || glfwGetKey(w, GLFW_KEY_RIGHT_SHIFT) == GLFW_PRESS;
    }

    if (s.playing && !s.playbackOver) {
        const CameraPath& path = *s.playing;
        if (s.options.playFrames) {
            s.panel.settings.camera = path.keys[std::min<size_t>(s.playFrame, path.keys.size() - 1)].camera;
            s.playbackOver = ++s.playFrame >= path.keys.size();
        } else {
            if (s.playStart == Clock::time_point{}) s.playStart = Clock::now();  // the first frame with a scene
            const double t = std::chrono::duration<double>(Clock::now() - s.playStart).count();
            s.panel.settings.camera = cameraAt(path, t);
            s.playbackOver = t >= path.duration();
        }
        s.fly.setCamera(s.panel.settings.camera);
        if (s.playbackOver) std::printf("raypack: frame %u: camera path played to its end\n", s.frameIndex);
        return;
    }
    if (s.orbitMode) {
        OrbitInput orbit;
        orbit.orbitPixels = s.orbitPixels;
        orbit.panPixels = s.panPixels;
        orbit.wheel = input.wheel;
        orbit.viewportHeight = std::max(1u, s.panel.settings.height);
        if (orbit.wheel != 0.0f)
            if (std::optional<PickHit> hit = pickUnderCursor(s, s.lastCursor)) orbit.zoomTarget = hit->point;
        s.orbit.setCamera(s.panel.settings.camera);
        if (s.orbit.update(orbit)) s.panel.settings.camera = s.orbit.camera();
    } else {
        s.fly.setCamera(s.panel.settings.camera);
        if (s.fly.update(input, float(frameSeconds))) s.panel.settings.camera = s.fly.camera();
    }
    s.orbitPixels = s.panPixels = glm::vec2(0.0f);
    if (s.pivotPick) {
        if (std::optional<PickHit> hit = pickUnderCursor(s, *s.pivotPick)) {
            s.orbit.setCamera(s.panel.settings.camera);
            s.orbit.setPivot(hit->point);
        }
        s.pivotPick.reset();
    }
}

void handleKeys(Session& s, PanelActions& actions) {
    for (const KeyPress& press : s.pressed) {
        if (press.key == GLFW_KEY_F)
            actions.frameAll = true;
        else if (press.key == GLFW_KEY_F1)
            s.showHelp = !s.showHelp;
        else if (press.key == GLFW_KEY_F12)
            actions.screenshot = true;
        else if (press.key == GLFW_KEY_TAB)
            actions.toggleCameraMode = true;
        else if (press.key == GLFW_KEY_Q && (press.mods & GLFW_MOD_CONTROL))
            glfwSetWindowShouldClose(s.window.window, GLFW_TRUE);
        else if (press.key >= GLFW_KEY_1 && press.key <= GLFW_KEY_9) {
            const int n = press.key - GLFW_KEY_0;
            if (press.mods & GLFW_MOD_CONTROL)
                actions.saveBookmark = n;
            else
                actions.recallBookmark = n;
        }
    }
    s.pressed.clear();
}

void drawHelp(Session& s) {
    if (!s.showHelp) return;
    const ImGuiIO& io = ImGui::GetIO();
    ImGui::SetNextWindowPos(ImVec2(io.DisplaySize.x * 0.5f, io.DisplaySize.y * 0.5f), ImGuiCond_Always,
                            ImVec2(0.5f, 0.5f));
    ImGui::SetNextWindowBgAlpha(0.9f);
    if (!ImGui::Begin("Controls (F1 or ? closes)", &s.showHelp,
                      ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoCollapse)) {
        ImGui::End();
        return;
    }
    constexpr const char* kControls[][2] = {
        {"W / S", "fly forward / back"},
        {"A / D", "fly left / right"},
        {"Q / E", "fly down / up"},
        {"Shift", "fly faster (x4)"},
        {"mouse wheel (fly)", "flying speed (x1.2 a step)"},
        {"right drag", "look around"},
        {"F", "frame the whole scene"},
        {"1 .. 9", "recall a camera bookmark"},
        {"Ctrl+1 .. 9", "save a camera bookmark"},
        {"F12", "screenshot of the image shown (PNG + JSON sidecar)"},
        {"Tab", "switch between the fly and the orbit camera"},
        {"left drag (orbit)", "orbit the pivot"},
        {"middle drag (orbit)", "pan"},
        {"wheel (orbit)", "zoom toward the point under the cursor"},
        {"double-click (orbit)", "set the pivot on the point under the cursor"},
        {"F1 or ?", "this help"},
        {"Ctrl+Q", "quit"},
        {"drop a file", "open a scene (OBJ, PLY, glTF, GLB)"},
    };
    if (ImGui::BeginTable("controls", 2, ImGuiTableFlags_RowBg)) {
        for (const auto& row : kControls) {
            ImGui::TableNextRow();
            ImGui::TableNextColumn();
            ImGui::TextUnformatted(row[0]);
            ImGui::TableNextColumn();
            ImGui::TextUnformatted(row[1]);
        }
        ImGui::EndTable();
    }
    ImGui::TextDisabled("Moving: the image is traced at a lower resolution to keep the frame budget;");
    ImGui::TextDisabled("still: full resolution, then anti-aliasing samples, then no tracing at all.");
    ImGui::End();
}

void handleActions(Session& s, const PanelActions& a, const RenderSettings& before) {
    if (a.dismissError) s.info.error.clear();
    if (a.open && !s.panel.openPath.empty()) requestLoad(s, s.panel.openPath);
    if (a.rebuild) s.builder->requestRebuild(s.scene, s.panel.bvh, needsHostTree(s));
    if (a.frameAll && s.scene) {
        s.fly.frameAll();
        s.panel.settings.camera = s.fly.camera();
        s.orbit.frameAll();
    }
    if (a.toggleCameraMode && s.scene) {
        s.fly.setCamera(s.panel.settings.camera);
        s.orbit.setCamera(s.panel.settings.camera);
        s.orbitMode = !s.orbitMode;
        if (s.orbitMode) {
            // The pivot: the scene point at the image's centre, else (background) the orbit's own.
            const RenderSettings& st = s.panel.settings;
            std::optional<glm::vec3> pivot;
            if (std::optional<PickHit> hit =
                    pickPixel(*s.scene, hostBvh(s), st.camera, st.width, st.height, st.width / 2, st.height / 2))
                pivot = hit->point;
            switchToOrbit(s.fly, s.orbit, s.scene->bounds(), pivot);
        } else {
            switchToFly(s.orbit, s.fly);
        }
        s.panel.settings.camera = s.orbitMode ? s.orbit.camera() : s.fly.camera();
    }
    if (a.layoutChanged) {
        s.config.panel = s.panel.layout;
        saveConfig(s);
    }
    if (a.presentMode) setPresentMode(s.window, *a.presentMode);
    if (a.copyCameraArguments) {
        ImGui::SetClipboardText(s.info.cameraArguments.c_str());
        std::printf("%s\n", s.info.cameraArguments.c_str());
    }
    if (a.saveBookmark) saveBookmark(s, a.saveBookmark);
    if (a.recallBookmark) recallBookmark(s, a.recallBookmark);
    if (a.tracerChanged) setTracer(s, s.panel.tracer, "chosen in the panel");
    // The kernel radio buttons of the Tracer section pick among the Vulkan kernels.
    if (!isCpuTracer(s.panel.tracer) && s.panel.settings.kernel != kernelOf(s.panel.tracer))
        setTracer(s, vulkanTracerFor(s.panel.settings.kernel), "chosen in the panel");
    if (a.compare) {
        try {
            compareWithReference(s);
        } catch (const Error& e) {
            s.report(std::string("compare: ") + e.what());
        }
    }
    // A packet the device cannot run keeps the previous one.
    const uint32_t maxRays = s.context.info.maxWorkgroupInvocations;
    if (s.panel.settings.packet.rays() > maxRays) {
        s.report("packet " + std::to_string(s.panel.settings.packet.width) + "x" +
                 std::to_string(s.panel.settings.packet.height) + " has more rays than the device's " +
                 std::to_string(maxRays) + " invocations per workgroup");
        s.panel.settings.packet = before.packet;
    }
}

// What the image depends on; a change starts the frame loop over (reduced frames, then full,
// then refinement).
std::string viewKey(const Session& s) {
    RenderSettings settings = s.panel.settings;
    settings.pixelJitter = glm::vec2(0.0f);
    settings.collectCounters = false;
    nlohmann::json key = toJson(settings);
    key["tracer"] = cliName(s.panel.tracer);
    if (s.panel.sideBySide)
        key["side_by_side"] = {cliName(s.panel.sideBySideTracer), s.panel.sideBySidePacket.width,
                               s.panel.sideBySidePacket.height};
    key["tree"] = s.treeGeneration;
    return key.dump();
}

std::string describeSize(uint32_t width, uint32_t height) {
    return std::to_string(width) + "x" + std::to_string(height);
}

// Kernel times T_K of a traced frame into the panel's statistics (and the scripted run's medians).
void recordKernelTimes(Session& s, const FrameTimings& kernel, uint32_t width, uint32_t height,
                       const std::string& note) {
    LiveStatistics& st = s.info.stats;
    st.kernelTimesValid = true;
    st.kernelTimesNote = note;
    // Which path the Vulkan kernels read the tree's nodes through (NodeFetch), as render prints it.
    if (!isCpuTracer(s.panel.tracer) && s.tracer && s.tracer->hasScene())
        st.kernelTimesNote += std::string("\nnodes read through the ") + toString(s.tracer->nodeFetch()) + " buffer";
    st.primaryKernelSeconds = kernel.primarySeconds;
    st.shadowKernelSeconds = kernel.shadowSeconds;
    s.primaryKernelTimes.push_back(kernel.primarySeconds);
    s.shadowKernelTimes.push_back(kernel.shadowSeconds);
    st.primaryRays = uint64_t(width) * height;
    const double tracing = kernel.primarySeconds + kernel.shadowSeconds;
    st.nonTracingShare = st.frameSeconds > 0 ? std::max(0.0, 1.0 - tracing / st.frameSeconds) : 0.0;
}

// The 99th percentile of the heat map's count (primary + shadow ray) over a frame's pixels, for
// the heat maps' automatic full scale.
float heatPercentile(const Frame& frame, ViewMode view) {
    if (frame.counters.empty() || view == ViewMode::Shaded) return 0.0f;
    std::vector<uint32_t> counts(frame.counters.size());
    for (size_t i = 0; i < counts.size(); ++i) {
        const RayCounters& c = frame.counters[i];
        counts[i] = view == ViewMode::HeatTraversal ? c.primaryNodes + c.shadowNodes : c.primaryTests + c.shadowTests;
    }
    const size_t k = (counts.size() * 99) / 100;
    std::nth_element(counts.begin(), counts.begin() + k, counts.end());
    return float(counts[k]);
}

void takeCounters(Session& s, const Frame& frame, const std::string& source) {
    if (s.panel.settings.view != ViewMode::Shaded) {
        s.heatPercentile = heatPercentile(frame, s.panel.settings.view);
        s.heatPercentileView = s.panel.settings.view;
    }
    s.info.stats.counters = summarizeCounters(frame);
    s.info.stats.countersValid = true;
    s.countersTime = Clock::now();
    s.countersSource = source;
}

// The Vulkan kernels count N_TR / N_IT only in their statistics variant: a counting frame of its
// own, kept within budget: at most once a second, never twice in a row, at most 10% of the wall
// time, at the resolution whose predicted cost is at most 5% of a second, and only for a view
// the counters do not already describe.
void measureCounters(Session& s, const std::string& key) {
    s.lastFrameCounted = false;
    if (!s.panel.liveCounters || isCpuTracer(s.panel.tracer) || !s.tracer->hasScene()) return;
    const Clock::time_point now = Clock::now();
    if (key == s.countedViewKey || now - s.lastCounting < std::chrono::seconds(1)) return;
    if (s.countingSeconds > 0.1 * s.secondsSinceStart(now)) return;
    const FrameCostModel& cost = s.loop.cost();
    const uint32_t width = s.panel.settings.width, height = s.panel.settings.height;
    uint32_t scale = 1;
    // The statistics variant costs about twice a plain frame (measured on lavapipe and the H100).
    while (scale < 64 && cost.measured() &&
           2.0 * cost.secondsPerPixel() * double(scaledExtent(width, scale)) * scaledExtent(height, scale) > 0.05)
        scale *= 2;
    RenderSettings settings = s.panel.settings;
    settings.width = scaledExtent(width, scale);
    settings.height = scaledExtent(height, scale);
    settings.pixelJitter = glm::vec2(0.0f);
    settings.collectCounters = true;
    FrameRequest request;
    request.image = false;
    request.counters = true;
    try {
        const Clock::time_point start = Clock::now();
        const Frame frame = s.tracer->render(settings, request);
        s.countingSeconds += std::chrono::duration<double>(Clock::now() - start).count();
        takeCounters(s, frame, "counting frame " + describeSize(settings.width, settings.height));
        s.lastCounting = now;
        s.lastFrameCounted = true;
        s.countedViewKey = key;
    } catch (const Error& e) {
        s.report(e.what());
    }
}

void updateCountersNote(Session& s) {
    LiveStatistics& st = s.info.stats;
    if (!s.panel.liveCounters) {
        st.countersNote = st.countersValid ? "off; the numbers below are of an earlier frame" : "off";
        return;
    }
    if (!st.countersValid) {
        st.countersNote = isCpuTracer(s.panel.tracer) ? "from the next traced frame"
                                                      : "from the next counting frame (at most one a second)";
        return;
    }
    const double age = std::chrono::duration<double>(Clock::now() - s.countersTime).count();
    char text[160];
    std::snprintf(
        text, sizeof text, "from the %s, %.1f s ago%s", s.countersSource.c_str(), age,
        s.countedViewKey == s.tracedViewKey || isCpuTracer(s.panel.tracer) ? "" : " (the view changed since)");
    st.countersNote = text;
}

void updateTitle(Session& s) {
    if (s.offscreen) return;
    const Clock::time_point now = Clock::now();
    if (now - s.lastTitle < std::chrono::milliseconds(500)) return;
    s.lastTitle = now;
    const std::string scene = s.sceneSpec.empty() ? s.options.scene : fs::path(s.sceneSpec).filename().string();
    char title[512];
    std::snprintf(title, sizeof title, "raypack - %s - %s - %.1f fps", scene.c_str(), toString(s.panel.tracer),
                  s.smoothedFrameSeconds > 0 ? 1.0 / s.smoothedFrameSeconds : 0.0);
    glfwSetWindowTitle(s.window.window, title);
}

// Whether the frame of `plan` stays on the GPU (recorded into the window's command buffer): a
// plain full-resolution Vulkan frame on a GPU, not split with another tracer.
bool recordsOnGpu(const Session& s, const FramePlan& plan) {
    return !s.cpuDevice && !isCpuTracer(s.panel.tracer) && plan.scale == 1 && plan.kind != FrameKind::Refine &&
           !s.panel.sideBySide;
}

// Side by side: the same view traced by the second tracer, whose right half replaces the right
// half of `frame`; both tracers' kernel times go to the panel and the overlay.
void traceRightHalf(Session& s, const RenderSettings& traced, Frame& frame) {
    RenderSettings other = traced;
    other.packet = s.panel.sideBySidePacket;
    if (!isCpuTracer(s.panel.sideBySideTracer)) other.kernel = kernelOf(s.panel.sideBySideTracer);
    const Frame right = traceOnHost(s, s.panel.sideBySideTracer, other, FrameRequest{});
    const uint32_t half = frame.width / 2;
    for (uint32_t y = 0; y < frame.height; ++y)
        std::copy(right.rgba.begin() + size_t(y) * frame.width + half, right.rgba.begin() + size_t(y + 1) * frame.width,
                  frame.rgba.begin() + size_t(y) * frame.width + half);
    SideBySideTimes& t = s.info.sideBySideTimes;
    t.left = frame.timings.primarySeconds + frame.timings.shadowSeconds;
    t.right = right.timings.primarySeconds + right.timings.shadowSeconds;
    t.width = frame.width;
    t.height = frame.height;
}

// The names and kernel times of the two halves over the image, and the line between them.
void drawSideBySideLabels(const Session& s) {
    if (!s.panel.sideBySide || s.shown != ShownSource::Host) return;
    const ImGuiIO& io = ImGui::GetIO();
    const float scale = io.DisplayFramebufferScale.x > 0 ? io.DisplayFramebufferScale.x : 1.0f;
    const float left = s.imageOffsetX / scale;
    const float middle = left + float(s.panel.settings.width / 2) / scale;
    ImDrawList* draw = ImGui::GetForegroundDrawList();
    draw->AddLine(ImVec2(middle, 0), ImVec2(middle, io.DisplaySize.y), IM_COL32(255, 255, 255, 160));
    const SideBySideTimes& t = s.info.sideBySideTimes;
    const auto label = [&](TracerChoice tracer, PacketShape packet, double seconds) {
        char text[160];
        std::snprintf(text, sizeof text, "%s%s  T_K %.2f ms at %ux%u", toString(tracer),
                      tracesPackets(tracer)
                          ? (" " + std::to_string(packet.width) + "x" + std::to_string(packet.height)).c_str()
                          : "",
                      seconds * 1e3, t.width, t.height);
        return std::string(text);
    };
    const std::string a = label(s.panel.tracer, s.panel.settings.packet, t.left);
    const std::string b = label(s.panel.sideBySideTracer, s.panel.sideBySidePacket, t.right);
    // Each label is clipped to its own half, so a narrow image does not run one into the other.
    const float right = left + float(s.panel.settings.width) / scale;
    const auto drawLabel = [&](float x0, float x1, const std::string& text) {
        draw->PushClipRect(ImVec2(x0, 0), ImVec2(x1 - 2, 24), true);
        draw->AddRectFilled(ImVec2(x0 + 4, 4), ImVec2(x0 + 8 + ImGui::CalcTextSize(text.c_str()).x, 22),
                            IM_COL32(0, 0, 0, 160));
        draw->AddText(ImVec2(x0 + 6, 5), IM_COL32(255, 255, 255, 255), text.c_str());
        draw->PopClipRect();
    };
    drawLabel(left, middle, a);
    drawLabel(middle, right, b);
}

// Traces what `plan` asks for into what is shown; returns the tracing seconds.
double traceFrame(Session& s, const FramePlan& plan, const FrameTarget* target) {
    RenderSettings& settings = s.panel.settings;
    const uint32_t width = settings.width, height = settings.height;
    const bool gpuDevicePath = recordsOnGpu(s, plan) && target;
    if (gpuDevicePath) {
        // On a GPU the plain frame stays on the device: recorded into the window's command buffer.
        GpuRecordOptions recordOptions;
        recordOptions.bgra = target->bgra;
        s.tracer->recordFrame(target->cmd, settings, recordOptions);
        s.shown = ShownSource::TracerOutput;
        double seconds = 0.0;
        if (std::optional<FrameTimings> kernel = s.tracer->lastKernelTimes()) {
            recordKernelTimes(s, *kernel, width, height, "T_K: GPU timestamps of a recent frame");
            seconds = kernel->primarySeconds + kernel->shadowSeconds;
        }
        return seconds;
    }
    RenderSettings traced = settings;
    traced.width = scaledExtent(width, plan.scale);
    traced.height = scaledExtent(height, plan.scale);
    traced.pixelJitter = plan.jitter;
    traced.collectCounters = false;
    FrameRequest request;
    // Free on the CPU; the heat maps' automatic scale needs them too.
    request.counters = isCpuTracer(s.panel.tracer) && (s.panel.liveCounters || settings.view != ViewMode::Shaded);
    const Clock::time_point start = Clock::now();
    Frame frame = traceOnHost(s, s.panel.tracer, traced, request);
    if (s.panel.sideBySide) traceRightHalf(s, traced, frame);  // the budget counts both tracers
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    recordKernelTimes(s, frame.timings, traced.width, traced.height,
                      std::string("T_K: ") +
                          (isCpuTracer(s.panel.tracer) ? "host clock"
                           : s.cpuDevice               ? "host clock (CPU device)"
                                                       : "GPU timestamps") +
                          ", frame of " + describeSize(traced.width, traced.height));
    if (request.counters) takeCounters(s, frame, "frame shown (" + describeSize(traced.width, traced.height) + ")");
    Image image{frame.width, frame.height, frame.rgba};
    switch (plan.kind) {
    case FrameKind::Moving:
        s.shownHost = scaleImage(image, width, height,
                                 settings.view == ViewMode::Shaded ? ScaleFilter::Bilinear : ScaleFilter::Nearest);
        break;
    case FrameKind::Full: s.shownHost = std::move(image); break;
    case FrameKind::Refine:
        if (plan.sampleIndex == 0) s.accumulator.reset(width, height);
        s.accumulator.add(image.rgba);
        s.shownHost = Image{width, height, s.accumulator.resolve()};
        break;
    case FrameKind::Idle: break;
    }
    s.shown = ShownSource::Host;
    return seconds;
}

// Copies what is shown into the acquired swapchain image.
void presentShown(Session& s, const FrameTarget& target) {
    const RenderSettings& settings = s.panel.settings;
    const Image* compare = s.panel.showing == Showing::Reference    ? &s.referenceImage
                           : s.panel.showing == Showing::Difference ? &s.differenceImage
                                                                    : nullptr;
    if (compare && (compare->width != settings.width || compare->height != settings.height)) {
        s.panel.showing = Showing::Traced;  // the window changed size since the comparison
        compare = nullptr;
    }
    const Image* host = compare ? compare : s.shown == ShownSource::Host ? &s.shownHost : nullptr;
    const ImageRegion region{uint32_t(s.imageOffsetX), settings.width, settings.height, settings.background};
    // The window can shrink between the frame's trace and its presentation (a resize while moving):
    // an image that no longer fits the acquired swapchain image is not shown; the next frame traces
    // at the new size.
    const bool fits = region.x + region.width <= target.extent.width && region.height <= target.extent.height;
    if (!fits) {
        clearImage(s.window, target, settings.background.x, settings.background.y, settings.background.z);
    } else if (host && host->width == region.width && host->height == region.height) {
        const VkDeviceSize bytes = VkDeviceSize(host->width) * host->height * 4;
        ensureHostBuffer(s.context, s.shownImage, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, "image shown");
        copyTexels(static_cast<uint32_t*>(s.shownImage.mapped), host->rgba.data(), host->rgba.size(), target.bgra);
        copyImage(s.window, target, s.shownImage.buffer, region);
    } else if (s.shown == ShownSource::TracerOutput && !compare &&
               s.tracer->outputBytes() == VkDeviceSize(region.width) * region.height * 4) {
        copyImage(s.window, target, s.tracer->outputBuffer(), region);
    } else {
        clearImage(s.window, target, settings.background.x, settings.background.y, settings.background.z);
    }
}

struct FrameResult {
    bool traced = false;
    bool presented = false;
    FrameKind kind = FrameKind::Idle;
};

// After a traced frame: the cost model, the view on screen, the panel's status.
void noteTraced(Session& s, const FramePlan& plan, const std::string& key, double traceSeconds, double frameSeconds,
                FrameResult& result) {
    const RenderSettings& settings = s.panel.settings;
    s.loop.traced(plan, uint64_t(scaledExtent(settings.width, plan.scale)) * scaledExtent(settings.height, plan.scale),
                  traceSeconds, frameSeconds);
    s.tracedViewKey = key;
    result.traced = true;
    result.kind = plan.kind;
    FrameLoopStatus& st = s.info.frameLoop;
    st.lastKind = plan.kind;
    st.scale = plan.scale;
    st.samplesShown = plan.kind == FrameKind::Refine ? s.loop.samplesDone() : 0;
    ++st.framesTraced;
}

// --offscreen: a frame that stays on the GPU is recorded into the offscreen command buffer and
// waited for (what presenting is in a window); a frame traced on the host is done already.
FrameResult finishOffscreenFrame(Session& s, const FramePlan& plan, const std::string& key, bool traced,
                                 double traceSeconds, Clock::time_point frameStart, const std::string& screenshotPath) {
    FrameResult result;
    if (plan.kind == FrameKind::Idle) {
        if (!screenshotPath.empty()) saveScreenshot(s, screenshotPath);
        return result;
    }
    if (!traced) {
        try {
            vk::submitAndWait(s.context, s.offscreenPool, [&](VkCommandBuffer cmd) {
                FrameTarget target;
                target.cmd = cmd;
                target.extent = {s.panel.settings.width, s.panel.settings.height};
                traceSeconds = traceFrame(s, plan, &target);
            });
            traced = true;
        } catch (const Error& e) {
            s.report(e.what());
            s.loop.invalidate();
        }
    }
    result.presented = true;
    const double frameSeconds = std::chrono::duration<double>(Clock::now() - frameStart).count();
    if (traced) noteTraced(s, plan, key, traceSeconds, frameSeconds, result);
    ++s.info.frameLoop.framesPresented;
    if (!screenshotPath.empty()) saveScreenshot(s, screenshotPath);
    if (traced) measureCounters(s, key);
    s.smoothedFrameSeconds =
        s.smoothedFrameSeconds == 0.0 ? frameSeconds : 0.9 * s.smoothedFrameSeconds + 0.1 * frameSeconds;
    s.info.stats.frameSeconds = s.smoothedFrameSeconds;
    s.frameTimes.push_back(frameSeconds);
    return result;
}

FrameResult drawFrame(Session& s, const std::string& screenshotPath, const std::string& windowShotPath,
                      FlyInput scriptedInput) {
    FrameResult result;
    const RenderSettings before = s.panel.settings;
    const Clock::time_point frameStart = Clock::now();
    const double seconds = std::chrono::duration<double>(frameStart - s.lastFrame).count();
    s.lastFrame = frameStart;

    // The window's size decides the traced size; a minimised window traces nothing.
    int fbWidth = int(s.options.width), fbHeight = int(s.options.height);
    if (!s.offscreen) glfwGetFramebufferSize(s.window.window, &fbWidth, &fbHeight);
    if (fbWidth <= 0 || fbHeight <= 0) return result;

    if (!s.offscreen) {
        ImGui_ImplVulkan_NewFrame();
        ImGui_ImplGlfw_NewFrame();
        ImGui::NewFrame();
    }
    moveCamera(s, scriptedInput, seconds);
    s.info.build = s.builder->status();
    s.info.cameraArguments = cameraCliArguments(s.panel.settings.camera);
    s.info.flySpeed = s.fly.speed();
    s.info.orbitCamera = s.orbitMode;
    s.info.presentMode = s.window.swapchain.presentMode;
    s.info.presentModes = s.window.presentModes;
    s.info.bookmarkSet.assign(kBookmarkSlots, false);
    if (s.bookmarks)
        for (int n = 1; n <= kBookmarkSlots; ++n) s.info.bookmarkSet[n - 1] = s.bookmarks->slot(n).has_value();
    updateCountersNote(s);
    s.info.frameLoop.samplesWanted = s.panel.frameLoop.samples;
    s.info.frameLoop.costMeasured = s.loop.cost().measured();
    s.info.frameLoop.secondsPerMegapixel = s.loop.cost().secondsPerPixel() * 1e6;
    s.info.frameLoop.fixedSeconds = s.loop.cost().fixedSeconds();

    PanelActions actions;
    if (!s.offscreen) {
        if (!s.options.hidePanel) actions = drawPanel(s.panel, s.info);
        drawHelp(s);
        drawSideBySideLabels(s);
        handleKeys(s, actions);
        ImGui::Render();
    }
    handleActions(s, actions, before);
    // The panel's Screenshot button and F12: a fresh name in the current folder.
    const bool userScreenshot = actions.screenshot;

    // The image fills the part of the window the panel leaves free; when that part would be
    // narrower than the panel itself (a small window), the panel lies over the image instead.
    RenderSettings& settings = s.panel.settings;
    // The heat maps' automatic full scale: the newest counted frame's 99th percentile, in two
    // significant digits, changed only when it moves by more than 10% (no retrace for noise).
    if (s.panel.heatAuto && settings.view != ViewMode::Shaded && s.heatPercentileView == settings.view &&
        s.heatPercentile > 0.0f) {
        const float magnitude = std::pow(10.0f, std::floor(std::log10(s.heatPercentile)) - 1.0f);
        const float wanted = std::max(1.0f, std::round(s.heatPercentile / magnitude) * magnitude);
        if (settings.heatFullScale <= 0.0f || std::abs(wanted - settings.heatFullScale) > 0.1f * settings.heatFullScale)
            settings.heatFullScale = wanted;
    }
    const float covered = s.options.hidePanel ? 0.0f : s.panel.coveredWidthPixels;
    s.imageOffsetX = covered > 0.0f && float(fbWidth) - covered >= covered ? std::floor(covered) : 0.0f;
    settings.width = uint32_t(fbWidth) - uint32_t(s.imageOffsetX);
    settings.height = uint32_t(fbHeight);
    const std::string key = viewKey(s);
    const bool changed = key != s.tracedViewKey;
    FramePlan plan;
    if (s.tracer->hasScene() && s.panel.showing == Showing::Traced)
        plan = s.loop.plan(s.panel.frameLoop, settings.width, settings.height, changed, s.forcedScale,
                           settings.view == ViewMode::Shaded);
    s.forcedScale.reset();
    const bool nothingNew = plan.kind == FrameKind::Idle;
    const bool wantShot = !screenshotPath.empty() || userScreenshot;
    const bool present =
        !nothingNew || (!s.offscreen && (s.uiFramesPending > 0 || !windowShotPath.empty() ||
                                         s.shown == ShownSource::Nothing || s.info.build.phase != BuildPhase::Idle));
    if (!present) {
        if (wantShot) saveScreenshot(s, screenshotPath.empty() ? nextScreenshotName() : screenshotPath);
        return result;
    }
    s.uiFramesPending = std::max(0, s.uiFramesPending - 1);

    // Frames traced on the host come first, before the swapchain image is acquired.
    double traceSeconds = 0.0;
    bool traced = false;
    const bool recordOnGpu = recordsOnGpu(s, plan);
    if (!nothingNew && !recordOnGpu) {
        try {
            traceSeconds = traceFrame(s, plan, nullptr);
            traced = true;
        } catch (const Error& e) {
            s.report(e.what());
            s.loop.invalidate();
        }
    }
    if (s.offscreen) return finishOffscreenFrame(s, plan, key, traced, traceSeconds, frameStart, screenshotPath);
    std::optional<FrameTarget> target = beginFrame(s.context, s.window);
    if (!target) return result;  // out of date: drawn again next time
    if (!nothingNew && recordOnGpu) {
        try {
            traceSeconds = traceFrame(s, plan, &*target);
            traced = true;
        } catch (const Error& e) {
            s.report(e.what());
            s.loop.invalidate();
        }
    }
    presentShown(s, *target);
    finishFrame(s.context, s.window, *target, ImGui::GetDrawData(), !windowShotPath.empty());
    result.presented = true;
    const double frameSeconds = std::chrono::duration<double>(Clock::now() - frameStart).count();
    if (traced) noteTraced(s, plan, key, traceSeconds, frameSeconds, result);
    ++s.info.frameLoop.framesPresented;

    if (wantShot) saveScreenshot(s, screenshotPath.empty() ? nextScreenshotName() : screenshotPath);
    if (!windowShotPath.empty()) {
        uint32_t w = 0, h = 0;
        std::vector<uint32_t> texels = readWindowImage(s.context, s.window, w, h);
        writePng(windowShotPath, w, h, texels);
        std::printf("raypack: window screenshot %s (%ux%u)\n", windowShotPath.c_str(), w, h);
    }
    if (traced) measureCounters(s, key);
    s.smoothedFrameSeconds =
        s.smoothedFrameSeconds == 0.0 ? frameSeconds : 0.9 * s.smoothedFrameSeconds + 0.1 * frameSeconds;
    s.info.stats.frameSeconds = s.smoothedFrameSeconds;
    s.frameTimes.push_back(frameSeconds);
    updateTitle(s);
    return result;
}

nlohmann::json summaryJson(const Session& s) {
    nlohmann::json summary = s.run.summary();
    summary["device"] = s.info.device;
    summary["tracer"] = cliName(s.panel.tracer);
    summary["scene"] = s.sceneSpec;
    summary["window"] = {s.panel.settings.width, s.panel.settings.height};
    summary["frame_budget_ms"] = s.panel.frameLoop.frameBudgetMs;
    summary["samples_wanted"] = s.panel.frameLoop.samples;
    summary["trees"] = s.treesTaken;
    return summary;
}

// After a frame: the run's record (ui/run_statistics.h) and the camera path being recorded.
void recordFrame(Session& s, const FrameResult& result, double startSeconds, double idleWallSeconds,
                 double idleCpuSeconds) {
    FrameOutcome frame;
    frame.startSeconds = startSeconds;
    frame.endSeconds = s.secondsSinceStart();
    frame.traced = result.traced;
    frame.presented = result.presented;
    frame.kind = result.kind;
    frame.scale = s.info.frameLoop.scale;
    frame.samplesShown = s.info.frameLoop.samplesShown;
    frame.samplesWanted = s.panel.frameLoop.samples;
    frame.firstInputSeconds = s.firstInputSeconds;
    frame.idleWallSeconds = idleWallSeconds;
    frame.idleCpuSeconds = idleCpuSeconds;
    s.run.record(frame);
    if (result.presented) s.firstInputSeconds = -1.0;
    if (!s.options.recordPath.empty() && s.scene)
        s.recording.keys.push_back({frame.endSeconds, s.panel.settings.camera});
}

// Where the viewer starts: the tracer by device, the camera path to play.
void chooseStartTracer(Session& s) {
    s.info.tracers.assign(std::begin(kAllTracerChoices), std::end(kAllTracerChoices));
    if (s.options.tracer) {
        setTracer(s, *s.options.tracer, "chosen by --tracer");
    } else if (s.options.kernelGiven) {
        // A kernel named on the command line is a Vulkan kernel (packet, single or hybrid), so its
        // tracer draws, on a CPU device too.
        setTracer(s, vulkanTracerFor(s.options.settings.kernel), "chosen by --kernel");
    } else if (s.cpuDevice) {
        // Measured on a 2-core EPYC with lavapipe (docs/viewer.md): the CPU packet tracer traces
        // the same view about 3x faster than the CPU reference and far faster than the Vulkan
        // kernels on lavapipe.
        setTracer(s, TracerChoice::CpuPacket,
                  std::string("Default on a CPU device: the CPU packet tracer (") + toString(cpuSimdSelected()) +
                      "), the fastest tracer measured on CPU devices (docs/viewer.md).");
    } else {
        setTracer(s, vulkanTracerFor(s.options.settings.kernel), "Default on a GPU: the Vulkan packet kernel.");
    }
}

}  // namespace

int runViewer(const ViewerOptions& options) {
    std::optional<CameraPath> path;
    if (!options.playPath.empty()) path = readCameraPath(options.playPath);  // before any window opens
    if (!options.offscreen) initWindowSystem();
    Session s(options);
    s.offscreen = options.offscreen;
    vk::VulkanContextOptions contextOptions;
    contextOptions.device = options.device;
    contextOptions.validation = options.validation;
    if (!s.offscreen) addWindowRequirements(contextOptions);
    s.context = vk::createVulkanContext(contextOptions);
    s.cpuDevice = s.context.info.type == VK_PHYSICAL_DEVICE_TYPE_CPU;
    if (s.offscreen) {
        s.offscreenPool = vk::createCommandPool(s.context, VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
                                                "vkCreateCommandPool (offscreen)");
    } else {
        ViewerWindowOptions windowOptions;
        windowOptions.width = options.width;
        windowOptions.height = options.height;
        windowOptions.presentMode = options.presentMode;
        s.window = createViewerWindow(s.context, windowOptions);
        installCallbacks(s);
    }
    s.tracer = std::make_unique<GpuTracer>(s.context);
    // On lavapipe the timestamps of the window's frames do not bracket the dispatches (measured: 17
    // us for a 57 ms pass), so there GpuTracer::render times each pass on the host.
    s.tracer->setHostTimedPasses(s.cpuDevice);
    // A device builder (gpu-lbvh, gpu-ploc) runs on the viewer's own device: on a GPU the worker
    // builds into buffers the tracer adopts at a frame boundary, while the previous tree is still
    // drawn; on a CPU device (one queue, whose submissions run one at a time on the CPU) through a
    // device of its own, so that the frames do not wait behind the build (docs/viewer.md).
    // RAYPACK_DEVICE_BUILD=shared|own chooses either, for measuring them against each other.
    DeviceBuilds deviceBuilds = s.cpuDevice ? DeviceBuilds::OwnDevice : DeviceBuilds::SharedDevice;
    if (const char* mode = std::getenv("RAYPACK_DEVICE_BUILD")) {
        if (std::string(mode) == "shared")
            deviceBuilds = DeviceBuilds::SharedDevice;
        else if (std::string(mode) == "own")
            deviceBuilds = DeviceBuilds::OwnDevice;
        else
            throw Error(std::string("RAYPACK_DEVICE_BUILD: '") + mode + "' is neither shared nor own");
    }
    s.builder = std::make_unique<AsyncSceneBuilder>(
        [](const std::string& spec, LoadProgress& progress) { return openScene(spec, &progress); }, &s.context,
        deviceBuilds);
    // A replaced tree is freed on the worker, not between two frames.
    s.tracer->setRetiredTreeSink([&s](std::unique_ptr<GpuTree> tree) {
        if (s.builder) s.builder->retire(std::move(tree));
    });

    s.panel.settings = options.settings;
    s.panel.bvh = options.bvh;
    s.panel.liveCounters = options.liveCounters;
    s.panel.openPath = options.scene;
    s.panel.frameLoop = options.frameLoop;
    s.panel.heatAuto = options.settings.heatFullScale <= 0.0f;
    s.info.device = describe(s.context.info);
    s.info.maxPacketRays = s.context.info.maxWorkgroupInvocations;
    {
        ViewerConfigLoad loaded = loadViewerConfig(s.configFile);
        s.config = std::move(loaded.config);
        if (!loaded.warning.empty()) s.report(loaded.warning);
        s.panel.layout = s.config.panel;
        s.config.recent.pruneMissing();
        s.info.recentFiles = s.config.recent.entries();
    }
    chooseStartTracer(s);
    if (options.sideBySide) setSideBySide(s, *options.sideBySide);
    if (options.packetGiven) s.panel.settings.packet = options.settings.packet;  // for the tracer drawing
    s.playing = std::move(path);
    std::printf("raypack: device %s; tracer %s\n", s.info.device.c_str(), cliName(s.panel.tracer));
    requestLoad(s, options.scene);

    if (s.offscreen) {
        // No window to show progress in: the first frame waits for the scene.
        s.builder->waitIdle();
        takeWorkerResults(s);
        if (!s.scene) {
            std::fprintf(stderr, "raypack: %s\n", s.info.error.c_str());
            return kViewerExitError;
        }
    }
    const bool scripted = options.frames > 0;
    bool idle = false;
    const auto running = [&] {
        const bool done = idle && s.scene && (!s.playing || s.playbackOver);  // played and converged
        if (options.exitWhenConverged && done) return false;
        if (scripted) return s.frameIndex < options.frames && (s.offscreen || !glfwWindowShouldClose(s.window.window));
        if (!s.offscreen) return !glfwWindowShouldClose(s.window.window);
        return !done;  // offscreen without --frames: until the path is played and the image converged
    };
    while (running()) {
        const Clock::time_point iterationStart = Clock::now();
        const double cpuStart = processCpuSeconds();
        if (s.offscreen) {
            if (idle) std::this_thread::sleep_for(std::chrono::milliseconds(1));
        } else if (idle) {
            // Nothing to trace: sleep until an event (or, while the worker loads or builds, until
            // its progress is worth showing). A scripted run counts the frame and goes on.
            const bool working = s.builder->status().phase != BuildPhase::Idle;
            glfwWaitEventsTimeout(scripted ? 0.01 : working ? 0.05 : 0.5);
        } else {
            glfwPollEvents();
        }
        for (const std::string& file : s.droppedFiles) requestLoad(s, file);
        s.droppedFiles.clear();
        std::string screenshot, windowShot;
        FlyInput scriptedInput;
        if (scripted) {
            applyScriptSteps(s, screenshot, windowShot, scriptedInput);
            if (s.frameIndex + 1 == options.frames) {
                // The last frame shows the last request: wait for the worker once, here only.
                s.builder->waitIdle();
                if (screenshot.empty()) screenshot = options.screenshot;
                if (windowShot.empty()) windowShot = options.windowScreenshot;
            }
        }
        takeWorkerResults(s);
        const bool building = s.builder->status().phase != BuildPhase::Idle;
        const double startSeconds = s.secondsSinceStart(iterationStart);
        const FrameResult result = drawFrame(s, screenshot, windowShot, scriptedInput);
        if (building) {
            ++s.framesWhileBuilding;
            s.longestFrameWhileBuilding = std::max(
                s.longestFrameWhileBuilding, std::chrono::duration<double>(Clock::now() - iterationStart).count());
        }
        idle = !result.presented;
        const double idleWall = idle ? std::chrono::duration<double>(Clock::now() - iterationStart).count() : 0.0;
        const double idleCpu = idle ? processCpuSeconds() - cpuStart : 0.0;
        recordFrame(s, result, startSeconds, idleWall, idleCpu);
        ++s.frameIndex;
    }
    vk::deviceWaitIdle(s.context);

    if (!options.recordPath.empty()) {
        CameraPath recorded = s.recording;
        recorded.scene = s.sceneSpec;
        const double t0 = recorded.keys.empty() ? 0.0 : recorded.keys.front().seconds;
        for (CameraKey& k : recorded.keys) k.seconds -= t0;
        writeCameraPath(options.recordPath, recorded);
        std::printf("raypack: camera path of %zu frames (%.2f s) in %s\n", recorded.keys.size(), recorded.duration(),
                    options.recordPath.c_str());
    }
    if (!options.summaryPath.empty()) {
        writeJsonFile(options.summaryPath, summaryJson(s));
        std::printf("raypack: summary in %s\n", options.summaryPath.c_str());
    }
    if (options.validation) {
        const uint32_t messages = vk::validationMessageCount(s.context);
        std::printf("raypack: %u validation messages\n", messages);
        if (s.context.validation) {
            std::lock_guard lock(s.context.validation->mutex);
            for (const std::string& m : s.context.validation->messages) std::printf("  %s\n", m.c_str());
        }
        if (messages) return kViewerExitValidation;
    }
    if (scripted) {
        std::printf("raypack: %u frames (%" PRIu64 " traced), swapchain re-created %u times\n", s.frameIndex,
                    s.info.frameLoop.framesTraced, s.window.swapchainRecreations);
        std::printf(
            "raypack: second half of the run, medians: frame %.2f ms, T_K primary %.2f ms, "
            "T_K shadow %.2f ms\n",
            steadyMedian(s.frameTimes) * 1e3, steadyMedian(s.primaryKernelTimes) * 1e3,
            steadyMedian(s.shadowKernelTimes) * 1e3);
        if (s.firstLoadFailed) {
            std::fprintf(stderr, "raypack: the scene %s could not be loaded\n", options.scene.c_str());
            return kViewerExitError;
        }
    }
    return kViewerExitOk;
}

}  // namespace raypack::ui
