#pragma once
// What every loader shares to survive hostile input (issue 11): overflow-checked size arithmetic,
// the one check that a file a scene names (an MTL library, a glTF buffer or image) lies inside the
// scene's folder and is a regular file of bounded size, and the resource limits of docs/scenes.md.
//
// Limits have defaults meant to refuse hostile files, not real ones; each can be raised with an
// environment variable, and the error that enforces a limit names it and the variable.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace raypack {

// a + b and a * b, or a raypack::Error "FILE: WHAT is too large (overflows 64 bits)".
uint64_t checkedAdd(uint64_t a, uint64_t b, const std::filesystem::path& file, const std::string& what);
uint64_t checkedMul(uint64_t a, uint64_t b, const std::filesystem::path& file, const std::string& what);

// The resource limits (docs/scenes.md "Resource limits"). Each value is its default unless the
// environment variable named in the comment holds a positive integer.
struct LoadLimit {
    const char* variable;  // e.g. "RAYPACK_MAX_GLTF_DEPTH"
    uint64_t value;
};
LoadLimit maxGltfNodeDepth();            // RAYPACK_MAX_GLTF_DEPTH, default 1024 levels of nesting
LoadLimit maxGltfInstances();            // RAYPACK_MAX_GLTF_INSTANCES, default 1,000,000 node instances
LoadLimit maxInstancedTriangleFactor();  // RAYPACK_MAX_INSTANCING_FACTOR, default 1024: triangles
                                         // after instancing per triangle stored in the file
LoadLimit maxReferencedFileBytes();      // RAYPACK_MAX_REFERENCED_FILE_BYTES, default 4 GiB per file
LoadLimit maxMtlFileBytes();             // RAYPACK_MAX_MTL_BYTES, default 64 MiB per MTL library

// "FILE: WHAT (limit LIMIT, set VARIABLE to raise it)" as a raypack::Error.
[[noreturn]] void throwLimitError(const std::filesystem::path& file, const std::string& what, const LoadLimit& limit);

// The file `name` that `sceneFile` refers to (`what` says as what: "mtllib", "buffer 0 uri",
// "image 3 uri"), checked: `name` is a relative path (already percent-decoded where it came from
// a URI) that, with symbolic links resolved, stays inside the scene file's folder, names an
// existing regular file (not a device, FIFO or folder) of at most `maxBytes` bytes. Returns the
// resolved path; anything else throws one raypack::Error naming the scene file, `what` and the
// reason. Every loader calls this before opening any file a scene names, texture images included.
std::filesystem::path resolveReferencedFile(const std::filesystem::path& sceneFile, const std::string& name,
                                            const std::string& what, const LoadLimit& maxBytes);

// As resolveReferencedFile, but a file that would lie inside the folder and does not exist gives
// nullopt instead of an error (a missing MTL library is a warning, as in other OBJ readers).
std::optional<std::filesystem::path> findReferencedFile(const std::filesystem::path& sceneFile, const std::string& name,
                                                        const std::string& what, const LoadLimit& maxBytes);

// The bytes of a file resolveReferencedFile returned, read with a size check (the file may have
// grown since): at most maxBytes.value bytes, else throwLimitError.
std::string readReferencedFile(const std::filesystem::path& sceneFile, const std::filesystem::path& resolved,
                               const std::string& what, const LoadLimit& maxBytes);

}  // namespace raypack
