// `raypack-cli bench` end to end: the quick suite on lavapipe and the CPU writes a results file
// whose every record carries every statistic, finite (no timing thresholds: the numbers depend on
// the machine); Embree, when built in, agrees with the CPU reference on hit distances; and
// scripts/bench-report turns the results into markdown and figures.
#include "cli_runner.h"

#include "renderer/settings_json.h"
#include "renderer/settings_text.h"

#include <gtest/gtest.h>
#include <algorithm>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

namespace raypack::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const ScratchDir& scratch() {
    static ScratchDir dir("raypack-test-bench");
    return dir;
}

// The quick suite, run once for the whole program (about 20 s on 2 cores with lavapipe).
const json& quickResults() {
    static const json results = [] {
        const fs::path out = scratch() / "quick.json";
        const CliResult r = runCli("bench --suite quick --out " + quoted(out));
        EXPECT_EQ(r.exitCode, 0) << r.output;
        EXPECT_NE(r.output.find("cell 1 of"), std::string::npos) << r.output;
        if (r.exitCode != 0) return json();
        return readJsonFile(out.string());
    }();
    return results;
}

void expectFiniteNumber(const json& record, const char* key) {
    ASSERT_TRUE(record.contains(key)) << key << " missing in " << record.dump();
    ASSERT_TRUE(record.at(key).is_number()) << key << " in " << record.dump();
    EXPECT_TRUE(std::isfinite(record.at(key).get<double>())) << key << " in " << record.dump();
}

const char* kTable1Keys[] = {"triangles",
                             "degenerate_triangles",
                             "t_load_s",
                             "load_mb_s",
                             "n_l_leaves",
                             "d_avg_leaf_depth",
                             "d_max_leaf_depth",
                             "o_avg_prims_per_leaf",
                             "t_b_s",
                             "nodes",
                             "sah_cost",
                             "bvh_bytes",
                             "bvh_bytes_per_triangle",
                             "leaf_size"};
const char* kTable2Keys[] = {"t_r_us_per_ray",
                             "n_it_tests_per_ray",
                             "n_tr_nodes_per_ray",
                             "n_q_rays",
                             "t_f_s",
                             "t_cu_s",
                             "t_k_s",
                             "t_k_min_s",
                             "t_k_max_s",
                             "perf_mrays_s",
                             "perf_with_upload_mrays_s",
                             "frame_s",
                             "width_px",
                             "height_px",
                             "repeats"};
const char* kEmbreeKeys[] = {"triangles",
                             "t_b_s",
                             "n_q_rays",
                             "t_k_s",
                             "t_k_min_s",
                             "t_k_max_s",
                             "t_r_us_per_ray",
                             "perf_mrays_s",
                             "hits_compared",
                             "hits_agree_share",
                             "hits_max_rel_t_error",
                             "threads"};

