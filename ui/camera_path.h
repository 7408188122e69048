#pragma once
// Recorded camera paths: `raypack --record-path FILE` writes the camera of every frame with its
// time since the recording started; `--play-path FILE` flies the same path again, following the
// recorded timing on the wall clock (the camera at time t interpolated between the two keys around
// t), or, with --play-frames, one key per frame (frame for frame, for tests and comparisons).
//
// File (JSON): {"format": "raypack-camera-path-1", "scene": "...",
//               "keys": [{"t": seconds, "eye": [x,y,z], "at": [..], "up": [..], "fov_y_degrees": f}, ...]}
#include "renderer/camera.h"

#include <string>
#include <vector>

namespace raypack::ui {

struct CameraKey {
    double seconds = 0.0;  // since the first key
    Camera camera;
};

struct CameraPath {
    std::string scene;  // the scene it was recorded on (informative)
    std::vector<CameraKey> keys;
    double duration() const { return keys.empty() ? 0.0 : keys.back().seconds; }
};

// Throws raypack::Error naming the file when it cannot be written.
void writeCameraPath(const std::string& path, const CameraPath& cameraPath);
// Throws raypack::Error naming the file and the key when it cannot be read, is not a camera path,
// has no keys, a non-finite value or times that go backwards.
CameraPath readCameraPath(const std::string& path);

// The camera at `seconds`: the first key before it, the last after it, linear interpolation of
// eye, at, up and fov between the keys around it. The path must have keys.
Camera cameraAt(const CameraPath& path, double seconds);

}  // namespace raypack::ui
