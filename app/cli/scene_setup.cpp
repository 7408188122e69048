#include "app/cli/scene_setup.h"

#include "app/cli/tracing.h"
#include "renderer/gpu_bvh.h"
#include "scenes/load.h"

#include <chrono>
#include <filesystem>
#include <limits>

namespace raypack::cli {

LoadedScene loadSceneTimed(const std::string& spec) {
    LoadedScene loaded;
    const auto start = std::chrono::steady_clock::now();
    loaded.scene = openScene(spec);
    loaded.info.loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    loaded.info.spec = spec;
    loaded.info.triangles = loaded.scene.triangleCount();
    loaded.info.degenerateTriangles = loaded.scene.degenerateCount();
    loaded.info.textureCount = loaded.scene.textures.size();
    loaded.info.textureBytes = loaded.scene.textureBytes();
    // The bytes of every file the loader read (a glTF's buffers and images too), else the file's
    // size, else (a generator) the scene's memory.
    std::error_code error;
    const bool isFile = std::filesystem::is_regular_file(spec, error);
    loaded.info.inputBytes = isFile ? std::filesystem::file_size(spec, error) : 0;
    if (!isFile || error) loaded.info.inputBytes = loaded.scene.bytes();
    if (loaded.scene.sourceBytes > 0) loaded.info.inputBytes = loaded.scene.sourceBytes;
    return loaded;
}

void addBvhFlags(CLI::App& command, BvhFlags& flags) {
    std::string builders;
    for (BvhBuilder b : kAllBvhBuilders) builders += std::string(builders.empty() ? "" : ", ") + toString(b);
    command
        .add_option("--leaf-size", flags.leafSize,
                    "BVH leaf threshold: a node with at most N triangles becomes a leaf (at most " +
                        std::to_string(kMaxLeafPrimitives) + ", what a GPU ray can test within its traversal budget)")
        ->check(CLI::Range(1u, kMaxLeafPrimitives))
        ->capture_default_str();
    command
        .add_option("--builder", flags.builder,
                    "BVH builder: " + builders + " (the gpu-* builders build on the Vulkan device, docs/bvh.md)")
        ->capture_default_str();
    command
        .add_option("--bins", flags.binCount,
                    "Most bins per axis of the binned SAH builder (sah-binned only; a node of N triangles uses "
                    "min(this, 4 + N/20)), 2..256")
        ->check(CLI::Range(2u, 256u))
        ->capture_default_str();
    command
        .add_option("--split-alpha", flags.splitAlpha,
                    "sah-split only: try spatial splits where the best object split's children overlap by more "
                    "than this fraction of the root's surface area (Stich et al. 2009), 0..1; 0 = everywhere")
        ->check(CLI::Range(0.0f, 1.0f))
        ->capture_default_str();
    command
        .add_option("--split-budget", flags.splitBudget,
                    "sah-split only: at most this many triangle references per triangle in all leaves together, "
                    "1..4; 1 = no spatial splits")
        ->check(CLI::Range(1.0f, 4.0f))
        ->capture_default_str();
    command
        .add_option("--ploc-radius", flags.plocRadius,
                    "gpu-ploc and gpu-hploc only: clusters searched on either side for each one's nearest neighbour "
                    "(Meister and Bittner's r), 1..64; smaller builds faster, larger finds better pairs "
                    "(gpu-hploc searches a workgroup's 32 clusters, all of them from 16 up); 0: the builder's own, "
                    "16 for gpu-ploc; for gpu-hploc 16 below 524,288 triangles, else 8")
        ->check(CLI::Range(0u, kMaxPlocRadius))
        ->capture_default_str();
    command
        .add_option("--treelet-rounds", flags.treeletRounds,
                    "gpu-ploc and gpu-hploc only: rounds of treelet restructuring (Karras and Aila 2013) of the "
                    "clustered tree, 0..8: each rebuilds every treelet of 7 leaves below a node of at least "
                    "--treelet-gamma triangles into its cheapest topology by the SAH; 0: none")
        ->check(CLI::Range(0u, kMaxTreeletRounds))
        ->capture_default_str();
    command
        .add_option("--treelet-gamma", flags.treeletGamma,
                    "gpu-ploc and gpu-hploc only: the least triangles below a node whose treelet a round rebuilds "
                    "(Karras and Aila's gamma), 2 or more; larger rebuilds fewer treelets, those near the root, "
                    "for a faster round")
        ->check(CLI::Range(kMinTreeletGamma, std::numeric_limits<uint32_t>::max()))
        ->capture_default_str();
    command
        .add_option("--top-rebuild", flags.topRebuild,
                    "gpu-ploc and gpu-hploc only: rebuild the clustered tree's top, every node of at least this "
                    "many triangles (2 or more), top down by the binned SAH over the subtrees below it, before any "
                    "treelet round; smaller rebuilds more of the tree for a longer build. 0: the builder's own "
                    "(gpu-hploc: 8192 from 524,288 triangles, none below; gpu-ploc: none); 1: none")
        ->capture_default_str();
}

BvhBuildOptions toBvhOptions(const BvhFlags& flags) {
    BvhBuildOptions options;
    options.builder = parseBvhBuilder(flags.builder);
    options.leafSize = flags.leafSize;
    options.binCount = flags.binCount;
    options.splitAlpha = flags.splitAlpha;
    options.splitBudget = flags.splitBudget;
    options.plocRadius = flags.plocRadius;
    options.treeletRounds = flags.treeletRounds;
    options.treeletGamma = flags.treeletGamma;
    options.topRebuild = flags.topRebuild;
    return options;
}

Bvh buildSceneBvh(const Scene& scene, const BvhBuildOptions& options, const std::string& gpu) {
    if (!isGpuBvhBuilder(options.builder)) return buildBvh(scene, options);
    const VulkanSession session(gpu, false);
    return buildBvhOnDevice(session.context, scene, options);
}

std::string sceneArgumentHelp() {
    return std::string("Scene: an .obj, .ply, .gltf or .glb file, or a generator spec.\n") + sceneSpecHelp();
}

}  // namespace raypack::cli
