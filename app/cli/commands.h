#pragma once
// raypack-cli's subcommands. Each add*Command declares its options on `app` and returns what runs
// it once the command line has been parsed; main() runs the one the user chose and turns a
// raypack::Error into one line on stderr and exit code 2.
#include <CLI/CLI.hpp>

#include <functional>
#include <string>

namespace raypack::cli {

// Exit codes shared by every subcommand (documented in --help and README.md).
constexpr int kExitOk = 0;
constexpr int kExitDiffer = 1;  // `diff` only: the images differ beyond the threshold
constexpr int kExitError = 2;   // bad arguments, unreadable file, no device, ...

using CommandRunner = std::function<int()>;

// The command line as typed (arguments joined by spaces, quoted where they hold spaces), for
// results that say how they were made. Set once by main().
const std::string& commandLine();
void setCommandLine(int argc, char** argv);

CommandRunner addRenderCommand(CLI::App& app);
CommandRunner addStatsCommand(CLI::App& app);
CommandRunner addDiffCommand(CLI::App& app);
CommandRunner addGenerateCommand(CLI::App& app);
CommandRunner addBenchCommand(CLI::App& app);

}  // namespace raypack::cli
