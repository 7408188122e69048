#include "ui/run_statistics.h"

#include "renderer/measure/spread.h"

#include <sys/resource.h>

#include <algorithm>
#include <map>
#include <string>

namespace raypack::ui {

void RunStatistics::record(const FrameOutcome& frame) {
    FrameRecord record;
    record.startSeconds = frame.startSeconds;
    record.kind = frame.traced ? frame.kind : FrameKind::Idle;
    record.scale = frame.scale;
    record.presented = frame.presented;
    if (frame.presented && frame.firstInputSeconds >= 0.0)
        record.inputLatencySeconds = frame.endSeconds - frame.firstInputSeconds;
    if (!frames_.empty()) frames_.back().seconds = frame.startSeconds - frames_.back().startSeconds;
    frames_.push_back(record);
    if (frame.traced && frame.kind == FrameKind::Moving) {
        lastChange_ = frame.endSeconds;
        fullAfterChange_ = convergedAfterChange_ = -1.0;
    }
    if (lastChange_ >= 0.0 && frame.traced) {
        if (frame.kind == FrameKind::Full || (frame.kind == FrameKind::Moving && record.scale == 1))
            fullAfterChange_ = frame.endSeconds - lastChange_;
        if (frame.kind == FrameKind::Refine && frame.samplesShown >= frame.samplesWanted)
            convergedAfterChange_ = frame.endSeconds - lastChange_;
    }
    if (!frame.presented) {
        ++idleFrames_;
        idleWall_ += frame.idleWallSeconds;
        idleCpu_ += frame.idleCpuSeconds;
    }
}

nlohmann::json RunStatistics::summary() const {
    std::vector<double> moving, still, latency;
    std::map<uint32_t, uint64_t> scales, movingScales;
    uint64_t traced = 0, presented = 0;
    for (const FrameRecord& r : frames_) {
        if (r.kind != FrameKind::Idle) {
            ++traced;
            (r.kind == FrameKind::Moving ? moving : still).push_back(r.seconds);
            ++scales[r.scale];
            if (r.kind == FrameKind::Moving) ++movingScales[r.scale];
        }
        presented += r.presented;
        if (r.inputLatencySeconds >= 0.0) latency.push_back(r.inputLatencySeconds);
    }
    nlohmann::json scaleJson = nlohmann::json::object();
    for (const auto& [scale, count] : scales) scaleJson[std::to_string(scale)] = count;
    nlohmann::json movingScaleJson = nlohmann::json::object();
    for (const auto& [scale, count] : movingScales) movingScaleJson[std::to_string(scale)] = count;
    const auto fps = [](const std::vector<double>& v) {
        const double m = upperMedian(v);
        return m > 0 ? 1.0 / m : 0.0;
    };
    return {
        {"frames", frames_.size()},
        {"frames_traced", traced},
        {"frames_presented", presented},
        {"frames_moving", moving.size()},
        {"fps_moving_median", fps(moving)},
        {"fps_still_median", fps(still)},
        {"resolution_scales", scaleJson},
        {"resolution_scales_moving", movingScaleJson},
        {"input_to_photon_ms_median", upperMedian(latency) * 1e3},
        {"input_frames", latency.size()},
        {"idle_frames", idleFrames_},
        {"idle_wall_s", idleWall_},
        {"idle_cpu_share", idleWall_ > 0 ? idleCpu_ / idleWall_ : 0.0},
        {"full_resolution_after_stop_s", fullAfterChange_},
        {"converged_after_stop_s", convergedAfterChange_},
    };
}

double processCpuSeconds() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
           1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

}  // namespace raypack::ui
