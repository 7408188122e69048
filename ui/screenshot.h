#pragma once
// Screenshots: the traced image as PNG, and beside it a JSON sidecar (same name, .json) that holds
// the scene, the camera, every setting (renderer/settings_json.h, the format of
// `raypack-cli render --from SIDE.json`) and the statistics of the frame, so the image can be
// reproduced exactly.
#include "renderer/image.h"
#include "renderer/settings_json.h"

#include <nlohmann/json.hpp>

#include <string>

namespace raypack::ui {

// "shot.png" -> "shot.json".
std::string sidecarPath(const std::string& pngPath);

// Writes the PNG and its sidecar: toJson(setup) plus "stats": `statistics` and, when given,
// "device_kind" ("cpu": `raypack-cli render --from` then traces with the sidecar's kernel on the
// CPU, as `render --json` files say). Throws raypack::Error naming the file when either cannot be
// written.
void writeScreenshot(const std::string& pngPath, const Image& image, const RenderSetup& setup,
                     const nlohmann::json& statistics, const std::string& deviceKind = "");

// A fresh name in the current folder: raypack-YYYYmmdd-HHMMSS[-N].png.
std::string nextScreenshotName();

}  // namespace raypack::ui