TEST(Bench, QuickSuiteRecordsCarryEveryStatisticFinite) {
    const json& results = quickResults();
    ASSERT_TRUE(results.is_object());
    EXPECT_EQ(results.at("format"), "raypack-bench-1");
    EXPECT_TRUE(results.at("date").is_string());
    EXPECT_NE(results.at("command").get<std::string>().find("bench --suite quick"), std::string::npos);
    const json& machine = results.at("machine");
    EXPECT_FALSE(machine.at("cpu_model").get<std::string>().empty());
    EXPECT_GE(machine.at("cpu_threads").get<int>(), 1);
    EXPECT_TRUE(machine.at("gpu").is_string());  // lavapipe at least
    EXPECT_TRUE(machine.at("gpu_driver").is_string());

    const json& settings = results.at("settings");
    const std::vector<std::string> packets = settings.at("packets");
    const std::vector<std::string> cpuPackets = settings.at("cpu_packets");
    const json& records = results.at("records");
    ASSERT_TRUE(records.is_array());
    std::set<std::string> scenes;
    // (scene, tracer, packet, ray kind) of every raypack record.
    std::set<std::tuple<std::string, std::string, std::string, std::string>> cells;
    for (const json& r : records) {
        const std::string tracer = r.at("tracer");
        scenes.insert(r.at("scene").get<std::string>());
        const std::string kind = r.at("ray_kind");
        EXPECT_TRUE(kind == "primary" || kind == "shadow") << kind;
        EXPECT_TRUE(r.at("device").is_string());
        if (tracer == "embree") {
            for (const char* key : kEmbreeKeys) expectFiniteNumber(r, key);
            continue;
        }
        for (const char* key : kTable1Keys) expectFiniteNumber(r, key);
        for (const char* key : kTable2Keys) expectFiniteNumber(r, key);
        EXPECT_GT(r.at("n_q_rays").get<uint64_t>(), 0u) << r.dump();
        EXPECT_GT(r.at("perf_mrays_s").get<double>(), 0.0) << r.dump();
        EXPECT_LE(r.at("t_k_min_s").get<double>(), r.at("t_k_s").get<double>());
        EXPECT_LE(r.at("t_k_s").get<double>(), r.at("t_k_max_s").get<double>());
        if (kind == "primary") {
            EXPECT_EQ(r.at("n_q_rays").get<uint64_t>(),
                      r.at("width_px").get<uint64_t>() * r.at("height_px").get<uint64_t>());
        }
        if (tracer == "cpu-reference" || tracer == "cpu-packet") {
            EXPECT_EQ(r.at("t_cu_s").get<double>(), 0.0);
        } else {
            EXPECT_GT(r.at("t_cu_s").get<double>(), 0.0) << r.dump();
        }
        if (tracer.rfind("gpu-", 0) == 0) {
            EXPECT_GT(r.at("device_scene_bytes").get<uint64_t>(), 0u) << r.dump();
            // The frames traced back to back before the timed ones (renderer/measure/warm_up.h):
            // at least one, their time, and whether they had stopped speeding up.
            EXPECT_GE(r.at("gpu_warm_up_frames").get<uint32_t>(), 1u) << r.dump();
            EXPECT_GT(r.at("gpu_warm_up_s").get<double>(), 0.0) << r.dump();
            EXPECT_TRUE(r.at("gpu_warm_up_steady").is_boolean()) << r.dump();
        }
        if (tracer == "cpu-packet") {
            EXPECT_EQ(r.at("hits_identical_to_reference_share").get<double>(), 1.0) << r.dump();
        }
        cells.emplace(r.at("scene"), tracer, r.at("packet").is_string() ? r.at("packet") : "", kind);
    }
    // Every cell of the matrix is there, primary and shadow: CPU reference, each packet shape,
    // the single-ray kernel in its default workgroup (recorded as its "packet") over the binary and
    // the 8-wide tree, the hybrid kernel
    // per packet shape (one K, one visit ratio by default), on each scene.
    EXPECT_EQ(scenes.size(), 2u);
    for (const std::string& scene : scenes)
        for (const char* kind : {"primary", "shadow"}) {
            EXPECT_TRUE(cells.count({scene, "cpu-reference", "", kind})) << scene << " " << kind;
            const RenderSettings defaults;
            const PacketShape group = std::string(kind) == "shadow" ? defaults.singleShadowGroup : defaults.singleGroup;
            EXPECT_TRUE(cells.count({scene, "gpu-single", toString(group), kind})) << scene << " " << kind;
            EXPECT_TRUE(cells.count({scene, "gpu-cwbvh", toString(group), kind})) << scene << " " << kind;
            for (const std::string& packet : packets)
                EXPECT_TRUE(cells.count({scene, "gpu-packet", packet, kind})) << scene << " " << packet << " " << kind;
            for (const std::string& packet : packets)
                EXPECT_TRUE(cells.count({scene, "gpu-hybrid", packet, kind})) << scene << " " << packet << " " << kind;
            for (const std::string& packet : cpuPackets)
                EXPECT_TRUE(cells.count({scene, "cpu-packet", packet, kind})) << scene << " " << packet << " " << kind;
        }
    EXPECT_EQ(cells.size(), scenes.size() * 2 * (3 + 2 * packets.size() + cpuPackets.size()));
}

