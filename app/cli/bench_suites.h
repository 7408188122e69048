#pragma once
// The benchmark suites of issue 5: which scenes, from which files, seen from which cameras.
#include "renderer/bvh.h"
#include "renderer/camera.h"
#include "renderer/measure/warm_up.h"
#include "renderer/settings.h"

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace raypack::cli {

struct BenchScene {
    std::string name;              // as tables and figures label it ("Sibenik")
    std::string spec;              // file path (resolved against the scene folder) or generator spec
    std::optional<Camera> camera;  // nullopt: frameScene over the scene's bounds
    // A closed scene that its camera sees everywhere: every primary ray must hit it, and the trade
    // suite records the rays that miss as leaked.
    bool closed = false;
};

// The speed/accuracy matrix of the trade suites (issue 15, docs/trade.md): every build (builder
// and leaf size) x every intersection mode x every kernel, per scene.
struct TradeMatrix {
    std::vector<BvhBuildOptions> builds;  // builds[0] is the reference build (sah-exact, leaf 1)
    std::vector<IntersectMode> modes = {IntersectMode::Robust, IntersectMode::Fast};
    // Tracers by registry name, each at the suite's first packet shape where it traces packets.
    std::vector<std::string> tracers = {"gpu-packet", "gpu-single", "cpu-packet"};
    // The CPU reference runs at the reference build only (both modes): at full size it takes about
    // a second a cell on 16 threads, which over every build would double the suite's time.
    bool cpuReferenceAtReferenceBuild = true;
    // GPU time traced back to back before the timed frames (renderer/measure/protocol.h): the
    // first GPU cell after a build (the build left the GPU idle) gets `firstWarmUpSeconds`, the
    // cells that follow it `warmUpSeconds`.
    double firstWarmUpSeconds = kGpuWarmUpSeconds;
    double warmUpSeconds = 0.05;
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
    // The trade suites (trade, trade-quick): their matrix, and their scenes for an image size (the
    // lattice and its camera are sized to the image, generators.h latticeCamera).
    std::optional<TradeMatrix> trade;
    std::function<std::vector<BenchScene>(uint32_t width, uint32_t height)> scenesFor;
};

// "report", "scaling", "quick", "trade" or "trade-quick"; scene files resolved against `sceneDir`. Throws
// raypack::Error for an unknown name, or naming the file (and the folder) when a scene file is missing.
BenchSuite benchSuite(const std::string& name, const std::string& sceneDir);

// The suites' names, for --help and messages.
std::vector<std::string> benchSuiteNames();

// A suite of the given specs (files or generator specs), framed by frameScene, named by file
// stem. Relative files are taken as given (from the current directory).
BenchSuite customSuite(const std::vector<std::string>& specs);

// The scene folder: `explicitDir` when given; else $RAYPACK_SCENE_DIR; else ../shared/scenes
// next to the source tree raypack-cli was built from; else ../shared/scenes from the current
// directory. Returns the first that exists; throws raypack::Error listing what was tried.
std::string resolveSceneDir(const std::string& explicitDir);

}  // namespace raypack::cli
