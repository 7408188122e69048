// `raypack-cli bench`: issue 5's matrix runner. For every scene of a suite: load, build the BVH
// (Table 1), then one cell per tracer of the registry (renderer/tracers/registry.h) that the flags
// ask for, and per packet shape for the packet tracers, each with untimed warm-up runs (one counting N_TR / N_IT, then
// 0.3 s of frames back to back on a GPU) and N timed runs, written as one JSON record per cell and ray kind (primary,
// shadow) with the machine and the date.
#include "app/cli/bench_suites.h"
#include "app/cli/commands.h"
#include "app/cli/scene_setup.h"
#include "app/cli/tracing.h"
#include "renderer/error.h"
#include "renderer/measure/agreement.h"
#include "renderer/measure/machine.h"
#include "renderer/measure/protocol.h"
#include "renderer/settings_json.h"
#include "renderer/settings_text.h"
#include "renderer/tracers/registry.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>

namespace raypack::cli {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

struct BenchFlags {
    std::string scenes, suite = "report", device = "all", kernel = "all", packets, cpuPackets, gpu, out, sceneDir;
    std::string only;  // names of the suite's scenes to run, comma-separated; empty: all
    std::string hybridMinRays = std::to_string(HybridParams{}.minRays);
    std::string hybridVisitRatios = "0";
    std::string shadowOrder = "nearest";
    uint32_t width = 0, height = 0, repeat = 0;
    BvhFlags bvh;
    bool noEmbree = false;
    bool noDriverRt = false;
    bool pipelineStatistics = false;
};

// What one cell traces: a tracer, with a packet shape where it traces packets, and the split rules
// for the hybrid kernel.
struct Cell {
    Tracer* tracer;
    std::optional<PacketShape> packet;
    std::optional<HybridParams> hybrid;
    std::string hybridMinRaysText;  // the --hybrid-min-rays entry ("1/4" or "8")
    std::string label() const {
        std::string text = tracer->name() + (packet ? " " + toString(*packet) : std::string());
        if (hybrid) {
            char rules[96];
            std::snprintf(rules, sizeof rules, " K=%u (%s) visit ratio %g", hybrid->minRays, hybridMinRaysText.c_str(),
                          double(hybrid->visitRatio));
            text += rules;
        }
        return text;
    }
};

json sceneFields(const BenchScene& scene, const LoadedScene& loaded, const Bvh& bvh, const BvhBuildOptions& options,
                 const Camera& camera) {
    json j = table1Json(loaded.info, bvh.stats, options);
    j["scene"] = scene.name;
    j["scene_spec"] = scene.spec;
    j["camera"] = {{"eye", {camera.eye.x, camera.eye.y, camera.eye.z}},
                   {"at", {camera.at.x, camera.at.y, camera.at.z}},
                   {"up", {camera.up.x, camera.up.y, camera.up.z}},
                   {"fov_y_degrees", camera.fovYDegrees},
                   {"framed", !scene.camera.has_value()}};
    return j;
}

// Two records (primary, shadow) of a frame tracer's cell.
void addFrameRecords(json& records, const json& scene, const Tracer& tracer, const Cell& cell,
                     const MeasuredFrames& measured) {
    const std::optional<PacketShape>& packet = cell.packet;
    const FrameStats& s = measured.stats;
    for (const char* kind : {"primary", "shadow"}) {
        json r = scene;
        r["tracer"] = tracer.name();
        r["device"] = s.device;
        r["driver"] = tracer.driver();
        r["kernel"] = tracer.kernel();
        r["packet"] = packet ? json(toString(*packet)) : json(nullptr);
        r["hybrid_min_rays"] = cell.hybrid ? json(cell.hybrid->minRays) : json(nullptr);
        r["hybrid_min_rays_spec"] = cell.hybrid ? json(cell.hybridMinRaysText) : json(nullptr);
        r["hybrid_visit_ratio"] = cell.hybrid ? json(cell.hybrid->visitRatio) : json(nullptr);
        r["ray_kind"] = kind;
        r["width_px"] = s.width;
        r["height_px"] = s.height;
        r["repeats"] = s.repeats;
        r["frame_s"] = s.frameSeconds.median;
        r["frame_min_s"] = s.frameSeconds.min;
        r["frame_max_s"] = s.frameSeconds.max;
        r.update(toJson(std::string(kind) == "primary" ? s.primary : s.shadow));
        if (s.gpu) {
            // T_CU split (issue 13): buffers created, layout written into staging memory, copied.
            r["t_cu_allocation_s"] = s.uploadAllocationSeconds;
            r["t_cu_conversion_s"] = s.uploadConversionSeconds;
            r["t_cu_transfer_s"] = s.uploadTransferSeconds;
        }
        records.push_back(r);
    }
}

struct Progress {
    size_t total = 0;
    size_t done = 0;
    Clock::time_point start = Clock::now();
    void begin(const std::string& scene, const std::string& what) const {
        const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
        std::string remaining = "unknown";
        if (done > 0) {
            char text[32];
            std::snprintf(text, sizeof text, "about %.0f s", elapsed / double(done) * double(total - done));
            remaining = text;
        }
        std::fprintf(stderr, "bench: cell %zu of %zu (%s, %s): elapsed %.1f s, remaining %s\n", done + 1, total,
                     scene.c_str(), what.c_str(), elapsed, remaining.c_str());
        std::fflush(stderr);
    }
};

int runBench(const BenchFlags& f, const CLI::App& command) {
    const auto given = [&](const char* name) { return command.get_option(name)->count() > 0; };
    if (given("--scenes") && given("--suite")) throw Error("bench: give either --scenes or --suite, not both");
    BenchSuite suite =
        given("--scenes") ? customSuite(splitList(f.scenes)) : benchSuite(f.suite, resolveSceneDir(f.sceneDir));
    if (given("--only")) {
        std::vector<BenchScene> chosen;
        for (const std::string& name : splitList(f.only)) {
            const auto it = std::find_if(suite.scenes.begin(), suite.scenes.end(),
                                         [&](const BenchScene& s) { return s.name == name; });
            if (it == suite.scenes.end()) {
                std::string names;
                for (const BenchScene& s : suite.scenes) names += (names.empty() ? "" : ", ") + s.name;
                throw Error("--only: \"" + name + "\" is not a scene of suite " + suite.name + " (" + names + ")");
            }
            chosen.push_back(*it);
        }
        suite.scenes = chosen;
    }
    const uint32_t width = given("--width") ? f.width : suite.width;
    const uint32_t height = given("--height") ? f.height : suite.height;
    const uint32_t repeats = given("--repeat") ? f.repeat : suite.repeats;
    const std::vector<PacketShape> packets =
        parsePacketShapes("--packets", given("--packets") ? f.packets : suite.packets);
    const std::vector<PacketShape> cpuPackets =
        parsePacketShapes("--cpu-packets", given("--cpu-packets") ? f.cpuPackets : suite.cpuPackets);
    const BvhBuildOptions bvhOptions = toBvhOptions(f.bvh);
    const bool cpu = f.device != "gpu";
    const bool gpu = f.device != "cpu";
    const std::optional<ShadowOrder> parsedOrder = parseShadowOrder(f.shadowOrder);
    if (!parsedOrder) throw Error("--shadow-order: \"" + f.shadowOrder + "\" is not " + shadowOrderNames());
    const ShadowOrder shadowOrder = *parsedOrder;
    const bool packetKernel = f.kernel == "all" || f.kernel == "packet";
    const bool singleKernel = f.kernel == "all" || f.kernel == "single";
    const bool hybridKernel = f.kernel == "all" || f.kernel == "hybrid";
    const std::vector<HybridMinRaysSpec> hybridMinRays = parseHybridMinRaysList("--hybrid-min-rays", f.hybridMinRays);
    const std::vector<float> hybridVisitRatios = parseHybridVisitRatios("--hybrid-visit-ratios", f.hybridVisitRatios);

    std::optional<VulkanSession> session;
    json machine = {{"cpu_model", cpuModel()},  {"cpu_threads", cpuThreads()}, {"os", operatingSystem()},
                    {"gpu", nullptr},           {"gpu_driver", nullptr},       {"gpu_type", nullptr},
                    {"embree_version", nullptr}};
    if (gpu) {
        session.emplace(f.gpu, false, !f.noDriverRt, f.pipelineStatistics);
        const vk::DeviceInfo& info = session->context.info;
        machine["gpu"] = info.name;
        machine["gpu_driver"] = info.driver;
        machine["gpu_type"] = vk::toString(info.type);
        std::fprintf(stderr, "bench: GPU %s\n", vk::describe(info).c_str());
    }
    TracerEnvironment environment;
    environment.vulkan = session ? &session->context : nullptr;

    // The tracers the flags ask for, in the registry's order, each with its packet shapes.
    json skipped = json::array();
    std::vector<std::unique_ptr<Tracer>> tracers;
    std::vector<Cell> cells;
    for (const TracerInfo& info : listTracers(environment)) {
        if (!(info.device == TracerDevice::Cpu ? cpu : gpu)) continue;
        if ((info.kernel == "packet" && !packetKernel) || (info.kernel == "single" && !singleKernel) ||
            (info.kernel == "hybrid" && !hybridKernel))
            continue;
        if ((info.name == "embree" && f.noEmbree) || (info.name == "driver-rt" && f.noDriverRt)) continue;
        if (!info.unavailable.empty()) {
            skipped.push_back(info.unavailable);
            continue;
        }
        Tracer* tracer = tracers.emplace_back(makeTracer(info.name, environment)).get();
        if (info.name == "embree") machine["embree_version"] = embreeVersion();
        if (info.kernel == "hybrid") {
            for (const PacketShape& p : packets)
                for (const HybridMinRaysSpec& k : hybridMinRays)
                    for (const float ratio : hybridVisitRatios)
                        cells.push_back({tracer, p, HybridParams{k.resolve(p), ratio}, k.text});
        } else if (tracer->capabilities().packetShapes) {
            for (const PacketShape& p : info.device == TracerDevice::Cpu ? cpuPackets : packets)
                cells.push_back({tracer, p, std::nullopt, ""});
        } else {
            cells.push_back({tracer, std::nullopt, std::nullopt, ""});
        }
    }

    json records = json::array();
    Progress progress;
    progress.total = cells.size() * suite.scenes.size();
    for (const BenchScene& benchScene : suite.scenes) {
        std::fprintf(stderr, "bench: loading %s (%s) and building its BVH\n", benchScene.name.c_str(),
                     benchScene.spec.c_str());
        const LoadedScene loaded = loadSceneTimed(benchScene.spec);
        const Bvh bvh = buildBvh(loaded.scene, bvhOptions);
        RenderSettings settings;
        settings.width = width;
        settings.height = height;
        settings.camera = benchScene.camera ? *benchScene.camera : frameScene(loaded.scene.bounds());
        settings.shadowOrder = shadowOrder;
        const json scene = sceneFields(benchScene, loaded, bvh, bvhOptions, settings.camera);

        // The first frame tracer's hits (the CPU reference's, or without it the first GPU cell's)
        // are what the others are compared with.
        std::vector<HitRecord> referenceHits;
        std::map<const Tracer*, Preparation> prepared;  // on a tracer's first cell of the scene
        for (const Cell& cell : cells) {
            progress.begin(benchScene.name, cell.label());
            Tracer& tracer = *cell.tracer;
            if (!prepared.count(&tracer)) prepared[&tracer] = tracer.prepare(loaded.scene, bvh);
            RenderSettings cellSettings = settings;
            if (cell.packet) cellSettings.packet = *cell.packet;
            if (cell.hybrid) cellSettings.hybrid = *cell.hybrid;
            if (std::optional<json> peer = tracer.peerRecords(cellSettings, repeats, referenceHits)) {
                for (json record : *peer) {
                    for (const char* key : {"scene", "scene_spec", "camera", "triangles", "degenerate_triangles"})
                        record[key] = scene[key];
                    records.push_back(record);
                }
            } else {
                MeasuredFrames measured = measureFrames(tracer, prepared[&tracer], cellSettings, repeats, false);
                addFrameRecords(records, scene, tracer, cell, measured);
                if (f.pipelineStatistics)
                    if (const json stats = tracer.pipelineStatistics(cellSettings); !stats.is_null())
                        for (size_t k = records.size() - 2; k < records.size(); ++k)
                            records[k]["pipeline_statistics"] =
                                stats.value(records[k]["ray_kind"].get<std::string>(), json());
                if (tracer.capabilities().bitExactWithReference && !referenceHits.empty() &&
                    referenceHits.size() == measured.frame.hits.size())
                    for (size_t k = records.size() - 2; k < records.size(); ++k)
                        records[k]["hits_identical_to_reference_share"] =
                            identicalHitShare(measured.frame.hits, referenceHits);
                if (referenceHits.empty()) referenceHits = std::move(measured.frame.hits);
            }
            ++progress.done;
        }
    }

    json result = {
        {"format", "raypack-bench-1"},
        {"date", utcDate()},
        {"command", commandLine()},
        {"machine", machine},
        {"settings",
         {{"suite", suite.name},
          {"width_px", width},
          {"height_px", height},
          {"repeats", repeats},
          {"devices", f.device},
          {"kernels", f.kernel},
          {"hybrid_min_rays", f.hybridMinRays},
          {"hybrid_visit_ratios", f.hybridVisitRatios},
          {"shadow_order", f.shadowOrder},
          {"packets",
           [&] {
               json list = json::array();
               for (const PacketShape& p : packets) list.push_back(toString(p));
               return list;
           }()},
          {"cpu_packets",
           [&] {
               json list = json::array();
               for (const PacketShape& p : cpuPackets) list.push_back(toString(p));
               return list;
           }()},
          {"bvh", toJson(bvhOptions)}}},
        {"skipped", skipped},
        {"records", records},
    };
    const std::string out = f.out.empty() ? "bench-" + suite.name + ".json" : f.out;
    writeJsonFile(out, result);
    const double elapsed = std::chrono::duration<double>(Clock::now() - progress.start).count();
    std::printf("bench: %zu records (%zu cells) written to %s in %.1f s\n", records.size(), progress.total, out.c_str(),
                elapsed);
    for (const auto& line : skipped) std::printf("bench: skipped: %s\n", line.get<std::string>().c_str());
    return kExitOk;
}

}  // namespace