TEST(Bench, EmbreeAgreesWithTheReferenceOnHitDistances) {
    // 200x200 = 40,000 rays, so that 99.99% allows a few rays through shared edges to differ
    // (Embree's default triangle test is not watertight; raypack's is).
    const fs::path out = scratch() / "embree.json";
    const CliResult r = runCli(
        "bench --device cpu --scenes gen:sphereflake:20k,gen:terrain:20k "
        "--width 200 --height 200 --repeat 1 --out " +
        quoted(out));
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const json results = readJsonFile(out.string());
    size_t embreeRecords = 0;
    size_t intersect16Records = 0;  // none where this Embree has no 16-ray packets
    for (const json& record : results.at("records")) {
        if (record.at("tracer") != "embree") continue;
        ++embreeRecords;
        if (record.at("kernel") == "rtcIntersect16") ++intersect16Records;
        EXPECT_EQ(record.at("hits_compared").get<uint64_t>(), 40000u);
        EXPECT_GE(record.at("hits_agree_share").get<double>(), 0.9999) << record.dump();
        EXPECT_GE(record.at("shadows_agree_share").get<double>(), 0.999) << record.dump();
    }
    if (embreeRecords == 0) {
        const std::string skipped = results.at("skipped").dump();
        ASSERT_NE(skipped.find("without Embree"), std::string::npos) << skipped;
        GTEST_SKIP() << "raypack-cli was built without Embree";
    }
    // Two scenes x two build qualities x (rtcIntersect1, rtcIntersect8, rtcOccluded1,
    // rtcOccluded8), and rtcIntersect16 where Embree has it.
    EXPECT_TRUE(intersect16Records == 0 || intersect16Records == 4u) << intersect16Records;
    EXPECT_EQ(embreeRecords, 16u + intersect16Records);
}

// --build-repeat builds each tree several times: T_B is the median of the runs it lists.
TEST(Bench, BuildRepeatReportsTheMedianOfItsRuns) {
    const fs::path out = scratch() / "build-repeat.json";
    const CliResult r = runCli(
        "bench --device cpu --no-embree --scenes gen:terrain:20k --builder sah-binned --width 8 --height 8 "
        "--repeat 1 --build-repeat 3 --out " +
        quoted(out));
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const json results = readJsonFile(out.string());
    size_t checked = 0;
    for (const json& record : results.at("records")) {
        std::vector<double> runs = record.at("t_b_runs_s").get<std::vector<double>>();
        ASSERT_EQ(runs.size(), 3u) << record.dump();
        for (double seconds : runs) EXPECT_GT(seconds, 0.0);
        std::sort(runs.begin(), runs.end());
        EXPECT_DOUBLE_EQ(record.at("t_b_s").get<double>(), runs[1]);
        ++checked;
    }
    EXPECT_GT(checked, 0u);
}

TEST(Bench, ReportScriptWritesTablesAndFigures) {
    const json& results = quickResults();
    ASSERT_TRUE(results.is_object());
    const fs::path json = scratch() / "quick.json";
    const fs::path markdown = scratch() / "benchmarks.md";
    const fs::path images = scratch() / "img";
    std::ofstream(markdown) << "# Benchmarks\n\nHand-written text that must stay.\n";
    const std::string script = std::string(RAYPACK_SOURCE_DIR) + "/scripts/bench-report";
    const std::string command = "/usr/bin/python3 '" + script + "' " + quoted(json) + " --markdown " +
                                quoted(markdown) + " --img-dir " + quoted(images) + " > /dev/null 2>&1";
    // Twice: the second run replaces its section instead of appending another.
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
    std::stringstream text;
    text << std::ifstream(markdown).rdbuf();
    const std::string md = text.str();
    EXPECT_NE(md.find("Hand-written text that must stay."), std::string::npos);
    for (const char* expected : {"Table 1", "Table 2 (primary rays)", "Table 2 (shadow rays)", "| N_L |",
                                 "bench --suite quick", "quick-figure1.png", "quick-figure2.png"})
        EXPECT_NE(md.find(expected), std::string::npos) << expected << " in\n" << md;
    size_t sections = 0;
    for (size_t at = md.find("bench-report:begin quick"); at != std::string::npos;
         at = md.find("bench-report:begin quick", at + 1))
        ++sections;
    EXPECT_EQ(sections, 1u);
    EXPECT_GT(fs::file_size(images / "quick-figure1.png"), 1000u);
    EXPECT_GT(fs::file_size(images / "quick-figure2.png"), 1000u);
}

