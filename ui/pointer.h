#pragma once
// The mouse over the traced image, for the orbit camera's pick (renderer/pick.h): which pixel of
// the traced image lies under the cursor, and a double-click told apart from two clicks by the
// wall clock of the events themselves. ImGui's own double-click measures its 0.3 s in frames'
// time, so at lavapipe's frame rates (a frame of a second or more) it never fires; GLFW's
// mouse-button callback with glfwGetTime() does not depend on the frame rate.
#include <glm/glm.hpp>

#include <cstdint>
#include <optional>

namespace raypack::ui {

// Where the traced image is shown, in framebuffer pixels: its rectangle in the swapchain image
// (e.g. the part of the window the panel leaves free, PanelState::coveredWidthPixels) and the size
// it was traced at (smaller than the rectangle when it is traced at reduced resolution and scaled
// up).
struct ShownImage {
    glm::vec2 origin{0.0f};     // top-left corner in the framebuffer
    glm::vec2 size{0.0f};       // of the rectangle in the framebuffer
    glm::uvec2 traced{0u, 0u};  // width and height the image was traced at
};

// The traced image's pixel (x right, y down, row 0 at the top) under a cursor at `cursor` in
// window coordinates (glfwGetCursorPos) of a window of `windowSize` (glfwGetWindowSize) whose
// framebuffer is `framebufferSize` (glfwGetFramebufferSize); nullopt when the cursor is outside
// the shown image.
std::optional<glm::uvec2> imagePixelUnderCursor(glm::dvec2 cursor, glm::ivec2 windowSize, glm::ivec2 framebufferSize,
                                                const ShownImage& image);

// Presses of one mouse button, by the time of the press: press() is true for the second of two
// presses less than kMaxSeconds apart and kMaxDistance window units apart (ImGui's defaults); a
// third press starts over.
class DoubleClickDetector {
public:
    static constexpr double kMaxSeconds = 0.30;
    static constexpr double kMaxDistance = 6.0;

    bool press(double seconds, glm::dvec2 position);

private:
    std::optional<double> lastSeconds_;
    glm::dvec2 lastPosition_{0.0};
};

}  // namespace raypack::ui
