#include "ui/camera_path.h"

#include "renderer/error.h"
#include "renderer/settings_json.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace raypack::ui {
namespace {

constexpr const char* kFormat = "raypack-camera-path-1";

nlohmann::json vec3Json(const glm::vec3& v) { return {v.x, v.y, v.z}; }

glm::vec3 readVec3(const nlohmann::json& key, const char* name, const std::string& where) {
    const auto it = key.find(name);
    if (it == key.end() || !it->is_array() || it->size() != 3)
        throw Error(where + ": \"" + name + "\" is not an array of three numbers");
    glm::vec3 v;
    for (int i = 0; i < 3; ++i) {
        if (!(*it)[i].is_number()) throw Error(where + ": \"" + name + "\" is not an array of three numbers");
        v[i] = (*it)[i].get<float>();
        if (!std::isfinite(v[i])) throw Error(where + ": \"" + name + "\" is not finite");
    }
    return v;
}

}  // namespace

void writeCameraPath(const std::string& path, const CameraPath& cameraPath) {
    nlohmann::json keys = nlohmann::json::array();
    for (const CameraKey& k : cameraPath.keys)
        keys.push_back({{"t", k.seconds},
                        {"eye", vec3Json(k.camera.eye)},
                        {"at", vec3Json(k.camera.at)},
                        {"up", vec3Json(k.camera.up)},
                        {"fov_y_degrees", k.camera.fovYDegrees}});
    writeJsonFile(path, {{"format", kFormat}, {"scene", cameraPath.scene}, {"keys", keys}});
}

CameraPath readCameraPath(const std::string& path) {
    const nlohmann::json json = readJsonFile(path);
    if (!json.is_object() || json.value("format", std::string()) != kFormat)
        throw Error(path + ": not a camera path (\"format\" is not \"" + kFormat + "\")");
    CameraPath result;
    if (json.contains("scene") && json["scene"].is_string()) result.scene = json["scene"].get<std::string>();
    const auto keys = json.find("keys");
    if (keys == json.end() || !keys->is_array() || keys->empty())
        throw Error(path + ": \"keys\" is not a non-empty array");
    for (size_t i = 0; i < keys->size(); ++i) {
        const nlohmann::json& key = (*keys)[i];
        const std::string where = path + ": key " + std::to_string(i);
        if (!key.is_object() || !key.contains("t") || !key["t"].is_number()) throw Error(where + ": no time \"t\"");
        CameraKey k;
        k.seconds = key["t"].get<double>();
        if (!std::isfinite(k.seconds) || (!result.keys.empty() && k.seconds < result.keys.back().seconds))
            throw Error(where + ": time " + std::to_string(k.seconds) + " is not finite or goes backwards");
        k.camera.eye = readVec3(key, "eye", where);
        k.camera.at = readVec3(key, "at", where);
        k.camera.up = readVec3(key, "up", where);
        if (!key.contains("fov_y_degrees") || !key["fov_y_degrees"].is_number())
            throw Error(where + ": no \"fov_y_degrees\"");
        k.camera.fovYDegrees = key["fov_y_degrees"].get<float>();
        result.keys.push_back(k);
    }
    return result;
}

Camera cameraAt(const CameraPath& path, double seconds) {
    RAYPACK_CHECK(!path.keys.empty());
    const std::vector<CameraKey>& keys = path.keys;
    if (seconds <= keys.front().seconds) return keys.front().camera;
    if (seconds >= keys.back().seconds) return keys.back().camera;
    const auto next =
        std::upper_bound(keys.begin(), keys.end(), seconds, [](double s, const CameraKey& k) { return s < k.seconds; });
    const CameraKey& b = *next;
    const CameraKey& a = *(next - 1);
    const double span = b.seconds - a.seconds;
    const float w = span > 0.0 ? float((seconds - a.seconds) / span) : 1.0f;
    Camera c;
    c.eye = glm::mix(a.camera.eye, b.camera.eye, w);
    c.at = glm::mix(a.camera.at, b.camera.at, w);
    c.up = glm::mix(a.camera.up, b.camera.up, w);
    c.fovYDegrees = a.camera.fovYDegrees + (b.camera.fovYDegrees - a.camera.fovYDegrees) * w;
    return c;
}

}  // namespace raypack::ui