// scripts/hybrid-gap-report (scripts/device-hybrid-gap.sh's table) over a bench run in the shape
// that script runs, on lavapipe's 8-lane subgroups: one-subgroup 8x1 packets, K = 8 and K = 9
// (above the packet's rays: every packet splits at the root), one and four packets a workgroup,
// the single-ray kernel in the packet's 8x1 and the grouped 8x4. A row per scene and ray kind, and
// in each the root-split hybrid's N_TR is the single-ray kernel's: the same traversal. (One small
// scene: the time goes to building the eleven cells' pipelines on lavapipe.)
TEST(Bench, HybridGapReportSplitsTheGapIntoSteps) {
    const fs::path out = scratch() / "hybrid-gap.json";
    const CliResult r = runCli(
        "bench --scenes gen:sphereflake:1k --device gpu --kernel all --packets 8x1 "
        "--single-groups 8x16/32x4,8x1/8x1,8x4/8x4 --hybrid-min-rays 8,9 --hybrid-visit-ratios 0 "
        "--hybrid-packets-per-group 1,4 --width 48 --height 32 --repeat 1 --no-embree --no-driver-rt --out " +
        quoted(out));
    ASSERT_EQ(r.exitCode, 0) << r.output;
    // The counts asked for are the counts that ran (only "auto" resolves to another).
    const nlohmann::json results = nlohmann::json::parse(std::ifstream(out));
    size_t hybridRecords = 0;
    // Every binary kernel reads its nodes through texels on a CPU device (NodeFetch), the 8-wide
    // tree always through storage.
    const bool cpuDevice = results["machine"]["gpu_type"] == "CPU";
    for (const nlohmann::json& record : results["records"]) {
        if (record["tracer"] == "gpu-cwbvh")
            EXPECT_EQ(record["node_fetch"], "storage") << record.dump();
        else
            EXPECT_EQ(record["node_fetch"], cpuDevice ? "texel" : "storage") << record.dump();
        if (record["kernel"] != "hybrid") continue;
        ++hybridRecords;
        EXPECT_EQ(record["hybrid_packets_per_group"], record["hybrid_packets_per_group_requested"]) << record.dump();
    }
    EXPECT_EQ(hybridRecords, 8u);  // K = 8 and 9, one and four a workgroup, primary and shadow
    const fs::path table = scratch() / "hybrid-gap.md";
    const std::string command = "/usr/bin/python3 '" + std::string(RAYPACK_SOURCE_DIR) +
                                "/scripts/hybrid-gap-report' " + quoted(out) + " > " + quoted(table) + " 2>&1";
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
    std::stringstream text;
    text << std::ifstream(table).rdbuf();
    const std::string md = text.str();
    EXPECT_NE(md.find("Packets 8x1; K = 8 against K = 9"), std::string::npos) << md;
    EXPECT_NE(md.find("4 packets a workgroup against the single-ray kernel in 8x4"), std::string::npos) << md;
    size_t rows = 0;
    std::istringstream lines(md);
    for (std::string line; std::getline(lines, line);) {
        if (line.rfind("| gen:", 0) != 0) continue;
        ++rows;
        // The cells between '|': scene, rays, then the ratios; N_TR "single / K=9 / K=8" is the
        // third from the end.
        std::vector<std::string> cells;
        for (size_t at = 1, next; (next = line.find('|', at)) != std::string::npos; at = next + 1)
            cells.push_back(line.substr(at, next - at));
        ASSERT_EQ(cells.size(), 13u) << line;
        for (size_t c = 3; c <= 9; ++c) EXPECT_EQ(cells[c].find('-'), std::string::npos) << "missing cell: " << line;
        std::istringstream ntr(cells[10]);
        std::string single, slash, root;
        ntr >> single >> slash >> root;
        EXPECT_EQ(single, root) << "N_TR of the root-split hybrid against the single-ray kernel: " << line;
    }
    EXPECT_EQ(rows, 2u) << md;  // primary and shadow rays
}

// The trade suite's quick variant (issue 15), run once for the whole program (about 20-30 s on 2
// cores with lavapipe): every cell of its matrix, every record with every field, the accuracy
// fields on primary records only, leaks only on the closed scenes, and none on the robust path.
const json& tradeQuickResults() {
    static const json results = [] {
        const fs::path out = scratch() / "trade-quick.json";
        const CliResult r = runCli("bench --suite trade-quick --out " + quoted(out));
        EXPECT_EQ(r.exitCode, 0) << r.output;
        if (r.exitCode != 0) return json();
        return readJsonFile(out.string());
    }();
    return results;
}

