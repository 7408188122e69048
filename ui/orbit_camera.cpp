#include "ui/orbit_camera.h"

#include "ui/fly_camera.h"

#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>

namespace raypack::ui {

namespace {

// Right vector of a view along `forward` with `worldUp`; any horizontal one when the two are
// parallel (a camera set from outside looking straight along up).
glm::vec3 rightOf(const glm::vec3& forward, const glm::vec3& worldUp) {
    glm::vec3 right = glm::cross(forward, worldUp);
    if (glm::length(right) < 1e-6f)
        right = glm::cross(worldUp, std::abs(worldUp.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 0, 1));
    return glm::normalize(right);
}

}  // namespace

void OrbitCamera::reset(const Camera& camera, const Aabb& sceneBounds, std::optional<glm::vec3> pivot) {
    camera_ = camera;
    sceneBounds_ = sceneBounds;
    pivot_ = pivot.value_or(camera.at);
}

void OrbitCamera::frameAll() {
    camera_ = frameScene(sceneBounds_);
    pivot_ = camera_.at;
}

void OrbitCamera::setCamera(const Camera& camera) {
    const bool sameView = camera.eye == camera_.eye && camera.at == camera_.at && camera.up == camera_.up;
    if (!sameView) {
        const float distance = glm::length(pivot_ - camera_.eye);
        pivot_ = camera.eye + glm::normalize(camera.at - camera.eye) * distance;
    }
    camera_ = camera;
}

float OrbitCamera::distanceLimit(float perDiagonal) const {
    float diagonal = glm::length(sceneBounds_.extent());
    if (!(diagonal > 0.0f)) diagonal = 1.0f;  // empty or single-point scene: frameScene's unit radius
    return perDiagonal * diagonal;
}

bool OrbitCamera::update(const OrbitInput& input) {
    bool changed = false;
    if (input.orbitPixels != glm::vec2(0.0f)) changed |= orbit(input.orbitPixels);
    if (input.panPixels != glm::vec2(0.0f)) changed |= pan(input.panPixels, input.viewportHeight);
    if (input.wheel != 0.0f) changed |= zoom(input.wheel, input.zoomTarget.value_or(pivot_));
    return changed;
}

bool OrbitCamera::orbit(glm::vec2 pixels) {
    const glm::vec3 worldUp = glm::normalize(camera_.up);
    const glm::vec3 forward = glm::normalize(camera_.at - camera_.eye);
    // Dragging right moves the camera left around the pivot (the scene turns with the cursor);
    // dragging down moves it up, so the view tilts down. The pitch is the view's, measured from
    // the plane perpendicular to up, and stops short of the poles.
    const float yaw = -pixels.x * kRadiansPerPixel;
    const float pitch = std::asin(std::clamp(glm::dot(forward, worldUp), -1.0f, 1.0f));
    const float newPitch = std::clamp(pitch - pixels.y * kRadiansPerPixel, -kMaxPitchRadians, kMaxPitchRadians);
    const glm::quat rotation =
        glm::angleAxis(yaw, worldUp) * glm::angleAxis(newPitch - pitch, rightOf(forward, worldUp));
    camera_.eye = pivot_ + rotation * (camera_.eye - pivot_);
    camera_.at = pivot_ + rotation * (camera_.at - pivot_);
    return true;
}

bool OrbitCamera::pan(glm::vec2 pixels, uint32_t viewportHeight) {
    const glm::vec3 forward = glm::normalize(camera_.at - camera_.eye);
    const glm::vec3 right = rightOf(forward, glm::normalize(camera_.up));
    const glm::vec3 upInView = glm::cross(right, forward);
    // World units per pixel at the pivot's depth (shaders/camera.h: v spans 2 tan(fov/2) over the
    // image height at unit depth). A pivot behind the eye pans at the depth of `at`.
    float depth = glm::dot(pivot_ - camera_.eye, forward);
    if (!(depth > 0.0f)) depth = glm::length(camera_.at - camera_.eye);
    const float unitsPerPixel =
        2.0f * depth * std::tan(glm::radians(camera_.fovYDegrees) * 0.5f) / float(std::max(viewportHeight, 1u));
    const glm::vec3 delta = (-pixels.x * right + pixels.y * upInView) * unitsPerPixel;
    camera_.eye += delta;
    camera_.at += delta;
    pivot_ += delta;
    return true;
}

bool OrbitCamera::zoom(float steps, const glm::vec3& target) {
    const float distance = glm::length(pivot_ - camera_.eye);
    float factor = std::pow(kZoomFactor, steps);
    if (distance > 0.0f)
        factor = std::clamp(factor, distanceLimit(kMinDistancePerDiagonal) / distance,
                            distanceLimit(kMaxDistancePerDiagonal) / distance);
    if (factor == 1.0f) return false;
    // A scaling about the target: the target stays on its pixel's ray (the view direction does not
    // change and the eye moves along that ray), every distance shrinks by the same factor.
    auto scale = [&](const glm::vec3& p) { return target + (p - target) * factor; };
    camera_.eye = scale(camera_.eye);
    camera_.at = scale(camera_.at);
    pivot_ = scale(pivot_);
    return true;
}

void switchToOrbit(const FlyCamera& fly, OrbitCamera& orbit, const Aabb& sceneBounds, std::optional<glm::vec3> pivot) {
    orbit.reset(fly.camera(), sceneBounds, pivot);
}

void switchToFly(const OrbitCamera& orbit, FlyCamera& fly) { fly.setCamera(orbit.camera()); }

}  // namespace raypack::ui
