// `raypack-cli stats SCENE`: loads a scene, builds its BVH and prints one row of the report's
// Table 1 (plus what raypack adds), as text or JSON.
#include "app/cli/commands.h"
#include "app/cli/scene_setup.h"

#include <cstdio>
#include <memory>

namespace raypack::cli {

CommandRunner addStatsCommand(CLI::App& app) {
    struct Flags {
        std::string scene;
        BvhFlags bvh;
        std::string gpu;
        bool json = false;
    };
    auto flags = std::make_shared<Flags>();
    CLI::App* command =
        app.add_subcommand("stats",
                           "Load SCENE, build its BVH and print one row of the report's Table 1: N_L (leaves), D_AVG "
                           "(average leaf depth, root = 0), D_MAX (maximal leaf depth), O_AVG (average triangles per "
                           "leaf), T_B (build time, seconds), plus node count, SAH cost (relative to the root's "
                           "area), BVH bytes and bytes per triangle, triangles and degenerate (zero-area) triangles, "
                           "load time (seconds) and load speed (MB/s of file, or of scene memory for a generator).");
    command->add_option("SCENE", flags->scene, sceneArgumentHelp())->required();
    addBvhFlags(*command, flags->bvh);
    command->add_option("--gpu", flags->gpu,
                        "Vulkan device a device builder (--builder gpu-lbvh) runs on: index or case-insensitive "
                        "name substring (default: discrete > integrated > CPU/lavapipe)");
    command->add_flag("--json", flags->json,
                      "Print the row as one JSON object (keys carry their units) instead of text");
    return [flags] {
        const BvhBuildOptions options = toBvhOptions(flags->bvh);
        const LoadedScene loaded = loadSceneTimed(flags->scene);
        const Bvh bvh = buildSceneBvh(loaded.scene, options, flags->gpu);
        if (flags->json)
            std::printf("%s\n", table1Json(loaded.info, bvh.stats, options).dump(2).c_str());
        else
            printTable1(stdout, loaded.info, bvh.stats, options);
        return kExitOk;
    };
}

}  // namespace raypack::cli
