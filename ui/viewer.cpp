#include "ui/viewer.h"

#include "renderer/async_build.h"
#include "renderer/cpu_tracer.h"
#include "renderer/error.h"
#include "renderer/gpu_tracer.h"
#include "renderer/image.h"
#include "renderer/settings_json.h"
#include "renderer/vk/context.h"
#include "scenes/load.h"
#include "ui/bookmarks.h"
#include "ui/fly_camera.h"
#include "ui/panel.h"
#include "ui/screenshot.h"
#include "ui/viewer_window.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_vulkan.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>

namespace raypack::ui {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

PacketShape parseShape(const std::string& text, const std::string& what) {
    unsigned w = 0, h = 0;
    char x = 0, extra = 0;
    if (std::sscanf(text.c_str(), "%u%c%u%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X') || !w || !h)
        throw Error(what + ": \"" + text + "\" is not WIDTHxHEIGHT");
    return {w, h};
}

uint32_t parseCount(const std::string& text, const std::string& what) {
    try {
        size_t used = 0;
        const unsigned long value = std::stoul(text, &used);
        if (used == text.size() && value > 0 && value <= 0xFFFFFFFFul) return uint32_t(value);
    } catch (const std::exception&) {
    }
    throw Error(what + ": \"" + text + "\" is not a positive integer");
}

// Swaps R and B of every texel: Frame::rgba is RGBA8, a B8G8R8A8 swapchain wants BGRA8.
void swapRedBlue(std::vector<uint32_t>& texels) {
    for (uint32_t& t : texels) t = (t & 0xFF00FF00u) | ((t & 0xFFu) << 16) | ((t >> 16) & 0xFFu);
}

// A scene spec as the sidecar and the bookmarks keep it: an existing file becomes absolute, so
// `raypack-cli render --from` works from any folder; a generator spec stays as it is.
std::string canonicalSpec(const std::string& spec) {
    std::error_code error;
    if (fs::is_regular_file(spec, error)) return fs::absolute(spec).lexically_normal().string();
    return spec;
}

// Median of the second half of `values` (the steady state after start-up), 0 when empty.
double steadyMedian(std::vector<double> values) {
    values.erase(values.begin(), values.begin() + values.size() / 2);
    if (values.empty()) return 0.0;
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
}

std::string bookmarksFile() { return (fs::path(configDirectory()) / "bookmarks.json").string(); }

// Everything the frame loop passes between the modules. Destroyed in the reverse order of use:
// the worker first (it may still be building), then the tracer, the window and the context.
struct Session {
    const ViewerOptions& options;
    vk::VulkanContext context;
    ViewerWindow window;
    std::unique_ptr<GpuTracer> tracer;
    std::unique_ptr<AsyncSceneBuilder> builder;

    std::shared_ptr<const Scene> scene;
    std::shared_ptr<const Bvh> bvh;
    std::string sceneSpec;
    bool firstScene = true;
    double uploadSeconds = 0.0;

    PanelState panel;
    PanelInfo info;
    FlyCamera fly;
    std::optional<BookmarkStore> bookmarks;
    std::vector<std::string> droppedFiles;
    glm::dvec2 lastCursor{0.0};
    bool looking = false;

    // The compare view: images shown instead of the traced one.
    Image referenceImage, differenceImage;
    vk::Buffer shownImage;  // host-visible copy of the image shown, in the swapchain's byte order
    vk::Buffer screenshotReadback;

    Clock::time_point lastFrame = Clock::now();
    Clock::time_point lastCounting = Clock::now();
    double smoothedFrameSeconds = 0.0;
    uint32_t frameIndex = 0;
    // Every frame's wall time and kernel times, for the summary of a scripted run.
    std::vector<double> frameTimes, primaryKernelTimes, shadowKernelTimes;

    explicit Session(const ViewerOptions& o) : options(o) {}
    ~Session() {
        builder.reset();
        if (context.device) vkDeviceWaitIdle(context.device);
        tracer.reset();
        vk::destroyBuffer(context, shownImage);
        vk::destroyBuffer(context, screenshotReadback);
        destroyViewerWindow(context, window);
        destroyVulkanContext(context);
        glfwTerminate();
    }

    void report(const std::string& message) {
        info.error = message;
        if (options.frames) std::fprintf(stderr, "raypack: %s\n", message.c_str());
    }
};

void onDrop(GLFWwindow* window, int count, const char** paths) {
    auto* session = static_cast<Session*>(glfwGetWindowUserPointer(window));
    for (int i = 0; i < count; ++i) session->droppedFiles.emplace_back(paths[i]);
}

void requestLoad(Session& s, const std::string& spec) {
    s.builder->requestLoad(spec, s.panel.bvh);
    if (s.options.frames) std::printf("raypack: frame %u: open %s\n", s.frameIndex, spec.c_str());
}

// At the frame boundary: swap in what the worker finished (upload, then trace it from this frame
// on), and show what failed.
void takeWorkerResults(Session& s) {
    if (std::optional<BuildFailure> failure = s.builder->takeFailure())
        s.report((failure->scenePath.empty() ? std::string("rebuild: ") : failure->scenePath + ": ") +
                 failure->message);
    std::optional<SceneBuild> build = s.builder->takeFinished();
    if (!build) return;
    try {
        s.uploadSeconds = s.tracer->upload(*build->scene, *build->bvh);
    } catch (const Error& e) {
        s.report(e.what());
        return;
    }
    const bool newScene = build->scene != s.scene;
    s.scene = build->scene;
    s.bvh = build->bvh;
    s.info.bvhStats = s.bvh->stats;
    s.info.builtWith = s.bvh->options;
    s.info.hasBvh = true;
    s.info.compare.valid = false;
    s.panel.showing = Showing::Traced;
    if (!newScene) return;
    s.sceneSpec = canonicalSpec(build->scenePath);
    s.info.scene = s.sceneSpec;
    s.info.triangles = s.scene->triangleCount();
    s.info.loadSeconds = build->loadSeconds;
    const Aabb bounds = s.scene->bounds();
    // The start camera is the CLI's default framing, so the viewer and raypack-cli render agree.
    const Camera camera = (s.firstScene && s.options.cameraGiven) ? s.options.settings.camera : frameScene(bounds);
    s.firstScene = false;
    s.panel.settings.camera = camera;
    s.fly.reset(camera, bounds);
    try {
        s.bookmarks.emplace(bookmarksFile(), s.sceneSpec);
    } catch (const Error& e) {
        s.bookmarks.reset();
        s.report(std::string("bookmarks: ") + e.what());
    }
}

void applyScriptStep(Session& s, const ScriptStep& step) {
    RenderSettings& settings = s.panel.settings;
    std::printf("raypack: frame %u: %s %s\n", s.frameIndex, step.action.c_str(), step.value.c_str());
    if (step.action == "resize") {
        const PacketShape size = parseShape(step.value, "resize");
        glfwSetWindowSize(s.window.window, int(size.width), int(size.height));
    } else if (step.action == "packet") {
        settings.packet = parseShape(step.value, "packet");
    } else if (step.action == "leaf-size" || step.action == "builder") {
        if (step.action == "leaf-size") s.panel.bvh.leafSize = parseCount(step.value, "leaf-size");
        else s.panel.bvh.builder = parseBvhBuilder(step.value);
        s.builder->requestRebuild(s.scene, s.panel.bvh);
    } else if (step.action == "shadows") {
        if (step.value != "on" && step.value != "off") throw Error("shadows: \"" + step.value + "\" is not on or off");
        settings.shadows = step.value == "on";
    } else if (step.action == "kernel") {
        const std::optional<KernelKind> kind = parseKernelKind(step.value);
        if (!kind) throw Error("kernel: \"" + step.value + "\" is not packet or single");
        settings.kernel = *kind;
    } else if (step.action == "view") {
        const std::optional<ViewMode> mode = parseViewMode(step.value);
        if (!mode) throw Error("view: \"" + step.value + "\" is not shaded, nodes or tests");
        settings.view = *mode;
    } else if (step.action == "open") {
        const BuildStatus status = s.builder->status();
        std::printf("raypack: frame %u: worker %s when the load was requested\n", s.frameIndex,
                    toString(status.phase));
        requestLoad(s, step.value);
    } else if (step.action == "wait") {
        s.builder->waitIdle();
        takeWorkerResults(s);
    } else {
        throw Error("script: unknown action \"" + step.action + "\"");
    }
}

FlyInput readFlyInput(Session& s) {
    FlyInput input;
    const ImGuiIO& io = ImGui::GetIO();
    GLFWwindow* w = s.window.window;
    if (!io.WantCaptureKeyboard) {
        input.forward = glfwGetKey(w, GLFW_KEY_W) == GLFW_PRESS;
        input.back = glfwGetKey(w, GLFW_KEY_S) == GLFW_PRESS;
        input.left = glfwGetKey(w, GLFW_KEY_A) == GLFW_PRESS;
        input.right = glfwGetKey(w, GLFW_KEY_D) == GLFW_PRESS;
        input.down = glfwGetKey(w, GLFW_KEY_Q) == GLFW_PRESS;
        input.up = glfwGetKey(w, GLFW_KEY_E) == GLFW_PRESS;
        input.fast = glfwGetKey(w, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS ||
                     glfwGetKey(w, GLFW_KEY_RIGHT_SHIFT) == GLFW_PRESS;
    }
    glm::dvec2 cursor;
    glfwGetCursorPos(w, &cursor.x, &cursor.y);
    const bool rightDown = glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
    // A drag looks only when it started over the image, not over the panel.
    if (rightDown && !s.looking && !io.WantCaptureMouse) s.looking = true;
    if (!rightDown) s.looking = false;
    if (s.looking) input.lookPixels = glm::vec2(cursor - s.lastCursor);
    s.lastCursor = cursor;
    if (!io.WantCaptureMouse) input.wheel = io.MouseWheel;
    return input;
}

void handleKeys(PanelActions& actions) {
    const ImGuiIO& io = ImGui::GetIO();
    if (io.WantCaptureKeyboard) return;
    if (ImGui::IsKeyPressed(GLFW_KEY_F, false)) actions.frameAll = true;
    for (int n = 1; n <= kBookmarkSlots; ++n) {
        if (!ImGui::IsKeyPressed(GLFW_KEY_0 + n, false)) continue;
        if (io.KeyCtrl) actions.saveBookmark = n;
        else actions.recallBookmark = n;
    }
}

nlohmann::json statisticsJson(const Session& s) {
    const LiveStatistics& st = s.info.stats;
    nlohmann::json stats = {
        {"device", s.info.device},
        {"frame_s", st.frameSeconds},
        {"primary_rays", st.primaryRays},
        {"primary_kernel_s", st.primaryKernelSeconds},
        {"shadow_kernel_s", st.shadowKernelSeconds},
        {"primary_mrays_s", st.primaryKernelSeconds > 0 ? double(st.primaryRays) / st.primaryKernelSeconds / 1e6 : 0.0},
        {"upload_s", s.uploadSeconds},
    };
    if (st.countersValid) {
        stats["primary_nodes_per_ray"] = st.counters.primaryNodes;
        stats["primary_tests_per_ray"] = st.counters.primaryTests;
        stats["shadow_rays"] = st.counters.shadowRays;
        stats["shadow_nodes_per_ray"] = st.counters.shadowNodes;
        stats["shadow_tests_per_ray"] = st.counters.shadowTests;
    }
    if (s.bvh) {
        const BvhStats& b = s.bvh->stats;
        stats["bvh"] = {{"leaves", b.leafCount},          {"avg_leaf_depth", b.avgLeafDepth},
                        {"max_leaf_depth", b.maxLeafDepth}, {"avg_prims_per_leaf", b.avgPrimsPerLeaf},
                        {"build_s", b.buildSeconds},       {"sah_cost", b.sahCost},
                        {"nodes", b.nodeCount},            {"bytes", b.bytes},
                        {"triangles", s.scene->triangleCount()}};
    }
    return stats;
}

void ensureHostBuffer(Session& s, vk::Buffer& buffer, VkDeviceSize bytes, VkBufferUsageFlags usage, const char* what) {
    if (buffer.size == bytes) return;
    vkDeviceWaitIdle(s.context.device);
    vk::destroyBuffer(s.context, buffer);
    buffer = vk::createBuffer(s.context, bytes, usage,
                              VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, what);
}

// The CPU reference of the same view and the difference, shown in the panel (raypack-cli diff's
// numbers) and, on request, in place of the traced image.
void compareWithReference(Session& s) {
    if (!s.scene || !s.bvh) return;
    RenderSettings settings = s.panel.settings;
    settings.collectCounters = false;
    const Frame gpuFrame = s.tracer->render(settings);
    const Frame cpuFrame = renderCpu(*s.scene, *s.bvh, settings);
    const Image gpuImage{gpuFrame.width, gpuFrame.height, gpuFrame.rgba};
    s.referenceImage = Image{cpuFrame.width, cpuFrame.height, cpuFrame.rgba};
    const ImageDiff diff = diffImages(s.referenceImage, gpuImage, 0, "CPU reference", "GPU image");
    s.differenceImage = diff.difference;
    s.info.compare = CompareResult{true, diff.differingPixels, diff.pixels, diff.differingShare,
                                   diff.maxChannelDifference, cpuFrame.timings.totalSeconds};
    if (s.options.frames)
        std::printf("raypack: compare: %llu of %llu pixels differ\n", (unsigned long long)diff.differingPixels,
                    (unsigned long long)diff.pixels);
}

void saveScreenshot(Session& s, const std::string& path, const FrameTarget& target) {
    std::vector<uint32_t> texels(size_t(target.extent.width) * target.extent.height);
    std::memcpy(texels.data(), s.screenshotReadback.mapped, texels.size() * 4);
    if (target.bgra) swapRedBlue(texels);
    RenderSetup setup{s.sceneSpec, s.panel.settings, s.bvh ? s.bvh->options : s.panel.bvh};
    setup.settings.width = target.extent.width;
    setup.settings.height = target.extent.height;
    writeScreenshot(path, Image{target.extent.width, target.extent.height, std::move(texels)}, setup,
                    statisticsJson(s));
    s.info.lastScreenshot = path;
    std::printf("raypack: screenshot %s (%ux%u) and %s\n", path.c_str(), target.extent.width,
                target.extent.height, sidecarPath(path).c_str());
}

void handleActions(Session& s, const PanelActions& a, const RenderSettings& before) {
    if (a.dismissError) s.info.error.clear();
    if (a.open && !s.panel.openPath.empty()) requestLoad(s, s.panel.openPath);
    if (a.rebuild) s.builder->requestRebuild(s.scene, s.panel.bvh);
    if (a.frameAll && s.scene) {
        s.fly.frameAll();
        s.panel.settings.camera = s.fly.camera();
    }
    if (a.presentMode) setPresentMode(s.window, *a.presentMode);
    if (a.copyCameraArguments) {
        ImGui::SetClipboardText(s.info.cameraArguments.c_str());
        std::printf("%s\n", s.info.cameraArguments.c_str());
    }
    if (a.saveBookmark && s.bookmarks) {
        try {
            s.bookmarks->save(a.saveBookmark, s.panel.settings.camera);
        } catch (const Error& e) {
            s.report(e.what());
        }
    }
    if (a.recallBookmark && s.bookmarks && s.bookmarks->slot(a.recallBookmark)) {
        s.panel.settings.camera = *s.bookmarks->slot(a.recallBookmark);
        s.fly.setCamera(s.panel.settings.camera);
    }
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

// Once a second (when asked), a synchronous frame of the counting kernel for N_TR / N_IT.
// On lavapipe (a CPU device) the timestamps of the window's frames do not bracket the dispatches
// (measured: 17 us for a 57 ms pass), so there the panel's T_K comes from the counting frame, which
// GpuTracer::render times on the host (setHostTimedPasses) and which runs the statistics variant of
// the kernel: a little slower than the frames shown.
bool frameTimestampsReliable(const Session& s) {
    return s.context.info.type != VK_PHYSICAL_DEVICE_TYPE_CPU;
}

// Kernel times T_K into the panel's statistics (and the scripted run's medians).
void recordKernelTimes(Session& s, const FrameTimings& kernel, const RenderSettings& settings) {
    LiveStatistics& st = s.info.stats;
    st.kernelTimesValid = true;
    st.kernelTimesFromCountingFrame = !frameTimestampsReliable(s);
    st.primaryKernelSeconds = kernel.primarySeconds;
    st.shadowKernelSeconds = kernel.shadowSeconds;
    s.primaryKernelTimes.push_back(kernel.primarySeconds);
    s.shadowKernelTimes.push_back(kernel.shadowSeconds);
    st.primaryRays = uint64_t(settings.width) * settings.height;
    const double tracing = kernel.primarySeconds + kernel.shadowSeconds;
    st.nonTracingShare = st.frameSeconds > 0 ? std::max(0.0, 1.0 - tracing / st.frameSeconds) : 0.0;
}

void measureCounters(Session& s) {
    if (!s.panel.liveCounters || !s.tracer->hasScene()) return;
    if (Clock::now() - s.lastCounting < std::chrono::seconds(1)) return;
    s.lastCounting = Clock::now();
    RenderSettings settings = s.panel.settings;
    settings.collectCounters = true;
    FrameRequest request;
    request.image = false;
    request.counters = true;
    try {
        const Frame frame = s.tracer->render(settings, request);
        s.info.stats.counters = summarizeCounters(frame);
        s.info.stats.countersValid = true;
        if (!frameTimestampsReliable(s)) recordKernelTimes(s, frame.timings, settings);
    } catch (const Error& e) {
        s.report(e.what());
    }
}

void drawFrame(Session& s, const std::string& screenshotPath, const std::string& windowShotPath) {
    const RenderSettings before = s.panel.settings;
    ImGui_ImplVulkan_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();

    const Clock::time_point now = Clock::now();
    const double seconds = std::chrono::duration<double>(now - s.lastFrame).count();
    s.lastFrame = now;
    if (s.frameIndex > 0) s.frameTimes.push_back(seconds);
    s.smoothedFrameSeconds = s.smoothedFrameSeconds == 0.0 ? seconds : 0.9 * s.smoothedFrameSeconds + 0.1 * seconds;

    if (s.scene) {
        s.fly.setCamera(s.panel.settings.camera);
        if (s.fly.update(readFlyInput(s), float(seconds))) s.panel.settings.camera = s.fly.camera();
    }
    s.info.stats.frameSeconds = s.smoothedFrameSeconds;
    s.info.build = s.builder->status();
    s.info.cameraArguments = cameraCliArguments(s.panel.settings.camera);
    s.info.flySpeed = s.fly.speed();
    s.info.presentMode = s.window.swapchain.presentMode;
    s.info.presentModes = s.window.presentModes;
    s.info.bookmarkSet.assign(kBookmarkSlots, false);
    if (s.bookmarks)
        for (int n = 1; n <= kBookmarkSlots; ++n) s.info.bookmarkSet[n - 1] = s.bookmarks->slot(n).has_value();

    PanelActions actions;
    if (!s.options.hidePanel) actions = drawPanel(s.panel, s.info);
    handleKeys(actions);
    ImGui::Render();
    handleActions(s, actions, before);

    std::optional<FrameTarget> target = beginFrame(s.context, s.window);
    if (!target) {
        glfwWaitEventsTimeout(0.05);  // minimised or out of date: nothing to draw this time
        return;
    }
    RenderSettings& settings = s.panel.settings;
    settings.width = target->extent.width;
    settings.height = target->extent.height;
    const VkDeviceSize imageBytes = VkDeviceSize(settings.width) * settings.height * 4;

    const Image* shown = s.panel.showing == Showing::Reference ? &s.referenceImage
                         : s.panel.showing == Showing::Difference ? &s.differenceImage
                                                                  : nullptr;
    if (shown && (shown->width != settings.width || shown->height != settings.height)) {
        s.panel.showing = Showing::Traced;  // the window changed size since the comparison
        shown = nullptr;
    }
    bool traced = false;
    if (shown) {
        ensureHostBuffer(s, s.shownImage, imageBytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, "compare image");
        std::vector<uint32_t> texels = shown->rgba;
        if (target->bgra) swapRedBlue(texels);
        std::memcpy(s.shownImage.mapped, texels.data(), imageBytes);
        copyImage(s.window, *target, s.shownImage.buffer);
    } else if (s.tracer->hasScene()) {
        GpuRecordOptions recordOptions;
        recordOptions.bgra = target->bgra;
        s.tracer->recordFrame(target->cmd, settings, recordOptions);
        copyImage(s.window, *target, s.tracer->outputBuffer());
        traced = true;
    } else {
        clearImage(s.window, *target, settings.background.x, settings.background.y, settings.background.z);
    }
    const bool wantShot = !screenshotPath.empty() && traced;
    if (wantShot) {
        ensureHostBuffer(s, s.screenshotReadback, imageBytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, "screenshot");
        const VkBufferCopy region{0, 0, imageBytes};
        vkCmdCopyBuffer(target->cmd, s.tracer->outputBuffer(), s.screenshotReadback.buffer, 1, &region);
        VkBufferMemoryBarrier toHost{VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER};
        toHost.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        toHost.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
        toHost.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        toHost.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        toHost.buffer = s.screenshotReadback.buffer;
        toHost.size = VK_WHOLE_SIZE;
        vkCmdPipelineBarrier(target->cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 0,
                             nullptr, 1, &toHost, 0, nullptr);
    }
    finishFrame(s.context, s.window, *target, ImGui::GetDrawData(), !windowShotPath.empty());

    if (wantShot || !windowShotPath.empty())
        vk::check(vkWaitForFences(s.context.device, 1, &s.window.frameDone, VK_TRUE, UINT64_MAX),
                  "vkWaitForFences (screenshot)");
    if (wantShot) saveScreenshot(s, screenshotPath, *target);
    if (!windowShotPath.empty()) {
        uint32_t w = 0, h = 0;
        std::vector<uint32_t> texels = readWindowImage(s.context, s.window, w, h);
        writePng(windowShotPath, w, h, texels);
        std::printf("raypack: window screenshot %s (%ux%u)\n", windowShotPath.c_str(), w, h);
    }

    if (frameTimestampsReliable(s))
        if (std::optional<FrameTimings> kernel = s.tracer->lastKernelTimes())
            recordKernelTimes(s, *kernel, settings);
    measureCounters(s);
    ++s.frameIndex;
}

}  // namespace

ScriptStep parseScriptStep(const std::string& text) {
    const size_t first = text.find(':');
    if (first == std::string::npos) throw Error("script step \"" + text + "\": expected FRAME:ACTION[:VALUE]");
    ScriptStep step;
    const std::string frame = text.substr(0, first);
    if (frame.empty() || frame.find_first_not_of("0123456789") != std::string::npos || frame.size() > 9)
        throw Error("script step \"" + text + "\": \"" + frame + "\" is not a frame number");
    step.frame = uint32_t(std::stoul(frame));
    const size_t second = text.find(':', first + 1);
    step.action = text.substr(first + 1, second == std::string::npos ? std::string::npos : second - first - 1);
    if (second != std::string::npos) step.value = text.substr(second + 1);
    if (step.action.empty()) throw Error("script step \"" + text + "\": no action");
    return step;
}

int runViewer(const ViewerOptions& options) {
    initWindowSystem();
    Session s(options);
    vk::VulkanContextOptions contextOptions;
    contextOptions.device = options.device;
    contextOptions.validation = options.validation;
    addWindowRequirements(contextOptions);
    s.context = vk::createVulkanContext(contextOptions);
    ViewerWindowOptions windowOptions;
    windowOptions.width = options.width;
    windowOptions.height = options.height;
    windowOptions.presentMode = options.presentMode;
    s.window = createViewerWindow(s.context, windowOptions);
    glfwSetWindowUserPointer(s.window.window, &s);
    glfwSetDropCallback(s.window.window, onDrop);
    s.tracer = std::make_unique<GpuTracer>(s.context);
    s.tracer->setHostTimedPasses(!frameTimestampsReliable(s));
    s.builder = std::make_unique<AsyncSceneBuilder>(
        [](const std::string& spec, LoadProgress& progress) { return openScene(spec, &progress); });

    s.panel.settings = options.settings;
    s.panel.bvh = options.bvh;
    s.panel.liveCounters = options.liveCounters;
    s.panel.openPath = options.scene;
    s.info.device = describe(s.context.info);
    s.info.maxPacketRays = s.context.info.maxWorkgroupInvocations;
    s.info.scene = options.scene + " (loading)";
    std::printf("raypack: device %s\n", s.info.device.c_str());
    requestLoad(s, options.scene);

    const bool scripted = options.frames > 0;
    while (!glfwWindowShouldClose(s.window.window) && (!scripted || s.frameIndex < options.frames)) {
        glfwPollEvents();
        for (const std::string& path : s.droppedFiles) requestLoad(s, path);
        s.droppedFiles.clear();
        std::string screenshot, windowShot;
        if (scripted) {
            for (const ScriptStep& step : options.script) {
                if (step.frame != s.frameIndex) continue;
                if (step.action == "screenshot") screenshot = step.value;
                else if (step.action == "window-screenshot") windowShot = step.value;
                else applyScriptStep(s, step);
            }
            if (s.frameIndex + 1 == options.frames) {
                // The last frame shows the last request: wait for the worker once, here only.
                s.builder->waitIdle();
                if (screenshot.empty()) screenshot = options.screenshot;
                if (windowShot.empty()) windowShot = options.windowScreenshot;
            }
        }
        takeWorkerResults(s);
        // A frame skipped while minimised is not counted, so the last one is always drawn.
        drawFrame(s, screenshot, windowShot);
    }
    vkDeviceWaitIdle(s.context.device);

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
        std::printf("raypack: %u frames, swapchain re-created %u times\n", s.frameIndex,
                    s.window.swapchainRecreations);
        std::printf("raypack: second half of the run, medians: frame %.2f ms, T_K primary %.2f ms, "
                    "T_K shadow %.2f ms\n", steadyMedian(s.frameTimes) * 1e3,
                    steadyMedian(s.primaryKernelTimes) * 1e3, steadyMedian(s.shadowKernelTimes) * 1e3);
    }
    return kViewerExitOk;
}

}  // namespace raypack::ui
