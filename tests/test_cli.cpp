// raypack-cli end to end: the built program run as a user runs it, on the default scene and small
// images (lavapipe and the CPU reference are slow; 96x64 keeps each run well under a second).
#include "cli_runner.h"

#include "renderer/bvh.h"
#include "renderer/cpu_tracer.h"
#include "renderer/hits_io.h"
#include "renderer/image.h"
#include "renderer/settings_json.h"
#include "scenes/load.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace raypack::test {
namespace {

namespace fs = std::filesystem;

// The bundled default scene; the generator spec of the very same scene while the file has not been
// generated into the source tree (scenes/generators.h: default.ply is makeDefaultScene()).
std::string defaultScene() {
    const fs::path file = fs::path(RAYPACK_SOURCE_DIR) / "scenes" / "data" / "default.ply";
    return fs::exists(file) ? file.string() : std::string("gen:default");
}

const ScratchDir& scratch() {
    static ScratchDir dir("raypack-test-cli");
    return dir;
}

// An error is reported on one line naming the problem, with the documented exit code 2, and never
// as a crash or an internal check.
void expectCleanError(const CliResult& r, const std::string& mentions) {
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_NE(r.output.find(mentions), std::string::npos) << "expected \"" << mentions << "\" in:\n" << r.output;
    EXPECT_EQ(r.output.find("internal check failed"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("terminate"), std::string::npos) << r.output;
}

TEST(Cli, EverySubcommandHasHelpAndExitsZero) {
    for (const char* command : {"", "render", "stats", "diff", "generate", "bench"}) {
        const CliResult r = runCli(std::string(command) + " --help");
        EXPECT_EQ(r.exitCode, 0) << command << ":\n" << r.output;
        EXPECT_NE(r.output.find("Usage"), std::string::npos) << command << ":\n" << r.output;
    }
    // The help says what is printed, with units.
    EXPECT_NE(runCli("render --help").output.find("Mrays/s"), std::string::npos);
    EXPECT_NE(runCli("diff --help").output.find("Exit code"), std::string::npos);
}

TEST(Cli, RenderWritesImageHitsAndJsonThatAgreeWithTheReference) {
    const fs::path png = scratch() / "render.png";
    const fs::path hits = scratch() / "render.hits";
    const fs::path json = scratch() / "render.json";
    const uint32_t width = 96, height = 64;  // not square, so that a transposition shows
    const CliResult r = runCli("render " + defaultScene() + " --width 96 --height 64 --out " + quoted(png) +
                               " --hits " + quoted(hits) + " --json " + quoted(json));
    ASSERT_EQ(r.exitCode, 0) << r.output;
    for (const char* printed : {"device", "Table 1", "Table 2", "primary", "shadow", "N_L"})
        EXPECT_NE(r.output.find(printed), std::string::npos) << printed << " in\n" << r.output;

    const Image image = readPng(png.string());
    EXPECT_EQ(image.width, width);
    EXPECT_EQ(image.height, height);

    // Hits file: header, size, and values a ray tracer can produce.
    EXPECT_EQ(fs::file_size(hits), kHitsHeaderBytes + size_t(width) * height * kHitsRecordBytes);
    const HitsFile file = readHits(hits.string());
    ASSERT_EQ(file.width, width);
    ASSERT_EQ(file.height, height);
    ASSERT_EQ(file.records.size(), size_t(width) * height);

    const nlohmann::json stats = readJsonFile(json.string());
    const RenderSetup setup = renderSetupFromJson(stats);
    const glm::vec3 eye = setup.settings.camera.eye;
    const Scene scene = openScene(setup.scene);
    const Bvh bvh = buildBvh(scene, setup.bvh);
    size_t hitCount = 0;
    for (const HitRecord& h : file.records) {
        EXPECT_EQ(glm::vec3(h.orgX, h.orgY, h.orgZ), eye);
        EXPECT_NEAR(glm::length(glm::vec3(h.dirX, h.dirY, h.dirZ)), 1.0f, 1e-5f);
        EXPECT_EQ(h.reserved, 0u);
        if (h.prim == gpu::kNoHit) {
            EXPECT_TRUE(std::isinf(h.t));
            EXPECT_EQ(h.shadow, gpu::kShadowNone);
        } else {
            ++hitCount;
            EXPECT_LT(h.prim, scene.triangleCount());
            EXPECT_TRUE(std::isfinite(h.t) && h.t > 0.0f);
            EXPECT_TRUE(h.shadow == gpu::kShadowLit || h.shadow == gpu::kShadowOccluded);
        }
    }
    // The default framing puts the scene in view.
    EXPECT_GT(hitCount, file.records.size() / 10);
    // Every 37th ray traced again through the library gives the same closest hit.
    for (size_t i = 0; i < file.records.size(); i += 37) {
        const HitRecord& h = file.records[i];
        const HitRecord again =
            traceClosest(scene, bvh, glm::vec3(h.orgX, h.orgY, h.orgZ), glm::vec3(h.dirX, h.dirY, h.dirZ));
        EXPECT_EQ(again.prim, h.prim) << "pixel " << i;
        if (h.prim != gpu::kNoHit) {
            EXPECT_EQ(again.t, h.t) << "pixel " << i;
        }
    }

    // JSON: every statistic with its unit, finite.
    const auto& table1 = stats.at("table1");
    for (const char* key :
         {"n_l_leaves", "d_avg_leaf_depth", "d_max_leaf_depth", "o_avg_prims_per_leaf", "t_b_s", "nodes", "sah_cost",
          "bvh_bytes", "triangles", "degenerate_triangles", "t_load_s", "load_mb_s"})
        EXPECT_TRUE(table1.at(key).is_number()) << key;
    EXPECT_EQ(table1.at("triangles").get<uint64_t>(), scene.triangleCount());
    EXPECT_EQ(table1.at("n_l_leaves").get<uint32_t>(), bvh.stats.leafCount);
    for (const char* kind : {"primary", "shadow"}) {
        const auto& row = stats.at("table2").at(kind);
        for (const char* key : {"t_r_us_per_ray", "n_it_tests_per_ray", "n_tr_nodes_per_ray", "n_q_rays", "t_f_s",
                                "t_cu_s", "t_k_s", "perf_mrays_s", "perf_with_upload_mrays_s"}) {
            ASSERT_TRUE(row.at(key).is_number()) << kind << "." << key;
            EXPECT_TRUE(std::isfinite(row.at(key).get<double>())) << kind << "." << key;
        }
    }
    EXPECT_EQ(stats["table2"]["primary"]["n_q_rays"].get<uint64_t>(), uint64_t(width) * height);
    EXPECT_EQ(stats["table2"]["shadow"]["n_q_rays"].get<uint64_t>(), hitCount);
}

TEST(Cli, FromReproducesTheSameImageAndFlagsOverrideIt) {
    const fs::path a = scratch() / "from-a.png";
    const fs::path b = scratch() / "from-b.png";
    const fs::path c = scratch() / "from-c.png";
    const fs::path side = scratch() / "from.json";
    ASSERT_EQ(runCli("render " + defaultScene() +
                     " --width 80 --height 60 --eye 3,2.5,4 --at 0,0.5,0 --fov 50 "
                     "--light-height 0.5 --leaf-size 4 --out " +
                     quoted(a) + " --json " + quoted(side))
                  .exitCode,
              0);
    const CliResult again = runCli("render --from " + quoted(side) + " --out " + quoted(b));
    ASSERT_EQ(again.exitCode, 0) << again.output;
    const CliResult same = runCli("diff " + quoted(a) + " " + quoted(b));
    EXPECT_EQ(same.exitCode, 0) << same.output;
    EXPECT_NE(same.output.find("0 of 4800"), std::string::npos) << same.output;

    // A flag given beside --from wins over the file.
    ASSERT_EQ(runCli("render --from " + quoted(side) + " --no-shadows --out " + quoted(c)).exitCode, 0);
    EXPECT_EQ(runCli("diff " + quoted(a) + " " + quoted(c)).exitCode, 1);
}

TEST(Cli, DiffCountsDifferencesAndHasDocumentedExitCodes) {
    Image base;
    base.width = 4;
    base.height = 3;
    base.rgba.assign(12, 0xFF204060u);
    Image changed = base;
    changed.rgba[5] = 0xFF204070u;  // one pixel, blue channel +16
    const fs::path a = scratch() / "diff-a.png", b = scratch() / "diff-b.png";
    const fs::path small = scratch() / "diff-small.png", out = scratch() / "diff-out.png";
    writePng(a.string(), base);
    writePng(b.string(), changed);
    writePng(small.string(), 2, 2, std::vector<uint32_t>(4, 0xFF000000u));

    const CliResult same = runCli("diff " + quoted(a) + " " + quoted(a));
    EXPECT_EQ(same.exitCode, 0) << same.output;
    EXPECT_NE(same.output.find("inf dB"), std::string::npos) << same.output;

    const CliResult differ = runCli("diff " + quoted(a) + " " + quoted(b) + " --out " + quoted(out));
    EXPECT_EQ(differ.exitCode, 1) << differ.output;
    EXPECT_NE(differ.output.find("1 of 12"), std::string::npos) << differ.output;
    EXPECT_NE(differ.output.find("max channel diff   16"), std::string::npos) << differ.output;
    const Image difference = readPng(out.string());
    EXPECT_EQ(difference.width, 4u);
    EXPECT_EQ(difference.height, 3u);

    // Within the threshold the images count as equal.
    EXPECT_EQ(runCli("diff " + quoted(a) + " " + quoted(b) + " --threshold 16").exitCode, 0);

    expectCleanError(runCli("diff " + quoted(a) + " " + quoted(small)), "diff-small.png");
    expectCleanError(runCli("diff " + quoted(a) + " " + quoted(scratch() / "missing.png")), "missing.png");
    expectCleanError(runCli("diff " + quoted(a)), "B");
}

// render --device gpu with a device builder and a camera builds in the GPU tracer's own buffers
// (no host tree): its hits are the CPU reference's over the same builder's downloaded tree, and
// Table 1 carries the device's statistics. Without a camera the start view needs the tree on the
// host, and the tree is downloaded as before.
TEST(Cli, RenderWithADeviceBuilderBuildsInTheTracer) {
    const std::string camera = " --eye 0.5,3,-4 --at 0,0,0 --width 64 --height 48 --builder gpu-lbvh";
    const fs::path gpuHits = scratch() / "own-build-gpu.hits", cpuHits = scratch() / "own-build-cpu.hits";
    const CliResult own =
        runCli("render gen:terrain:10k --device gpu --kernel single" + camera + " --hits " + quoted(gpuHits));
    ASSERT_EQ(own.exitCode, 0) << own.output;
    EXPECT_NE(own.output.find("built in the tracer's own buffers"), std::string::npos) << own.output;
    EXPECT_NE(own.output.find("built on the device in"), std::string::npos) << own.output;
    const CliResult reference = runCli("render gen:terrain:10k --device cpu" + camera + " --hits " + quoted(cpuHits));
    ASSERT_EQ(reference.exitCode, 0) << reference.output;
    const HitsFile a = readHits(gpuHits.string()), b = readHits(cpuHits.string());
    ASSERT_EQ(a.records.size(), b.records.size());
    size_t same = 0;
    for (size_t i = 0; i < a.records.size(); ++i)
        same += a.records[i].prim == b.records[i].prim && a.records[i].shadow == b.records[i].shadow;
    EXPECT_GE(double(same), 0.9999 * double(a.records.size())) << same << " of " << a.records.size();
    const CliResult framed = runCli("render gen:terrain:10k --device gpu --width 32 --height 24 --builder gpu-lbvh");
    ASSERT_EQ(framed.exitCode, 0) << framed.output;
    EXPECT_EQ(framed.output.find("built in the tracer's own buffers"), std::string::npos) << framed.output;
}

// --bvh-width 8 (docs/cli.md): the same hits as the binary tree, with a device builder too (its tree
// downloaded and collapsed); refused where it does not apply; a settings file's 8-wide tree is
// dropped for the CPU.
TEST(Cli, BvhWidthEightGivesTheBinaryTreesHits) {
    const std::string camera = " --eye 0.5,3,-4 --at 0,0,0 --width 64 --height 48";
    for (const char* builder : {"sah-exact", "gpu-lbvh"}) {
        const fs::path binary = scratch() / "width-2.hits", wide = scratch() / "width-8.hits";
        const std::string common =
            "render gen:terrain:10k --device gpu --kernel single --builder " + std::string(builder) + camera;
        const CliResult two = runCli(common + " --hits " + quoted(binary));
        ASSERT_EQ(two.exitCode, 0) << two.output;
        const CliResult eight = runCli(common + " --bvh-width 8 --hits " + quoted(wide));
        ASSERT_EQ(eight.exitCode, 0) << eight.output;
        EXPECT_NE(eight.output.find("compressed 8-wide"), std::string::npos) << eight.output;
        const HitsFile a = readHits(binary.string()), b = readHits(wide.string());
        ASSERT_EQ(a.records.size(), b.records.size());
        EXPECT_EQ(std::memcmp(a.records.data(), b.records.data(), a.records.size() * sizeof(HitRecord)), 0) << builder;
    }
    expectCleanError(runCli("render gen:terrain:1k --device cpu --bvh-width 8 --width 8 --height 8"), "--bvh-width");
    expectCleanError(runCli("render gen:terrain:1k --device gpu --kernel packet --bvh-width 8 --width 8 --height 8"),
                     "--bvh-width");
    expectCleanError(runCli("render gen:terrain:1k --device gpu --kernel single --bvh-width 4 --width 8 --height 8"),
                     "--bvh-width");
    expectCleanError(runCli("render gen:terrain:1k --device gpu --kernel single --bvh-width 8 --shadow-order tree "
                            "--width 8 --height 8"),
                     "--shadow-order");
    const fs::path json = scratch() / "width-8.json";
    ASSERT_EQ(runCli("render gen:terrain:1k --device gpu --kernel single --bvh-width 8 --width 16 --height 12 --json " +
                     quoted(json))
                  .exitCode,
              0);
    const CliResult cpu = runCli("render --from " + quoted(json) + " --device cpu");
    EXPECT_EQ(cpu.exitCode, 0) << cpu.output;
}

// The hybrid kernel's flags (docs/gpu.md): GPU only, with --kernel hybrid only, ratios in range.
TEST(Cli, HybridFlagsApplyToTheHybridKernelOnly) {
    expectCleanError(runCli("render gen:terrain:1k --kernel hybrid --width 8 --height 8"), "--device gpu");
    expectCleanError(runCli("render gen:terrain:1k --device gpu --kernel packet --hybrid-min-rays 4"),
                     "--hybrid-min-rays");
    expectCleanError(runCli("render gen:terrain:1k --device gpu --kernel hybrid --hybrid-visit-ratio 5000"),
                     "--hybrid-visit-ratio");
    expectCleanError(runCli("bench --suite quick --device gpu --kernel hybrid --hybrid-min-rays 1/0"),
                     "--hybrid-min-rays");
    expectCleanError(runCli("bench --suite quick --device gpu --kernel hybrid --hybrid-visit-ratios 0.5"),
                     "--hybrid-visit-ratios");
    expectCleanError(runCli("bench --suite quick --device gpu --kernel hybrid --hybrid-packets-per-group 1,0"),
                     "--hybrid-packets-per-group");
    expectCleanError(runCli("render gen:terrain:1k --device gpu --kernel packet --hybrid-packets-per-group 2"),
                     "--hybrid-packets-per-group");
    expectCleanError(runCli("render gen:terrain:1k --device gpu --kernel hybrid --hybrid-packets-per-group 65"),
                     "--hybrid-packets-per-group");
    expectCleanError(runCli("bench --suite quick --only Sibenik"), "Sibenik");
}

// The hybrid kernel's packets per workgroup: `render` says how many ran and whether "auto" chose
// them (one for 16x16 packets, which span several subgroups on every device; docs/gpu.md), and
// runs a count it is given.
TEST(Cli, RenderSaysHowManyHybridPacketsShareAWorkgroup) {
    const CliResult automatic =
        runCli("render gen:terrain:1k --device gpu --kernel hybrid --packet 16x16 --width 16 --height 16");
    ASSERT_EQ(automatic.exitCode, 0) << automatic.output;
    EXPECT_NE(automatic.output.find("1 packet a workgroup (auto)"), std::string::npos) << automatic.output;
    const CliResult three = runCli(
        "render gen:terrain:1k --device gpu --kernel hybrid --packet 8x1 "
        "--hybrid-packets-per-group 3 --width 16 --height 8");
    ASSERT_EQ(three.exitCode, 0) << three.output;
    EXPECT_NE(three.output.find("3 packets a workgroup\n"), std::string::npos) << three.output;
}

TEST(Cli, BadInputGivesOneClearLineAndExitCodeTwo) {
    const fs::path garbage = scratch() / "garbage.ply";
    std::ofstream(garbage) << "ply\nformat binary_little_endian 1.0\nelement vertex 1000000\n"
                              "property float x\nproperty float y\nproperty float z\nend_header\n"
                              "not nearly enough bytes";
    expectCleanError(runCli("render " + quoted(scratch() / "no-such-scene.ply")), "no-such-scene.ply");
    expectCleanError(runCli("render " + quoted(garbage) + " --width 8 --height 8"), "garbage.ply");
    expectCleanError(runCli("stats " + quoted(garbage)), "garbage.ply");
    expectCleanError(runCli("render gen:terrain:1k --width abc"), "--width");
    expectCleanError(runCli("render gen:terrain:1k --eye 1,2"), "--eye");
    expectCleanError(runCli("render gen:terrain:1k --eye 1,2,3 --at 1,2,3 --width 8 --height 8"), "camera");
    expectCleanError(runCli("render gen:terrain:1k --packet 0x4"), "--packet");
    expectCleanError(runCli("render gen:terrain:1k --kernel warp"), "--kernel");
    expectCleanError(runCli("render gen:terrain:1k --device tpu"), "--device");
    expectCleanError(runCli("stats gen:terrain:1k --builder magic"), "magic");
    expectCleanError(runCli("render gen:nothing:5"), "gen:nothing:5");
    expectCleanError(runCli("render --from " + quoted(scratch() / "absent.json")), "absent.json");
    const fs::path badJson = scratch() / "bad.json";
    std::ofstream(badJson) << R"({"scene": "gen:terrain:1k", "camera": {"fov_y_degrees": "wide"}})";
    expectCleanError(runCli("render --from " + quoted(badJson)), "camera.fov_y_degrees");
    expectCleanError(runCli("frobnicate"), "frobnicate");
    expectCleanError(runCli("render gen:terrain:1k --view tests --heat-scale 0 --width 8 --height 8"),
                     "--heat-scale: \"0\" is not a finite number above 0");
    expectCleanError(runCli("diff a.png"), "see raypack-cli diff --help");
    // Output names are refused before anything is read or made: the images do not exist.
    expectCleanError(runCli("diff " + quoted(scratch() / "absent-a.png") + " " + quoted(scratch() / "absent-b.png") +
                            " --out " + quoted(scratch() / "d.bmp")),
                     "--out");
    expectCleanError(runCli("generate gen:nothing:5 " + quoted(scratch() / "scene.obj")), "must end in .ply");
    expectCleanError(runCli("render gen:terrain:1k --device gpu --gpu no-such-device-name "
                            "--width 8 --height 8"),
                     "no-such-device-name");
}

// The "camera" line of a render's output: "--eye X --at Y ..." and what came from the start view.
std::string cameraLine(const CliResult& r) {
    const size_t at = r.output.find("camera     --eye ");
    return at == std::string::npos ? std::string() : r.output.substr(at, r.output.find('\n', at) - at);
}
// The value after `flag` in a camera line ("1,2,3").
std::string cameraValue(const std::string& line, const std::string& flag) {
    const size_t at = line.find(flag + " ");
    if (at == std::string::npos) return {};
    const size_t begin = at + flag.size() + 1;
    return line.substr(begin, line.find(' ', begin) - begin);
}

TEST(Cli, EyeOrAtAloneKeepsTheOtherPointOfTheStartView) {
    const std::string render = "render gen:terrain:1k --width 8 --height 8";
    const std::string start = cameraLine(runCli(render));
    ASSERT_NE(start.find("(start view)"), std::string::npos) << start;
    const std::string eyeOnly = cameraLine(runCli(render + " --eye 1,2,3"));
    EXPECT_EQ(cameraValue(eyeOnly, "--eye"), "1,2,3") << eyeOnly;
    EXPECT_EQ(cameraValue(eyeOnly, "--at"), cameraValue(start, "--at")) << eyeOnly << "\n" << start;
    EXPECT_NE(eyeOnly.find("(--at of the start view)"), std::string::npos) << eyeOnly;
    const std::string atOnly = cameraLine(runCli(render + " --at 0,0.5,0"));
    EXPECT_EQ(cameraValue(atOnly, "--at"), "0,0.5,0") << atOnly;
    EXPECT_EQ(cameraValue(atOnly, "--eye"), cameraValue(start, "--eye")) << atOnly << "\n" << start;
    EXPECT_NE(atOnly.find("(--eye of the start view)"), std::string::npos) << atOnly;
    const std::string both = cameraLine(runCli(render + " --eye 1,2,3 --at 0,0.5,0"));
    EXPECT_EQ(both.find("start view"), std::string::npos) << both;
}

TEST(Cli, StatsPrintsTable1AsJson) {
    const CliResult r = runCli("stats gen:terrain:2k --leaf-size 3 --json");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const nlohmann::json row = nlohmann::json::parse(r.output);
    EXPECT_EQ(row.at("leaf_size").get<uint32_t>(), 3u);
    EXPECT_LE(row.at("triangles").get<uint64_t>(), 2000u);
    EXPECT_GT(row.at("n_l_leaves").get<uint64_t>(), 0u);
    EXPECT_LE(row.at("o_avg_prims_per_leaf").get<double>(), 3.0);
    EXPECT_GE(row.at("d_max_leaf_depth").get<double>(), row.at("d_avg_leaf_depth").get<double>());
    const CliResult text = runCli("stats gen:terrain:2k");
    EXPECT_EQ(text.exitCode, 0);
    EXPECT_NE(text.output.find("D_AVG"), std::string::npos) << text.output;
}

// Issue 10: --out x.jpg wrote PNG bytes into a .jpg.
TEST(Cli, RenderWritesJpegForJpgAndRefusesUnknownExtensionsBeforeRendering) {
    for (const char* name : {"render.jpg", "render.JPEG"}) {
        const fs::path jpg = scratch() / name;
        const CliResult r = runCli("render gen:terrain:1k --width 32 --height 24 --out " + quoted(jpg));
        ASSERT_EQ(r.exitCode, 0) << r.output;
        std::ifstream file(jpg, std::ios::binary);
        unsigned char magic[3] = {};
        file.read(reinterpret_cast<char*>(magic), 3);
        EXPECT_EQ(magic[0], 0xFF) << name;  // JPEG start-of-image marker FF D8 FF
        EXPECT_EQ(magic[1], 0xD8) << name;
        EXPECT_EQ(magic[2], 0xFF) << name;
    }
    const fs::path bmp = scratch() / "render.bmp";
    const CliResult r = runCli("render gen:terrain:1k --width 32 --height 24 --out " + quoted(bmp));
    expectCleanError(r, "unknown image format \".bmp\"");
    EXPECT_EQ(r.output.find("Table 1"), std::string::npos) << "rendered before refusing:\n" << r.output;
    EXPECT_FALSE(fs::exists(bmp));
}

// Issue 10: --out into a missing folder failed only after the whole render.
TEST(Cli, RenderIntoAMissingFolderFailsBeforeLoading) {
    for (const char* flag : {"--out", "--hits", "--json"}) {
        const std::string target = (scratch() / "missing-dir" / "x.png").string();
        const CliResult r = runCli("render gen:terrain:1k --width 32 --height 24 " + std::string(flag) + " " +
                                   quoted(fs::path(target)));
        expectCleanError(r, std::string(flag) + " " + target + ": the folder");
        EXPECT_NE(r.output.find("does not exist"), std::string::npos) << r.output;
        EXPECT_EQ(r.output.find("scene "), std::string::npos) << flag << " loaded the scene first:\n" << r.output;
    }
}

// Issue 10: stats of a .gltf reported MB/s of the JSON alone, without its .bin and images.
TEST(Cli, StatsOfAGltfCountsItsBuffersAndImages) {
    const fs::path folder = fs::path(RAYPACK_SHARED_SCENES) / "gltf" / "Duck" / "glTF";
    const CliResult r = runCli("stats " + quoted(folder / "Duck.gltf") + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const nlohmann::json row = nlohmann::json::parse(r.output);
    const uint64_t expected = fs::file_size(folder / "Duck.gltf") + fs::file_size(folder / "Duck0.bin") +
                              fs::file_size(folder / "DuckCM.png");
    EXPECT_EQ(row.at("input_bytes").get<uint64_t>(), expected);
    EXPECT_EQ(row.at("textures").get<uint64_t>(), 1u);
    EXPECT_GT(row.at("texture_bytes").get<uint64_t>(), 0u);
    const CliResult text = runCli("stats " + quoted(folder / "Duck.gltf"));
    EXPECT_NE(text.output.find("textures   1,"), std::string::npos) << text.output;
}

// Issue 10: scripts/bench-report rewrote the repository's docs/benchmarks.md and docs/img by default.
TEST(Cli, BenchReportWritesNextToTheResultsByDefault) {
    const fs::path folder = scratch() / "my-results";
    fs::create_directories(folder);
    const fs::path results = folder / "mine.json";
    // A minimal result as `bench` writes it: one CPU cell.
    std::ofstream(results)
        << R"({"machine": {"cpu_model": "test CPU", "cpu_threads": 2}, "command": "raypack-cli bench",
      "date": "2026-12-01T00:00:00Z", "settings": {"width_px": 8, "height_px": 8}, "skipped": [], "records": []})";
    const fs::path repositoryMarkdown = fs::path(RAYPACK_SOURCE_DIR) / "docs" / "benchmarks.md";
    const auto before = fs::last_write_time(repositoryMarkdown);
    const std::string command = "/usr/bin/python3 '" + std::string(RAYPACK_SOURCE_DIR) + "/scripts/bench-report' " +
                                quoted(results) + " > /dev/null 2>&1";
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
    EXPECT_TRUE(fs::exists(folder / "benchmarks.md"));
    std::stringstream text;
    text << std::ifstream(folder / "benchmarks.md").rdbuf();
    EXPECT_NE(text.str().find("bench-report:begin mine"), std::string::npos) << text.str();
    EXPECT_EQ(fs::last_write_time(repositoryMarkdown), before);
}

TEST(Cli, GenerateWritesAPlyThatLoadsBackTheSameScene) {
    const fs::path ply = scratch() / "terrain.ply";
    const CliResult r = runCli("generate gen:terrain:3k " + quoted(ply));
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const Scene generated = openScene("gen:terrain:3k");
    const Scene loaded = loadScene(ply);
    EXPECT_EQ(loaded.triangles, generated.triangles);
    EXPECT_EQ(loaded.positions, generated.positions);
    EXPECT_NE(r.output.find(std::to_string(generated.triangleCount()) + " triangles"), std::string::npos) << r.output;
}

TEST(Cli, GpuRenderOnLavapipeWithValidationMatchesTheHitsFormat) {
    const fs::path hits = scratch() / "gpu.hits", json = scratch() / "gpu.json";
    const CliResult r = runCli("render " + defaultScene() +
                               " --device gpu --validation --width 64 --height 48 --packet 5x6 "
                               "--hits " +
                               quoted(hits) + " --json " + quoted(json));
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("validation no messages"), std::string::npos) << r.output;
    const HitsFile file = readHits(hits.string());
    EXPECT_EQ(file.records.size(), 64u * 48u);
    const nlohmann::json stats = readJsonFile(json.string());
    EXPECT_EQ(stats.at("device_kind"), "gpu");
    EXPECT_GT(stats["table2"]["primary"]["t_cu_s"].get<double>(), 0.0);
    EXPECT_EQ(stats.at("packet").at("width").get<uint32_t>(), 5u);
}

