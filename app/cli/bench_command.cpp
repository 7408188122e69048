// `raypack-cli bench`: issue 5's matrix runner. For every scene of a suite: load, build the BVH
// (Table 1), then one cell per tracer of the registry (renderer/tracers/registry.h) that the flags
// ask for, and per packet shape for the packet tracers, each with untimed warm-up runs (one counting N_TR / N_IT, then
// on a GPU frames back to back for at least 0.5 s and until their speed settles) and N timed runs, written as one JSON
// record per cell and ray kind (primary, shadow) with the machine and the date.
#include "app/cli/bench_suites.h"
#include "app/cli/commands.h"
#include "app/cli/scene_setup.h"
#include "app/cli/tracing.h"
#include "renderer/error.h"
#include "renderer/gpu_bvh.h"
#include "renderer/measure/accuracy.h"
#include "renderer/measure/agreement.h"
#include "renderer/measure/machine.h"
#include "renderer/measure/protocol.h"
#include "renderer/measure/spread.h"
#include "renderer/settings_json.h"
#include "renderer/settings_text.h"
#include "renderer/tracers/registry.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <optional>

namespace raypack::cli {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

// A --single-groups entry: "P" when both passes run in P, else "P/S".
std::string singleGroupsEntry(const PacketShape& primary, const PacketShape& shadow) {
    return toString(primary) + (primary == shadow ? "" : "/" + toString(shadow));
}

struct BenchFlags {
    std::string scenes, suite = "report", device = "all", kernel = "all", packets, cpuPackets, gpu, out, sceneDir;
    // The GPU single-ray kernel's workgroups.
    std::string singleGroups = singleGroupsEntry(RenderSettings{}.singleGroup, RenderSettings{}.singleShadowGroup);
    std::string intersect;  // "robust", "fast" or a list of them (the trade suites); "": the suite's
    std::string only;       // names of the suite's scenes to run, comma-separated; empty: all
    std::string hybridMinRays = std::to_string(HybridParams{}.minRays);
    std::string hybridVisitRatios = "0";
    std::string hybridPacketsPerGroup = "auto";
    std::string shadowOrder = "nearest";
    std::string hitDistances = "auto";  // the GPU kernels' cells, one per entry
    uint32_t width = 0, height = 0, repeat = 0;
    uint32_t buildRepeat = 1;  // builds per scene (raypack's CPU builders and Embree); T_B is the median
    BvhFlags bvh;
    bool noEmbree = false;
    bool noDriverRt = false;
    bool pipelineStatistics = false;
};

// What one cell traces: a tracer, with a packet shape where it traces packets, and the split rules
// for the hybrid kernel.
struct Cell {
    Tracer* tracer;
    std::optional<PacketShape> packet;  // the single-ray kernel: its primary pass's workgroup
    std::optional<HybridParams> hybrid;
    std::string hybridMinRaysText;               // the --hybrid-min-rays entry ("1/4" or "8")
    std::optional<PacketShape> shadowGroup;      // the single-ray kernel's shadow-pass workgroup
    std::optional<HitDistanceMath> hitDistance;  // raypack's GPU kernels (one cell per --hit-distance entry)
    std::string label() const {
        std::string text = tracer->name() + (packet ? " " + toString(*packet) : std::string());
        if (shadowGroup) text += "/" + toString(*shadowGroup);
        if (hitDistance) text += std::string(" hit distance ") + toString(*hitDistance);
        if (hybrid) {
            const std::string packets = hybrid->packetsPerGroup == kAutoPacketsPerGroup
                                            ? std::string("auto")
                                            : std::to_string(hybrid->packetsPerGroup);
            char rules[128];
            std::snprintf(rules, sizeof rules, " K=%u (%s) visit ratio %g, %s packet(s) a workgroup", hybrid->minRays,
                          hybridMinRaysText.c_str(), double(hybrid->visitRatio), packets.c_str());
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
                     const RenderSettings& ran, const MeasuredFrames& measured) {
    const std::optional<PacketShape>& packet = cell.packet;
    const FrameStats& s = measured.stats;
    for (const char* kind : {"primary", "shadow"}) {
        json r = scene;
        r["tracer"] = tracer.name();
        r["device"] = s.device;
        r["driver"] = tracer.driver();
        r["kernel"] = tracer.kernel();
        // The workgroup this pass ran in (the single-ray kernel's two passes may differ).
        const std::optional<PacketShape>& shape =
            std::string(kind) == "shadow" && cell.shadowGroup ? cell.shadowGroup : packet;
        r["packet"] = shape ? json(toString(*shape)) : json(nullptr);
        r["hybrid_min_rays"] = cell.hybrid ? json(cell.hybrid->minRays) : json(nullptr);
        r["hybrid_min_rays_spec"] = cell.hybrid ? json(cell.hybridMinRaysText) : json(nullptr);
        r["hybrid_visit_ratio"] = cell.hybrid ? json(cell.hybrid->visitRatio) : json(nullptr);
        // What the device ran ("auto" resolved), and what was asked for.
        r["hybrid_packets_per_group"] = cell.hybrid ? json(ran.hybrid.packetsPerGroup) : json(nullptr);
        r["hybrid_packets_per_group_requested"] =
            cell.hybrid ? hybridPacketsPerGroupJson(cell.hybrid->packetsPerGroup) : json(nullptr);
        const auto fetch = tracer.nodeFetch();
        r["node_fetch"] = fetch ? json(fetch->first) : json(nullptr);
        r["hit_distance_requested"] = cell.hitDistance ? json(toString(*cell.hitDistance)) : json(nullptr);
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
            // The tracer's arrays on the device (nodes of its own tree, leaf-order triangles and
            // attributes, materials, textures): the 8-wide tree's cells differ from the binary ones.
            // (The driver's ray tracing reports no size of its structures: none is written there.)
            if (s.preparedBytes > 0) r["device_scene_bytes"] = s.preparedBytes;
            // The frames traced back to back before the timed ones, until their speed settled.
            r.update(toJson(s.warmUp));
        }
        records.push_back(r);
    }
}

// The arithmetic of the accurate hit distance that the last cell's two records traced with.
void addHitDistance(json& records, Tracer& tracer, const RenderSettings& settings) {
    const std::optional<std::string> math = tracer.hitDistance(settings);
    const double rate = tracer.float64Rate();
    for (size_t k = records.size() - 2; k < records.size(); ++k) {
        records[k]["hit_distance"] = math ? json(*math) : json(nullptr);
        records[k]["float64_rate"] = rate > 0.0 ? json(rate) : json(nullptr);
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

// "sah-binned/16 leaf 4": one build of the trade matrix, as its records and figures name it.
std::string buildLabel(const BvhBuildOptions& o) {
    std::string label = toString(o.builder);
    if (o.builder == BvhBuilder::SahBinned) label += "/" + std::to_string(o.binCount);
    return label + " leaf " + std::to_string(o.leafSize);
}

// What the cells of a tracer are compared with: its robust frame at the reference build.
struct TradeReference {
    std::vector<uint32_t> image;
    std::vector<HitRecord> hits;
};

// The accuracy fields of a trade cell's primary record (docs/trade.md): rays leaked on a closed
// scene, the hit distances against the double-precision oracle, and the pixels and hits that differ
// from the tracer's robust frame at the reference build.
void addAccuracyFields(json& primary, const BenchScene& scene, const Scene& geometry, const Frame& frame,
                       const TradeReference* reference) {
    if (scene.closed) {
        const LeakCount leaks = countLeaks(frame.hits);
        primary["rays_leaked"] = leaks.leaked;
        primary["rays_leaked_per_million"] = leaks.perMillion();
    }
    const HitDistanceErrors errors = hitDistanceErrors(geometry, frame.hits);
    primary["t_error_hits"] = errors.hits;
    primary["t_rel_error_max"] = errors.maxRelative;
    primary["t_rel_error_p999"] = errors.p999Relative;
    if (reference) {
        const uint64_t pixels = differingPixels(frame.rgba, reference->image);
        primary["pixels_differing"] = pixels;
        primary["pixels_differing_share"] = frame.rgba.empty() ? 0.0 : double(pixels) / double(frame.rgba.size());
        primary["hits_differing"] = differingHits(frame.hits, reference->hits);
    } else {
        primary["pixels_differing"] = nullptr;
        primary["pixels_differing_share"] = nullptr;
        primary["hits_differing"] = nullptr;
    }
}

std::vector<IntersectMode> parseIntersectModes(const std::string& text) {
    std::vector<IntersectMode> modes;
    for (const std::string& name : splitList(text)) {
        const IntersectMode mode = requireIntersectMode("--intersect", name);
        if (std::find(modes.begin(), modes.end(), mode) == modes.end()) modes.push_back(mode);
    }
    if (modes.empty()) throw Error("--intersect: no mode given");
    return modes;
}

// The trade suites (issue 15): per scene, every build of the matrix, and per build every tracer x
// intersection mode; the CPU reference at the reference build only. The GPU cells of a build run
// first, right after it (renderer/measure/protocol.h: the first gets the long warm-up).
json runTrade(const BenchSuite& suite, const TradeMatrix& matrix, const std::vector<IntersectMode>& modes,
              const std::vector<std::unique_ptr<Tracer>>& tracers, Tracer* cpuReference, const PacketShape& gpuPacket,
              const PacketShape& cpuPacket, uint32_t width, uint32_t height, uint32_t repeats, ShadowOrder shadowOrder,
              const std::function<void(const json&)>& sceneDone) {
    json records = json::array();
    Progress progress;
    progress.total =
        suite.scenes.size() * modes.size() * (matrix.builds.size() * tracers.size() + (cpuReference ? 1 : 0));
    for (const BenchScene& benchScene : suite.scenes) {
        std::fprintf(stderr, "bench: loading %s (%s)\n", benchScene.name.c_str(), benchScene.spec.c_str());
        const LoadedScene loaded = loadSceneTimed(benchScene.spec);
        RenderSettings settings;
        settings.width = width;
        settings.height = height;
        settings.shadowOrder = shadowOrder;
        settings.camera = benchScene.camera ? *benchScene.camera : frameScene(loaded.scene.bounds());
        std::map<std::string, TradeReference> references;  // by tracer, from the reference build
        for (size_t b = 0; b < matrix.builds.size(); ++b) {
            const BvhBuildOptions& build = matrix.builds[b];
            const Bvh bvh = buildBvh(loaded.scene, build);
            json scene = sceneFields(benchScene, loaded, bvh, build, settings.camera);
            scene["closed"] = benchScene.closed;
            scene["bin_count"] = build.builder == BvhBuilder::SahBinned ? json(build.binCount) : json(nullptr);
            scene["build"] = buildLabel(build);
            scene["reference_build"] = b == 0;
            std::vector<Tracer*> cells;
            for (const auto& t : tracers) cells.push_back(t.get());
            if (b == 0 && cpuReference) cells.push_back(cpuReference);
            bool gpuWarm = false;
            for (Tracer* tracer : cells) {
                const Preparation preparation = tracer->prepare(loaded.scene, bvh);
                const bool gpu = tracer->device() == TracerDevice::Gpu;
                std::optional<PacketShape> packet;
                if (tracer->capabilities().packetShapes) packet = gpu ? gpuPacket : cpuPacket;
                for (IntersectMode mode : modes) {
                    progress.begin(benchScene.name, buildLabel(build) + ", " + tracer->name() + ", " + toString(mode));
                    RenderSettings cellSettings = settings;
                    cellSettings.intersect = mode;
                    if (packet) cellSettings.packet = *packet;
                    const double warmUp = gpuWarm ? matrix.warmUpSeconds : matrix.firstWarmUpSeconds;
                    MeasuredFrames measured = measureFrames(*tracer, preparation, cellSettings, repeats, true, warmUp);
                    gpuWarm = gpuWarm || gpu;
                    if (b == 0 && mode == IntersectMode::Robust)
                        references[tracer->name()] = {measured.frame.rgba, measured.frame.hits};
                    addFrameRecords(records, scene, *tracer, Cell{tracer, packet, std::nullopt, ""}, cellSettings,
                                    measured);
                    addHitDistance(records, *tracer, cellSettings);
                    for (size_t k = records.size() - 2; k < records.size(); ++k)
                        records[k]["intersect"] = toString(mode);
                    const auto reference = references.find(tracer->name());
                    addAccuracyFields(records[records.size() - 2], benchScene, loaded.scene, measured.frame,
                                      reference == references.end() ? nullptr : &reference->second);
                    ++progress.done;
                }
            }
        }
        sceneDone(records);
    }
    return records;
}

int runBench(const BenchFlags& f, const CLI::App& command) {
    const auto given = [&](const char* name) { return command.get_option(name)->count() > 0; };
    if (given("--scenes") && given("--suite")) throw Error("bench: give either --scenes or --suite, not both");
    BenchSuite suite =
        given("--scenes") ? customSuite(splitList(f.scenes)) : benchSuite(f.suite, resolveSceneDir(f.sceneDir));
    const uint32_t width = given("--width") ? f.width : suite.width;
    const uint32_t height = given("--height") ? f.height : suite.height;
    const uint32_t repeats = given("--repeat") ? f.repeat : suite.repeats;
    const std::vector<PacketShape> packets =
        parsePacketShapes("--packets", given("--packets") ? f.packets : suite.packets);
    const std::vector<PacketShape> cpuPackets =
        parsePacketShapes("--cpu-packets", given("--cpu-packets") ? f.cpuPackets : suite.cpuPackets);
    // "P" (both passes) or "P/S" (primary pass, shadow pass) per entry.
    std::vector<std::pair<PacketShape, PacketShape>> singleGroups;
    for (const std::string& entry : splitList(f.singleGroups)) {
        const size_t slash = entry.find('/');
        const PacketShape primary = parsePacketShape("--single-groups", entry.substr(0, slash));
        singleGroups.emplace_back(primary, slash == std::string::npos
                                               ? primary
                                               : parsePacketShape("--single-groups", entry.substr(slash + 1)));
    }
    const BvhBuildOptions bvhOptions = toBvhOptions(f.bvh);
    if (suite.scenesFor && (given("--width") || given("--height"))) suite.scenes = suite.scenesFor(width, height);
    // After scenesFor: the chosen scenes keep the cameras of this image size.
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
    const std::vector<IntersectMode> modes =
        f.intersect.empty() ? (suite.trade ? suite.trade->modes : std::vector<IntersectMode>{IntersectMode::Robust})
                            : parseIntersectModes(f.intersect);
    if (!suite.trade && modes.size() > 1)
        throw Error("--intersect: one mode outside the trade suites (robust or fast)");
    if (suite.trade && (given("--builder") || given("--leaf-size") || given("--bins")))
        throw Error("bench --suite " + suite.name +
                    ": the suite builds every builder and leaf size itself; "
                    "--builder, --leaf-size and --bins do not apply");
    if (f.buildRepeat > 1 && (suite.trade || isGpuBvhBuilder(bvhOptions.builder)))
        throw Error("--build-repeat: repeats CPU builds outside the trade suites only (got " +
                    (suite.trade ? "suite " + suite.name : std::string("builder ") + toString(bvhOptions.builder)) +
                    ")");
    const bool cpu = f.device != "gpu";
    const bool gpu = f.device != "cpu";
    const ShadowOrder shadowOrder = requireShadowOrder("--shadow-order", f.shadowOrder);
    std::vector<HitDistanceMath> hitDistances;
    for (const std::string& name : splitList(f.hitDistances))
        hitDistances.push_back(requireHitDistanceMath("--hit-distance", name));
    if (hitDistances.empty()) throw Error("--hit-distance: no arithmetic given");
    const bool packetKernel = f.kernel == "all" || f.kernel == "packet";
    const bool singleKernel = f.kernel == "all" || f.kernel == "single";
    const bool hybridKernel = f.kernel == "all" || f.kernel == "hybrid";
    const std::vector<HybridMinRaysSpec> hybridMinRays = parseHybridMinRaysList("--hybrid-min-rays", f.hybridMinRays);
    const std::vector<float> hybridVisitRatios = parseHybridVisitRatios("--hybrid-visit-ratios", f.hybridVisitRatios);
    std::vector<uint32_t> hybridPacketsPerGroup;
    for (const std::string& entry : splitList(f.hybridPacketsPerGroup))
        hybridPacketsPerGroup.push_back(parseHybridPacketsPerGroup("--hybrid-packets-per-group", entry));
    if (hybridPacketsPerGroup.empty()) throw Error("--hybrid-packets-per-group: no count given");

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
    environment.buildRepeats = f.buildRepeat;

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
        const size_t firstCell = cells.size();
        if (info.kernel == "hybrid") {
            for (const PacketShape& p : packets)
                for (const HybridMinRaysSpec& k : hybridMinRays)
                    for (const float ratio : hybridVisitRatios)
                        for (const uint32_t group : hybridPacketsPerGroup)
                            cells.push_back({tracer, p, HybridParams{k.resolve(p), ratio, group}, k.text});
        } else if (info.kernel == "single" && info.device == TracerDevice::Gpu) {
            // The single-ray kernel's workgroup: which pixels run side by side, not a packet.
            for (const auto& [primary, shadow] : singleGroups)
                cells.push_back({tracer, primary, std::nullopt, "", shadow});
        } else if (tracer->capabilities().packetShapes) {
            for (const PacketShape& p : info.device == TracerDevice::Cpu ? cpuPackets : packets)
                cells.push_back({tracer, p, std::nullopt, ""});
        } else {
            cells.push_back({tracer, std::nullopt, std::nullopt, ""});
        }
        // raypack's GPU kernels: each of those cells once per hit-distance arithmetic.
        if (info.device == TracerDevice::Gpu && info.name != "driver-rt") {
            std::vector<Cell> tracerCells(cells.begin() + long(firstCell), cells.end());
            cells.resize(firstCell);
            for (const Cell& base : tracerCells)
                for (const HitDistanceMath math : hitDistances) {
                    Cell cell = base;
                    cell.hitDistance = math;
                    cells.push_back(cell);
                }
        }
    }

    // The results file; the trade suites also write it after every scene ("complete": false), so
    // that a run cut short (a device's time limit) keeps what it measured.
    const std::string out = f.out.empty() ? "bench-" + suite.name + ".json" : f.out;
    // The trade matrix's tracers that run here (the flags and the machine choose among them).
    std::vector<std::string> tradeTracers;
    bool tradeReference = false;
    const auto writeResults = [&](const json& records, bool complete) {
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
              {"hybrid_packets_per_group", f.hybridPacketsPerGroup},
              {"shadow_order", f.shadowOrder},
              {"hit_distances", f.hitDistances},
              {"packets",
               [&] {
                   json list = json::array();
                   for (const PacketShape& p : packets) list.push_back(toString(p));
                   return list;
               }()},
              {"single_groups",
               [&] {
                   json list = json::array();
                   for (const auto& [primary, shadow] : singleGroups)
                       list.push_back(singleGroupsEntry(primary, shadow));
                   return list;
               }()},
              {"cpu_packets",
               [&] {
                   json list = json::array();
                   for (const PacketShape& p : cpuPackets) list.push_back(toString(p));
                   return list;
               }()},
              {"intersect",
               [&] {
                   json list = json::array();
                   for (IntersectMode m : modes) list.push_back(toString(m));
                   return list;
               }()},
              {"bvh", suite.trade ? json(nullptr) : toJson(bvhOptions)},
              {"trade", suite.trade
                            ? json{{"builds",
                                    [&] {
                                        json list = json::array();
                                        for (const BvhBuildOptions& o : suite.trade->builds) list.push_back(toJson(o));
                                        return list;
                                    }()},
                                   {"tracers", tradeTracers},
                                   {"cpu_reference_at_reference_build", tradeReference},
                                   {"reference", "the same tracer's robust frame at builds[0] (sah-exact, leaf 1)"},
                                   {"gpu_warm_up_s", {suite.trade->firstWarmUpSeconds, suite.trade->warmUpSeconds}}}
                            : json(nullptr)}}},
            {"skipped", skipped},
            {"records", records},
            {"complete", complete},
        };
        writeJsonFile(out, result);
    };

