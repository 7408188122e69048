#pragma once
// Running the built raypack-cli (RAYPACK_CLI) from a test: the command line, its exit code and
// everything it printed (stdout and stderr together), plus a scratch folder per test program.
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

namespace raypack::test {

struct CliResult {
    int exitCode = -1;
    std::string output;
};

// Runs `raypack-cli ARGS` through the shell (ARGS already quoted as needed).
inline CliResult runCli(const std::string& args) {
    const std::string command =
        std::string("XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp} '") + RAYPACK_CLI + "' " + args + " 2>&1";
    CliResult result;
    FILE* pipe = popen(command.c_str(), "r");
    if (!pipe) return result;
    std::array<char, 4096> buffer;
    size_t n;
    while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
    const int status = pclose(pipe);
    result.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return result;
}

// Appended, not built with operator+, which GCC 12 warns about wrongly (-Wrestrict).
inline std::string quoted(const std::filesystem::path& path) {
    std::string text(1, '\'');
    text.append(path.string());
    text.push_back('\'');
    return text;
}

// A fresh folder under the system's temporary folder, removed at the end of the program.
class ScratchDir {
public:
    explicit ScratchDir(const std::string& name)
        : path_(std::filesystem::temp_directory_path() / (name + "-" + std::to_string(::getpid()))) {
        std::filesystem::remove_all(path_);
        std::filesystem::create_directories(path_);
    }
    ~ScratchDir() {
        std::error_code ignored;
        std::filesystem::remove_all(path_, ignored);
    }
    std::filesystem::path operator/(const std::string& name) const { return path_ / name; }
    const std::filesystem::path& path() const { return path_; }

private:
    std::filesystem::path path_;
};

}  // namespace raypack::test
