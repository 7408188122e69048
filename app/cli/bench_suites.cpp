#include "app/cli/bench_suites.h"

#include "renderer/error.h"
#include "scenes/generators.h"

#include <cstdlib>
#include <filesystem>

namespace raypack::cli {
namespace {

namespace fs = std::filesystem;

Camera camera(glm::vec3 eye, glm::vec3 at, float fov) {
    Camera c;
    c.eye = eye;
    c.at = at;
    c.up = glm::vec3(0.0f, 1.0f, 0.0f);
    c.fovYDegrees = fov;
    return c;
}

// Issue 5's stand-ins for the report's four scenes, with the cameras every tool and machine uses
// so that the figures compare.
std::vector<BenchScene> reportScenes() {
    return {
        {"Sibenik", "sibenik/sibenik_geom_75284.ply", camera({-18, -11, 0}, {0, -8, 0}, 70)},
        {"Sponza", "dabrovic_sponza/sponza.obj", camera({-14, 4, 0}, {10, 5, 0}, 70)},
        {"Conference", "conference/conference_geom.ply", camera({1500, 350, -900}, {0, 150, 0}, 70)},
        {"Armadillo", "stanford/armadillo_decimated_99976.obj", camera({0, 0.1f, 2.4f}, {0, 0, 0}, 45)},
        {"Dragon", "stanford/dragon_vrip_res2.ply", camera({0, 0.14f, 0.32f}, {-0.005f, 0.125f, 0}, 45)},
    };
}

const char* kDragonFile = "stanford/dragon_vrip_res2.ply";

// Issue 15's "far from the origin" and "tiny" placements (scenes/generators.h placeScene): offsets
// that integers survive exactly (float holds every integer below 2^24) and a power-of-two scale.
const glm::vec3 kFarOffset(1.0e5f, 1.0e5f, 1.0e5f);
const char* kFarPlacement = "place:1:100000,100000,100000:";
const float kTinyScale = 0x1p-14f;  // 6.1e-5
const char* kTinyPlacement = "place:6.103515625e-5:0,0,0:";

// The closed scenes, each near the origin, far from it and tiny: an icosphere of `levels` seen from
// its centre, and a lattice whose pixel rays cross vertices and edges (sized to the image).
std::vector<BenchScene> closedScenes(uint32_t levels, uint32_t width, uint32_t height) {
    std::vector<BenchScene> scenes;
    const std::string sphere = "gen:icosphere:" + std::to_string(levels);
    const glm::uvec2 cells = latticeCellsFor(width, height);
    const std::string lattice = "gen:lattice:" + std::to_string(cells.x) + "x" + std::to_string(cells.y);
    const Camera sphereCamera = icosphereCamera(), gridCamera = latticeCamera(width, height);
    scenes.push_back({"icosphere", sphere, sphereCamera, true});
    scenes.push_back({"icosphere far", kFarPlacement + sphere, placeCamera(sphereCamera, 1.0f, kFarOffset), true});
    scenes.push_back(
        {"icosphere tiny", kTinyPlacement + sphere, placeCamera(sphereCamera, kTinyScale, glm::vec3(0.0f)), true});
    scenes.push_back({"lattice", lattice, gridCamera, true});
    scenes.push_back({"lattice far", kFarPlacement + lattice, placeCamera(gridCamera, 1.0f, kFarOffset), true});
    scenes.push_back(
        {"lattice tiny", kTinyPlacement + lattice, placeCamera(gridCamera, kTinyScale, glm::vec3(0.0f)), true});
    return scenes;
}

// Every builder of issue 15 (sah-exact, sah-binned at 8, 16 and 32 bins, sah-split with its
// defaults) at every leaf size of `leafSizes`; sah-exact at the first leaf size first (the
// reference build of the pixel comparisons).
std::vector<BvhBuildOptions> tradeBuilds(const std::vector<BvhBuilder>& builders, const std::vector<uint32_t>& bins,
                                         const std::vector<uint32_t>& leafSizes) {
    std::vector<BvhBuildOptions> builds;
    for (BvhBuilder builder : builders)
        for (uint32_t leaf : leafSizes) {
            BvhBuildOptions o;
            o.builder = builder;
            o.leafSize = leaf;
            if (builder != BvhBuilder::SahBinned) {
                builds.push_back(o);
                continue;
            }
            for (uint32_t b : bins) {
                o.binCount = b;
                builds.push_back(o);
            }
        }
    return builds;
}

}  // namespace

std::string resolveSceneDir(const std::string& explicitDir) {
    std::vector<fs::path> candidates;
    if (!explicitDir.empty()) {
        if (!fs::is_directory(explicitDir)) throw Error("--scene-dir: \"" + explicitDir + "\" is not a folder");
        return explicitDir;
    }
    if (const char* env = std::getenv("RAYPACK_SCENE_DIR"); env && *env) candidates.push_back(env);
    // The configured folder (CMake's RAYPACK_SHARED_SCENES, by default ../shared/scenes beside the
    // source tree). Not derived from __FILE__: ccache's base_dir makes that relative.
    candidates.push_back(RAYPACK_DEFAULT_SCENE_DIR);
    candidates.push_back(fs::current_path() / ".." / "shared" / "scenes");
    std::string tried;
    for (const fs::path& c : candidates) {
        std::error_code error;
        if (fs::is_directory(c, error)) return fs::weakly_canonical(c, error).string();
        tried += (tried.empty() ? "" : ", ") + c.string();
    }
    throw Error("no scene folder found (tried " + tried + "); give --scene-dir DIR or set RAYPACK_SCENE_DIR");
}

BenchSuite benchSuite(const std::string& name, const std::string& sceneDir) {
    BenchSuite suite;
    suite.name = name;
    const auto file = [&](const std::string& relative) {
        const fs::path path = fs::path(sceneDir) / relative;
        if (!fs::is_regular_file(path))
            throw Error("suite " + name + ": scene file " + path.string() + " is missing (scene folder " + sceneDir +
                        "; see --scene-dir)");
        return path.string();
    };
    if (name == "report") {
        for (BenchScene scene : reportScenes()) {
            scene.spec = file(scene.spec);
            suite.scenes.push_back(scene);
        }
    } else if (name == "scaling") {
        // A procedural scene from 10k to 10M triangles, and subdivided versions of a real scan
        // (each level splits every triangle in four: the 202k dragon becomes 810k, 3.2M, 13M).
        for (const char* count : {"10k", "100k", "1M", "10M"})
            suite.scenes.push_back(
                {std::string("terrain ") + count, std::string("gen:terrain:") + count, std::nullopt});
        const std::string dragon = file(kDragonFile);
        const Camera dragonCamera = *reportScenes().back().camera;
        suite.scenes.push_back({"Dragon 202k", dragon, dragonCamera});
        for (int level = 1; level <= 3; ++level)
            suite.scenes.push_back({"Dragon subdiv " + std::to_string(level),
                                    "subdiv:" + std::to_string(level) + ":" + dragon, dragonCamera});
    } else if (name == "quick") {
        // Small, for CI on lavapipe: two generated scenes of a few thousand triangles.
        suite.scenes = {{"terrain 4k", "gen:terrain:4k", std::nullopt},
                        {"sphereflake 5k", "gen:sphereflake:5k", std::nullopt}};
        suite.width = 96;
        suite.height = 96;
        suite.repeats = 2;
        suite.packets = "8x4,5x6";
        suite.cpuPackets = "16x16";
    } else if (name == "trade") {
        // Issue 15's full matrix: the report scenes and the closed scenes at 1024x768, 5 timed
        // runs; 20 builds x 2 modes x (GPU packet, GPU single, CPU packet) per scene plus the CPU
        // reference at the reference build (docs/trade.md gives the cell count and run time).
        const std::vector<BenchScene> report = benchSuite("report", sceneDir).scenes;
        suite.width = 1024;
        suite.height = 768;
        suite.repeats = 5;
        suite.packets = "8x4";
        suite.cpuPackets = "16x16";
        TradeMatrix matrix;
        matrix.builds =
            tradeBuilds({BvhBuilder::SahExact, BvhBuilder::SahBinned, BvhBuilder::SahSplit}, {8, 16, 32}, {1, 2, 4, 8});
        suite.trade = matrix;
        suite.scenesFor = [report](uint32_t width, uint32_t height) {
            std::vector<BenchScene> scenes = report;
            for (BenchScene& s : closedScenes(6, width, height)) scenes.push_back(s);
            return scenes;
        };
    } else if (name == "trade-quick") {
        // The trade suite's shape for CI on lavapipe and 2 cores (about 20 s): small generated
        // scenes at 96x96, one timed run, three builders at two leaf sizes, the GPU packet and CPU
        // packet tracers (and the CPU reference at the reference build).
        suite.width = 96;
        suite.height = 96;
        suite.repeats = 1;
        suite.packets = "8x4";
        suite.cpuPackets = "16x16";
        TradeMatrix matrix;
        matrix.builds = tradeBuilds({BvhBuilder::SahExact, BvhBuilder::SahBinned, BvhBuilder::SahSplit}, {8}, {1, 4});
        matrix.tracers = {"gpu-packet", "cpu-packet"};  // gpu-single: the full suite's (time on lavapipe)
        matrix.firstWarmUpSeconds = 0.0;                // lavapipe has no clocks to raise
        matrix.warmUpSeconds = 0.0;
        suite.trade = matrix;
        suite.scenesFor = [](uint32_t width, uint32_t height) {
            std::vector<BenchScene> scenes = {{"terrain 4k", "gen:terrain:4k", std::nullopt, false}};
            for (BenchScene& s : closedScenes(3, width, height))
                if (s.name != "icosphere far" && s.name != "lattice tiny") scenes.push_back(s);
            return scenes;
        };
    } else {
        throw Error("--suite: \"" + name + "\" is not report, scaling, quick, trade or trade-quick");
    }
    if (suite.scenesFor) suite.scenes = suite.scenesFor(suite.width, suite.height);
    return suite;
}

std::vector<std::string> benchSuiteNames() { return {"report", "scaling", "quick", "trade", "trade-quick"}; }

BenchSuite customSuite(const std::vector<std::string>& specs) {
    BenchSuite suite;
    suite.name = "custom";
    for (const std::string& spec : specs) {
        std::string name = spec;
        if (fs::is_regular_file(spec)) name = fs::path(spec).stem().string();
        suite.scenes.push_back({name, spec, std::nullopt});
    }
    if (suite.scenes.empty()) throw Error("--scenes: no scene given");
    return suite;
}

}  // namespace raypack::cli
