#pragma once
// The first two arrows of raypack's data flow as the CLI runs them, timed: scene spec -> Scene
// (openScene) -> Bvh (buildBvh), plus the flags that choose the BVH build.
#include "renderer/bvh.h"
#include "renderer/measure/statistics.h"
#include "renderer/scene.h"

#include <CLI/CLI.hpp>

#include <string>

namespace raypack::cli {

struct LoadedScene {
    Scene scene;
    SceneInfo info;
};

// Opens a file path or generator spec (scenes/load.h) and times it. Throws raypack::Error.
LoadedScene loadSceneTimed(const std::string& spec);

// --leaf-size, --builder, --bins, --split-alpha, --split-budget, bound to `options` (defaults from
// BvhBuildOptions).
struct BvhFlags {
    uint32_t leafSize = BvhBuildOptions{}.leafSize;
    std::string builder = toString(BvhBuildOptions{}.builder);
    uint32_t binCount = BvhBuildOptions{}.binCount;
    float splitAlpha = BvhBuildOptions{}.splitAlpha;
    float splitBudget = BvhBuildOptions{}.splitBudget;
    uint32_t plocRadius = BvhBuildOptions{}.plocRadius;
    uint32_t treeletRounds = BvhBuildOptions{}.treeletRounds;
    uint32_t treeletGamma = BvhBuildOptions{}.treeletGamma;
    uint32_t topRebuild = BvhBuildOptions{}.topRebuild;
};
void addBvhFlags(CLI::App& command, BvhFlags& flags);
// Throws raypack::Error for an unknown builder name.
BvhBuildOptions toBvhOptions(const BvhFlags& flags);

// Builds the scene's BVH with `options`: on the CPU (buildBvh), or for a device builder (gpu-lbvh)
// on the Vulkan device `gpu` names ("" automatic, as --gpu) and downloaded (buildBvhOnDevice), so
// that every tracer and printout takes it. T_B is the device build's wall time then.
Bvh buildSceneBvh(const Scene& scene, const BvhBuildOptions& options, const std::string& gpu = "");

// The help line of the SCENE argument: a file or a generator spec (sceneSpecHelp()).
std::string sceneArgumentHelp();

}  // namespace raypack::cli
