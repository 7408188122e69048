// The measurement library (renderer/measure/): medians and spreads, hit agreement, and the
// protocol over a tracer (warm-ups, timed runs, Table 2), on the CPU.
#include "renderer/bvh.h"
#include "renderer/measure/accuracy.h"
#include "renderer/measure/agreement.h"
#include "renderer/measure/protocol.h"
#include "renderer/measure/spread.h"
#include "renderer/measure/warm_up.h"
#include "renderer/tracers/registry.h"
#include "scenes/generators.h"
#include "scenes/load.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace raypack {
namespace {

TEST(Measure, MediansAndSpreads) {
    const Spread odd = spreadOf({3.0, 1.0, 2.0});
    EXPECT_EQ(odd.median, 2.0);
    EXPECT_EQ(odd.min, 1.0);
    EXPECT_EQ(odd.max, 3.0);
    EXPECT_EQ(spreadOf({4.0, 1.0, 2.0, 3.0}).median, 2.5) << "mean of the two middle values";
    EXPECT_EQ(spreadOf({}).median, 0.0);
    EXPECT_EQ(upperMedian({4.0, 1.0, 2.0, 3.0}), 3.0) << "the upper middle value, one that was measured";
    EXPECT_EQ(upperMedian({}), 0.0);
    // The second half in measured order: {5, 1, 2} -> upper median 2.
    EXPECT_EQ(steadyMedian({100.0, 90.0, 80.0, 5.0, 1.0, 2.0}), 2.0);
}

// A device whose frames take `slow` seconds at first and speed up linearly to `fast` over the first
// `rampFor` seconds of back-to-back work (a GPU raising its clocks), as a warm-up batch sees it: the
// seconds of `frames` frames from the work done so far.
struct RampingDevice {
    double slow, fast, rampFor;
    double busy = 0.0;  // seconds of frames run so far
    double frameSeconds() const { return slow + (fast - slow) * std::min(busy / rampFor, 1.0); }
    double run(uint32_t frames) {
        double seconds = 0.0;
        for (uint32_t i = 0; i < frames; ++i) {
            const double t = frameSeconds();
            seconds += t;
            busy += t;
        }
        return seconds;
    }
};

TEST(Measure, GpuWarmUpRunsUntilTheFramesStopSpeedingUp) {
    // Steady from the start (frames of 1/1024 s, so that the sums are exact): three batches of a
    // third of the minimum, then the first comparison stops it.
    RampingDevice steady{1.0 / 1024, 1.0 / 1024, 1.0};
    GpuWarmUp w = warmUpUntilSteady([&](uint32_t n) { return steady.run(n); }, 1.0 / 1024, 0.375);
    EXPECT_TRUE(w.steady);
    EXPECT_EQ(w.batches, 3u);
    EXPECT_EQ(w.frames, 384u);
    EXPECT_EQ(w.seconds, 0.375);

    // 3 ms frames speeding up to 1 ms over 1.3 s: the warm-up outlasts the ramp, which a fixed 0.3 s
    // would not, and stops within three batches of its end (the one that ends the ramp, one at the
    // new speed that is still faster than it, one to compare), where the timed frames run at 1 ms.
    RampingDevice ramping{3e-3, 1e-3, 1.3};
    w = warmUpUntilSteady([&](uint32_t n) { return ramping.run(n); }, 3e-3, 0.3);
    EXPECT_TRUE(w.steady);
    EXPECT_GE(ramping.busy, 1.3) << "stopped before the clocks had settled";
    EXPECT_LE(ramping.busy, 1.3 + 3 * 0.1 + 1e-9);
    EXPECT_NEAR(ramping.frameSeconds(), 1e-3, 1e-12);
    EXPECT_NEAR(w.seconds, ramping.busy, 1e-9);

    // Still speeding up at the limit: it stops there and says so.
    RampingDevice endless{3e-3, 1e-4, 1.2};
    w = warmUpUntilSteady([&](uint32_t n) { return endless.run(n); }, 3e-3, 0.3, 1.0);
    EXPECT_FALSE(w.steady);
    EXPECT_GE(w.seconds, 1.0);
    EXPECT_LT(w.seconds, 1.0 + 0.1);

    // A frame longer than a batch (a CPU device, a huge frame) keeps the device busy by itself.
    RampingDevice longFrames{0.5, 0.5, 1.0};
    w = warmUpUntilSteady([&](uint32_t n) { return longFrames.run(n); }, 0.5, 0.3);
    EXPECT_TRUE(w.steady);
    EXPECT_EQ(w.frames, 1u);

    // No warm-up asked for (the trade suite on lavapipe): one frame.
    RampingDevice none{1e-3, 1e-3, 1.0};
    w = warmUpUntilSteady([&](uint32_t n) { return none.run(n); }, 1e-3, 0.0);
    EXPECT_EQ(w.frames, 1u);
    EXPECT_EQ(w.batches, 1u);
}

HitRecord hit(float t, uint32_t prim, uint32_t shadow) {
    HitRecord h{};
    h.t = t;
    h.prim = prim;
    h.shadow = shadow;
    return h;
}

TEST(Measure, IdenticalHitsAreToTheBit) {
    const std::vector<HitRecord> reference = {hit(1.0f, 1, gpu::kShadowLit), hit(2.0f, 2, gpu::kShadowOccluded)};
    std::vector<HitRecord> same = reference;
    EXPECT_EQ(identicalHitShare(same, reference), 1.0);
    same[1].t = std::nextafter(2.0f, 3.0f);  // one ulp: agrees within the bar, not identical
    EXPECT_EQ(identicalHitShare(same, reference), 0.5);
    EXPECT_EQ(compareHits(same, reference).rayShare(), 1.0);
    EXPECT_EQ(identicalHitShare(same, {}), 0.0);
}

TEST(Measure, ProtocolOverTheCpuReference) {
    const Scene scene = openScene("gen:default");
    const Bvh bvh = buildBvh(scene, BvhBuildOptions{});
    const std::unique_ptr<Tracer> tracer = makeTracer("cpu-reference", TracerEnvironment{});
    const Preparation preparation = tracer->prepare(scene, bvh);
    EXPECT_FALSE(preparation.isUpload);
    EXPECT_GT(preparation.bytes, 0u);
    RenderSettings settings;
    settings.width = 64;
    settings.height = 48;
    settings.camera = frameScene(scene.bounds());
    const MeasuredFrames m = measureFrames(*tracer, preparation, settings, 3, true);
    EXPECT_EQ(m.stats.repeats, 3u);
    EXPECT_EQ(m.stats.width, 64u);
    EXPECT_EQ(m.stats.primary.rays, 64u * 48u);
    EXPECT_TRUE(m.stats.countersMeasured);
    EXPECT_FALSE(m.stats.gpu);
    EXPECT_EQ(m.stats.primary.uploadSeconds, 0.0) << "the report's CPU rows have T_CU = 0";
    EXPECT_NE(m.stats.device.find("CPU reference"), std::string::npos) << m.stats.device;
    EXPECT_GT(m.stats.primary.nodesPerRay, 0.0);
    EXPECT_GT(m.stats.shadow.rays, 0u);
    EXPECT_LE(m.stats.primary.kernelSeconds.min, m.stats.primary.kernelSeconds.median);
    EXPECT_LE(m.stats.primary.kernelSeconds.median, m.stats.primary.kernelSeconds.max);
    EXPECT_EQ(m.frame.hits.size(), 64u * 48u);
    EXPECT_EQ(m.frame.rgba.size(), 64u * 48u);
    EXPECT_EQ(m.frame.counters.size(), 64u * 48u);
}

// ---- The trade suite's accuracy measures (renderer/measure/accuracy.h).

HitRecord rayHit(glm::vec3 org, glm::vec3 dir, float t, uint32_t prim) {
    return gpu::makeHitRecord(org, dir, t, prim, gpu::kShadowNone);
}

TEST(Accuracy, ExactPlaneDistanceAndItsErrors) {
    Scene scene;
    scene.positions = {{-1, -1, 3}, {1, -1, 3}, {0, 1, 3}};
    scene.triangles = {{0, 1, 2}};
    EXPECT_EQ(exactPlaneDistance({0, 0, 0}, {0, 0, 1}, scene.positions[0], scene.positions[1], scene.positions[2]),
              3.0);
    EXPECT_EQ(exactPlaneDistance({0, 0, 1}, {0, 0, -0.5f}, scene.positions[0], scene.positions[1], scene.positions[2]),
              -4.0);
    // 2000 hits at the exact t, three of them moved by 1e-3, 2e-3 and 4e-3 (relative), and misses.
    std::vector<HitRecord> hits;
    for (int i = 0; i < 2000; ++i) {
        const glm::vec3 dir = glm::normalize(glm::vec3(0.0001f * float(i % 50), 0.0001f * float(i / 50), 1.0f));
        const double exact =
            exactPlaneDistance({0, 0, 0}, dir, scene.positions[0], scene.positions[1], scene.positions[2]);
        hits.push_back(rayHit({0, 0, 0}, dir, float(exact), 0));
    }
    const HitDistanceErrors roundedOnly = hitDistanceErrors(scene, hits);
    EXPECT_EQ(roundedOnly.hits, 2000u);
    EXPECT_LE(roundedOnly.maxRelative, 0x1p-24) << "t rounded once to float";
    const auto perturb = [&](HitRecord& h, double relative) {
        h.t = float(exactPlaneDistance({0, 0, 0}, {h.dirX, h.dirY, h.dirZ}, scene.positions[0], scene.positions[1],
                                       scene.positions[2]) *
                    (1.0 + relative));
    };
    perturb(hits[10], 1e-3);
    perturb(hits[500], -2e-3);
    perturb(hits[1999], 4e-3);
    hits.push_back(rayHit({0, 0, 0}, {0, 0, 1}, INFINITY, gpu::kNoHit));
    const HitDistanceErrors errors = hitDistanceErrors(scene, hits);
    EXPECT_EQ(errors.hits, 2000u) << "misses are not compared";
    EXPECT_NEAR(errors.maxRelative, 4e-3, 1e-6);
    // Nearest rank ceil(0.999 * 2000) = 1998 of the sorted errors: the smallest of the three.
    EXPECT_NEAR(errors.p999Relative, 1e-3, 1e-6);
    hits.push_back(rayHit({0, 0, 0}, {0, 0, 1}, 3.0f, 7));
    EXPECT_THROW(hitDistanceErrors(scene, hits), Error) << "triangle 7 of a scene of 1";
    EXPECT_EQ(nearestRankQuantile({}, 0.5), 0.0);
    EXPECT_EQ(nearestRankQuantile({5, 1, 3, 2, 4}, 0.5), 3.0);
    EXPECT_EQ(nearestRankQuantile({5, 1, 3, 2, 4}, 1.0), 5.0);
}

TEST(Accuracy, LeaksAndDifferences) {
    std::vector<HitRecord> hits(1000, rayHit({0, 0, 0}, {0, 0, 1}, 1.0f, 3));
    EXPECT_EQ(countLeaks(hits).leaked, 0u);
    hits[17].prim = gpu::kNoHit;
    hits[18].prim = gpu::kNoHit;
    const LeakCount leaks = countLeaks(hits);
    EXPECT_EQ(leaks.rays, 1000u);
    EXPECT_EQ(leaks.leaked, 2u);
    EXPECT_DOUBLE_EQ(leaks.perMillion(), 2000.0);
    std::vector<HitRecord> other = hits;
    other[2].prim = 4;
    other[17].prim = 3;
    EXPECT_EQ(differingHits(other, hits), 2u);
    EXPECT_THROW(differingHits(other, {}), Error);
    std::vector<uint32_t> image(64, 0xff102030u), changed = image;
    changed[5] = 0xff102031u;
    EXPECT_EQ(differingPixels(changed, image), 1u);
    EXPECT_EQ(differingPixels(image, image), 0u);
    EXPECT_THROW(differingPixels(image, {1u}), Error);
}

// The robust CPU reference on the closed scenes: no primary ray leaks, and every hit distance is
// within issue 15's 1e-5 of the exact one (the same figures the trade suite records).
TEST(Accuracy, RobustReferenceDoesNotLeakOnTheClosedScenes) {
    const std::unique_ptr<Tracer> tracer = makeTracer("cpu-reference", TracerEnvironment{});
    struct Case {
        const char* name;
        Scene scene;
        Camera camera;
    };
    const uint32_t width = 64, height = 48;
    const glm::uvec2 cells = latticeCellsFor(width, height);
    const glm::vec3 far(1e5f, 1e5f, 1e5f);
    std::vector<Case> cases;
    cases.push_back({"icosphere", makeIcosphere(3), icosphereCamera()});
    cases.push_back({"lattice", makeLattice(cells.x, cells.y), latticeCamera(width, height)});
    cases.push_back({"far lattice", placeScene(makeLattice(cells.x, cells.y), 1.0f, far),
                     placeCamera(latticeCamera(width, height), 1.0f, far)});
    cases.push_back({"tiny icosphere", placeScene(makeIcosphere(3), 0x1p-14f, glm::vec3(0.0f)),
                     placeCamera(icosphereCamera(), 0x1p-14f, glm::vec3(0.0f))});
    for (const Case& c : cases) {
        const Bvh bvh = buildBvh(c.scene, BvhBuildOptions{});
        tracer->prepare(c.scene, bvh);
        RenderSettings settings;
        settings.width = width;
        settings.height = height;
        settings.camera = c.camera;
        FrameRequest request;
        request.hits = true;
        const Frame frame = tracer->render(settings, request);
        EXPECT_EQ(countLeaks(frame.hits).leaked, 0u) << c.name;
        const HitDistanceErrors errors = hitDistanceErrors(c.scene, frame.hits);
        EXPECT_EQ(errors.hits, uint64_t(width) * height) << c.name;
        EXPECT_LE(errors.maxRelative, 1e-5) << c.name;
        EXPECT_LE(errors.p999Relative, errors.maxRelative) << c.name;
    }
}

}  // namespace
}  // namespace raypack
