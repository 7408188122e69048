#pragma once
// What every raypack fuzz target shares: a private scratch folder for the files a loader reads, and
// the property every target checks, that bad input gives one raypack::Error of one line, never a
// crash, another exception or a multi-line message (issue 11).
#include "renderer/error.h"

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace raypack::fuzz {

// /dev/shm when there is one (no disk writes per input), else the temporary folder; one per process.
inline const std::filesystem::path& scratch() {
    static const std::filesystem::path folder = [] {
        const std::filesystem::path base = std::filesystem::exists("/dev/shm") ? std::filesystem::path("/dev/shm")
                                                                               : std::filesystem::temp_directory_path();
        std::filesystem::path path = base / ("raypack-fuzz-" + std::to_string(::getpid()));
        std::filesystem::create_directories(path);
        return path;
    }();
    return folder;
}

inline std::filesystem::path writeScratch(const std::string& name, std::string_view bytes) {
    const std::filesystem::path path = scratch() / name;
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    return path;
}

// Input split at the first occurrence of `separator`: what comes before and what after (empty
// when the separator is absent). Lets one input carry a scene and the file it names.
inline std::pair<std::string_view, std::string_view> splitAt(std::string_view input, std::string_view separator) {
    const size_t at = input.find(separator);
    if (at == std::string_view::npos) return {input, {}};
    return {input.substr(0, at), input.substr(at + separator.size())};
}

// Runs `f`; a raypack::Error is the expected outcome of bad input and must be one line.
template <typename F>
void expectCleanOutcome(F&& f) {
    try {
        f();
    } catch (const Error& e) {
        if (std::strchr(e.what(), '\n')) {
            std::fprintf(stderr, "raypack fuzz: error message of more than one line:\n%s\n", e.what());
            std::abort();
        }
    }
}

}  // namespace raypack::fuzz
