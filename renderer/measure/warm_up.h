#pragma once
// The GPU warm-up before timed frames: frames back to back until the device's clocks have settled
// (measureFrames in protocol.h, and the driver's ray tracing peer, renderer/vk/rt_peer.h).
#include <cstdint>
#include <functional>

namespace raypack {

// What a GPU warm-up ran before the timed frames (warmUpUntilSteady).
struct GpuWarmUp {
    double seconds = 0.0;  // host time of its batches
    uint32_t frames = 0;
    uint32_t batches = 0;
    // The last batch traced no faster per frame than the one before (the clocks had settled), or a
    // single frame outlasted a batch; false where it stopped at its time limit still speeding up.
    bool steady = false;
};

// GPU time traced back to back right before the timed frames at least, by default
// (renderer/measure/protocol.cpp says why): on the H200 a clock that had fallen to 480-615 MHz while
// the host built a 13M-triangle scene came back to 1980 MHz only after 0.2-0.3 s of full load, and
// warm-ups that ran until their frames stopped speeding up took 0.33-0.54 s there (2026-12-07).
constexpr double kGpuWarmUpSeconds = 0.5;
// The longest GPU warm-up: a device whose frames still speed up after this long is measured as it
// is, and its records say so (gpu_warm_up_steady false).
constexpr double kGpuWarmUpMaxSeconds = 3.0;
// A batch of the warm-up is steady when it traces no faster per frame than the batch before it,
// within this share.
constexpr double kGpuWarmUpSteadyShare = 0.02;

// Traces frames back to back in batches until the device's clocks have settled: runBatch(n) traces
// n frames in one submission and returns the host seconds that took; frameSeconds (one frame's
// time, measured before) sizes the first batch. Each batch lasts about a third of minSeconds, so
// at least three run; after minSeconds it stops at the first batch no faster per frame than the
// one before (within kGpuWarmUpSteadyShare), or once maxSeconds have run, or at once where one
// frame outlasts a batch (it keeps the device busy on its own). minSeconds <= 0: one frame.
GpuWarmUp warmUpUntilSteady(const std::function<double(uint32_t frames)>& runBatch, double frameSeconds,
                            double minSeconds, double maxSeconds = kGpuWarmUpMaxSeconds);

}  // namespace raypack
