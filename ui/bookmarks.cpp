#include "ui/bookmarks.h"

#include "renderer/error.h"
#include "renderer/settings_json.h"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace raypack::ui {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Nine significant digits always read back to the same float (IEEE 754 single: 9 digits suffice).
std::string exactFloat(float value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.9g", value);
    return text;
}

std::string exactVec3(const glm::vec3& v) { return exactFloat(v.x) + "," + exactFloat(v.y) + "," + exactFloat(v.z); }

json cameraToJson(const Camera& camera) {
    RenderSettings settings;
    settings.camera = camera;
    return toJson(settings)["camera"];
}

Camera cameraFromJson(const json& value) { return renderSettingsFromJson(json{{"camera", value}}).camera; }

// One key per file, whatever relative path or symlink opened it.
std::string sceneKeyOf(const std::string& scenePath) {
    std::error_code error;
    const fs::path canonical = fs::weakly_canonical(scenePath, error);
    return error ? scenePath : canonical.string();
}

}  // namespace

std::string configDirectory() {
    if (const char* xdg = std::getenv("XDG_CONFIG_HOME"); xdg && *xdg) return (fs::path(xdg) / "raypack").string();
    if (const char* home = std::getenv("HOME"); home && *home) return (fs::path(home) / ".config" / "raypack").string();
    return (fs::temp_directory_path() / "raypack").string();
}

std::string cameraCliArguments(const Camera& camera) {
    return "--eye " + exactVec3(camera.eye) + " --at " + exactVec3(camera.at) + " --up " + exactVec3(camera.up) +
           " --fov " + exactFloat(camera.fovYDegrees);
}

BookmarkStore::BookmarkStore(std::string file, std::string scenePath)
    : file_(std::move(file)), sceneKey_(sceneKeyOf(scenePath)) {
    if (!fs::exists(file_)) return;
    const json all = readJsonFile(file_);
    if (!all.is_object() || !all.contains(sceneKey_)) return;
    const json& scene = all[sceneKey_];
    if (!scene.is_object()) throw Error(file_ + ": the entry of " + sceneKey_ + " is not an object");
    for (int number = 1; number <= kBookmarkSlots; ++number) {
        const std::string key = std::to_string(number);
        if (!scene.contains(key)) continue;
        try {
            slots_[number - 1] = cameraFromJson(scene[key]);
        } catch (const Error& e) {
            throw Error(file_ + ": bookmark " + key + " of " + sceneKey_ + ": " + e.what());
        }
    }
}

const std::optional<Camera>& BookmarkStore::slot(int number) const {
    RAYPACK_CHECK(number >= 1 && number <= kBookmarkSlots);
    return slots_[number - 1];
}

void BookmarkStore::save(int number, const Camera& camera) {
    RAYPACK_CHECK(number >= 1 && number <= kBookmarkSlots);
    slots_[number - 1] = camera;
    // Re-read so that bookmarks saved meanwhile by another viewer for other scenes survive.
    json all = json::object();
    if (fs::exists(file_)) {
        all = readJsonFile(file_);
        if (!all.is_object()) all = json::object();
    }
    json scene = json::object();
    for (int n = 1; n <= kBookmarkSlots; ++n)
        if (slots_[n - 1]) scene[std::to_string(n)] = cameraToJson(*slots_[n - 1]);
    all[sceneKey_] = scene;
    std::error_code error;
    fs::create_directories(fs::path(file_).parent_path(), error);
    if (error) throw Error(file_ + ": cannot create its folder: " + error.message());
    writeJsonFile(file_, all);
}

}  // namespace raypack::ui
