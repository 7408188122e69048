#pragma once
// The benchmark suites of issue 5: which scenes, from which files, seen from which cameras.
#include "renderer/camera.h"

#include <optional>
#include <string>
#include <vector>

namespace raypack::cli {

struct BenchScene {
    std::string name;              // as tables and figures label it ("Sibenik")
    std::string spec;              // file path (resolved against the scene folder) or generator spec
    std::optional<Camera> camera;  // nullopt: frameScene over the scene's bounds
};

struct BenchSuite {
    std::string name;
    std::vector<BenchScene> scenes;
    // Defaults the command line may override.
    uint32_t width = 800, height = 800;
    uint32_t repeats = 5;
    std::string packets = "8x4,4x8,5x6,8x8,16x16";
    // Packet shapes of the CPU packet tracer's cells (cpu-packet).
    std::string cpuPackets = "8x8,16x16";
};

// "report", "scaling" or "quick"; scene files resolved against `sceneDir`. Throws raypack::Error
// for an unknown name, or naming the file (and the folder) when a scene file is missing.
BenchSuite benchSuite(const std::string& name, const std::string& sceneDir);

// A suite of the given specs (files or generator specs), framed by frameScene, named by file
// stem. Relative files are taken as given (from the current directory).
BenchSuite customSuite(const std::vector<std::string>& specs);

// The scene folder: `explicitDir` when given; else $RAYPACK_SCENE_DIR; else ../shared/scenes
// next to the source tree raypack-cli was built from; else ../shared/scenes from the current
// directory. Returns the first that exists; throws raypack::Error listing what was tried.
std::string resolveSceneDir(const std::string& explicitDir);

}  // namespace raypack::cli
