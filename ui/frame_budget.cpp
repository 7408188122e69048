#include "ui/frame_budget.h"

#include "renderer/progressive.h"

#include <algorithm>

namespace raypack::ui {

namespace {
// Weight of the newest frame in the smoothed costs: reacts within a few frames to a view that
// suddenly costs more (flying into a detailed part of the scene), without following every outlier.
constexpr double kNewestWeight = 0.5;
}  // namespace

void FrameCostModel::addFrame(uint64_t pixels, double traceSeconds, double frameSeconds) {
    if (pixels == 0 || !(traceSeconds >= 0.0) || !(frameSeconds >= 0.0)) return;
    const double perPixel = traceSeconds / double(pixels);
    const double fixed = std::max(0.0, frameSeconds - traceSeconds);
    if (!measured_) {
        secondsPerPixel_ = perPixel;
        fixedSeconds_ = fixed;
        measured_ = true;
        return;
    }
    secondsPerPixel_ += kNewestWeight * (perPixel - secondsPerPixel_);
    fixedSeconds_ += kNewestWeight * (fixed - fixedSeconds_);
}

uint32_t chooseResolutionScale(const FrameCostModel& model, uint32_t width, uint32_t height, double budgetSeconds) {
    if (!model.measured()) return 1;
    for (const uint32_t scale : kResolutionScales) {
        const uint64_t pixels = uint64_t(scaledExtent(width, scale)) * scaledExtent(height, scale);
        if (model.predictSeconds(pixels) <= budgetSeconds) return scale;
    }
    return kResolutionScales[std::size(kResolutionScales) - 1];
}

}  // namespace raypack::ui
