// The measurement library (renderer/measure/): medians and spreads, hit agreement, and the
// protocol over a tracer (warm-ups, timed runs, Table 2), on the CPU.
#include "renderer/bvh.h"
#include "renderer/measure/agreement.h"
#include "renderer/measure/protocol.h"
#include "renderer/measure/spread.h"
#include "renderer/tracers/registry.h"
#include "scenes/load.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace raypack
