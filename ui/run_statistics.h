#pragma once
// What a viewer run measures about itself (`raypack --summary FILE.json`): every frame's kind,
// resolution scale and duration, the input-to-photon latency, the idle share of the CPU, and the
// times from the last camera change to full resolution and to convergence. Pure bookkeeping,
// testable headless; the session reports each frame and writes summary() with its identity.
#include "ui/frame_loop.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <vector>

namespace raypack::ui {

// One frame of the run.
struct FrameRecord {
    double startSeconds = 0.0;  // since the run started
    double seconds = 0.0;       // until the next frame started (0 for the last one)
    FrameKind kind = FrameKind::Idle;
    uint32_t scale = 1;
    bool presented = false;
    double inputLatencySeconds = -1.0;  // from the first input event to the present, when input came
};

// What the session knows about a frame when it is over.
struct FrameOutcome {
    double startSeconds = 0.0;  // since the run started
    double endSeconds = 0.0;
    bool traced = false;
    bool presented = false;
    FrameKind kind = FrameKind::Idle;  // the plan's kind when traced
    uint32_t scale = 1;                // the resolution scale on screen
    uint32_t samplesShown = 0;         // samples in the image on screen
    uint32_t samplesWanted = 1;        // the refinement's goal
    double firstInputSeconds = -1.0;   // the first input event since the last present, or -1
    // The frame's wall and CPU time when it presented nothing (the loop waited for events).
    double idleWallSeconds = 0.0, idleCpuSeconds = 0.0;
};

class RunStatistics {
public:
    void record(const FrameOutcome& frame);

    const std::vector<FrameRecord>& frames() const { return frames_; }
    // Seconds from the last moving frame to the first full-resolution one and to the converged
    // image; -1 when that has not happened since.
    double fullAfterChangeSeconds() const { return fullAfterChange_; }
    double convergedAfterChangeSeconds() const { return convergedAfterChange_; }

    // frames, frames_traced, frames_presented, frames_moving, fps_moving_median, fps_still_median,
    // resolution_scales(_moving), input_to_photon_ms_median, input_frames, idle_frames, idle_wall_s,
    // idle_cpu_share, full_resolution_after_stop_s, converged_after_stop_s.
    nlohmann::json summary() const;

private:
    std::vector<FrameRecord> frames_;
    uint64_t idleFrames_ = 0;  // frames that presented nothing
    double idleWall_ = 0.0, idleCpu_ = 0.0;
    double lastChange_ = -1.0, fullAfterChange_ = -1.0, convergedAfterChange_ = -1.0;
};

// User plus system CPU time of this process so far.
double processCpuSeconds();

}  // namespace raypack::ui