TEST(Bench, TradeQuickSuiteRecordsHaveTheTradeFields) {
    const json& results = tradeQuickResults();
    ASSERT_TRUE(results.is_object());
    const json& settings = results.at("settings");
    EXPECT_EQ(settings.at("suite"), "trade-quick");
    EXPECT_EQ(settings.at("intersect"), json::array({"robust", "fast"}));
    const json& trade = settings.at("trade");
    const size_t builds = trade.at("builds").size();
    ASSERT_GE(builds, 2u);
    EXPECT_EQ(trade.at("builds")[0].at("builder"), "sah-exact");
    EXPECT_EQ(trade.at("builds")[0].at("leaf_size"), 1);
    const std::vector<std::string> tracers = trade.at("tracers");
    std::set<std::string> scenes, closedScenes;
    // (scene, build, tracer, intersect, ray kind)
    std::set<std::tuple<std::string, std::string, std::string, std::string, std::string>> cells;
    for (const json& r : results.at("records")) {
        const std::string scene = r.at("scene"), build = r.at("build"), tracer = r.at("tracer");
        const std::string mode = r.at("intersect"), kind = r.at("ray_kind");
        EXPECT_TRUE(mode == "robust" || mode == "fast") << mode;
        scenes.insert(scene);
        const bool closed = r.at("closed").get<bool>();
        if (closed) closedScenes.insert(scene);
        EXPECT_TRUE(cells.emplace(scene, build, tracer, mode, kind).second) << "twice: " << r.dump();
        for (const char* key : kTable1Keys) expectFiniteNumber(r, key);
        for (const char* key : kTable2Keys) expectFiniteNumber(r, key);
        EXPECT_GT(r.at("perf_mrays_s").get<double>(), 0.0) << r.dump();
        EXPECT_GT(r.at("bvh_bytes_per_triangle").get<double>(), 0.0) << r.dump();
        EXPECT_EQ(r.at("reference_build").get<bool>(), build == "sah-exact leaf 1") << r.dump();
        if (r.at("builder") == "sah-binned") {
            EXPECT_GE(r.at("bin_count").get<int>(), 2);
        }
        if (kind == "shadow") {
            for (const char* key : {"rays_leaked", "t_rel_error_max", "pixels_differing"})
                EXPECT_FALSE(r.contains(key)) << key << " on a shadow record: " << r.dump();
            continue;
        }
        const uint64_t pixels = r.at("width_px").get<uint64_t>() * r.at("height_px").get<uint64_t>();
        expectFiniteNumber(r, "t_rel_error_max");
        expectFiniteNumber(r, "t_rel_error_p999");
        EXPECT_GT(r.at("t_error_hits").get<uint64_t>(), 0u) << r.dump();
        EXPECT_LE(r.at("t_error_hits").get<uint64_t>(), pixels);
        EXPECT_GE(r.at("t_rel_error_p999").get<double>(), 0.0);
        EXPECT_LE(r.at("t_rel_error_p999").get<double>(), r.at("t_rel_error_max").get<double>());
        if (mode == "robust") {
            EXPECT_LE(r.at("t_rel_error_max").get<double>(), 1e-5) << "issue 15's bar: " << r.dump();
        }
        EXPECT_EQ(r.contains("rays_leaked"), closed) << r.dump();
        EXPECT_EQ(r.contains("rays_leaked_per_million"), closed) << r.dump();
        if (closed) {
            EXPECT_LE(r.at("rays_leaked").get<uint64_t>(), pixels);
            // Every lattice ray crosses a shared vertex or edge: the fast path (Moller-Trumbore)
            // lets some through, the watertight one none.
            if (mode == "fast" && scene == "lattice") {
                EXPECT_GT(r.at("rays_leaked").get<uint64_t>(), 0u) << "the trade is real: " << r.dump();
            }
            if (mode == "robust") {
                EXPECT_EQ(r.at("rays_leaked").get<uint64_t>(), 0u) << "robust leaked: " << r.dump();
                EXPECT_EQ(r.at("t_error_hits").get<uint64_t>(), pixels) << "every ray hits: " << r.dump();
            }
        }
        ASSERT_TRUE(r.at("pixels_differing").is_number_unsigned()) << r.dump();
        EXPECT_LE(r.at("pixels_differing").get<uint64_t>(), pixels);
        EXPECT_LE(r.at("hits_differing").get<uint64_t>(), pixels);
        expectFiniteNumber(r, "pixels_differing_share");
        if (mode == "robust" && build == "sah-exact leaf 1") {
            EXPECT_EQ(r.at("pixels_differing").get<uint64_t>(), 0u) << "the reference itself: " << r.dump();
        }
    }
    EXPECT_GE(scenes.size(), 2u);
    EXPECT_GE(closedScenes.size(), 1u);
    EXPECT_LT(closedScenes.size(), scenes.size()) << "no scene without the leak field";
    // Every build x tracer x mode x kind on every scene, and the CPU reference at the reference build.
    std::set<std::string> buildLabels;
    for (const auto& cell : cells) buildLabels.insert(std::get<1>(cell));
    EXPECT_EQ(buildLabels.size(), builds);
    for (const std::string& scene : scenes)
        for (const char* mode : {"robust", "fast"})
            for (const char* kind : {"primary", "shadow"}) {
                EXPECT_TRUE(cells.count({scene, "sah-exact leaf 1", "cpu-reference", mode, kind})) << scene;
                for (const std::string& build : buildLabels)
                    for (const std::string& tracer : tracers)
                        EXPECT_TRUE(cells.count({scene, build, tracer, mode, kind}))
                            << scene << ", " << build << ", " << tracer << ", " << mode << ", " << kind;
            }
    EXPECT_EQ(cells.size(), scenes.size() * 2 * 2 * (builds * tracers.size() + 1));
}

