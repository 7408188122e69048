#include "app/cli/bench_suites.h"

#include "renderer/error.h"

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
    } else {
        throw Error("--suite: \"" + name + "\" is not report, scaling or quick");
    }
    return suite;
}

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
