// loadScene / openScene: extension dispatch, generator specs, and the file reading shared by the
// format loaders.
#include "renderer/file_names.h"
#include "scenes/formats.h"
#include "scenes/generators.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string_view>
#include <system_error>

namespace raypack {

void FreeDeleter::operator()(char* p) const { std::free(p); }

void throwFileError(const std::filesystem::path& path, const std::string& what) {
    throw Error(path.string() + ": " + what);
}

FileBytes readWholeFile(const std::filesystem::path& path, LoadProgress* progress) {
    std::error_code error;
    const auto status = std::filesystem::status(path, error);
    if (error || !std::filesystem::exists(status)) throwFileError(path, "no such file");
    if (std::filesystem::is_directory(status)) throwFileError(path, "is a directory, not a scene file");
    const uintmax_t size = std::filesystem::file_size(path, error);
    if (error) throwFileError(path, "cannot determine the file size: " + error.message());
    if (size == 0) throwFileError(path, "file is empty");

    std::ifstream stream(path, std::ios::binary);
    if (!stream) throwFileError(path, "cannot open for reading");
    FileBytes file;
    // Huge-page aligned and advised before the read touches it (renderer/huge_pages.h).
    constexpr size_t kHugePage = size_t(2) << 20;
    const size_t capacity = (size_t(size) + kHugePage - 1) / kHugePage * kHugePage;
    file.data.reset(static_cast<char*>(std::aligned_alloc(kHugePage, capacity)));
    if (!file.data) throwFileError(path, "out of memory reading " + std::to_string(size) + " bytes");
    adviseHugePages(file.data.get(), capacity);
    file.size = size_t(size);
    if (progress) {
        progress->total = 2 * uint64_t(size);
        progress->done = 0;
    }
    // Large reads with a cancel check in between: 64 MiB runs at disk speed and keeps the viewer's
    // cancel button responsive.
    constexpr size_t kChunk = size_t(64) << 20;
    size_t done = 0;
    while (done < file.size) {
        if (progress && progress->cancel) throw LoadCancelled(path.string() + ": loading cancelled");
        const size_t chunk = std::min(kChunk, file.size - done);
        stream.read(file.data.get() + done, std::streamsize(chunk));
        if (size_t(stream.gcount()) != chunk)
            throwFileError(path, "read failed at byte offset " + std::to_string(done));
        done += chunk;
        if (progress) progress->done = done;
    }
    return file;
}

void reportParsed(LoadProgress* progress, const std::filesystem::path& path, uint64_t fileSize, uint64_t parsedBytes) {
    if (!progress) return;
    if (progress->cancel) throw LoadCancelled(path.string() + ": loading cancelled");
    progress->done = fileSize + std::min(parsedBytes, fileSize);
}

Scene loadScene(const std::filesystem::path& path, LoadProgress* progress) {
    const std::string extension = lowercaseExtension(path);
    if (extension == ".ply") return loadPly(path, progress);
    if (extension == ".obj") return loadObj(path, progress);
    if (extension == ".gltf" || extension == ".glb") return loadGltf(path, progress);
    throwFileError(path, extension.empty()
                             ? "no file extension; expected .obj, .ply, .gltf or .glb"
                             : "unknown scene format \"" + extension + "\"; expected .obj, .ply, .gltf or .glb");
}

const char* sceneSpecHelp() {
    static const std::string help =
        "SCENE is a file or a generator spec:\n"
        "  PATH                 a .obj (+ .mtl), .ply (ascii or binary) or .gltf/.glb file\n"
        "  gen:default          raypack's default scene (ground, sphere flake, coloured shapes)\n"
        "  gen:terrain:N        a height-field terrain of about N triangles (at most N)\n"
        "  gen:sphereflake:N    a sphere flake of tessellated spheres, about N triangles (at most N)\n"
        "  gen:deep:N           N nested triangles whose SAH tree is a spine of depth about N\n"
        "                       (N from 1 to " +
        std::to_string(kDeepSceneMaxTriangles) +
        ")\n"
        "  gen:icosphere:L      a closed icosphere: the icosahedron subdivided L times (20*4^L triangles),\n"
        "                       vertices shared, on the unit sphere (L from 0 to 12)\n"
        "  gen:lattice:N        a flat lattice of N x N unit cells in z = 0, two triangles each, integer\n"
        "  gen:lattice:NxM      vertices (shared); N x M cells\n"
        "  subdiv:L:SCENE       SCENE (a path or spec) with every triangle split in four, L times\n"
        "  place:S:X,Y,Z:SCENE  SCENE scaled by S about the origin, then moved by (X, Y, Z), e.g.\n"
        "                       place:1:1e5,1e5,0:gen:lattice:64 (far) or place:6.103515625e-5:0,0,0:...\n"
        "                       (tiny, 2^-14)\n"
        "N may end in k (thousand) or M (million): gen:terrain:2M is 2,000,000 triangles.";
    return help.c_str();
}

namespace {

// A positive count with an optional k (1e3) or M (1e6) suffix.
uint64_t parseCount(std::string_view text, const std::string& spec) {
    uint64_t multiplier = 1;
    if (!text.empty() && (text.back() == 'k' || text.back() == 'K'))
        multiplier = 1000, text.remove_suffix(1);
    else if (!text.empty() && (text.back() == 'm' || text.back() == 'M'))
        multiplier = 1000000, text.remove_suffix(1);
    uint64_t value = 0;
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || text.empty())
        throw Error("scene spec \"" + spec + "\": \"" + std::string(text) + "\" is not a count\n" + sceneSpecHelp());
    if (value > UINT32_MAX / multiplier)
        throw Error("scene spec \"" + spec + "\": count too large (at most 4294967295)");
    return value * multiplier;
}

// A finite float of place:'s scale or offset ("1e5", "-0.25", "6.103515625e-5").
float parsePlaceNumber(std::string_view text, const std::string& spec) {
    const std::string copy(text);
    char* end = nullptr;
    const float value = copy.empty() ? 0.0f : std::strtof(copy.c_str(), &end);
    if (copy.empty() || end != copy.c_str() + copy.size() || !std::isfinite(value))
        throw Error("scene spec \"" + spec + "\": \"" + copy + "\" is not a finite number\n" + sceneSpecHelp());
    return value;
}

}  // namespace

