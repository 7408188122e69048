// raypack-cli: the headless front end of raypack (render, stats, diff, generate, bench).
#include "app/cli/commands.h"
#include "renderer/error.h"

#include <cstdio>
#include <exception>
#include <utility>
#include <vector>

namespace raypack::cli {
namespace {
std::string typedCommandLine;
}

const std::string& commandLine() { return typedCommandLine; }

void setCommandLine(int argc, char** argv) {
    typedCommandLine.clear();
    for (int i = 0; i < argc; ++i) {
        std::string arg = i == 0 ? std::string("raypack-cli") : std::string(argv[i]);
        if (arg.find_first_of(" \t\"'") != std::string::npos) arg = "'" + arg + "'";
        typedCommandLine += (i ? " " : "") + arg;
    }
}

}  // namespace raypack::cli

int main(int argc, char** argv) {
    using namespace raypack::cli;
    setCommandLine(argc, argv);
    CLI::App app{
        "raypack-cli: headless front end of raypack, a ray tracer for triangle scenes (SAH BVH, "
        "Vulkan compute packet tracer, CPU reference).\n"
        "Exit codes: 0 success, 1 `diff` found differing images, 2 any error (bad argument, "
        "unreadable file, no device); errors are one line on stderr.",
        "raypack-cli"};
    app.require_subcommand(1);
    app.set_help_all_flag("--help-all", "Print the help of every subcommand and exit");

    std::vector<std::pair<CLI::App*, CommandRunner>> commands;
    const auto add = [&](CommandRunner (*addCommand)(CLI::App&)) {
        CommandRunner run = addCommand(app);
        commands.emplace_back(app.get_subcommands([](CLI::App*) { return true; }).back(), std::move(run));
    };
    add(addRenderCommand);
    add(addStatsCommand);
    add(addDiffCommand);
    add(addGenerateCommand);
    add(addBenchCommand);

    // The help a usage error points at: the subcommand's where one was named.
    std::string helpCommand = "raypack-cli --help";
    if (argc > 1 && argv[1][0] != '-') {
        std::string names;
        bool known = false;
        for (const auto& [subcommand, run] : commands) {
            known = known || subcommand->get_name() == argv[1];
            names += (names.empty() ? "" : ", ") + subcommand->get_name();
        }
        if (known) helpCommand = std::string("raypack-cli ") + argv[1] + " --help";
        if (!known) {
            std::fprintf(stderr, "raypack-cli: unknown subcommand \"%s\" (one of: %s)\n", argv[1], names.c_str());
            return kExitError;
        }
    }
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::fprintf(stderr, "raypack-cli: %s (see %s)\n", e.what(), helpCommand.c_str());
        return kExitError;
    }
    try {
        for (auto& [subcommand, run] : commands)
            if (subcommand->parsed()) return run();
    } catch (const raypack::Error& e) {
        std::fprintf(stderr, "raypack-cli: %s\n", e.what());
        return kExitError;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "raypack-cli: out of memory\n");
        return kExitError;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "raypack-cli: unexpected error: %s\n", e.what());
        return kExitError;
    }
    return kExitError;
}
