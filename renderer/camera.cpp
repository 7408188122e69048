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

bool isFinite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

GpuCamera makeGpuCamera(const Camera& camera, uint32_t width, uint32_t height, glm::vec2 pixelJitter) {
    if (width == 0 || height == 0)
        throw Error("camera: the image is empty (" + std::to_string(width) + "x" + std::to_string(height) + ")");
    if (!isFinite(camera.eye) || !isFinite(camera.at) || !isFinite(camera.up))
        throw Error("camera: eye " + describe(camera.eye) + ", at " + describe(camera.at) + " or up " +
                    describe(camera.up) + " is not finite");
    if (!(camera.fovYDegrees > 0.0f && camera.fovYDegrees < 180.0f))
        throw Error("camera: vertical field of view " + std::to_string(camera.fovYDegrees) +
                    " degrees is outside (0, 180)");
    // In double: a float view vector's squared length overflows past |at - eye| ~ 2e19 and
    // underflows below ~1e-19, while the tracer itself is watertight across that whole range.
    const glm::dvec3 view = glm::dvec3(camera.at) - glm::dvec3(camera.eye);
    if (view == glm::dvec3(0.0))
        throw Error("camera: eye and look-at point are the same (" + describe(camera.eye) + ")");
    if (camera.up == glm::vec3(0.0f)) throw Error("camera: the up vector is zero");
    const glm::dvec3 forwardD = glm::normalize(view);
    const glm::dvec3 sideD = glm::cross(forwardD, glm::normalize(glm::dvec3(camera.up)));
    // sin of the angle between view direction and up; below ~1e-6 the right vector is noise.
    if (!(glm::length(sideD) > 1e-6))
        throw Error("camera: up " + describe(camera.up) + " is parallel to the view direction " +
                    describe(glm::vec3(forwardD)));
    const glm::dvec3 rightD = glm::normalize(sideD);
    const glm::vec3 forward(forwardD);
    const glm::vec3 right(rightD);
    const glm::vec3 up(glm::cross(rightD, forwardD));
    const float tanHalfFov = std::tan(glm::radians(camera.fovYDegrees) * 0.5f);
    // shaders/camera.h's u and v as a step per pixel and the value at pixel 0, each rounded once
    // from doubles: u = (2(x + 0.5)/W - 1) tan W/H = x step + (1/W - 1) tan W/H, and
    // v = (1 - 2(y + 0.5)/H) tan = (1 - 1/H) tan - y step, with step = 2 tan / H for both.
    const double tanD = double(tanHalfFov), w = double(width), h = double(height);
    const double step = 2.0 * tanD / h;
    GpuCamera gpu;
    gpu.eye = glm::vec4(camera.eye, float(step));
    // u grows by jitter.x steps, v falls by jitter.y steps: the same offset for every pixel, so it
    // moves the image plane's centre.
    glm::vec3 centre = forward;
    if (pixelJitter != glm::vec2(0.0f))
        centre += float(double(pixelJitter.x) * step) * right - float(double(pixelJitter.y) * step) * up;
    gpu.forward = glm::vec4(centre, float(step));
    gpu.right = glm::vec4(right, float((1.0 / w - 1.0) * tanD * w / h));
    gpu.up = glm::vec4(up, float((1.0 - 1.0 / h) * tanD));
    return gpu;
}

Camera frameScene(const Aabb& bounds) {
    // In double, and by the scene's own scale: a box of size 1e20 or 1e-30 is framed like one of
    // size 1 (in float its diagonal's squared length overflows or underflows).
    glm::dvec3 center(0.0);
    double radius = 1.0;
    if (!bounds.empty()) {
        center = 0.5 * (glm::dvec3(bounds.lo) + glm::dvec3(bounds.hi));
        const double boxRadius = 0.5 * glm::length(glm::dvec3(bounds.hi) - glm::dvec3(bounds.lo));
        if (boxRadius > 0.0) radius = boxRadius;
    }
    Camera camera;
    camera.fovYDegrees = 60.0f;
    camera.up = glm::vec3(0.0f, 1.0f, 0.0f);
    // The bounding sphere (radius enlarged by 10%) touches the vertical field of view's edges.
    const double distance = 1.1 * radius / std::sin(glm::radians(double(camera.fovYDegrees)) * 0.5);
    camera.at = glm::vec3(center);
    camera.eye = glm::vec3(center + glm::normalize(glm::dvec3(0.5, 0.4, 1.0)) * distance);
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