TEST(SettingsJson, RoundTripKeepsEveryValueExactly) {
    RenderSetup setup;
    setup.scene = "gen:terrain:1k";
    RenderSettings& s = setup.settings;
    s.width = 321;
    s.height = 123;
    s.camera.eye = glm::vec3(0.1f, -2.3f, 1e-7f);
    s.camera.at = glm::vec3(3.0f, 1.0f / 3.0f, -7.25f);
    s.camera.up = glm::vec3(0.0f, 0.0f, 1.0f);
    s.camera.fovYDegrees = 37.7f;
    s.lightHeight = 0.7f;
    s.shadows = false;
    s.phong = {0.1f, 0.2f, 0.3f, 17.0f};
    s.background = glm::vec3(0.2f, 0.3f, 0.4f);
    s.kernel = KernelKind::Single;
    s.packet = {5, 6};
    s.singleGroup = {4, 32};
    s.singleShadowGroup = {32, 2};
    s.collectCounters = true;
    s.view = ViewMode::HeatIntersections;
    setup.bvh.builder = BvhBuilder::SahBinned;
    setup.bvh.leafSize = 7;
    setup.bvh.traversalCost = 1.5f;
    setup.bvh.intersectionCost = 0.75f;
    setup.bvh.binCount = 16;
    setup.bvh.plocRadius = 7;
    setup.bvh.treeletRounds = 2;
    setup.bvh.treeletGamma = 40;
    setup.bvh.topRebuild = 4096;

    // Through text, as a file would carry it.
    const RenderSetup back = renderSetupFromJson(nlohmann::json::parse(toJson(setup).dump()));
    EXPECT_EQ(back.scene, setup.scene);
    const RenderSettings& b = back.settings;
    EXPECT_EQ(b.width, s.width);
    EXPECT_EQ(b.height, s.height);
    EXPECT_EQ(b.camera.eye, s.camera.eye);
    EXPECT_EQ(b.camera.at, s.camera.at);
    EXPECT_EQ(b.camera.up, s.camera.up);
    EXPECT_EQ(b.camera.fovYDegrees, s.camera.fovYDegrees);
    EXPECT_EQ(b.lightHeight, s.lightHeight);
    EXPECT_EQ(b.shadows, s.shadows);
    EXPECT_EQ(b.phong.ambient, s.phong.ambient);
    EXPECT_EQ(b.phong.diffuse, s.phong.diffuse);
    EXPECT_EQ(b.phong.specular, s.phong.specular);
    EXPECT_EQ(b.phong.shininess, s.phong.shininess);
    EXPECT_EQ(b.background, s.background);
    EXPECT_EQ(b.kernel, s.kernel);
    EXPECT_EQ(b.packet, s.packet);
    EXPECT_EQ(b.singleGroup, s.singleGroup);
    EXPECT_EQ(b.singleShadowGroup, s.singleShadowGroup);
    EXPECT_EQ(b.collectCounters, s.collectCounters);
    EXPECT_EQ(b.view, s.view);
    EXPECT_EQ(back.bvh.builder, setup.bvh.builder);
    EXPECT_EQ(back.bvh.leafSize, setup.bvh.leafSize);
    EXPECT_EQ(back.bvh.plocRadius, setup.bvh.plocRadius);
    EXPECT_EQ(back.bvh.treeletRounds, setup.bvh.treeletRounds);
    EXPECT_EQ(back.bvh.treeletGamma, setup.bvh.treeletGamma);
    EXPECT_EQ(back.bvh.topRebuild, setup.bvh.topRebuild);
    EXPECT_EQ(back.bvh.traversalCost, setup.bvh.traversalCost);
    EXPECT_EQ(back.bvh.intersectionCost, setup.bvh.intersectionCost);
    EXPECT_EQ(back.bvh.binCount, setup.bvh.binCount);

    // Missing keys keep the defaults; unknown keys (a sidecar's "stats") are ignored.
    const RenderSettings defaults = renderSettingsFromJson(nlohmann::json::parse(R"({"stats": {"fps": 3}})"));
    EXPECT_EQ(defaults.width, RenderSettings{}.width);
    EXPECT_EQ(defaults.packet, RenderSettings{}.packet);
}

