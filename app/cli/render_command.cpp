// `raypack-cli render SCENE`: one frame through the CPU reference or the Vulkan tracer, with the
// report's statistics, and the image, hits file and JSON a user or a test asks for.
#include "app/cli/commands.h"
#include "app/cli/scene_setup.h"
#include "app/cli/tracing.h"
#include "renderer/camera.h"
#include "renderer/cpu_packet_tracer.h"
#include "renderer/error.h"
#include "renderer/gpu_bvh.h"
#include "renderer/hits_io.h"
#include "renderer/image.h"
#include "renderer/measure/protocol.h"
#include "renderer/progressive.h"
#include "renderer/settings_json.h"
#include "renderer/settings_text.h"
#include "renderer/start_view.h"
#include "renderer/tracers/registry.h"

#include <cstdio>
#include <memory>
#include <optional>

namespace raypack::cli {
namespace {

struct RenderFlags {
    std::string scene;
    uint32_t width = RenderSettings{}.width;
    uint32_t height = RenderSettings{}.height;
    std::string eye, at, up;
    float fov = 60.0f;
    float lightHeight = RenderSettings{}.lightHeight;
    bool noShadows = false;
    BvhFlags bvh;
    std::string device = "cpu";
    std::string gpu;
    std::string kernel;  // --kernel; the default depends on the device
    std::string packet;
    uint32_t hybridMinRays = HybridParams{}.minRays;
    float hybridVisitRatio = HybridParams{}.visitRatio;
    std::string hybridPacketsPerGroup = "auto";
    std::string view = "shaded";
    std::string intersect = "robust";
    std::string shadowOrder = "nearest";
    std::string hitDistance = "auto";
    uint32_t bvhWidth = 2;
    std::string out, hits, json, from;
    uint32_t repeat = 1;
    uint32_t spp = 1;
    std::string heatScale;
    uint32_t scale = 1;
    bool validation = false;
};

struct RenderOptions {
    CLI::Option *scene, *width, *height, *eye, *at, *up, *fov, *lightHeight, *noShadows, *leafSize, *builder, *bins,
        *splitAlpha, *splitBudget, *kernel, *packet, *view, *intersect, *shadowOrder, *spp, *scale, *heatScale,
        *hybridMinRays, *hybridVisitRatio, *hybridPacketsPerGroup, *plocRadius, *treeletRounds, *treeletGamma,
        *topRebuild, *bvhWidth, *hitDistance;
};

bool given(const CLI::Option* option) { return option->count() > 0; }

// The setup a render uses: --from first (when given), then every flag given on the command line
// on top of it, then the start view (startCamera) when neither gave a camera.
// `cpuKernelFromFile`: the --from file is a CPU render's (device_kind "cpu"), so its kernel and
// packet are what that render traced.
RenderSetup resolveSetup(const RenderFlags& f, const RenderOptions& o, CameraParts& cameraGiven,
                         bool& cpuKernelFromFile) {
    RenderSetup setup;
    cameraGiven = CameraParts{};
    cpuKernelFromFile = false;
    if (!f.from.empty()) {
        const nlohmann::json json = readJsonFile(f.from);
        try {
            setup = renderSetupFromJson(json);
        } catch (const Error& e) {
            throw Error(f.from + ": " + e.what());
        }
        if (json.is_object() && json.contains("camera")) cameraGiven = CameraParts{true, true, true, true};
        cpuKernelFromFile = json.is_object() && json.value("device_kind", "") == "cpu" && json.contains("kernel");
    }
    if (given(o.scene)) setup.scene = f.scene;
    if (setup.scene.empty()) throw Error("render: no scene: give SCENE or a --from file whose \"scene\" names one");
    RenderSettings& s = setup.settings;
    if (given(o.width)) s.width = f.width;
    if (given(o.height)) s.height = f.height;
    if (given(o.lightHeight)) s.lightHeight = f.lightHeight;
    if (given(o.noShadows)) s.shadows = !f.noShadows;
    if (given(o.kernel)) s.kernel = requireKernelKind("--kernel", f.kernel);
    if (given(o.packet)) s.packet = parsePacketShape("--packet", f.packet);
    if (given(o.hybridMinRays)) s.hybrid.minRays = f.hybridMinRays;
    if (given(o.hybridVisitRatio)) s.hybrid.visitRatio = f.hybridVisitRatio;
    if (given(o.hybridPacketsPerGroup))
        s.hybrid.packetsPerGroup = parseHybridPacketsPerGroup("--hybrid-packets-per-group", f.hybridPacketsPerGroup);
    if (given(o.view)) s.view = requireViewMode("--view", f.view);
    if (given(o.intersect)) s.intersect = requireIntersectMode("--intersect", f.intersect);
    if (given(o.shadowOrder)) s.shadowOrder = requireShadowOrder("--shadow-order", f.shadowOrder);
    if (given(o.hitDistance)) s.hitDistance = requireHitDistanceMath("--hit-distance", f.hitDistance);
    if (given(o.bvhWidth)) s.bvhWidth = f.bvhWidth;
    if (given(o.leafSize)) setup.bvh.leafSize = f.bvh.leafSize;
    if (given(o.builder)) setup.bvh.builder = parseBvhBuilder(f.bvh.builder);
    if (given(o.bins)) setup.bvh.binCount = f.bvh.binCount;
    if (given(o.splitAlpha)) setup.bvh.splitAlpha = f.bvh.splitAlpha;
    if (given(o.splitBudget)) setup.bvh.splitBudget = f.bvh.splitBudget;
    if (given(o.plocRadius)) setup.bvh.plocRadius = f.bvh.plocRadius;
    if (given(o.treeletRounds)) setup.bvh.treeletRounds = f.bvh.treeletRounds;
    if (given(o.treeletGamma)) setup.bvh.treeletGamma = f.bvh.treeletGamma;
    if (given(o.topRebuild)) setup.bvh.topRebuild = f.bvh.topRebuild;
    if (given(o.eye)) s.camera.eye = parseVec3("--eye", f.eye);
    if (given(o.at)) s.camera.at = parseVec3("--at", f.at);
    if (given(o.up)) s.camera.up = parseVec3("--up", f.up);
    if (given(o.fov)) s.camera.fovYDegrees = f.fov;
    // A flag's part replaces the file's or the start view's (withStartView, in the run below).
    cameraGiven.eye = cameraGiven.eye || given(o.eye);
    cameraGiven.at = cameraGiven.at || given(o.at);
    cameraGiven.up = cameraGiven.up || given(o.up);
    cameraGiven.fov = cameraGiven.fov || given(o.fov);
    if (given(o.spp)) setup.samples = f.spp;
    if (given(o.heatScale)) s.heatFullScale = parsePositiveFloat("--heat-scale", f.heatScale);
    if (given(o.scale)) setup.resolutionScale = f.scale;
    return setup;
}

// Refuses, before anything is allocated, a frame that needs more memory than the machine has
// available (MemAvailable of /proc/meminfo; no check where that cannot be read). Bytes per pixel
// measured as the growth of the peak RSS from 1024x1024 to 2048x2048 (gen:terrain:1k, shadows on,
// 2026-12-01, the 2-core development VM): 100 on the CPU, 189 on lavapipe, whose device memory is
// host memory (a discrete GPU needs less host memory; the estimate stays conservative).
void checkFrameMemory(const RenderSettings& settings, bool gpu) {
    const uint64_t bytesPerPixel = gpu ? 189 : 100;
    const uint64_t needed = uint64_t(settings.width) * settings.height * bytesPerPixel;
    std::FILE* meminfo = std::fopen("/proc/meminfo", "r");
    if (!meminfo) return;
    unsigned long long availableKb = 0;
    char line[256];
    while (std::fgets(line, sizeof line, meminfo))
        if (std::sscanf(line, "MemAvailable: %llu kB", &availableKb) == 1) break;
    std::fclose(meminfo);
    if (availableKb == 0 || needed <= uint64_t(availableKb) * 1024) return;
    char text[256];
    std::snprintf(text, sizeof text,
                  "render: a %ux%u frame needs about %.1f GB (%llu bytes a pixel on the %s), more than the %.1f GB "
                  "this machine has available; render a smaller image",
                  settings.width, settings.height, double(needed) / 1e9, (unsigned long long)bytesPerPixel,
                  gpu ? "GPU" : "CPU", double(availableKb) * 1024 / 1e9);
    throw Error(text);
}

// `startView`: what of the camera came from the start view, "" for nothing.
void printCamera(const Camera& c, const char* startView) {
    std::printf("camera     --eye %g,%g,%g --at %g,%g,%g --up %g,%g,%g --fov %g%s\n", c.eye.x, c.eye.y, c.eye.z, c.at.x,
                c.at.y, c.at.z, c.up.x, c.up.y, c.up.z, c.fovYDegrees, startView);
}

}  // namespace

CommandRunner addRenderCommand(CLI::App& app) {
    auto flags = std::make_shared<RenderFlags>();
    auto options = std::make_shared<RenderOptions>();
    RenderFlags& f = *flags;
    RenderOptions& o = *options;
    CLI::App* command = app.add_subcommand(
        "render",
        "Render one frame of SCENE (primary rays, then shadow rays from the point light) and print "
        "the device, the BVH's Table 1 row (N_L, D_AVG, D_MAX, O_AVG, T_B in s) and the report's "
        "Table 2 for primary and shadow rays: T_R (microseconds per ray), N_IT (triangle tests per "
        "ray), N_TR (nodes visited per ray), N_Q (rays), T_F = T_CU + T_K (s), T_CU (GPU data "
        "creation and upload, s; 0 on the CPU), T_K (tracing time, s: GPU timestamp queries, CPU "
        "wall clock), PERF (Mrays/s = N_Q / T_K, and with T_CU included).\n"
        "Warm-up runs are not timed: one counts N_TR / N_IT, then untimed frames in the timed configuration (one on "
        "the CPU; "
        "on a GPU frames back to back for at least 0.5 s and until their speed settles, so that its clocks are up); "
        "the --repeat N timed runs give the "
        "median (and min/max).\n"
        "Without --eye/--at (and no --from camera) the camera is the scene's start view: the "
        "file's own camera (glTF); else, when the centre of the scene's bounding box lies in a closed "
        "room (rays cast from it in every direction, 6 x 24 x 24: at least 90% hit, at most a fifth of "
        "the hits on back faces, at most half of them nearer than 2% of the box's diagonal), a view "
        "from inside: a third of the way along the box's longest horizontal axis, looking along it, "
        "fov 70 degrees, low enough that the default light stays under the ceiling; else it frames "
        "the scene, looking at the centre of the bounding box from direction (0.5, 0.4, 1.0) (front, "
        "right, above), up +y, vertical fov 60 degrees, at the distance where the bounding sphere "
        "fills the field of view with a 10% margin. --up / --fov override their part, and --eye or "
        "--at alone its point (the other point stays the start view's).");
    o.scene = command->add_option("SCENE", f.scene, sceneArgumentHelp());
    o.width = command->add_option("--width", f.width, "Image width in pixels")
                  ->check(CLI::Range(1u, 16384u))
                  ->capture_default_str();
    o.height = command->add_option("--height", f.height, "Image height in pixels")
                   ->check(CLI::Range(1u, 16384u))
                   ->capture_default_str();
    o.eye = command->add_option("--eye", f.eye, "Camera position x,y,z");
    o.at = command->add_option("--at", f.at, "Point the camera looks at, x,y,z");
    o.up = command->add_option("--up", f.up, "Camera up vector x,y,z (default 0,1,0)");
    o.fov = command->add_option("--fov", f.fov, "Vertical field of view in degrees (default 60)")
                ->check(CLI::Range(0.001f, 179.999f));
    o.lightHeight = command
                        ->add_option("--light-height", f.lightHeight,
                                     "Point light above the camera, in multiples of the scene's height "
                                     "(report 2.3)")
                        ->capture_default_str();
    o.noShadows = command->add_flag("--no-shadows", f.noShadows, "Trace no shadow rays");
    addBvhFlags(*command, f.bvh);
    o.leafSize = command->get_option("--leaf-size");
    o.builder = command->get_option("--builder");
    o.bins = command->get_option("--bins");
    o.splitAlpha = command->get_option("--split-alpha");
    o.splitBudget = command->get_option("--split-budget");
    o.plocRadius = command->get_option("--ploc-radius");
    o.treeletRounds = command->get_option("--treelet-rounds");
    o.treeletGamma = command->get_option("--treelet-gamma");
    o.topRebuild = command->get_option("--top-rebuild");
    command
        ->add_option("--device", f.device,
                     "Tracer: cpu (the reference, or the CPU packet tracer with --kernel packet) "
                     "or gpu (Vulkan)")
        ->check(CLI::IsMember({"cpu", "gpu"}))
        ->capture_default_str();
    command->add_option("--gpu", f.gpu,
                        "Vulkan device for --device gpu: index or case-insensitive name substring "
                        "(default: discrete > integrated > CPU/lavapipe)");
    o.kernel = command
                   ->add_option("--kernel", f.kernel,
                                "Kernel: packet (GPU: shared-stack packets, Gunther et al. 2007; "
                                "CPU: SIMD packets, Wald et al. 2007, docs/cpu-packet.md) or single "
                                "(GPU: one ray per invocation; CPU: the reference) or hybrid (GPU only: "
                                "packets while coherent, then single rays, Benthin et al. 2012, "
                                "docs/gpu.md). Default: packet on the GPU, single on the CPU")
                   ->check(CLI::IsMember({"packet", "single", "hybrid"}));
    o.packet = command->add_option("--packet", f.packet,
                                   "Packet shape WxH in pixels (rays) of --kernel packet or hybrid "
                                   "(default 8x4 on the GPU, 16x16 on the CPU)");
    o.hybridMinRays = command
                          ->add_option("--hybrid-min-rays", f.hybridMinRays,
                                       "--kernel hybrid: the packet splits into single rays at the first "
                                       "node fewer than K of its active rays want (0: never by this rule; above "
                                       "the packet's rays: at the root)")
                          ->capture_default_str();
    o.hybridVisitRatio = command
                             ->add_option("--hybrid-visit-ratio", f.hybridVisitRatio,
                                          "--kernel hybrid: the packet also splits once its inner-node visits "
                                          "over its active rays pass this multiple of the visits they wanted "
                                          "(0: off)")
                             ->check(CLI::Range(0.0f, kMaxHybridVisitRatio))
                             ->capture_default_str();
    o.hybridPacketsPerGroup =
        command
            ->add_option(
                "--hybrid-packets-per-group", f.hybridPacketsPerGroup,
                "--kernel hybrid: packets per workgroup, stacked in y: auto (4 where each packet fills "
                "one subgroup, 8x4 on NVIDIA, 8x1 on lavapipe; else 1) or a count from 1 to 64 (more than 1 needs "
                "packets of one subgroup)")
            ->capture_default_str();
    o.view = command
                 ->add_option("--view", f.view,
                              "Image: shaded (Phong), nodes (heat map of N_TR) or tests (heat map "
                              "of N_IT)")
                 ->check(CLI::IsMember({"shaded", "nodes", "tests"}))
                 ->capture_default_str();
    o.intersect = command
                      ->add_option("--intersect", f.intersect,
                                   "Ray/triangle and ray/box tests: robust (watertight, Woop et al. 2013; "
                                   "conservative slabs, Ize 2013; accurate hit distances) or fast "
                                   "(Moller-Trumbore, plain slabs: faster, may leak through shared "
                                   "edges; docs/trade.md)")
                      ->check(CLI::IsMember({"robust", "fast"}))
                      ->capture_default_str();
    o.shadowOrder = command
                        ->add_option("--shadow-order", f.shadowOrder,
                                     "GPU --kernel single: the child a shadow ray enters first when it "
                                     "hits both: nearest, tree (left, no comparison) or larger (surface "
                                     "area); the shadows are the same, the work differs (docs/gpu.md)")
                        ->check(CLI::IsMember({"nearest", "tree", "larger"}))
                        ->capture_default_str();
    o.hitDistance = command
                        ->add_option("--hit-distance", f.hitDistance,
                                     "GPU, --intersect robust: the arithmetic of the kept hit's accurate "
                                     "distance: fp64 (64-bit floats; needs shaderFloat64), float-pair "
                                     "(float pairs; any device) or auto (fp64 on a CPU device, and on a GPU "
                                     "that runs doubles at a quarter of the float rate or more, measured on "
                                     "the first frame; else float-pair); they agree to an ulp, only the "
                                     "speed differs (docs/trade.md)")
                        ->check(CLI::IsMember({"auto", "fp64", "float-pair"}))
                        ->capture_default_str();
    o.bvhWidth = command
                     ->add_option("--bvh-width", f.bvhWidth,
                                  "GPU --kernel single: trace the binary BVH (2) or the compressed 8-wide tree made "
                                  "from it at upload (8; Ylitie et al. 2017, the tracer gpu-cwbvh, docs/gpu.md)")
                     ->check(CLI::IsMember({2u, 8u}))
                     ->capture_default_str();
    command->add_option("--out", f.out,
                        "Write the image to this file: PNG for .png, JPEG (quality 95) for .jpg or "
                        ".jpeg; any other extension is refused before rendering");
    command->add_option("--hits", f.hits,
                        "Write every pixel's primary ray and result to this hits file "
                        "(RPKHITS1, docs/hits-format.md)");
    command->add_option("--json", f.json,
                        "Write the settings (usable with --from), Table 1 and Table 2 to this JSON "
                        "file; every key carries its unit");
    command->add_option("--from", f.from,
                        "Start from the settings of this JSON file (a viewer screenshot sidecar "
                        "or a render --json file); flags given as well override it");
    command->add_option("--repeat", f.repeat, "Timed runs after the warm-up; the median is reported")
        ->check(CLI::Range(1u, 1000u))
        ->capture_default_str();
    o.heatScale = command->add_option("--heat-scale", f.heatScale,
                                      "Count shown as full red in the heat maps of --view nodes|tests (default "
                                      "256 nodes, 128 tests; a viewer sidecar carries the viewer's); a number above 0");
    o.spp = command
                ->add_option("--spp", f.spp,
                             "Samples per pixel: 1 traces pixel centres; N > 1 averages the N samples of the "
                             "viewer's refinement pattern (Halton 2,3), so a converged viewer screenshot is "
                             "reproduced pixel for pixel. Statistics, hits and T_K are of the first sample")
                ->check(CLI::Range(1u, kMaxSamplesPerPixel))
                ->capture_default_str();
    o.scale = command
                  ->add_option("--scale", f.scale,
                               "Trace at 1/S of --width and --height in each axis and scale the image up "
                               "(bilinear; nearest for heat maps), as the viewer does while moving")
                  ->check(CLI::Range(1u, 64u))
                  ->capture_default_str();
    command->add_flag("--validation", f.validation,
                      "GPU: enable VK_LAYER_KHRONOS_validation; any validation message makes the "
                      "command fail (exit code 2)");

    return [flags, options] {
        const RenderFlags& f = *flags;
        CameraParts cameraGiven;
        bool cpuKernelFromFile = false;
        RenderSetup setup = resolveSetup(f, *options, cameraGiven, cpuKernelFromFile);
        RenderSettings& settings = setup.settings;
        // Flags that do not apply to the chosen device and kernel are errors, not ignored.
        const bool cpu = f.device != "gpu";
        if (cpu) {
            if (!f.gpu.empty()) throw Error("--gpu applies to --device gpu only");
            if (f.validation) throw Error("--validation applies to --device gpu only");
            // The CPU's default kernel is the reference (single rays); its default packet shape
            // is the CPU packet tracer's own.
            if (!given(options->kernel) && !cpuKernelFromFile) settings.kernel = KernelKind::Single;
            if (settings.kernel == KernelKind::Packet && !given(options->packet) && !cpuKernelFromFile)
                settings.packet = kDefaultCpuPacket;
        }
        if (settings.kernel == KernelKind::Single && given(options->packet))
            throw Error("--packet applies to --kernel packet or hybrid only");
        if (cpu && settings.kernel == KernelKind::Hybrid) throw Error("--kernel hybrid applies to --device gpu only");
        if (settings.kernel != KernelKind::Hybrid &&
            (given(options->hybridMinRays) || given(options->hybridVisitRatio) ||
             given(options->hybridPacketsPerGroup)))
            throw Error(
                "--hybrid-min-rays, --hybrid-visit-ratio and --hybrid-packets-per-group apply to --kernel hybrid only");
        // A settings file's 8-wide tree applies to the GPU single-ray kernel it was traced with; another
        // device or kernel (a flag beside --from) traces the binary tree. The flag itself is refused there.
        if (!given(options->bvhWidth) && (cpu || settings.kernel != KernelKind::Single)) settings.bvhWidth = 2;
        if (settings.bvhWidth != 2 && (cpu || settings.kernel != KernelKind::Single))
            throw Error("--bvh-width 8 applies to --device gpu --kernel single only");
        if (settings.bvhWidth != 2 && settings.shadowOrder != ShadowOrder::Nearest)
            throw Error(
                "--bvh-width 8 orders the children by each ray's octant; --shadow-order applies to the binary tree");
        if (given(options->shadowOrder) && (cpu || settings.kernel != KernelKind::Single))
            throw Error("--shadow-order applies to --device gpu --kernel single only");
        if (given(options->hitDistance) && cpu)
            throw Error("--hit-distance applies to --device gpu only (the CPU tracers take 64-bit floats)");
        // Output paths are checked before the scene is loaded: a typo fails at once, not after
        // the render.
        if (!f.out.empty()) checkImageOutputPath("--out", f.out);
        if (!f.hits.empty()) checkOutputPath("--hits", f.hits);
        if (!f.json.empty()) checkOutputPath("--json", f.json);
        checkFrameMemory(settings, f.device == "gpu");

        const LoadedScene loaded = loadSceneTimed(setup.scene);
        const bool gpu = f.device == "gpu";
        // A device builder on --device gpu builds in the GPU tracer's own buffers (issue 13: no tree
        // on the host, no second Vulkan device, no download and upload again). The start view
        // traces the tree on the host, so without a camera the tree is built and downloaded first.
        const bool buildInTracer =
            gpu && isGpuBvhBuilder(setup.bvh.builder) && cameraGiven.bothPoints() && settings.bvhWidth == 2;
        std::optional<Bvh> bvh;
        if (!buildInTracer) bvh = buildSceneBvh(loaded.scene, setup.bvh, f.gpu);
        if (!cameraGiven.bothPoints())
            settings.camera = withStartView(settings.camera, cameraGiven, startCamera(loaded.scene, *bvh));
        makeGpuCamera(settings.camera, settings.width, settings.height);  // throws if degenerate

        const bool wantImage = !f.out.empty();
        if (setup.resolutionScale > 1 && !f.hits.empty())
            throw Error("--hits: a hits file has one record per pixel of the image, which --scale " +
                        std::to_string(setup.resolutionScale) + " does not trace");
        // The tracer: the device and kernel the flags chose (renderer/tracers/registry.h).
        const bool packets = settings.kernel == KernelKind::Packet;
        const char* gpuTracer = packets                                 ? "gpu-packet"
                                : settings.kernel == KernelKind::Hybrid ? "gpu-hybrid"
                                : settings.bvhWidth == 8                ? "gpu-cwbvh"
                                                                        : "gpu-single";
        std::optional<VulkanSession> session;
        TracerEnvironment environment;
        if (gpu) {
            session.emplace(f.gpu, f.validation);
            environment.vulkan = &session->context;
        }
        const std::unique_ptr<Tracer> tracer =
            makeTracer(gpu ? gpuTracer : (packets ? "cpu-packet" : "cpu-reference"), environment);
        Preparation preparation;
        BvhStats bvhStats;
        if (buildInTracer) {
            const std::optional<Tracer::DeviceBuildPreparation> built =
                tracer->prepareWithDeviceBuild(loaded.scene, setup.bvh);
            RAYPACK_CHECK_MSG(built, "the GPU tracers build with the device builders");
            preparation = built->preparation;
            bvhStats = built->stats;
            std::printf("BVH        built in the tracer's own buffers on the device (no host tree)\n");
        } else {
            preparation = tracer->prepare(loaded.scene, *bvh);
            bvhStats = bvh->stats;
        }
        // Progressive display (renderer/progressive.h): a reduced resolution, scaled up after.
        const uint32_t outWidth = settings.width, outHeight = settings.height;
        settings.width = scaledExtent(outWidth, setup.resolutionScale);
        settings.height = scaledExtent(outHeight, setup.resolutionScale);
        if (setup.samples > 1) settings.pixelJitter = samplePatternOffset(0, setup.samples);
        MeasuredFrames measured = measureFrames(*tracer, preparation, settings, f.repeat, wantImage);
        if (wantImage && setup.samples > 1) {
            SampleAccumulator accumulator;
            accumulator.reset(settings.width, settings.height);
            accumulator.add(measured.frame.rgba);
            for (uint32_t k = 1; k < setup.samples; ++k) {
                RenderSettings sample = settings;
                sample.pixelJitter = samplePatternOffset(k, setup.samples);
                accumulator.add(tracer->render(sample, FrameRequest{}).rgba);
            }
            measured.frame.rgba = accumulator.resolve();
            std::printf("samples    %u per pixel (%s)\n", setup.samples, kSamplePatternName);
        }
        if (wantImage && setup.resolutionScale > 1) {
            const Image scaled =
                scaleImage(Image{settings.width, settings.height, measured.frame.rgba}, outWidth, outHeight,
                           settings.view == ViewMode::Shaded ? ScaleFilter::Bilinear : ScaleFilter::Nearest);
            measured.frame.width = outWidth;
            measured.frame.height = outHeight;
            measured.frame.rgba = scaled.rgba;
            std::printf("scale      traced %ux%u, scaled up to %ux%u\n", settings.width, settings.height, outWidth,
                        outHeight);
        }
        settings.width = outWidth;  // the JSON describes the image written
        settings.height = outHeight;
        settings.pixelJitter = glm::vec2(0.0f);

        const bool singleKernel = gpu && settings.kernel == KernelKind::Single;
        if (gpu || packets)
            std::printf("kernel     %s, %s %s\n", toString(settings.kernel), singleKernel ? "workgroup" : "packet",
                        toString(singleKernel ? gpuWorkgroup(settings) : settings.packet).c_str());
        if (gpu && settings.bvhWidth == 8)
            std::printf("tree       compressed 8-wide (Ylitie et al. 2017), made from the binary BVH at upload\n");
        if (settings.kernel == KernelKind::Hybrid) {
            const uint32_t perGroup = tracer->deviceSettings(settings).hybrid.packetsPerGroup;
            std::printf("hybrid     split below %u rays, visit ratio %g (0: off), %u packet%s a workgroup%s\n",
                        settings.hybrid.minRays, double(settings.hybrid.visitRatio), perGroup, perGroup == 1 ? "" : "s",
                        settings.hybrid.packetsPerGroup == kAutoPacketsPerGroup ? " (auto)" : "");
        }
        if (const auto fetch = tracer->nodeFetch())
            std::printf("nodes      read through %s buffer (%s)\n",
                        fetch->first == "texel" ? "a uniform texel" : "the storage", fetch->second.c_str());
        if (gpu && settings.intersect == IntersectMode::Robust)
            if (const std::optional<std::string> math = tracer->hitDistance(settings)) {
                std::string why = settings.hitDistance == HitDistanceMath::Auto ? "auto" : "as asked";
                if (const double rate = tracer->float64Rate(); rate > 0.0) {
                    char text[96];
                    std::snprintf(text, sizeof text, ": doubles measured at %.3g of the float rate", rate);
                    why += text;
                }
                std::printf("distance   accurate hit distance in %s (%s)\n",
                            *math == "fp64" ? "64-bit floats" : "float pairs", why.c_str());
            }
        printCamera(settings.camera, cameraGiven.bothPoints() ? ""
                                     : cameraGiven.eye        ? " (--at of the start view)"
                                     : cameraGiven.at         ? " (--eye of the start view)"
                                                              : " (start view)");
        printTable1(stdout, loaded.info, bvhStats, setup.bvh);
        printTable2(stdout, measured.stats);

        if (!f.out.empty()) {
            writeImage(f.out, measured.frame.width, measured.frame.height, measured.frame.rgba);
            std::printf("image      %s\n", f.out.c_str());
        }
        if (!f.hits.empty()) {
            writeHits(f.hits, measured.frame);
            std::printf("hits       %s\n", f.hits.c_str());
        }
        if (!f.json.empty()) {
            nlohmann::json json = toJson(setup);
            json["device"] = measured.stats.device;
            json["device_kind"] = gpu ? "gpu" : "cpu";
            json["table1"] = table1Json(loaded.info, bvhStats, setup.bvh);
            json["table2"] = toJson(measured.stats);
            writeJsonFile(f.json, json);
            std::printf("json       %s\n", f.json.c_str());
        }
        if (session && session->context.validation) {
            const uint32_t messages = vk::validationMessageCount(session->context);
            if (messages > 0)
                throw Error("Vulkan validation reported " + std::to_string(messages) + " message(s) (printed above)");
            std::printf("validation no messages\n");
        }
        return kExitOk;
    };
}

}  // namespace raypack::cli