TEST(Bench, ReportScriptDrawsTheTradeFronts) {
    const json& results = tradeQuickResults();
    ASSERT_TRUE(results.is_object());
    const fs::path json = scratch() / "trade-quick.json";
    const fs::path markdown = scratch() / "trade.md";
    const fs::path images = scratch() / "img";
    std::ofstream(markdown) << "# Trade\n";
    const std::string script = std::string(RAYPACK_SOURCE_DIR) + "/scripts/bench-report";
    const std::string command = "/usr/bin/python3 '" + script + "' " + quoted(json) + " --markdown " +
                                quoted(markdown) + " --img-dir " + quoted(images) + " > /dev/null 2>&1";
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
    std::stringstream text;
    text << std::ifstream(markdown).rdbuf();
    const std::string md = text.str();
    for (const char* expected : {"bench-report:begin trade-quick", "Pareto", "rays leaked per million",
                                 "trade-quick-build-vs-trace.png", "trade-quick-frames.png", "trade-quick-leaks.png"})
        EXPECT_NE(md.find(expected), std::string::npos) << expected << " in\n" << md;
    for (const char* figure : {"trade-quick-build-vs-trace.png", "trade-quick-frames.png", "trade-quick-leaks.png"})
        EXPECT_GT(fs::file_size(images / figure), 1000u) << figure;
}

TEST(Bench, BadArgumentsGiveOneClearLineAndExitCodeTwo) {
    for (const auto& [args, mentions] : std::vector<std::pair<std::string, std::string>>{
             {"bench --suite nope", "--suite"},
             {"bench --suite quick --packets 0x3", "--packets"},
             {"bench --suite report --scene-dir /no/such/folder", "/no/such/folder"},
             {"bench --scenes gen:terrain:1k --suite quick", "either --scenes or --suite"},
             {"bench --scenes /no/such/scene.ply --device cpu", "/no/such/scene.ply"},
             {"bench --suite trade-quick --builder sah-exact", "--builder"},
             {"bench --suite quick --intersect robust,fast", "--intersect"},
             {"bench --suite trade-quick --intersect sloppy", "sloppy"},
             {"bench --suite trade-quick --build-repeat 3", "--build-repeat"},
             {"bench --scenes gen:terrain:1k --builder gpu-lbvh --build-repeat 3", "--build-repeat"},
         }) {
        const CliResult r = runCli(args);
        EXPECT_EQ(r.exitCode, 2) << args << ":\n" << r.output;
        EXPECT_NE(r.output.find(mentions), std::string::npos) << args << ":\n" << r.output;
    }
}

}  // namespace
}  // namespace raypack::test
