// The hybrid packet / single-ray kernel (issue 14; shaders/trace.comp, traceHybrid; docs/gpu.md)
// on lavapipe, against the CPU reference and against the two kernels it is made of: a K above
// the packet's ray count splits every packet at the root, so each ray traverses as the single-ray
// kernel does (same hits, same N_TR and N_IT); K = 0 with the visit rule off never splits, so the
// packet traverses as the packet kernel does. Between the two, packets split part-way; their hits
// must still be the reference's, on coherent, incoherent (random sliver soup) and deep trees, for
// primary and shadow rays, and for packets of one subgroup (no barrier) and of several.
#include "random_geometry.h"
#include "test_gpu_common.h"

#include "renderer/error.h"
#include "scenes/generators.h"

#include <algorithm>
#include <cstring>
#include <vector>

namespace raypack::test {
namespace {

// Packets of one subgroup on lavapipe (a row of at most 8 rays: GpuTracer's packetIsOneSubgroup)
// and of several subgroups; 5x6 pads at the image edges.
const std::vector<PacketShape> kShapes = {{8, 1}, {8, 4}, {5, 6}, {16, 16}};
// Fewer where lavapipe is slow (the deep tree: every ray enters every one of its 60 levels).
const std::vector<PacketShape> kFewShapes = {{8, 1}, {8, 4}};

HybridParams neverSplits() { return HybridParams{0u, 0.0f}; }
HybridParams splitsAtTheRoot() { return HybridParams{0xFFFFFFFFu, 0.0f}; }

bool sameCounters(const Frame& a, const Frame& b) {
    return a.counters.size() == b.counters.size() &&
           (a.counters.empty() ||
            std::memcmp(a.counters.data(), b.counters.data(), a.counters.size() * sizeof(RayCounters)) == 0);
}

uint64_t primaryNodes(const Frame& f) {
    uint64_t n = 0;
    for (const RayCounters& c : f.counters) n += c.primaryNodes;
    return n;
}

std::string label(const PacketShape& shape, const HybridParams& h, bool shadows) {
    return "hybrid " + std::to_string(shape.width) + "x" + std::to_string(shape.height) +
           " K=" + std::to_string(h.minRays) + " ratio " + std::to_string(h.visitRatio) + (shadows ? " shadows" : "");
}

RenderSettings settingsFor(const Scene& scene, uint32_t width, uint32_t height) {
    RenderSettings settings;
    settings.width = width;
    settings.height = height;
    settings.camera = frameScene(scene.bounds());
    return settings;
}

// The two limits: the hybrid kernel is the single-ray kernel when it splits at the root, and the
// packet kernel when it never splits, hit for hit and count for count (statistics variant).
void expectLimitsAreTheTwoKernels(GpuTracer& tracer, RenderSettings settings, const Frame& cpu,
                                  const std::vector<PacketShape>& shapes) {
    const FrameRequest request{true, true, true};
    for (const bool shadows : {true, false}) {
        settings.shadows = shadows;
        for (const PacketShape& shape : shapes) {
            settings.packet = shape;
            settings.kernel = KernelKind::Single;
            const Frame single = tracer.render(settings, request);
            settings.kernel = KernelKind::Packet;
            const Frame packet = tracer.render(settings, request);
            settings.kernel = KernelKind::Hybrid;
            settings.hybrid = splitsAtTheRoot();
            const Frame split = tracer.render(settings, request);
            settings.hybrid = neverSplits();
            const Frame kept = tracer.render(settings, request);
            EXPECT_TRUE(sameHits(split, single)) << label(shape, splitsAtTheRoot(), shadows);
            EXPECT_TRUE(sameCounters(split, single)) << label(shape, splitsAtTheRoot(), shadows);
            EXPECT_TRUE(sameHits(kept, packet)) << label(shape, neverSplits(), shadows);
            EXPECT_TRUE(sameCounters(kept, packet)) << label(shape, neverSplits(), shadows);
            EXPECT_EQ(differingPixels(split, single), 0u) << label(shape, splitsAtTheRoot(), shadows);
            EXPECT_EQ(differingPixels(kept, packet), 0u) << label(shape, neverSplits(), shadows);
            if (shadows) {
                expectMatchesReference(split, cpu, label(shape, splitsAtTheRoot(), shadows));
                expectMatchesReference(kept, cpu, label(shape, neverSplits(), shadows));
            }
        }
    }
}

// Every split rule between the limits: hits as the reference's (every ray, every shadow ray).
void expectSplitsMatchReference(GpuTracer& tracer, RenderSettings settings, const Frame& cpu, bool exact,
                                const std::vector<PacketShape>& shapes) {
    const FrameRequest request{true, true, true};
    settings.kernel = KernelKind::Hybrid;
    for (const PacketShape& shape : shapes) {
        settings.packet = shape;
        const uint32_t rays = shape.rays();
        // K = the packet's rays is the default's rule (split at the first node not all rays
        // want), which a packet of one subgroup decides by one vote instead of a count.
        const HybridParams rules[] = {{rays, 0.0f},
                                      {std::max(1u, rays / 4), 0.0f},
                                      {std::max(1u, rays / 16), 0.0f},
                                      {std::max(1u, rays / 2), 0.0f},
                                      {0u, 1.5f},
                                      {std::max(1u, rays / 8), 2.0f},
                                      {1u, 1.0f}};
        for (const HybridParams& h : rules) {
            settings.hybrid = h;
            const Frame gpu = tracer.render(settings, request);
            if (exact) {
                const HitAgreement agreement = compareHits(gpu, cpu);
                EXPECT_EQ(agreement.agree, agreement.rays) << label(shape, h, true);
                EXPECT_EQ(agreement.shadowAgree, agreement.shadowRays) << label(shape, h, true);
            }
            expectMatchesReference(gpu, cpu, label(shape, h, true));
        }
    }
}

TEST(GpuHybrid, LimitsAreTheSingleRayAndPacketKernels) {
    const LoadedScene s = loadForTest("gen:default");
    GpuTracer tracer(validatedContext());
    tracer.upload(s.scene, s.bvh);
    const RenderSettings settings = settingsFor(s.scene, 97, 61);
    const Frame cpu = renderCpu(s.scene, s.bvh, settings, FrameRequest{true, true, false});
    expectLimitsAreTheTwoKernels(tracer, settings, cpu, kShapes);
    expectNoValidationMessages();
}

TEST(GpuHybrid, SplitPacketsMatchReferenceOnSibenik) {
    const LoadedScene s = loadForTest(sharedScene("sibenik/sibenik_geom_75284.ply"));
    GpuTracer tracer(validatedContext());
    tracer.upload(s.scene, s.bvh);
    RenderSettings settings = settingsFor(s.scene, 64, 48);
    settings.camera = s.camera;
    const Frame cpu = renderCpu(s.scene, s.bvh, settings, FrameRequest{true, true, false});
    expectSplitsMatchReference(tracer, settings, cpu, false, {{8, 1}, {8, 4}, {16, 16}});
    expectNoValidationMessages();
}

// Random slivers in random orientations (tests/random_geometry.h): neighbouring rays share few
// nodes, so packets split early and often.
Scene sliverSoup() { return randomSliverSoup(3000, 0.2f, 2.0f, 14); }

// 48x32 from just outside the soup, so that it fills the image (frameScene keeps the whole box in
// view, a small part of the image).
RenderSettings soupSettings(const Scene& soup) {
    RenderSettings settings = settingsFor(soup, 48, 32);
    settings.camera.eye = glm::vec3(0.3f, 0.2f, 4.5f);
    settings.camera.at = glm::vec3(0.0f);
    return settings;
}

TEST(GpuHybrid, IncoherentSoupHitsEqualReference) {
    const Scene scene = sliverSoup();
    const Bvh bvh = buildBvh(scene, BvhBuildOptions{});
    GpuTracer tracer(validatedContext());
    tracer.upload(scene, bvh);
    RenderSettings settings = soupSettings(scene);
    const Frame cpu = renderCpu(scene, bvh, settings, FrameRequest{true, true, false});
    size_t hits = 0;
    for (const HitRecord& h : cpu.hits) hits += h.prim != gpu::kNoHit;
    ASSERT_GT(hits, cpu.hits.size() / 4) << "the soup should fill much of the image";
    // 8x4 is in the limits below and in the Sibenik test.
    expectSplitsMatchReference(tracer, settings, cpu, true, {{8, 1}, {5, 6}});
    expectLimitsAreTheTwoKernels(tracer, settings, cpu, kFewShapes);

    // Each rule alone splits packets part-way here: N_TR lies strictly between the single-ray
    // kernel's (the fewest visits) and the packet kernel's (the union of its rays' visits).
    RenderSettings s = settings;
    s.packet = {8, 4};
    const FrameRequest request{false, false, true};
    s.kernel = KernelKind::Single;
    const uint64_t single = primaryNodes(tracer.render(s, request));
    s.kernel = KernelKind::Packet;
    const uint64_t packet = primaryNodes(tracer.render(s, request));
    ASSERT_LT(single, packet) << "the soup is meant to be incoherent";
    s.kernel = KernelKind::Hybrid;
    for (const HybridParams& h : {HybridParams{8u, 0.0f}, HybridParams{0u, 2.0f}}) {
        s.hybrid = h;
        const uint64_t hybrid = primaryNodes(tracer.render(s, request));
        EXPECT_GT(hybrid, single) << label(s.packet, h, false);
        EXPECT_LT(hybrid, packet) << label(s.packet, h, false);
        std::printf("soup 8x4, N_TR summed over primary rays: single %llu, packet %llu, %s: %llu\n",
                    (unsigned long long)single, (unsigned long long)packet, label(s.packet, h, false).c_str(),
                    (unsigned long long)hybrid);
    }
    expectNoValidationMessages();
}

// A tree far deeper than 32 levels: the packet's wanted bits end at entry 32 (deeper entries are
// assumed wanted) and each ray's stack after the split holds the packet's pending entries and its
// own; neither may overflow (render() throws on kStatusStackOverflow).
TEST(GpuHybrid, DeepTreeSplitsMatchReference) {
    LoadedScene s;
    s.scene = makeDeepScene(kDeepSceneMaxTriangles);
    BvhBuildOptions options;
    options.leafSize = 1;
    s.bvh = buildBvh(s.scene, options);
    ASSERT_GT(s.bvh.stats.maxLeafDepth, 50u);
    GpuTracer tracer(validatedContext());
    tracer.upload(s.scene, s.bvh);
    const RenderSettings settings = settingsFor(s.scene, 32, 24);
    const Frame cpu = renderCpu(s.scene, s.bvh, settings, FrameRequest{true, true, false});
    expectSplitsMatchReference(tracer, settings, cpu, true, kFewShapes);
    expectLimitsAreTheTwoKernels(tracer, settings, cpu, kFewShapes);
    expectNoValidationMessages();
}

// Several one-subgroup packets in one workgroup (HybridParams::packetsPerGroup; 8x1 rows are one
// subgroup each on lavapipe, a packet must fill its subgroup elsewhere, 8x4 on NVIDIA): each
// packet traverses alone with its own part of the shared stack, so the
// hits and the counts are those of one packet a workgroup, ray for ray, with rules that split
// packets part-way and a count that does not divide the image (3: padding packets below it). (One
// rule and one count: every combination is a pipeline, and each costs lavapipe about half a second.)
TEST(GpuHybrid, SeveralPacketsPerWorkgroupTraceAsOnePacketEach) {
    const Scene scene = sliverSoup();
    const Bvh bvh = buildBvh(scene, BvhBuildOptions{});
    GpuTracer tracer(validatedContext());
    tracer.upload(scene, bvh);
    RenderSettings settings = soupSettings(scene);
    const Frame cpu = renderCpu(scene, bvh, settings, FrameRequest{true, true, false});
    settings.kernel = KernelKind::Hybrid;
    const vk::DeviceInfo& device = tracer.device();
    const bool rowsAreSubgroups = device.name.find("llvmpipe") != std::string::npos;
    settings.packet = rowsAreSubgroups ? PacketShape{8, 1} : PacketShape{8, std::max(1u, device.subgroupSize / 8)};
    const FrameRequest request{true, true, true};
    for (const HybridParams rules : {HybridParams{2u, 1.5f, 1u}}) {
        settings.hybrid = rules;
        const Frame one = tracer.render(settings, request);
        for (const uint32_t packets : {3u}) {
            settings.hybrid.packetsPerGroup = packets;
            const Frame several = tracer.render(settings, request);
            const std::string what =
                label(settings.packet, rules, true) + ", " + std::to_string(packets) + " a workgroup";
            EXPECT_TRUE(sameHits(several, one)) << what;
            EXPECT_TRUE(sameCounters(several, one)) << what;
            EXPECT_EQ(differingPixels(several, one), 0u) << what;
            const HitAgreement agreement = compareHits(several, cpu);
            EXPECT_EQ(agreement.agree, agreement.rays) << what;
            EXPECT_EQ(agreement.shadowAgree, agreement.shadowRays) << what;
        }
        settings.hybrid.packetsPerGroup = 1;
    }
    // Packets of several subgroups cannot share a workgroup (their vote needs the workgroup's
    // barrier), nor can packets that share a subgroup.
    const PacketShape oneSubgroup = settings.packet;
    settings.packet = {16, 16};
    settings.hybrid.packetsPerGroup = 2;
    EXPECT_THROW(tracer.render(settings), Error);
    if (!rowsAreSubgroups && device.subgroupSize >= 2) {
        settings.packet = {1, 1};
        EXPECT_THROW(tracer.render(settings), Error);
    }
    // "auto" (the default): four packets that each fill a subgroup (the 8x1 row on lavapipe), one
    // for packets of several subgroups; the frame is that count's.
    settings.hybrid.packetsPerGroup = kAutoPacketsPerGroup;
    EXPECT_EQ(tracer.deviceSettings(settings).hybrid.packetsPerGroup, 1u) << "16x16: several subgroups";
    settings.packet = oneSubgroup;
    const uint32_t chosen = tracer.deviceSettings(settings).hybrid.packetsPerGroup;
    EXPECT_EQ(chosen, oneSubgroup.rays() == device.subgroupSize ? 4u : 1u);
    const Frame automatic = tracer.render(settings, request);
    settings.hybrid.packetsPerGroup = chosen;
    EXPECT_TRUE(sameHits(automatic, tracer.render(settings, request)));
    expectNoValidationMessages();
}

TEST(GpuHybrid, VisitRatioOutOfRangeIsAnError) {
    const LoadedScene s = loadForTest("gen:default");
    GpuTracer tracer(validatedContext());
    tracer.upload(s.scene, s.bvh);
    RenderSettings settings = settingsFor(s.scene, 16, 16);
    settings.kernel = KernelKind::Hybrid;
    settings.hybrid.visitRatio = -1.0f;
    EXPECT_THROW(tracer.render(settings), Error);
    settings.hybrid.visitRatio = 2.0f;
    EXPECT_NO_THROW(tracer.render(settings));
}

}  // namespace
}  // namespace raypack::test
