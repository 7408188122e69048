#include "ui/fly_camera.h"

#include <glm/gtc/constants.hpp>

#include <algorithm>
#include <cmath>

namespace raypack::ui {

void FlyCamera::reset(const Camera& camera, const Aabb& sceneBounds) {
    camera_ = camera;
    sceneBounds_ = sceneBounds;
}

void FlyCamera::frameAll() { camera_ = frameScene(sceneBounds_); }

float FlyCamera::speed() const {
    float diagonal = glm::length(sceneBounds_.extent());
    if (!(diagonal > 0.0f)) diagonal = 1.0f;  // empty or single-point scene: frameScene's unit radius
    return kBaseSpeedPerDiagonal * diagonal * speedMultiplier_;
}

bool FlyCamera::update(const FlyInput& input, float seconds) {
    bool changed = false;
    if (input.wheel != 0.0f) {
        speedMultiplier_ = std::clamp(speedMultiplier_ * std::pow(kWheelFactor, input.wheel), 1.0f / 1024.0f, 1024.0f);
    }

    const glm::vec3 worldUp = glm::normalize(camera_.up);
    glm::vec3 offset = camera_.at - camera_.eye;
    const float distance = glm::length(offset);
    glm::vec3 forward = offset / distance;

    if (input.lookPixels != glm::vec2(0.0f)) {
        // Yaw about the camera's up vector, pitch about its right vector, with the pitch measured
        // from the plane perpendicular to `up` and clamped short of the poles.
        const float yaw = -input.lookPixels.x * kRadiansPerPixel;
        float pitch = std::asin(std::clamp(glm::dot(forward, worldUp), -1.0f, 1.0f));
        const float newPitch =
            std::clamp(pitch - input.lookPixels.y * kRadiansPerPixel, -kMaxPitchRadians, kMaxPitchRadians);
        glm::vec3 horizontal = forward - glm::dot(forward, worldUp) * worldUp;
        if (glm::length(horizontal) < 1e-6f) {
            // Looking straight along `up` (only possible for a camera set from outside): pick any
            // horizontal direction perpendicular to it.
            horizontal = glm::cross(worldUp, std::abs(worldUp.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 0, 1));
        }
        horizontal = glm::normalize(horizontal);
        const glm::vec3 side = glm::cross(worldUp, horizontal);  // completes the basis
        const glm::vec3 turned = std::cos(yaw) * horizontal + std::sin(yaw) * side;
        forward = glm::normalize(std::cos(newPitch) * turned + std::sin(newPitch) * worldUp);
        camera_.at = camera_.eye + forward * distance;
        changed = true;
    }

    const glm::vec3 right = glm::normalize(glm::cross(forward, worldUp));
    glm::vec3 move(0.0f);
    if (input.forward) move += forward;
    if (input.back) move -= forward;
    if (input.right) move += right;
    if (input.left) move -= right;
    if (input.up) move += worldUp;
    if (input.down) move -= worldUp;
    // In seconds of flight: the held keys for `seconds`, the timed ones for their own durations.
    glm::vec3 travel(0.0f);
    if (move != glm::vec3(0.0f) && seconds > 0.0f) travel = glm::normalize(move) * seconds;
    travel += input.heldSeconds.x * right + input.heldSeconds.y * worldUp + input.heldSeconds.z * forward;
    const float travelSeconds = glm::length(travel);
    if (travelSeconds > 0.0f) {
        if (travelSeconds > kMaxStepSeconds) travel *= kMaxStepSeconds / travelSeconds;
        const glm::vec3 delta = travel * (speed() * (input.fast ? kFastFactor : 1.0f));
        camera_.eye += delta;
        camera_.at += delta;
        changed = true;
    }
    return changed;
}

}  // namespace raypack::ui
