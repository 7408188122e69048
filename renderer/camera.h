#pragma once
// Pinhole camera, default framing and the light above the camera. The primary-ray formula itself
// lives in shaders/camera.h so that GLSL and C++ share it.
#include "renderer/aabb.h"
#include "shaders/camera.h"

#include <glm/glm.hpp>

#include <cstdint>

namespace raypack {

using gpu::GpuCamera;

struct Camera {
    glm::vec3 eye{0.0f, 0.0f, 1.0f};
    glm::vec3 at{0.0f, 0.0f, 0.0f};
    glm::vec3 up{0.0f, 1.0f, 0.0f};
    float fovYDegrees = 60.0f;  // vertical field of view
};

// Throws raypack::Error when the camera is degenerate (eye == at, up parallel to the view
// direction, fov outside (0, 180)) or the image is empty.
//
// `pixelJitter` moves every primary ray by that many pixels off its pixel's centre (x right, y
// down). It is folded into GpuCamera::forward (which then need not be unit length: the ray
// direction is normalized after the sum), so no kernel needs to know about it; zero leaves the
// camera bit for bit as without it.
GpuCamera makeGpuCamera(const Camera& camera, uint32_t width, uint32_t height, glm::vec2 pixelJitter = glm::vec2(0.0f));

// The deterministic default view of a scene: looks at the centre of `bounds` from the direction
// normalize(0.5, 0.4, 1.0) (front, right, above), up = +y, vertical fov 60 degrees, at the distance
// where the bounding sphere fills the vertical field of view with a 10% margin. An empty or
// single-point box gets a unit radius.
Camera frameScene(const Aabb& bounds);

// The point light (report 2.3): above the camera, along the camera's normalized up vector, by
// `lightHeight` times the scene's height, the extent of `sceneBounds` measured along that up vector.
glm::vec3 lightPosition(const Camera& camera, const Aabb& sceneBounds, float lightHeight);

}  // namespace raypack