TEST(SettingsJson, BadValuesNameTheKey) {
    const auto errorOf = [](const char* text) -> std::string {
        try {
            renderSetupFromJson(nlohmann::json::parse(text));
        } catch (const Error& e) {
            return e.what();
        }
        return "no error";
    };
    EXPECT_NE(errorOf(R"([1, 2])").find("object"), std::string::npos);
    EXPECT_NE(errorOf(R"({"width": -3})").find("width"), std::string::npos);
    EXPECT_NE(errorOf(R"({"width": 0})").find("width"), std::string::npos);
    EXPECT_NE(errorOf(R"({"camera": {"eye": [1, 2]}})").find("camera.eye"), std::string::npos);
    EXPECT_NE(errorOf(R"({"camera": {"fov_y_degrees": 200}})").find("fov"), std::string::npos);
    EXPECT_NE(errorOf(R"({"kernel": "warp"})").find("kernel"), std::string::npos);
    EXPECT_NE(errorOf(R"({"view": "xray"})").find("view"), std::string::npos);
    EXPECT_NE(errorOf(R"({"packet": {"width": 0, "height": 4}})").find("packet"), std::string::npos);
    EXPECT_NE(errorOf(R"({"single_group": {"width": 8, "height": 0}})").find("single_group"), std::string::npos);
    EXPECT_NE(errorOf(R"({"shadows": "yes"})").find("shadows"), std::string::npos);
    EXPECT_NE(errorOf(R"({"bvh": {"builder": "magic"}})").find("bvh.builder"), std::string::npos);
    EXPECT_NE(errorOf(R"({"bvh": {"leaf_size": 0}})").find("bvh.leaf_size"), std::string::npos);
    EXPECT_NE(errorOf(R"({"bvh": {"leaf_size": 5000}})").find("bvh.leaf_size"), std::string::npos);
    EXPECT_NE(errorOf(R"({"bvh": {"bin_count": 1}})").find("bvh.bin_count"), std::string::npos);

    const ScratchDir& dir = scratch();
    std::ofstream(dir / "broken.json") << "{\"width\": 3,";
    try {
        readJsonFile((dir / "broken.json").string());
        ADD_FAILURE() << "no error for broken JSON";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("broken.json"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("byte"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace raypack::test
