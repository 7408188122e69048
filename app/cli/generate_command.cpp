// `raypack-cli generate SPEC OUT.ply`: writes a generated (or subdivided) scene as binary PLY; this
// is how scenes/data/default.ply and the scaling scenes are made.
#include "app/cli/commands.h"
#include "app/cli/scene_setup.h"
#include "renderer/error.h"
#include "renderer/file_names.h"
#include "renderer/image.h"
#include "scenes/load.h"

#include <cstdio>
#include <memory>

namespace raypack::cli {

CommandRunner addGenerateCommand(CLI::App& app) {
    struct Flags {
        std::string spec, out;
    };
    auto flags = std::make_shared<Flags>();
    CLI::App* command =
        app.add_subcommand("generate",
                           "Write the scene SPEC (a generator spec, or any scene file, e.g. to convert it) to OUT as "
                           "binary little-endian PLY. Prints the triangle count and the seconds taken.");
    command->add_option("SPEC", flags->spec, sceneArgumentHelp())->required();
    command->add_option("OUT", flags->out, "Output file, its name ending in .ply (checked before SPEC is made)")
        ->required();
    return [flags] {
        checkOutputPath("OUT", flags->out);
        if (lowercaseExtension(flags->out) != ".ply")
            throw Error("OUT " + flags->out + ": generate writes binary PLY, so the name must end in .ply");
        const LoadedScene loaded = loadSceneTimed(flags->spec);
        savePly(loaded.scene, flags->out);
        std::printf("wrote %s: %zu triangles, %zu vertices (generated in %.3f s)\n", flags->out.c_str(),
                    loaded.scene.triangleCount(), loaded.scene.positions.size(), loaded.info.loadSeconds);
        return kExitOk;
    };
}

}  // namespace raypack::cli
