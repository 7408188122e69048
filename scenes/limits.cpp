#include "scenes/limits.h"

#include "renderer/error.h"

#include <charconv>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <system_error>

namespace raypack {
namespace {

LoadLimit limitFromEnvironment(const char* variable, uint64_t defaultValue) {
    LoadLimit limit{variable, defaultValue};
    if (const char* text = std::getenv(variable)) {
        uint64_t value = 0;
        const char* end = text + std::strlen(text);
        auto [stop, ec] = std::from_chars(text, end, value);
        if (ec == std::errc() && stop == end && value > 0) limit.value = value;
    }
    return limit;
}

[[noreturn]] void fail(const std::filesystem::path& file, const std::string& what) {
    throw Error(file.string() + ": " + what);
}

// True when `inner` is `outer` or lies below it (both absolute and lexically normal).
bool isInside(const std::filesystem::path& inner, const std::filesystem::path& outer) {
    auto i = inner.begin();
    for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
        if (o->empty()) continue;  // a trailing separator
        if (i == inner.end() || *i != *o) return false;
    }
    return true;
}

// A name as an error quotes it: control characters (a URI may hold a newline) as '?', and cut to
// 80 characters, so that the message stays one readable line (found by fuzz_gltf).
std::string printable(const std::string& name) {
    std::string text = name.size() > 80 ? name.substr(0, 77) + "..." : name;
    for (char& c : text)
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
    return text;
}

}  // namespace

uint64_t checkedAdd(uint64_t a, uint64_t b, const std::filesystem::path& file, const std::string& what) {
    uint64_t sum = 0;
    if (__builtin_add_overflow(a, b, &sum)) fail(file, what + " is too large (overflows 64 bits)");
    return sum;
}

uint64_t checkedMul(uint64_t a, uint64_t b, const std::filesystem::path& file, const std::string& what) {
    uint64_t product = 0;
    if (__builtin_mul_overflow(a, b, &product)) fail(file, what + " is too large (overflows 64 bits)");
    return product;
}

LoadLimit maxGltfNodeDepth() { return limitFromEnvironment("RAYPACK_MAX_GLTF_DEPTH", 1024); }
LoadLimit maxGltfInstances() { return limitFromEnvironment("RAYPACK_MAX_GLTF_INSTANCES", 1000000); }
LoadLimit maxInstancedTriangleFactor() { return limitFromEnvironment("RAYPACK_MAX_INSTANCING_FACTOR", 1024); }
LoadLimit maxReferencedFileBytes() {
    return limitFromEnvironment("RAYPACK_MAX_REFERENCED_FILE_BYTES", uint64_t(4) << 30);
}
LoadLimit maxMtlFileBytes() { return limitFromEnvironment("RAYPACK_MAX_MTL_BYTES", uint64_t(64) << 20); }

void throwLimitError(const std::filesystem::path& file, const std::string& what, const LoadLimit& limit) {
    fail(file, what + " (limit " + std::to_string(limit.value) + "; set " + limit.variable + " to raise it)");
}

std::filesystem::path resolveReferencedFile(const std::filesystem::path& sceneFile, const std::string& name,
                                            const std::string& what, const LoadLimit& maxBytes) {
    if (std::optional<std::filesystem::path> found = findReferencedFile(sceneFile, name, what, maxBytes)) return *found;
    fail(sceneFile, what + " \"" + printable(name) + "\": no such file");
}

std::optional<std::filesystem::path> findReferencedFile(const std::filesystem::path& sceneFile, const std::string& name,
                                                        const std::string& what, const LoadLimit& maxBytes) {
    namespace fs = std::filesystem;
    const std::string quoted = what + " \"" + printable(name) + "\"";
    if (name.empty()) fail(sceneFile, what + " is empty");
    if (name.find('\0') != std::string::npos) fail(sceneFile, what + " contains a NUL character");
    const fs::path relative(name);
    if (relative.is_absolute() || relative.has_root_name() || relative.has_root_directory())
        fail(sceneFile, quoted + " is an absolute path; only files inside the scene's folder are read");
    std::error_code error;
    const fs::path sceneFolder = fs::weakly_canonical(fs::absolute(sceneFile, error).parent_path(), error);
    if (error) fail(sceneFile, "cannot resolve the scene's folder: " + error.message());
    // weakly_canonical resolves every symbolic link of the part that exists, so a link pointing
    // out of the folder is caught like a "../".
    const fs::path resolved = fs::weakly_canonical(sceneFolder / relative, error);
    if (error) fail(sceneFile, quoted + " cannot be resolved: " + error.message());
    if (!isInside(resolved, sceneFolder))
        fail(sceneFile, quoted + " lies outside the scene's folder " + sceneFolder.string() + "; refused");
    const fs::file_status status = fs::status(resolved, error);
    if (error || !fs::exists(status)) return std::nullopt;
    if (!fs::is_regular_file(status)) fail(sceneFile, quoted + " is not a regular file");
    const uintmax_t size = fs::file_size(resolved, error);
    if (error) fail(sceneFile, quoted + ": cannot determine its size: " + error.message());
    if (size > maxBytes.value)
        throwLimitError(sceneFile, quoted + " has " + std::to_string(size) + " bytes, more than allowed", maxBytes);
    return resolved;
}

std::string readReferencedFile(const std::filesystem::path& sceneFile, const std::filesystem::path& resolved,
                               const std::string& what, const LoadLimit& maxBytes) {
    std::ifstream in(resolved, std::ios::binary);
    if (!in) fail(sceneFile, what + " \"" + printable(resolved.string()) + "\": cannot open for reading");
    std::string bytes;
    char chunk[1 << 16];
    while (in) {
        in.read(chunk, sizeof chunk);
        bytes.append(chunk, size_t(in.gcount()));
        if (bytes.size() > maxBytes.value)
            throwLimitError(sceneFile, what + " \"" + printable(resolved.string()) + "\" is larger than allowed",
                            maxBytes);
    }
    if (in.bad()) fail(sceneFile, what + " \"" + printable(resolved.string()) + "\": read failed");
    return bytes;
}

}  // namespace raypack