CommandRunner addBenchCommand(CLI::App& app) {
    auto flags = std::make_shared<BenchFlags>();
    BenchFlags& f = *flags;
    CLI::App* command = app.add_subcommand(
        "bench",
        "Run a benchmark matrix and write one JSON record per cell and ray kind (primary, shadow): "
        "scene, triangles, tracer (cpu-reference, cpu-packet, gpu-packet, gpu-single, gpu-hybrid, embree, driver-rt), "
        "device and "
        "driver, kernel, packet shape, Table 1 (n_l_leaves, d_avg_leaf_depth, d_max_leaf_depth, "
        "o_avg_prims_per_leaf, t_b_s, sah_cost, bvh_bytes_per_triangle, ...) and Table 2 "
        "(t_r_us_per_ray, n_it_tests_per_ray, n_tr_nodes_per_ray, n_q_rays, t_f_s, t_cu_s, "
        "t_k_s with t_k_min_s / t_k_max_s, perf_mrays_s, perf_with_upload_mrays_s), plus the "
        "machine (CPU model, threads, GPU, driver) and the date. Every cell runs once as a "
        "warm-up that counts N_TR / N_IT, then untimed (once on the CPU, plus 0.3 s of frames back to back on a GPU, "
        "so that its clocks are "
        "up), then --repeat times; medians are reported. "
        "Embree (when built in) traces the same rays (rtcIntersect1/8/16, rtcOccluded1/8) at build "
        "qualities medium and high and its "
        "hit distances are compared with the CPU reference's; the driver's own ray tracing "
        "(VK_KHR_ray_tracing_pipeline) runs where the GPU offers it, and a \"skipped\" line in "
        "the results says why where it does not. A progress line per cell goes to "
        "stderr. Suites: report (Sibenik, Sponza, Conference, Armadillo, Dragon from the scene "
        "folder, with fixed cameras), scaling (terrain 10k..10M, the dragon subdivided to 13M), "
        "quick (two small generated scenes at 96x96, for CI).");
    command->add_option("--scenes", f.scenes,
                        "Comma-separated scene files or generator specs instead of a suite "
                        "(framed by the default camera)");
    command->add_option("--suite", f.suite, "Suite: report, scaling or quick")
        ->check(CLI::IsMember({"report", "scaling", "quick"}))
        ->capture_default_str();
    command->add_option("--scene-dir", f.sceneDir,
                        "Folder of the suite's scene files (default: $RAYPACK_SCENE_DIR, else "
                        "../shared/scenes beside the source tree, else ../shared/scenes from the "
                        "current directory)");
    command->add_option("--device", f.device, "Tracers: cpu (reference, CPU packets + Embree), gpu, or all")
        ->check(CLI::IsMember({"cpu", "gpu", "all"}))
        ->capture_default_str();
    command
        ->add_option("--kernel", f.kernel,
                     "Kernels: packet (GPU packets, CPU packets), single (GPU single rays), hybrid "
                     "(GPU packets splitting into single rays, docs/gpu.md) or all; the CPU "
                     "reference and Embree always run with --device cpu/all")
        ->check(CLI::IsMember({"packet", "single", "hybrid", "all"}))
        ->capture_default_str();
    command
        ->add_option("--hybrid-min-rays", f.hybridMinRays,
                     "Hybrid kernel: the values of K to run, comma-separated, each a ray count or a share "
                     "of the packet (1/4: a quarter of its rays); the packet splits into single rays at "
                     "the first node fewer than K of its active rays want (0: never by this rule)")
        ->capture_default_str();
    command
        ->add_option("--hybrid-visit-ratios", f.hybridVisitRatios,
                     "Hybrid kernel: the visit ratios to run, comma-separated (0: the rule off); the "
                     "packet also splits once its inner-node visits over its active rays pass this "
                     "multiple of the visits they wanted. One cell per packet shape, K and ratio")
        ->capture_default_str();
    command->add_option("--only", f.only,
                        "Run only these scenes of the suite, comma-separated names as the suite "
                        "names them (e.g. \"Sibenik,terrain 10M,Dragon subdiv 3\")");
    command->add_option("--packets", f.packets,
                        "Packet shapes of the packet kernel, e.g. 8x4,4x8,5x6,8x8,16x16 (default: "
                        "the suite's; quick: 8x4,5x6)");
    command->add_option("--cpu-packets", f.cpuPackets,
                        "Packet shapes of the CPU packet tracer, e.g. 4x4,8x8,16x16,32x32 "
                        "(default: the suite's; report and scaling: 8x8,16x16; quick: 16x16)");
    command->add_option("--width", f.width, "Image width in pixels (default: the suite's)")
        ->check(CLI::Range(1u, 16384u));
    command->add_option("--height", f.height, "Image height in pixels (default: the suite's)")
        ->check(CLI::Range(1u, 16384u));
    command->add_option("--repeat", f.repeat, "Timed runs per cell after the warm-up (default: the suite's; report 5)")
        ->check(CLI::Range(1u, 1000u));
    command->add_option("--out", f.out, "Results file (default: bench-SUITE.json)");
    command->add_option("--gpu", f.gpu, "Vulkan device: index or case-insensitive name substring");
    command->add_flag("--no-embree", f.noEmbree, "Do not run the Embree peer");
    command->add_flag("--no-driver-rt", f.noDriverRt,
                      "Do not run the driver's ray tracing peer (VK_KHR_ray_tracing_pipeline; "
                      "it runs where the GPU offers it, after raypack's GPU cells)");
    command->add_flag("--pipeline-statistics", f.pipelineStatistics,
                      "GPU cells also record the compiler's statistics of their kernels (registers, "
                      "spills, ... as the driver names them; VK_KHR_pipeline_executable_properties, where "
                      "the device offers it) as \"pipeline_statistics\"");
    command
        ->add_option("--shadow-order", f.shadowOrder,
                     "The child a shadow ray of the GPU single-ray kernel enters first: nearest, tree "
                     "or larger (docs/gpu.md); the other tracers ignore it")
        ->check(CLI::IsMember({"nearest", "tree", "larger"}))
        ->capture_default_str();
    addBvhFlags(*command, f.bvh);
    return [flags, command] { return runBench(*flags, *command); };
}

}  // namespace raypack::cli
