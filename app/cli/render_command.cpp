// `raypack-cli render SCENE`: one frame through the CPU reference or the Vulkan tracer, with the
// report's statistics, and the image, hits file and JSON a user or a test asks for.
#include "app/cli/arguments.h"
#include "app/cli/commands.h"
#include "app/cli/scene_setup.h"
#include "app/cli/tracing.h"
#include "renderer/camera.h"
#include "renderer/error.h"
#include "renderer/hits_io.h"
#include "renderer/image.h"
#include "renderer/settings_json.h"

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
    std::string kernel = "packet";
    std::string packet = "8x4";
    std::string view = "shaded";
    std::string out, hits, json, from;
    uint32_t repeat = 1;
    bool validation = false;
};

struct RenderOptions {
    CLI::Option *scene, *width, *height, *eye, *at, *up, *fov, *lightHeight, *noShadows, *leafSize,
        *builder, *bins, *kernel, *packet, *view;
};

bool given(const CLI::Option* option) { return option->count() > 0; }

// The setup a render uses: --from first (when given), then every flag given on the command line
// on top of it, then the default framing when neither gave a camera.
RenderSetup resolveSetup(const RenderFlags& f, const RenderOptions& o, bool& cameraGiven) {
    RenderSetup setup;
    cameraGiven = false;
    if (!f.from.empty()) {
        const nlohmann::json json = readJsonFile(f.from);
        try {
            setup = renderSetupFromJson(json);
        } catch (const Error& e) {
            throw Error(f.from + ": " + e.what());
        }
        cameraGiven = json.is_object() && json.contains("camera");
    }
    if (given(o.scene)) setup.scene = f.scene;
    if (setup.scene.empty())
        throw Error("render: no scene: give SCENE or a --from file whose \"scene\" names one");
    RenderSettings& s = setup.settings;
    if (given(o.width)) s.width = f.width;
    if (given(o.height)) s.height = f.height;
    if (given(o.lightHeight)) s.lightHeight = f.lightHeight;
    if (given(o.noShadows)) s.shadows = !f.noShadows;
    if (given(o.kernel)) {
        const auto kernel = parseKernelKind(f.kernel);
        if (!kernel) throw Error("--kernel: \"" + f.kernel + "\" is not packet or single");
        s.kernel = *kernel;
    }
    if (given(o.packet)) s.packet = parsePacketShape("--packet", f.packet);
    if (given(o.view)) {
        const auto view = parseViewMode(f.view);
        if (!view) throw Error("--view: \"" + f.view + "\" is not shaded, nodes or tests");
        s.view = *view;
    }
    if (given(o.leafSize)) setup.bvh.leafSize = f.bvh.leafSize;
    if (given(o.builder)) setup.bvh.builder = parseBvhBuilder(f.bvh.builder);
    if (given(o.bins)) setup.bvh.binCount = f.bvh.binCount;
    if (given(o.eye)) s.camera.eye = parseVec3("--eye", f.eye);
    if (given(o.at)) s.camera.at = parseVec3("--at", f.at);
    if (given(o.up)) s.camera.up = parseVec3("--up", f.up);
    if (given(o.fov)) s.camera.fovYDegrees = f.fov;
    cameraGiven = cameraGiven || given(o.eye) || given(o.at);
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

void printCamera(const Camera& c, bool framed) {
    std::printf("camera     --eye %g,%g,%g --at %g,%g,%g --up %g,%g,%g --fov %g%s\n", c.eye.x,
                c.eye.y, c.eye.z, c.at.x, c.at.y, c.at.z, c.up.x, c.up.y, c.up.z, c.fovYDegrees,
                framed ? " (default framing)" : "");
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
        "Warm-up runs are not timed: one counts N_TR / N_IT, then untimed frames in the timed configuration (one on the CPU; "
        "on a GPU 0.3 s of frames back to back, so that its clocks are up); the --repeat N timed runs give the "
        "median (and min/max).\n"
        "Without --eye/--at (and no --from camera) the camera frames the scene: it looks at the "
        "centre of the scene's bounding box from direction (0.5, 0.4, 1.0) (front, right, above), "
        "up +y, vertical fov 60 degrees, at the distance where the bounding sphere fills the "
        "field of view with a 10% margin; --up / --fov then still override their part.");
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
    o.lightHeight =
        command
            ->add_option("--light-height", f.lightHeight,
                         "Point light above the camera, in multiples of the scene's height "
                         "(report 2.3)")
            ->capture_default_str();
    o.noShadows = command->add_flag("--no-shadows", f.noShadows, "Trace no shadow rays");
    addBvhFlags(*command, f.bvh);
    o.leafSize = command->get_option("--leaf-size");
    o.builder = command->get_option("--builder");
    o.bins = command->get_option("--bins");
    command->add_option("--device", f.device, "Tracer: cpu (the reference) or gpu (Vulkan)")
        ->check(CLI::IsMember({"cpu", "gpu"}))
        ->capture_default_str();
    command->add_option("--gpu", f.gpu,
                        "Vulkan device for --device gpu: index or case-insensitive name substring "
                        "(default: discrete > integrated > CPU/lavapipe)");
    o.kernel = command
                   ->add_option("--kernel", f.kernel,
                                "GPU kernel: packet (shared-stack packets, Gunther et al. 2007) or "
                                "single (one ray per invocation)")
                   ->check(CLI::IsMember({"packet", "single"}))
                   ->capture_default_str();
    o.packet = command->add_option("--packet", f.packet, "GPU packet shape WxH in pixels (rays)")
                   ->capture_default_str();
    o.view = command
                 ->add_option("--view", f.view,
                              "Image: shaded (Phong), nodes (heat map of N_TR) or tests (heat map "
                              "of N_IT)")
                 ->check(CLI::IsMember({"shaded", "nodes", "tests"}))
                 ->capture_default_str();
    command->add_option("--out", f.out, "Write the image to this PNG file");
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
    command->add_flag("--validation", f.validation,
                      "GPU: enable VK_LAYER_KHRONOS_validation; any validation message makes the "
                      "command fail (exit code 2)");

    return [flags, options] {
        const RenderFlags& f = *flags;
        bool cameraGiven = false;
        RenderSetup setup = resolveSetup(f, *options, cameraGiven);
        RenderSettings& settings = setup.settings;
        checkFrameMemory(settings, f.device == "gpu");

        const LoadedScene loaded = loadSceneTimed(setup.scene);
        const Bvh bvh = buildBvh(loaded.scene, setup.bvh);
        if (!cameraGiven) {
            const Camera framed = frameScene(loaded.scene.bounds());
            settings.camera.eye = framed.eye;
            settings.camera.at = framed.at;
            if (!given(options->up)) settings.camera.up = framed.up;
            if (!given(options->fov)) settings.camera.fovYDegrees = framed.fovYDegrees;
        }
        makeGpuCamera(settings.camera, settings.width, settings.height);  // throws if degenerate

        const bool wantImage = !f.out.empty();
        MeasuredFrames measured;
        std::optional<GpuSession> session;
        std::optional<CpuSceneView> cpuView;
        FrameSource source;
        if (f.device == "gpu") {
            session.emplace(f.gpu, f.validation);
            source.gpu = session->tracer.get();
            source.uploadSeconds = source.gpu->upload(loaded.scene, bvh);
        } else {
            cpuView.emplace(makeCpuSceneView(loaded.scene, bvh));
            source.cpu = &*cpuView;
        }
        measured = measureFrames(source, settings, f.repeat, wantImage);

        if (source.gpu)
            std::printf("kernel     %s, packet %s\n", jsonName(settings.kernel),
                        toString(settings.packet).c_str());
        printCamera(settings.camera, !cameraGiven);
        printTable1(stdout, loaded.info, bvh.stats, setup.bvh);
        printTable2(stdout, measured.stats);

        if (!f.out.empty()) {
            writePng(f.out, measured.frame.width, measured.frame.height, measured.frame.rgba);
            std::printf("image      %s\n", f.out.c_str());
        }
        if (!f.hits.empty()) {
            writeHits(f.hits, measured.frame);
            std::printf("hits       %s\n", f.hits.c_str());
        }
        if (!f.json.empty()) {
            nlohmann::json json = toJson(setup);
            json["device"] = measured.stats.device;
            json["device_kind"] = source.gpu ? "gpu" : "cpu";
            json["table1"] = table1Json(loaded.info, bvh.stats, setup.bvh);
            json["table2"] = toJson(measured.stats);
            writeJsonFile(f.json, json);
            std::printf("json       %s\n", f.json.c_str());
        }
        if (session && session->context.validation) {
            const uint32_t messages = vk::validationMessageCount(session->context);
            if (messages > 0)
                throw Error("Vulkan validation reported " + std::to_string(messages) +
                            " message(s) (printed above)");
            std::printf("validation no messages\n");
        }
        return kExitOk;
    };
}

}  // namespace raypack::cli
