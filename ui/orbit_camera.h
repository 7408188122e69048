#pragma once
// The viewer's orbit camera, beside the fly camera (ui/fly_camera.h): dragging with the left mouse
// button orbits a pivot, dragging with the middle button pans, the wheel zooms toward the point
// under the cursor. Pure logic over a Camera value, like the fly camera: the window code turns
// GLFW events into an OrbitInput (and picks the point under the cursor, renderer/pick.h), which
// keeps this testable headless.
//
// Every motion moves the whole camera (eye, at and pivot) rigidly or by one scaling, so the
// Camera value stays a plain pinhole camera that the fly camera, the bookmarks and raypack-cli
// read as they are:
// - orbit: a rotation about the pivot, yaw about the camera's up vector, pitch about its right
//   vector, the pitch of the view stopping kMaxPitchRadians short of the poles as the fly camera's;
// - pan: a translation in the view plane by the cursor's motion at the depth of the pivot, so the
//   pivot (and everything at its depth) follows the cursor;
// - zoom: a scaling of eye, at and pivot about the zoom target (the point under the cursor, or
//   the pivot when the cursor is over the background), so the target stays under the cursor and
//   the distance to the pivot shrinks by kZoomFactor per wheel step.
// A pivot set from a picked point (double-click) changes nothing on screen; the next orbit turns
// about it. Switching between fly and orbit (Tab) passes the Camera value across: no jump.
#include "renderer/aabb.h"
#include "renderer/camera.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <optional>

namespace raypack::ui {

class FlyCamera;

struct OrbitInput {
    glm::vec2 orbitPixels{0.0f};  // mouse motion while the left button is held
    glm::vec2 panPixels{0.0f};    // mouse motion while the middle button is held
    float wheel = 0.0f;           // scroll steps this frame (positive: closer)
    // The scene point under the cursor when the wheel turned (renderer/pick.h); nullopt when the
    // cursor is over the background: then the wheel zooms toward the pivot.
    std::optional<glm::vec3> zoomTarget;
    uint32_t viewportHeight = 1;  // pixels of the traced image's height, for the pan's scale
};

class OrbitCamera {
public:
    static constexpr float kRadiansPerPixel = 0.005f;  // orbit sensitivity
    static constexpr float kZoomFactor = 0.85f;        // distance to the target per wheel step
    static constexpr float kMaxPitchRadians = 1.55f;   // as FlyCamera's
    // The distance from the eye to the pivot stays within these multiples of the scene's
    // bounding-box diagonal, so the wheel can neither reach the pivot nor lose the scene.
    static constexpr float kMinDistancePerDiagonal = 1e-4f;
    static constexpr float kMaxDistancePerDiagonal = 100.0f;

    // Starts at `camera` with the pivot at camera.at, or at `pivot` when given (e.g. the point
    // picked at the centre of the image when Tab switches from the fly camera).
    void reset(const Camera& camera, const Aabb& sceneBounds, std::optional<glm::vec3> pivot = {});
    // F: back to the default framing of the whole scene (frameScene), the pivot at its centre.
    void frameAll();
    // Moves the camera by one frame of input. Returns whether the camera changed.
    bool update(const OrbitInput& input);

    // The pivot becomes `point` (a picked point); the view does not move.
    void setPivot(const glm::vec3& point) { pivot_ = point; }
    const glm::vec3& pivot() const { return pivot_; }
    const Camera& camera() const { return camera_; }
    // The camera set from outside (a bookmark, the fov slider): the pivot keeps its distance in
    // front of the new eye, on the new view axis.
    void setCamera(const Camera& camera);

private:
    float distanceLimit(float perDiagonal) const;
    bool orbit(glm::vec2 pixels);
    bool pan(glm::vec2 pixels, uint32_t viewportHeight);
    bool zoom(float steps, const glm::vec3& target);

    Camera camera_;
    Aabb sceneBounds_;
    glm::vec3 pivot_{0.0f};
};

// Tab: the camera passes from one mode to the other unchanged (same eye, at, up and fov, so the
// image does not jump); the orbit pivot starts at camera.at unless a picked point is given.
void switchToOrbit(const FlyCamera& fly, OrbitCamera& orbit, const Aabb& sceneBounds,
                   std::optional<glm::vec3> pivot = {});
void switchToFly(const OrbitCamera& orbit, FlyCamera& fly);

}  // namespace raypack::ui
