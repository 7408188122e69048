#pragma once
// Scene files and scene specs -> raypack::Scene (renderer/scene.h).
//
// Triangle order is the file's order, because a triangle index ("prim") must mean the same thing
// to every tracer and to the hits file: OBJ and PLY polygons are fan-triangulated as
// (v0, v(k-1), v(k)), k = 2..n-1; glTF primitives come in node traversal order (depth first,
// parents before children, children in the order the node lists them).
//
// Bad input (truncated file, counts the file cannot hold, indices out of range, NaN/Inf vertices,
// unknown formats, empty files) throws one raypack::Error naming the file and what is wrong, with
// a line number for text formats and a byte offset for binary ones. Degenerate triangles are kept.
#include "renderer/error.h"
#include "renderer/progress.h"  // LoadProgress, LoadCancelled
#include "renderer/scene.h"

#include <cstdint>
#include <filesystem>
#include <string>

namespace raypack {

// A loading thread reports through LoadProgress (renderer/progress.h) so that a viewer can draw a
// progress bar and cancel: `total` is set once the file's size is known and `done` grows to it, in
// bytes of work (every byte of the file counted once when read and once when parsed, so total = 2 *
// file size). Setting cancel makes the loader throw LoadCancelled at its next check (at least every
// few MiB).

// Loads .obj, .ply, .gltf or .glb (extension compared case-insensitively); anything else throws.
Scene loadScene(const std::filesystem::path& path, LoadProgress* progress = nullptr);

// A file path or a generator spec (grammar in sceneSpecHelp() and docs/scenes.md):
//   gen:default | gen:terrain:N | gen:sphereflake:N | gen:deep:N | subdiv:L:PATH
Scene openScene(const std::string& spec, LoadProgress* progress = nullptr);

// The spec grammar as text for --help.
const char* sceneSpecHelp();

// Writes binary little-endian PLY: float x y z (+ nx ny nz when the scene has normals), and a
// uchar-count / uint-index face list (+ uchar red green blue per face when it has materials, the
// material's diffuse colour rounded to 8 bits). Material names travel as
// "comment raypack_material R G B NAME" header lines, so that loadScene gives back the same scene
// when every material's colour is a distinct multiple of 1/255 (see colourFromByte). Throws
// raypack::Error when the file cannot be written.
void savePly(const Scene& scene, const std::filesystem::path& path);

// The exact float the PLY loader makes of an 8-bit colour channel; generators that want to round
// trip through PLY build their colours with it.
inline float colourFromByte(uint8_t value) { return float(value) / 255.0f; }

}  // namespace raypack
