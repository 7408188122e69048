#include "renderer/camera.h"

#include "renderer/error.h"

#include <cmath>
#include <sstream>
#include <string>

namespace raypack {
namespace {

std::string describe(const glm::vec3& v) {
    std::ostringstream s;
    s << v.x << "," << v.y << "," << v.z;
    return s.str();
}

bool isFinite(const glm::vec3& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

}  // namespace

GpuCamera makeGpuCamera(const Camera& camera, uint32_t width, uint32_t height, glm::vec2 pixelJitter) {
    if (width == 0 || height == 0)
        throw Error("camera: the image is empty (" + std::to_string(width) + "x" +
                    std::to_string(height) + ")");
    if (!isFinite(camera.eye) || !isFinite(camera.at) || !isFinite(camera.up))
        throw Error("camera: eye " + describe(camera.eye) + ", at " + describe(camera.at) +
                    " or up " + describe(camera.up) + " is not finite");
    if (!(camera.fovYDegrees > 0.0f && camera.fovYDegrees < 180.0f))
        throw Error("camera: vertical field of view " + std::to_string(camera.fovYDegrees) +
                    " degrees is outside (0, 180)");
    const glm::vec3 view = camera.at - camera.eye;
    if (view == glm::vec3(0.0f))
        throw Error("camera: eye and look-at point are the same (" + describe(camera.eye) + ")");
    if (camera.up == glm::vec3(0.0f)) throw Error("camera: the up vector is zero");
    const glm::vec3 forward = glm::normalize(view);
    const glm::vec3 side = glm::cross(forward, glm::normalize(camera.up));
    // sin of the angle between view direction and up; below ~1e-6 the right vector is noise.
    if (!(glm::length(side) > 1e-6f))
        throw Error("camera: up " + describe(camera.up) + " is parallel to the view direction " +
                    describe(forward));
    const glm::vec3 right = glm::normalize(side);
    const glm::vec3 up = glm::cross(right, forward);

    const float tanHalfFov = std::tan(glm::radians(camera.fovYDegrees) * 0.5f);
    const float aspect = float(width) / float(height);
    GpuCamera gpu;
    gpu.eye = glm::vec4(camera.eye, tanHalfFov * aspect);
    // u grows by 2 * jitter.x / W * (tan * aspect) across the image, v falls by 2 * jitter.y / H *
    // tan (shaders/camera.h): the same offset for every pixel, so it moves the image plane's centre.
    glm::vec3 centre = forward;
    if (pixelJitter != glm::vec2(0.0f))
        centre += (2.0f * pixelJitter.x / float(width) * tanHalfFov * aspect) * right -
                  (2.0f * pixelJitter.y / float(height) * tanHalfFov) * up;
    gpu.forward = glm::vec4(centre, tanHalfFov);
    gpu.right = glm::vec4(right, float(width));
    gpu.up = glm::vec4(up, float(height));
    return gpu;
}

Camera frameScene(const Aabb& bounds) {
    glm::vec3 center(0.0f);
    float radius = 1.0f;
    if (!bounds.empty()) {
        center = bounds.center();
        const float boxRadius = 0.5f * glm::length(bounds.extent());
        if (boxRadius > 0.0f) radius = boxRadius;
    }
    Camera camera;
    camera.fovYDegrees = 60.0f;
    camera.up = glm::vec3(0.0f, 1.0f, 0.0f);
    // The bounding sphere (radius enlarged by 10%) touches the vertical field of view's edges.
    const float distance = 1.1f * radius / std::sin(glm::radians(camera.fovYDegrees) * 0.5f);
    camera.at = center;
    camera.eye = center + glm::normalize(glm::vec3(0.5f, 0.4f, 1.0f)) * distance;
    return camera;
}

glm::vec3 lightPosition(const Camera& camera, const Aabb& sceneBounds, float lightHeight) {
    if (camera.up == glm::vec3(0.0f)) throw Error("camera: the up vector is zero");
    const glm::vec3 up = glm::normalize(camera.up);
    // Extent of the box projected on `up`: the sum of its edges' projections.
    const glm::vec3 extent = sceneBounds.extent();
    const float sceneHeight = glm::dot(glm::abs(up), extent);
    return camera.eye + up * (lightHeight * sceneHeight);
}

}  // namespace raypack
