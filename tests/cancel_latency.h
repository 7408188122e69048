#pragma once
// How quickly a BVH build notices `BuildProgress::cancel` (test_bvh, test_bvh_split): the builders
// check every 16k primitives of work, a few hundred microseconds (a few milliseconds under ASan);
// a phase without checks would run on for a second or more at the sizes tested, at the same point
// every time. What is not polled is allocation: sah-split's root references (3M x 32 bytes, zeroed
// by one thread) took 260 ms on this 2-core machine while other tests ran, 2026-12-07. The cores
// are shared (in CI with a second sanitizer test process), and a cancelled sah-split once took
// 570 ms under ASan to stop, so the best of up to three tries must be under the bound, and the
// bound is four times as long in a sanitizer build, which allocates and runs several times slower.
#include "renderer/bvh_build.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <thread>

namespace raypack::test {

// Milliseconds from setting `cancel` `delayMs` into `build(&progress)` to its BuildCancelled;
// nothing (and a failure) when the build finishes first.
template <class Build>
std::optional<double> cancelLatencyMs(int delayMs, const Build& build) {
    BuildProgress progress;
    std::atomic<int64_t> cancelledAt{0};
    std::thread canceller([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(delayMs));
        cancelledAt = std::chrono::steady_clock::now().time_since_epoch().count();
        progress.cancel = true;
    });
    bool threw = false;
    try {
        build(&progress);
    } catch (const BuildCancelled&) {
        threw = true;
    }
    const int64_t stoppedAt = std::chrono::steady_clock::now().time_since_epoch().count();
    canceller.join();
    EXPECT_TRUE(threw) << "the build finished before it was cancelled";
    if (!threw) return std::nullopt;
    return double(stoppedAt - cancelledAt.load()) * 1e-6;
}

// The default bound: four times as long in a sanitizer build (above).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr double kCancelBoundMs = 2000.0;
#else
inline constexpr double kCancelBoundMs = 500.0;
#endif

// The best of up to three cancellations `delayMs` into `build` stops within `boundMs`; prints each.
template <class Build>
void expectCancelledQuickly(const std::string& what, int delayMs, const Build& build, double boundMs = kCancelBoundMs) {
    SCOPED_TRACE(what + " after " + std::to_string(delayMs) + " ms");
    double best = std::numeric_limits<double>::infinity();
    for (int attempt = 0; attempt < 3 && best >= boundMs; ++attempt) {
        const std::optional<double> latencyMs = cancelLatencyMs(delayMs, build);
        if (!latencyMs) return;
        std::printf("  %s cancelled after %d ms: stopped %.1f ms later\n", what.c_str(), delayMs, *latencyMs);
        best = std::min(best, *latencyMs);
    }
    EXPECT_LT(best, boundMs);
}

}  // namespace raypack::test
