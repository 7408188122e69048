#include "ui/pointer.h"

#include <algorithm>
#include <cmath>

namespace raypack::ui {

std::optional<glm::uvec2> imagePixelUnderCursor(glm::dvec2 cursor, glm::ivec2 windowSize, glm::ivec2 framebufferSize,
                                                const ShownImage& image) {
    if (windowSize.x <= 0 || windowSize.y <= 0 || image.traced.x == 0 || image.traced.y == 0 ||
        !(image.size.x > 0.0f) || !(image.size.y > 0.0f))
        return std::nullopt;
    // Window coordinates to framebuffer pixels (they differ on HiDPI screens).
    const glm::dvec2 framebuffer = cursor * glm::dvec2(framebufferSize) / glm::dvec2(windowSize);
    const glm::dvec2 local = (framebuffer - glm::dvec2(image.origin)) / glm::dvec2(image.size);
    if (local.x < 0.0 || local.y < 0.0 || local.x >= 1.0 || local.y >= 1.0) return std::nullopt;
    const glm::dvec2 pixel = glm::floor(local * glm::dvec2(image.traced));
    return glm::uvec2(std::min(uint32_t(pixel.x), image.traced.x - 1), std::min(uint32_t(pixel.y), image.traced.y - 1));
}

bool DoubleClickDetector::press(double seconds, glm::dvec2 position) {
    const bool isDouble =
        lastSeconds_ && seconds - *lastSeconds_ < kMaxSeconds && glm::length(position - lastPosition_) <= kMaxDistance;
    if (isDouble) {
        lastSeconds_.reset();
    } else {
        lastSeconds_ = seconds;
        lastPosition_ = position;
    }
    return isDouble;
}

}  // namespace raypack::ui