    json records = json::array();
    Progress progress;
    progress.total = cells.size() * suite.scenes.size();
    if (suite.trade) {
        // The matrix's tracers among those the flags ask for, in the matrix's order (GPU first).
        std::vector<std::unique_ptr<Tracer>> matrixTracers;
        std::unique_ptr<Tracer> reference;
        cells.clear();
        for (const std::string& name : suite.trade->tracers)
            for (auto& t : tracers)
                if (t && t->name() == name) matrixTracers.push_back(std::move(t));
        for (auto& t : tracers)
            if (t && t->name() == "cpu-reference" && suite.trade->cpuReferenceAtReferenceBuild)
                reference = std::move(t);
        tracers.clear();
        for (const auto& t : matrixTracers) tradeTracers.push_back(t->name());
        tradeReference = reference != nullptr;
        records =
            runTrade(suite, *suite.trade, modes, matrixTracers, reference.get(), packets.front(), cpuPackets.front(),
                     width, height, repeats, shadowOrder, [&](const json& partial) { writeResults(partial, false); });
        progress.total = records.size() / 2;
    }
    for (const BenchScene& benchScene : suite.trade ? std::vector<BenchScene>{} : suite.scenes) {
        std::fprintf(stderr, "bench: loading %s (%s) and building its BVH\n", benchScene.name.c_str(),
                     benchScene.spec.c_str());
        const LoadedScene loaded = loadSceneTimed(benchScene.spec);
        std::vector<double> buildRuns;
        Bvh bvh = buildSceneBvh(loaded.scene, bvhOptions, f.gpu);
        buildRuns.push_back(bvh.stats.buildSeconds);
        for (uint32_t r = 1; r < f.buildRepeat; ++r) {
            // The previous tree goes first, as Embree's repeated builds release their scene before
            // the next (renderer/tracers/embree.cpp): both builders then write memory the process
            // already holds, rather than raypack's alone fresh pages (docs/bvh.md).
            bvh = Bvh{};
            bvh = buildSceneBvh(loaded.scene, bvhOptions, f.gpu);  // the same tree: the builders are deterministic
            buildRuns.push_back(bvh.stats.buildSeconds);
        }
        bvh.stats.buildSeconds = spreadOf(buildRuns).median;
        RenderSettings settings;
        settings.width = width;
        settings.height = height;
        settings.intersect = modes.front();
        settings.camera = benchScene.camera ? *benchScene.camera : frameScene(loaded.scene.bounds());
        settings.shadowOrder = shadowOrder;
        json scene = sceneFields(benchScene, loaded, bvh, bvhOptions, settings.camera);
        scene["intersect"] = toString(settings.intersect);
        if (f.buildRepeat > 1) scene["t_b_runs_s"] = buildRuns;

        // The first frame tracer's hits (the CPU reference's, or without it the first GPU cell's)
        // are what the others are compared with.
        std::vector<HitRecord> referenceHits;
        std::map<const Tracer*, Preparation> prepared;  // on a tracer's first cell of the scene
        // Tracers that built the tree themselves (a device builder on a GPU tracer): its statistics.
        std::map<const Tracer*, BvhStats> builtInTracer;
        for (const Cell& cell : cells) {
            progress.begin(benchScene.name, cell.label());
            Tracer& tracer = *cell.tracer;
            if (!prepared.count(&tracer)) {
                std::optional<Tracer::DeviceBuildPreparation> built;
                if (isGpuBvhBuilder(bvhOptions.builder))
                    built = tracer.prepareWithDeviceBuild(loaded.scene, bvhOptions);
                if (built) {
                    prepared[&tracer] = built->preparation;
                    builtInTracer[&tracer] = built->stats;
                } else {
                    prepared[&tracer] = tracer.prepare(loaded.scene, bvh);
                }
            }
            RenderSettings cellSettings = settings;
            if (cell.packet)
                (cell.tracer->kernel() == "single" ? cellSettings.singleGroup : cellSettings.packet) = *cell.packet;
            if (cell.shadowGroup) cellSettings.singleShadowGroup = *cell.shadowGroup;
            if (cell.hybrid) cellSettings.hybrid = *cell.hybrid;
            if (cell.hitDistance) cellSettings.hitDistance = *cell.hitDistance;
            if (std::optional<json> peer = tracer.peerRecords(cellSettings, repeats, referenceHits)) {
                for (json record : *peer) {
                    for (const char* key : {"scene", "scene_spec", "camera", "triangles", "degenerate_triangles"})
                        record[key] = scene[key];
                    records.push_back(record);
                }
            } else {
                MeasuredFrames measured = measureFrames(tracer, prepared[&tracer], cellSettings, repeats, false);
                addFrameRecords(records, scene, tracer, cell, tracer.deviceSettings(cellSettings), measured);
                addHitDistance(records, tracer, cellSettings);
                if (const auto built = builtInTracer.find(&tracer); built != builtInTracer.end())
                    for (size_t k = records.size() - 2; k < records.size(); ++k) {
                        // The tree this tracer built in its own buffers (the same tree as the
                        // scene's downloaded one: the builder is deterministic), timed there.
                        json& record = records[k];
                        record["bvh_built_in_tracer"] = true;
                        record["t_b_s"] = built->second.buildSeconds;
                        record["t_b_device_s"] = built->second.deviceBuildSeconds;
                        record["t_b_device_sort_s"] = built->second.deviceSortSeconds;
                        record["t_b_device_hierarchy_s"] = built->second.deviceHierarchySeconds;
                        record["t_b_device_layout_s"] = built->second.deviceLayoutSeconds;
                        record["t_b_allocation_s"] = built->second.buildAllocationSeconds;
                        // From the scene in host memory to a traced frame: T_CU + T_B + one frame's
                        // wall time (frame_s; the report's T_F holds T_CU already). The kernels'
                        // pipelines are compiled before, in the warm-up.
                        record["t_scene_to_frame_s"] =
                            record.value("t_cu_s", 0.0) + built->second.buildSeconds + record.value("frame_s", 0.0);
                    }
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

    writeResults(records, true);
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
        "scene, triangles, tracer (cpu-reference, cpu-packet, gpu-packet, gpu-single, gpu-cwbvh, gpu-hybrid, embree, "
        "driver-rt), "
        "device and "
        "driver, kernel, packet shape, Table 1 (n_l_leaves, d_avg_leaf_depth, d_max_leaf_depth, "
        "o_avg_prims_per_leaf, t_b_s, sah_cost, bvh_bytes_per_triangle, ...) and Table 2 "
        "(t_r_us_per_ray, n_it_tests_per_ray, n_tr_nodes_per_ray, n_q_rays, t_f_s, t_cu_s, "
        "t_k_s with t_k_min_s / t_k_max_s, perf_mrays_s, perf_with_upload_mrays_s), plus the "
        "machine (CPU model, threads, GPU, driver) and the date. Every cell runs once as a "
        "warm-up that counts N_TR / N_IT, then untimed (once on the CPU, plus frames back to back on a GPU for at "
        "least 0.5 s "
        "and until their speed settles, at most 3 s, so that its clocks are up: gpu_warm_up_s, gpu_warm_up_frames, "
        "gpu_warm_up_steady), then --repeat times; medians are reported. "
        "Embree (when built in) traces the same rays (rtcIntersect1/8/16, rtcOccluded1/8) at build "
        "qualities medium and high and its "
        "hit distances are compared with the CPU reference's; the driver's own ray tracing "
        "(VK_KHR_ray_tracing_pipeline) runs where the GPU offers it, and a \"skipped\" line in "
        "the results says why where it does not. A progress line per cell goes to "
        "stderr. Suites: report (Sibenik, Sponza, Conference, Armadillo, Dragon from the scene "
        "folder, with fixed cameras), scaling (terrain 10k..10M, the dragon subdivided to 13M), "
        "quick (two small generated scenes at 96x96, for CI), "
        "trade (issue 15's speed/accuracy matrix: the report scenes and closed generated scenes -- an icosphere seen "
        "from inside, a lattice whose pixel rays cross its vertices and edges, each also far from the origin and "
        "tiny -- at 1024x768, every builder (sah-exact, sah-binned at 8/16/32 bins, sah-split) x leaf size 1/2/4/8 x "
        "--intersect robust/fast x GPU packet 8x4, GPU single and CPU packet 16x16, plus the CPU reference at "
        "sah-exact leaf 1; its primary records add rays_leaked(_per_million) on closed scenes, t_rel_error_max / "
        "t_rel_error_p999 against a double-precision oracle, and pixels_differing / hits_differing from the same "
        "tracer's robust frame at sah-exact leaf 1; docs/trade.md), trade-quick (its shape on small scenes at 96x96, "
        "for CI).");
    command->add_option("--scenes", f.scenes,
                        "Comma-separated scene files or generator specs instead of a suite "
                        "(framed by the default camera)");
    command->add_option("--suite", f.suite, "Suite: report, scaling, quick, trade or trade-quick")
        ->check(CLI::IsMember(benchSuiteNames()))
        ->capture_default_str();
    command->add_option("--intersect", f.intersect,
                        "Intersection tests: robust (watertight, accurate t) or fast (Moller-Trumbore, plain slabs); "
                        "the trade suites take a list (default robust,fast), the others one mode (default robust)");
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
                     "the first node fewer than K of its active rays want (0: never by this rule; above the "
                     "packet's rays, e.g. 33 for 8x4: at the root, the kernel without its packet phase)")
        ->capture_default_str();
    command
        ->add_option("--hybrid-visit-ratios", f.hybridVisitRatios,
                     "Hybrid kernel: the visit ratios to run, comma-separated (0: the rule off); the "
                     "packet also splits once its inner-node visits over its active rays pass this "
                     "multiple of the visits they wanted. One cell per packet shape, K and ratio")
        ->capture_default_str();
    command
        ->add_option("--hybrid-packets-per-group", f.hybridPacketsPerGroup,
                     "Hybrid kernel: packets per workgroup to run, comma-separated, each auto or a count "
                     "(1-64; more than 1 needs packets of one subgroup, e.g. 8x4 on NVIDIA, 8x1 on "
                     "lavapipe): an SM holds a limited number of workgroups, 32 on the H200. auto: 4 where "
                     "each packet fills one subgroup (8x4 on NVIDIA, 8x1 on lavapipe), else 1; the records' "
                     "hybrid_packets_per_group is what ran. One cell per packet shape, K, ratio and entry")
        ->capture_default_str();
    command->add_option("--only", f.only,
                        "Run only these scenes of the suite, comma-separated names as the suite "
                        "names them (e.g. \"Sibenik,Dragon\" of report, \"terrain 10M,Dragon subdiv 3\" of scaling)");
    command->add_option("--packets", f.packets,
                        "Packet shapes of the packet kernel, e.g. 8x4,4x8,5x6,8x8,16x16 (default: "
                        "the suite's; quick: 8x4,5x6)");
    command
        ->add_option("--single-groups", f.singleGroups,
                     "Workgroup shapes WxH of the GPU single-ray kernel, one cell each, e.g. "
                     "8x4,8x16,8x16/16x8 (P/S: the primary pass in P, the shadow pass in S; each ray "
                     "traces alone, the shape says which pixels share a workgroup; each record's "
                     "\"packet\" is its pass's)")
        ->capture_default_str();
    command->add_option("--cpu-packets", f.cpuPackets,
                        "Packet shapes of the CPU packet tracer, e.g. 4x4,8x8,16x16,32x32 "
                        "(default: the suite's; report and scaling: 8x8,16x16; quick: 16x16)");
    command->add_option("--width", f.width, "Image width in pixels (default: the suite's)")
        ->check(CLI::Range(1u, 16384u));
    command->add_option("--height", f.height, "Image height in pixels (default: the suite's)")
        ->check(CLI::Range(1u, 16384u));
    command->add_option("--repeat", f.repeat, "Timed runs per cell after the warm-up (default: the suite's; report 5)")
        ->check(CLI::Range(1u, 1000u));
    command
        ->add_option("--build-repeat", f.buildRepeat,
                     "Builds of each scene's tree, back to back, by raypack's CPU builder and by Embree "
                     "(each quality); t_b_s is the median, t_b_runs_s lists raypack's (default 1)")
        ->check(CLI::Range(1u, 100u))
        ->capture_default_str();
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
    command
        ->add_option("--hit-distance", f.hitDistances,
                     "The arithmetic of the GPU kernels' accurate hit distance (robust path): a comma-separated "
                     "list of auto, fp64 and float-pair, one cell of each GPU kernel per entry (records "
                     "\"hit_distance\": what it resolved to on the device; docs/trade.md)")
        ->capture_default_str();
    addBvhFlags(*command, f.bvh);
    return [flags, command] { return runBench(*flags, *command); };
}

}  // namespace raypack::cli
