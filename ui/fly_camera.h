#pragma once
// The viewer's fly camera: W/A/S/D move in the view plane, Q/E down and up, dragging with the right
// mouse button turns the view, the wheel changes the speed and Shift makes it faster. Speeds are
// in units of the scene's size, so a bunny and a cathedral fly the same. Pure logic over a Camera
// value: the window code turns GLFW events into a FlyInput, which keeps this testable headless.
#include "renderer/aabb.h"
#include "renderer/camera.h"

#include <glm/glm.hpp>

namespace raypack::ui {

struct FlyInput {
    // Keys held for the whole frame (moved by update's `seconds`)...
    bool forward = false, back = false;  // W, S
    bool left = false, right = false;    // A, D
    bool down = false, up = false;       // Q, E
    // ... and, from ui/input.h's HeldKeys, seconds each direction was held during the frame:
    // x right minus left, y up minus down, z forward minus back.
    glm::vec3 heldSeconds{0.0f};
    bool fast = false;           // Shift
    glm::vec2 lookPixels{0.0f};  // mouse motion while the right button is held
    float wheel = 0.0f;          // scroll steps this frame (positive: faster)
};

class FlyCamera {
public:
    // Speed: this share of the scene's bounding-box diagonal per second.
    static constexpr float kBaseSpeedPerDiagonal = 0.25f;
    static constexpr float kFastFactor = 4.0f;
    static constexpr float kWheelFactor = 1.2f;         // per scroll step
    static constexpr float kRadiansPerPixel = 0.0035f;  // mouse look sensitivity
    // Pitch stops this far from straight up or down, so `up` never becomes parallel to the view.
    static constexpr float kMaxPitchRadians = 1.55f;
    // One frame moves the camera by at most this many seconds of flight, however long the frame
    // took: a one-second frame cannot carry the camera through a wall.
    static constexpr float kMaxStepSeconds = 0.1f;

    // Starts at `camera` (the CLI's default framing of the scene when the viewer opens one).
    void reset(const Camera& camera, const Aabb& sceneBounds);
    // F: back to the default framing of the whole scene (frameScene), speed kept.
    void frameAll();
    // Moves and turns the camera by one frame of input lasting `seconds`; the step is at most
    // kMaxStepSeconds of flight. Returns whether the camera changed.
    bool update(const FlyInput& input, float seconds);

    const Camera& camera() const { return camera_; }
    void setCamera(const Camera& camera) { camera_ = camera; }
    float speed() const;  // scene units per second, without Shift
    float speedMultiplier() const { return speedMultiplier_; }

private:
    Camera camera_;
    Aabb sceneBounds_;
    float speedMultiplier_ = 1.0f;
};

}  // namespace raypack::ui
