#pragma once
// RenderSettings, BvhBuildOptions and the scene they apply to, to and from JSON. One format serves
// `raypack-cli render --from SIDE.json` and the viewer's screenshot sidecar, so that a screenshot
// can be reproduced exactly from its sidecar.
//
// Layout (every key optional on reading: a missing key keeps the default of RenderSettings /
// BvhBuildOptions; unknown keys, such as a sidecar's "stats", are ignored):
//   {
//     "scene": "path/or/gen:spec",
//     "width": 800, "height": 800,
//     "camera": {"eye": [x,y,z], "at": [x,y,z], "up": [x,y,z], "fov_y_degrees": 60},
//     "light_height": 0.25, "shadows": true,
//     "phong": {"ambient": 0.15, "diffuse": 0.75, "specular": 0.25, "shininess": 32},
//     "background": [r,g,b],
//     "kernel": "packet" | "single" | "hybrid", "packet": {"width": 8, "height": 4},
//     "hybrid": {"min_rays": 32, "visit_ratio": 0, "packets_per_group": "auto" | 4},
//     "collect_counters": false, "view": "shaded" | "nodes" | "tests",
//     "bvh": {"builder": "sah-exact" | "sah-binned", "leaf_size": 2, "traversal_cost": 1,
//             "intersection_cost": 1, "bin_count": 32},
//     "samples_per_pixel": 1, "sample_pattern": "halton-2-3", "resolution_scale": 1
//   }
// Floats are written as doubles with full precision, so a float survives the round trip exactly.
#include "renderer/bvh.h"
#include "renderer/settings.h"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>

namespace raypack {

// The largest image width or height a render accepts, from the command line (render --width) or
// a --from settings file alike.
inline constexpr uint32_t kMaxImageSide = 16384;

// What reproduces a frame: the scene, the settings and how its BVH was built.
struct RenderSetup {
    std::string scene;  // file path or generator spec; empty when unknown
    RenderSettings settings;
    BvhBuildOptions bvh;
    // Progressive display (renderer/progressive.h): samples per pixel of the pattern, averaged,
    // and the resolution divisor of an image traced smaller and scaled up to width x height.
    uint32_t samples = 1;
    uint32_t resolutionScale = 1;
};

nlohmann::json toJson(const RenderSettings& settings);
nlohmann::json toJson(const BvhBuildOptions& options);
// The settings' keys at the top level, plus "scene" and "bvh".
nlohmann::json toJson(const RenderSetup& setup);
// HybridParams::packetsPerGroup as the JSON holds it: "auto" (kAutoPacketsPerGroup) or the count.
nlohmann::json hybridPacketsPerGroupJson(uint32_t packetsPerGroup);

// Each throws raypack::Error naming the offending key and what is wrong (wrong type, out of range,
// unknown name). They read the layout above; renderSetupFromJson reads all three parts.
RenderSettings renderSettingsFromJson(const nlohmann::json& json);
BvhBuildOptions bvhBuildOptionsFromJson(const nlohmann::json& json);
RenderSetup renderSetupFromJson(const nlohmann::json& json);

// Reads and parses a JSON file; throws raypack::Error naming the file when it cannot be read or
// is not valid JSON (with the parser's byte offset).
nlohmann::json readJsonFile(const std::string& path);
// Writes `json` indented; throws raypack::Error naming the file when it cannot be written.
void writeJsonFile(const std::string& path, const nlohmann::json& json);

}  // namespace raypack