Scene openScene(const std::string& spec, LoadProgress* progress) {
    const std::string_view text(spec);
    if (text.starts_with("gen:")) {
        const std::string_view rest = text.substr(4);
        const size_t colon = rest.find(':');
        const std::string_view name = rest.substr(0, colon);
        if (name == "default") {
            if (colon != std::string_view::npos) throw Error("scene spec \"" + spec + "\": gen:default takes no count");
            return makeDefaultScene();
        }
        if (colon == std::string_view::npos)
            throw Error("scene spec \"" + spec + "\": missing triangle count\n" + sceneSpecHelp());
        if (name == "icosphere") return makeIcosphere(uint32_t(parseCount(rest.substr(colon + 1), spec)));
        if (name == "lattice") {
            const std::string_view cells = rest.substr(colon + 1);
            const size_t x = cells.find('x');
            const uint32_t cellsX = uint32_t(parseCount(cells.substr(0, x), spec));
            const uint32_t cellsY =
                x == std::string_view::npos ? cellsX : uint32_t(parseCount(cells.substr(x + 1), spec));
            return makeLattice(cellsX, cellsY);
        }
        const uint32_t count = uint32_t(parseCount(rest.substr(colon + 1), spec));
        if (name == "terrain") return makeTerrain(count);
        if (name == "sphereflake") return makeSphereFlake(count);
        if (name == "deep") return makeDeepScene(count);
        throw Error("scene spec \"" + spec + "\": unknown generator \"" + std::string(name) + "\"\n" + sceneSpecHelp());
    }
    if (text.starts_with("subdiv:")) {
        const std::string_view rest = text.substr(7);
        const size_t colon = rest.find(':');
        if (colon == std::string_view::npos || colon + 1 == rest.size())
            throw Error("scene spec \"" + spec + "\": expected subdiv:LEVELS:SCENE\n" + sceneSpecHelp());
        const uint32_t levels = uint32_t(parseCount(rest.substr(0, colon), spec));
        return subdivide(openScene(std::string(rest.substr(colon + 1)), progress), levels);
    }
    if (text.starts_with("place:")) {
        // place:S:X,Y,Z:SCENE; the scene may itself contain colons (gen:..., a Windows path).
        const std::string_view rest = text.substr(6);
        const size_t first = rest.find(':');
        const size_t second = first == std::string_view::npos ? first : rest.find(':', first + 1);
        if (second == std::string_view::npos || second + 1 == rest.size())
            throw Error("scene spec \"" + spec + "\": expected place:SCALE:X,Y,Z:SCENE\n" + sceneSpecHelp());
        const float scale = parsePlaceNumber(rest.substr(0, first), spec);
        const std::string_view offsetText = rest.substr(first + 1, second - first - 1);
        glm::vec3 offset;
        size_t start = 0;
        for (int axis = 0; axis < 3; ++axis) {
            const size_t comma = offsetText.find(',', start);
            if ((axis < 2) == (comma == std::string_view::npos))
                throw Error("scene spec \"" + spec + "\": the offset \"" + std::string(offsetText) +
                            "\" is not X,Y,Z\n" + sceneSpecHelp());
            offset[axis] = parsePlaceNumber(offsetText.substr(start, comma - start), spec);
            start = comma + 1;
        }
        return placeScene(openScene(std::string(rest.substr(second + 1)), progress), scale, offset);
    }
    return loadScene(std::filesystem::path(spec), progress);
}

}  // namespace raypack
