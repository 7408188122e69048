#pragma once
// The viewer's frame-time budget: while the camera moves or a setting changes, trace at the
// resolution that fits the budget (the window divided by 1, 2, 4 or 8 in each axis), chosen from
// the measured cost of the last frames; return to full resolution when motion stops.
//
// Cost model of one frame: fixedSeconds + tracedPixels * secondsPerPixel, where secondsPerPixel is
// the tracing time per traced pixel (host wall time of the CPU tracers, GPU timestamps or the host
// time of a synchronous GPU frame) and fixedSeconds the rest of the frame (panel, copy, present).
// Both are smoothed over the newest frames. Pure logic, testable headless.
#include <cstdint>

namespace raypack::ui {

constexpr uint32_t kResolutionScales[] = {1, 2, 4, 8};
constexpr double kDefaultFrameBudgetSeconds = 0.033;

class FrameCostModel {
public:
    // One traced frame: `pixels` traced, `traceSeconds` of tracing within `frameSeconds` in all.
    void addFrame(uint64_t pixels, double traceSeconds, double frameSeconds);
    bool measured() const { return measured_; }
    double secondsPerPixel() const { return secondsPerPixel_; }
    double fixedSeconds() const { return fixedSeconds_; }
    // The predicted wall time of a frame tracing `pixels`.
    double predictSeconds(uint64_t pixels) const { return fixedSeconds_ + double(pixels) * secondsPerPixel_; }
    void reset() { *this = FrameCostModel(); }

private:
    bool measured_ = false;
    double secondsPerPixel_ = 0.0;
    double fixedSeconds_ = 0.0;
};

// The smallest scale of kResolutionScales whose predicted frame fits `budgetSeconds`; the largest
// scale when none does; 1 before the first measurement.
uint32_t chooseResolutionScale(const FrameCostModel& model, uint32_t width, uint32_t height, double budgetSeconds);

}  // namespace raypack::ui
