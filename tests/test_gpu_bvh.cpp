// The GPU builders gpu-lbvh, gpu-ploc and gpu-hploc (renderer/gpu_bvh.h, issue 13) on the test device (lavapipe here):
// every tree it builds is a valid BVH for the tracers (every triangle in exactly one leaf, boxes that hold their
// children and their triangles, the leaf threshold kept, depth within the stack sizing), its device-side statistics
// equal a CPU recomputation from the downloaded tree, and rays traced through it hit what the CPU reference hits, on
// generated, degenerate and shared scenes.
#include "renderer/gpu_bvh.h"

#include "renderer/async_build.h"
#include "renderer/camera.h"
#include "renderer/cpu_tracer.h"
#include "renderer/gpu_tracer.h"
#include "scenes/generators.h"
#include "scenes/load.h"
#include "shaders/lbvh.h"
#include "test_gpu_common.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <optional>
#include <random>
#include <thread>

namespace raypack {
namespace {

using test::validatedContext;

// Every test runs for each device builder (GetParam()).
class GpuBuilder : public ::testing::TestWithParam<BvhBuilder> {
protected:
    BvhBuildOptions lbvhOptions(uint32_t leafSize = 1) const {
        BvhBuildOptions options;
        options.builder = GetParam();
        options.leafSize = leafSize;
        return options;
    }
};

Aabb triangleBox(const Scene& scene, uint32_t t) { return scene.triangleBounds(t); }

// Everything a tracer relies on, checked on the canonical tree of a device build.
void expectValidTree(const Scene& scene, const Bvh& bvh, uint32_t leafSize) {
    const size_t n = scene.triangleCount();
    ASSERT_EQ(bvh.primIndices.size(), n);
    std::vector<uint32_t> seen(n, 0);
    for (uint32_t t : bvh.primIndices) {
        ASSERT_LT(t, n);
        ++seen[t];
    }
    EXPECT_EQ(std::count(seen.begin(), seen.end(), 1u), std::ptrdiff_t(n)) << "the order is a permutation";
    std::vector<uint32_t> covered(n, 0);
    size_t problems = 0;
    walkBvh(bvh, [&](uint32_t, const BvhNode& node, uint32_t) {
        if (problems > 10) return;
        const Aabb box{node.lo, node.hi};
        if (node.isLeaf()) {
            if (n == 0) return;
            if (node.count > kMaxLeafPrimitives) ++problems;
            Aabb tight;
            for (uint32_t k = node.index; k < node.index + node.count; ++k) {
                ++covered[k];
                tight.grow(triangleBox(scene, bvh.primIndices[k]));
            }
            // A leaf's box is exactly its triangles' box.
            if (tight.lo != box.lo || tight.hi != box.hi) ++problems;
        } else {
            const BvhNode& l = bvh.nodes[node.index];
            const BvhNode& r = bvh.nodes[node.index + 1];
            // Children inside their parent, and the parent exactly their union.
            if (glm::min(l.lo, r.lo) != node.lo || glm::max(l.hi, r.hi) != node.hi) ++problems;
        }
    });
    EXPECT_EQ(problems, 0u);
    EXPECT_EQ(std::count(covered.begin(), covered.end(), 1u), std::ptrdiff_t(n)) << "every slot in one leaf";
    // Leaf threshold: count the triangles below each inner node; none may have leafSize or fewer.
    std::vector<uint32_t> below(bvh.nodes.size(), 0);
    for (size_t i = bvh.nodes.size(); i-- > 0;) {
        const BvhNode& node = bvh.nodes[i];
        below[i] = node.isLeaf() ? node.count : below[node.index] + below[node.index + 1];
        if (!node.isLeaf()) {
            EXPECT_GT(below[i], leafSize) << "inner node " << i << " should have been a leaf";
        }
    }
    EXPECT_LE(bvhMaxDepth(bvh), gpu::kLbvhMaxDepth);
}

TEST_P(GpuBuilder, BuildsValidTreesOfGeneratedScenesAtEveryLeafSize) {
    const Scene scene = makeSphereFlake(8000);
    for (uint32_t leafSize : {1u, 2u, 4u, 8u}) {
        SCOPED_TRACE("leaf size " + std::to_string(leafSize));
        const Bvh bvh = buildBvhOnDevice(validatedContext(), scene, lbvhOptions(leafSize));
        expectValidTree(scene, bvh, leafSize);
    }
    EXPECT_EQ(vk::validationMessageCount(validatedContext()), 0u);
}

TEST_P(GpuBuilder, DeviceStatisticsEqualACpuRecomputationOfTheDownloadedTree) {
    const Scene scene = makeTerrain(12000);
    GpuBvhBuilder builder(validatedContext());
    builder.setScene(scene);
    const GpuBvhSizes sizes = gpuBvhSizes(scene.triangleCount());
    const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    vk::Buffer nodes =
        vk::createBuffer(validatedContext(), sizes.nodes * 32, usage, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, "nodes");
    vk::Buffer triangles = vk::createBuffer(validatedContext(), sizes.triangles * 48, usage,
                                            VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, "triangles");
    const GpuBvhBuilder::Result built = builder.build(lbvhOptions(2), {nodes.buffer, triangles.buffer});
    vk::destroyBuffer(validatedContext(), nodes);
    vk::destroyBuffer(validatedContext(), triangles);
    const Bvh downloaded = buildBvhOnDevice(validatedContext(), scene, lbvhOptions(2));
    const BvhStats& cpu = downloaded.stats;
    const BvhStats& gpu = built.stats;
    EXPECT_EQ(gpu.nodeCount, cpu.nodeCount);
    EXPECT_EQ(gpu.leafCount, cpu.leafCount);
    EXPECT_EQ(gpu.maxLeafDepth, cpu.maxLeafDepth);
    EXPECT_DOUBLE_EQ(gpu.avgLeafDepth, cpu.avgLeafDepth);
    EXPECT_DOUBLE_EQ(gpu.avgPrimsPerLeaf, cpu.avgPrimsPerLeaf);
    EXPECT_NEAR(gpu.sahCost, cpu.sahCost, 1e-4 * cpu.sahCost);
    EXPECT_GT(built.scratchBytes, 0u);
    // Within reach of the CPU builders' quality on an ordinary scene.
    BvhBuildOptions exact;
    exact.leafSize = 2;
    EXPECT_LT(cpu.sahCost, 1.5 * buildBvh(scene, exact).stats.sahCost);
}

TEST_P(GpuBuilder, IsDeterministic) {
    const Scene scene = makeSphereFlake(5000);
    const Bvh a = buildBvhOnDevice(validatedContext(), scene, lbvhOptions(4));
    const Bvh b = buildBvhOnDevice(validatedContext(), scene, lbvhOptions(4));
    ASSERT_EQ(a.nodes.size(), b.nodes.size());
    EXPECT_EQ(a.primIndices, b.primIndices);
    EXPECT_EQ(0, std::memcmp(a.nodes.data(), b.nodes.data(), a.nodes.size() * sizeof(BvhNode)));
}

Scene sceneOfTriangles(std::vector<glm::vec3> positions) {
    Scene scene;
    scene.source = "test triangles";
    scene.positions = std::move(positions);
    for (uint32_t i = 0; i + 2 < scene.positions.size(); i += 3) scene.triangles.push_back({i, i + 1, i + 2});
    return scene;
}

TEST_P(GpuBuilder, DegenerateInputs) {
    // 0, 1 and 2 triangles.
    for (size_t count : {0u, 1u, 2u, 3u}) {
        std::vector<glm::vec3> p;
        for (size_t i = 0; i < count; ++i) {
            const float x = float(i) * 2.0f;
            p.insert(p.end(), {{x, 0, 0}, {x + 1, 0, 0}, {x, 1, 0}});
        }
        const Scene scene = sceneOfTriangles(p);
        SCOPED_TRACE(std::to_string(count) + " triangles");
        const Bvh bvh = buildBvhOnDevice(validatedContext(), scene, lbvhOptions());
        expectValidTree(scene, bvh, 1);
        EXPECT_EQ(bvh.stats.leafCount, count == 0 ? 1u : bvh.stats.leafCount);
    }
    // Every centroid equal (one Morton code for all): leaves stay within kMaxLeafPrimitives and the
    // index tie-break gives a balanced tree.
    {
        std::vector<glm::vec3> p;
        for (int i = 0; i < 5000; ++i) p.insert(p.end(), {{-1, -1, 0}, {1, -1, 0}, {0, 2, 0}});
        const Scene scene = sceneOfTriangles(p);
        const Bvh bvh = buildBvhOnDevice(validatedContext(), scene, lbvhOptions());
        expectValidTree(scene, bvh, 1);
        EXPECT_LE(bvh.stats.maxLeafDepth, 13u);
    }
    // Huge and tiny coordinates, and many triangles sharing one Morton cell beside a far one.
    for (float scale : {1e30f, 1e-30f}) {
        SCOPED_TRACE("scale " + std::to_string(scale));
        std::mt19937 random(7);
        std::uniform_real_distribution<float> u(-1.0f, 1.0f);
        std::vector<glm::vec3> p;
        for (int i = 0; i < 3000; ++i) {
            const glm::vec3 c(u(random), u(random), u(random));
            p.insert(p.end(), {scale * c, scale * (c + glm::vec3(0.01f, 0, 0)), scale * (c + glm::vec3(0, 0.01f, 0))});
        }
        for (int i = 0; i < 500; ++i) {
            const glm::vec3 c(1e-4f * u(random), 1e-4f * u(random), 0.0f);
            p.insert(p.end(), {scale * c, scale * (c + glm::vec3(1e-6f, 0, 0)), scale * (c + glm::vec3(0, 1e-6f, 0))});
        }
        const Scene scene = sceneOfTriangles(p);
        const Bvh bvh = buildBvhOnDevice(validatedContext(), scene, lbvhOptions());
        expectValidTree(scene, bvh, 1);
        EXPECT_TRUE(std::isfinite(bvh.stats.sahCost));
    }
    EXPECT_EQ(vk::validationMessageCount(validatedContext()), 0u);
}

// The tracer's own device build (GpuTracer::buildOnDevice: no host round trip) traces exactly what
// the downloaded tree traces through upload(), and both match the CPU reference over that tree: on
// Sibenik and on a textured glTF (the normals, UVs and textures gathered into leaf order).
TEST_P(GpuBuilder, TracerBuildsInItsOwnBuffersAndMatchesTheReference) {
    for (const char* relative : {"sibenik/sibenik_geom_75284.ply", "gltf/Duck/glTF/Duck.gltf"}) {
        SCOPED_TRACE(relative);
        const Scene scene = openScene(test::sharedScene(relative));
        RenderSettings settings;
        settings.width = 200;
        settings.height = 150;
        settings.camera = frameScene(scene.bounds());
        settings.kernel = KernelKind::Single;
        const FrameRequest request{true, true, false};

        GpuTracer own(validatedContext());
        const GpuTracer::DeviceBuild built = own.buildOnDevice(scene, lbvhOptions(2));
        EXPECT_GT(built.uploadSeconds, 0.0);
        const Frame ownFrame = own.render(settings, request);

        const Bvh downloaded = buildBvhOnDevice(validatedContext(), scene, lbvhOptions(2));
        EXPECT_EQ(built.stats.leafCount, downloaded.stats.leafCount);
        EXPECT_EQ(built.stats.nodeCount, downloaded.stats.nodeCount);
        EXPECT_EQ(built.stats.maxLeafDepth, downloaded.stats.maxLeafDepth);
        GpuTracer uploaded(validatedContext());
        uploaded.upload(scene, downloaded);
        const Frame uploadedFrame = uploaded.render(settings, request);
        EXPECT_EQ(ownFrame.rgba, uploadedFrame.rgba);
        ASSERT_EQ(ownFrame.hits.size(), uploadedFrame.hits.size());
        EXPECT_EQ(
            0, std::memcmp(ownFrame.hits.data(), uploadedFrame.hits.data(), ownFrame.hits.size() * sizeof(HitRecord)));
        test::expectMatchesReference(ownFrame, renderCpu(scene, downloaded, settings, request), relative);

        // Another leaf size over the same scene keeps the scene's upload and still traces right.
        const GpuTracer::DeviceBuild again = own.buildOnDevice(scene, lbvhOptions(8));
        EXPECT_EQ(again.uploadSeconds, 0.0);
        EXPECT_LT(again.stats.leafCount, built.stats.leafCount);
        BvhBuildOptions eight = lbvhOptions(8);
        test::expectMatchesReference(
            own.render(settings, request),
            renderCpu(scene, buildBvhOnDevice(validatedContext(), scene, eight), settings, request),
            std::string(relative) + " leaf 8");
    }
    test::expectNoValidationMessages();
}

// The viewer's path (issue 13): its worker builds on the tracer's own device, through a builder of
// its own, while the render thread keeps tracing the previous tree on the queue they share
// (vk::lockQueue); the tracer adopts the device tree
// without a host round trip, and the host tree is read back only when asked for. Requests that
// replace one another end in the last one, and nothing leaves a validation message.
TEST_P(GpuBuilder, AWorkerBuildsTreesTheTracerAdoptsWhileItStillTraces) {
    const std::string path = test::sharedScene("gltf/Duck/glTF/Duck.gltf");
    AsyncSceneBuilder builder(
        [](const std::string& spec, LoadProgress& progress) { return openScene(spec, &progress); },
        &validatedContext());
    GpuTracer tracer(validatedContext());
    // Replaced trees are freed on the worker, as in the viewer.
    tracer.setRetiredTreeSink([&](std::unique_ptr<GpuTree> tree) { builder.retire(std::move(tree)); });
    const FrameRequest request{true, true, false};

    // A load hands back the device tree and, for the start view, the host tree.
    builder.requestLoad(path, lbvhOptions(2));
    builder.waitIdle();
    std::optional<SceneBuild> loaded = builder.takeFinished();
    ASSERT_TRUE(loaded && loaded->deviceTree && loaded->bvh) << (builder.takeFailure() ? "failed" : "nothing");
    const std::shared_ptr<const Scene> scene = loaded->scene;
    const std::shared_ptr<const Bvh> loadedBvh = loaded->bvh;
    EXPECT_EQ(loaded->stats.leafCount, loadedBvh->stats.leafCount);
    EXPECT_GT(tracer.adopt(std::move(loaded->deviceTree)), 0.0) << "a new scene's tables are uploaded";
    RenderSettings settings;
    settings.width = 160;
    settings.height = 120;
    settings.camera = frameScene(scene->bounds());
    settings.kernel = KernelKind::Single;
    test::expectMatchesReference(tracer.render(settings, request), renderCpu(*scene, *loadedBvh, settings, request),
                                 "loaded");

    // A rebuild without the host tree, traced against while it builds.
    builder.requestRebuild(scene, lbvhOptions(8), /*hostTree=*/false);
    uint32_t framesDuringTheBuild = 0;
    while (builder.status().phase != BuildPhase::Idle || builder.status().requestWaiting) {
        tracer.render(settings);
        ++framesDuringTheBuild;
    }
    builder.waitIdle();
    std::optional<SceneBuild> rebuilt = builder.takeFinished();
    ASSERT_TRUE(rebuilt && rebuilt->deviceTree);
    EXPECT_FALSE(rebuilt->bvh) << "no host tree unless asked for";
    EXPECT_EQ(rebuilt->scene, scene);
    const BvhStats deviceStats = rebuilt->stats;
    EXPECT_EQ(tracer.adopt(std::move(rebuilt->deviceTree)), 0.0) << "the same scene's tables are kept";
    const Frame frame = tracer.render(settings, request);
    const Bvh downloaded = tracer.downloadBvh();
    expectValidTree(*scene, downloaded, 8);
    EXPECT_EQ(downloaded.stats.leafCount, deviceStats.leafCount);
    EXPECT_EQ(downloaded.stats.maxLeafDepth, deviceStats.maxLeafDepth);
    EXPECT_LT(downloaded.stats.leafCount, loadedBvh->stats.leafCount);
    test::expectMatchesReference(frame, renderCpu(*scene, downloaded, settings, request), "leaf 8");
    std::printf("frames traced during the rebuild: %u\n", framesDuringTheBuild);

    // Requests replacing one another: the last one's tree, its host tree asked for.
    for (const uint32_t leafSize : {1u, 4u, 3u}) builder.requestRebuild(scene, lbvhOptions(leafSize), true);
    builder.waitIdle();
    std::optional<SceneBuild> last = builder.takeFinished();
    ASSERT_TRUE(last && last->deviceTree && last->bvh);
    EXPECT_EQ(last->options.leafSize, 3u);
    expectValidTree(*scene, *last->bvh, 3);
    tracer.adopt(std::move(last->deviceTree));
    test::expectMatchesReference(tracer.render(settings, request), renderCpu(*scene, *last->bvh, settings, request),
                                 "leaf 3");
    test::expectNoValidationMessages();
}

// A device build stops at its next submission once cancelled (the viewer's worker cancels a
// superseded build): before it starts, and while gpu-ploc clusters (after the first batch of
// iterations has reported its merges); the builder builds again afterwards.
TEST(GpuBuilderCancel, ADeviceBuildStopsAtItsNextSubmission) {
    const Scene scene = makeSphereFlake(60000);
    BvhBuildOptions options;
    options.builder = BvhBuilder::GpuPloc;
    GpuBvhBuilder builder(validatedContext());
    BuildProgress cancelled;
    cancelled.cancel = true;
    EXPECT_THROW(buildGpuTree(builder, scene, options, false, &cancelled), BuildCancelled);

    BuildProgress progress;
    std::thread watcher([&] {
        while (progress.done.load() == 0) std::this_thread::sleep_for(std::chrono::microseconds(100));
        progress.cancel = true;
    });
    EXPECT_THROW(buildGpuTree(builder, scene, options, false, &progress), BuildCancelled);
    watcher.join();
    EXPECT_GT(progress.done.load(), 0u);

    const std::unique_ptr<GpuTree> tree = buildGpuTree(builder, scene, options, true);
    expectValidTree(scene, downloadGpuTree(*tree), 1);
    EXPECT_EQ(vk::validationMessageCount(validatedContext()), 0u);
}

// DeviceBuilds::OwnDevice (the viewer's choice on CPU devices): the worker builds on a Vulkan
// device of its own and hands back the host tree, the same tree the shared device builds.
TEST(GpuBuilderWorker, OnADeviceOfItsOwnTheWorkerHandsBackTheHostTree) {
    AsyncSceneBuilder builder(
        [](const std::string& spec, LoadProgress& progress) { return openScene(spec, &progress); }, &validatedContext(),
        DeviceBuilds::OwnDevice);
    auto scene = std::make_shared<const Scene>(makeSphereFlake(6000));
    BvhBuildOptions options;
    options.builder = BvhBuilder::GpuPloc;
    options.leafSize = 2;
    builder.requestRebuild(scene, options, /*hostTree=*/false);
    builder.waitIdle();
    std::optional<SceneBuild> built = builder.takeFinished();
    ASSERT_TRUE(built && built->bvh) << (builder.takeFailure() ? "failed" : "nothing");
    EXPECT_FALSE(built->deviceTree);
    expectValidTree(*scene, *built->bvh, 2);
    const Bvh shared = buildBvhOnDevice(validatedContext(), *scene, options);
    EXPECT_EQ(built->bvh->nodes.size(), shared.nodes.size());
    EXPECT_EQ(built->bvh->primIndices, shared.primIndices);
    EXPECT_EQ(vk::validationMessageCount(validatedContext()), 0u);
}

// Without a device a device build fails with a message, and the worker goes on.
TEST(GpuBuilderWorker, ADeviceBuildWithoutADeviceFailsWithAMessage) {
    AsyncSceneBuilder builder(
        [](const std::string& spec, LoadProgress& progress) { return openScene(spec, &progress); });
    auto scene = std::make_shared<const Scene>(sceneOfTriangles({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
    BvhBuildOptions options;
    options.builder = BvhBuilder::GpuPloc;
    builder.requestRebuild(scene, options);
    builder.waitIdle();
    EXPECT_FALSE(builder.takeFinished());
    const std::optional<BuildFailure> failure = builder.takeFailure();
    ASSERT_TRUE(failure);
    EXPECT_NE(failure->message.find("Vulkan device"), std::string::npos) << failure->message;
    options.builder = BvhBuilder::SahBinned;
    builder.requestRebuild(scene, options);
    builder.waitIdle();
    EXPECT_TRUE(builder.takeFinished());
}

TEST_P(GpuBuilder, RefusesWhatItCannotBuild) {
    Scene scene = sceneOfTriangles({{0, 0, 0}, {1, 0, 0}, {0, std::numeric_limits<float>::infinity(), 0}});
    EXPECT_THROW(buildBvhOnDevice(validatedContext(), scene, lbvhOptions()), Error);
    const Scene good = sceneOfTriangles({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
    EXPECT_THROW(buildBvhOnDevice(validatedContext(), good, lbvhOptions(0)), Error);
    EXPECT_THROW(buildBvh(good, lbvhOptions()), Error) << "buildBvh has no device";
}

// The search radius of gpu-ploc and gpu-hploc (BvhBuildOptions::plocRadius) changes the pairs
// found, never the tree's validity: radii 1, 4 and 64 on one builder (its nearest-neighbour pipelines
// rebuilt for each) give valid trees, a wider search no worse a SAH cost than radius 1 on this
// scene, 0 builds the tree of the builder's own radius (16 for gpu-ploc; for gpu-hploc 16 on this
// small scene, 8 from kHplocLargeScene triangles), and radii above 64 are refused.
TEST(GpuPlocRadius, EveryRadiusBuildsAValidTree) {
    for (const BvhBuilder builder : {BvhBuilder::GpuPloc, BvhBuilder::GpuHploc}) {
        SCOPED_TRACE(toString(builder));
        const Scene scene = makeSphereFlake(6000);
        BvhBuildOptions options;
        options.builder = builder;
        options.leafSize = 2;
        double narrowest = 0.0;
        for (const uint32_t radius : {1u, 4u, 64u, 16u}) {
            SCOPED_TRACE("radius " + std::to_string(radius));
            options.plocRadius = radius;
            const Bvh bvh = buildBvhOnDevice(validatedContext(), scene, options);
            expectValidTree(scene, bvh, 2);
            if (radius == 1) narrowest = bvh.stats.sahCost;
            if (radius == 64) {
                EXPECT_LE(bvh.stats.sahCost, narrowest * 1.001);
            }
        }
        options.plocRadius = 0;
        const Bvh own = buildBvhOnDevice(validatedContext(), scene, options);
        EXPECT_EQ(plocRadiusOf(options, scene.triangles.size()), 16u);
        EXPECT_EQ(plocRadiusOf(options, kHplocLargeScene - 1), 16u);
        EXPECT_EQ(plocRadiusOf(options, kHplocLargeScene), builder == BvhBuilder::GpuHploc ? 8u : 16u);
        options.plocRadius = 16;
        EXPECT_EQ(plocRadiusOf(options, kHplocLargeScene), 16u);
        const Bvh named = buildBvhOnDevice(validatedContext(), scene, options);
        EXPECT_EQ(own.primIndices, named.primIndices);
        ASSERT_EQ(own.nodes.size(), named.nodes.size());
        EXPECT_EQ(0, std::memcmp(own.nodes.data(), named.nodes.data(), own.nodes.size() * sizeof(BvhNode)));
        options.plocRadius = 65;
        EXPECT_THROW(buildBvhOnDevice(validatedContext(), scene, options), Error);
    }
    EXPECT_EQ(vk::validationMessageCount(validatedContext()), 0u);
}

// Treelet restructuring (BvhBuildOptions::treeletRounds, shaders/treelet.comp) rebuilds treelets of the
// clustered trees: every round count gives a valid tree (on an ordinary scene, on one of 2,000
// identical triangles whose treelets are all ties, and at 1e30), the same tree on every run, an SAH
// cost no higher than the round before it (each treelet's optimum includes its old topology), and
// hits equal to the CPU reference over the same tree; more than kMaxTreeletRounds is refused. A larger
// gamma (BvhBuildOptions::treeletGamma) rebuilds fewer treelets: a valid tree, no costlier than none
// rebuilt; gamma below kMinTreeletGamma is refused.
TEST(GpuTreelets, EveryRoundCountBuildsAValidTreeOfNoHigherCost) {
    std::vector<glm::vec3> identical;
    for (int i = 0; i < 2000; ++i) identical.insert(identical.end(), {{-1, -1, 0}, {1, -1, 0}, {0, 2, 0}});
    Scene huge = makeSphereFlake(1500);
    for (glm::vec3& p : huge.positions) p *= 1e30f;
    const Scene scenes[] = {makeTerrain(6000), sceneOfTriangles(identical), huge};
    for (const BvhBuilder builder : {BvhBuilder::GpuPloc, BvhBuilder::GpuHploc}) {
        for (const Scene& scene : scenes) {
            SCOPED_TRACE(std::string(toString(builder)) + ", " + std::to_string(scene.triangleCount()) + " triangles");
            BvhBuildOptions options;
            options.builder = builder;
            options.leafSize = 2;
            double previous = 0.0;
            for (const uint32_t rounds : {0u, 1u, 2u}) {
                SCOPED_TRACE("rounds " + std::to_string(rounds));
                options.treeletRounds = rounds;
                const Bvh bvh = buildBvhOnDevice(validatedContext(), scene, options);
                expectValidTree(scene, bvh, 2);
                EXPECT_TRUE(std::isfinite(bvh.stats.sahCost));
                if (rounds > 0) {
                    EXPECT_LE(bvh.stats.sahCost, previous * (1.0 + 1e-5));
                }
                previous = bvh.stats.sahCost;
                if (rounds == 2) {
                    const Bvh again = buildBvhOnDevice(validatedContext(), scene, options);
                    EXPECT_EQ(bvh.primIndices, again.primIndices);
                    ASSERT_EQ(bvh.nodes.size(), again.nodes.size());
                    EXPECT_EQ(0, std::memcmp(bvh.nodes.data(), again.nodes.data(), bvh.nodes.size() * sizeof(BvhNode)));
                }
            }
        }
        BvhBuildOptions restructured;
        restructured.builder = builder;
        restructured.treeletRounds = 2;
        const Bvh terrain = buildBvhOnDevice(validatedContext(), scenes[0], restructured);
        restructured.treeletRounds = 0;
        const double unrestructured = buildBvhOnDevice(validatedContext(), scenes[0], restructured).stats.sahCost;
        EXPECT_LT(terrain.stats.sahCost, unrestructured) << "the rounds find cheaper treelets on a terrain";
        restructured.treeletRounds = 1;
        restructured.treeletGamma = 64;
        const Bvh fewer = buildBvhOnDevice(validatedContext(), scenes[0], restructured);
        expectValidTree(scenes[0], fewer, BvhBuildOptions{}.leafSize);
        EXPECT_LT(fewer.stats.sahCost, unrestructured);
        restructured.treeletGamma = kMinTreeletGamma - 1;
        EXPECT_THROW(buildBvhOnDevice(validatedContext(), scenes[0], restructured), Error);
        restructured.treeletGamma = kTreeletLeaves;
        restructured.treeletRounds = kMaxTreeletRounds + 1;
        EXPECT_THROW(buildBvhOnDevice(validatedContext(), scenes[0], restructured), Error);
    }
    // Traced: the GPU over a restructured tree (its top rebuilt, top.comp, then the treelet rounds)
    // hits what the CPU reference hits over it.
    const Scene sibenik = openScene(test::sharedScene("sibenik/sibenik_geom_75284.ply"));
    BvhBuildOptions options;
    options.builder = BvhBuilder::GpuHploc;
    options.treeletRounds = 2;
    options.topRebuild = 256;
    RenderSettings settings;
    settings.width = 160;
    settings.height = 120;
    settings.camera = frameScene(sibenik.bounds());
    settings.kernel = KernelKind::Single;
    const FrameRequest request{true, true, false};
    GpuTracer tracer(validatedContext());
    tracer.buildOnDevice(sibenik, options);
    test::expectMatchesReference(
        tracer.render(settings, request),
        renderCpu(sibenik, buildBvhOnDevice(validatedContext(), sibenik, options), settings, request),
        "sibenik, the top rebuilt from 256 triangles, 2 treelet rounds");
    test::expectNoValidationMessages();
}

TEST(GpuTopRebuild, EveryThresholdBuildsAValidTreeTheSameOnEveryRun) {
    std::vector<glm::vec3> identical;
    for (int i = 0; i < 600; ++i) identical.insert(identical.end(), {{-1, -1, 0}, {1, -1, 0}, {0, 2, 0}});
    Scene huge = makeSphereFlake(800);
    for (glm::vec3& p : huge.positions) p *= 1e30f;
    // (No tiny scene: on the H200 every device builder's boxes lose denormal coordinates, whose min
    // and max the GPU flushes to zero; docs/bvh.md, Known limits.)
    const Scene scenes[] = {makeTerrain(3000), sceneOfTriangles(identical), huge, makeTerrain(3)};
    // gpu-ploc's tree goes through the same rebuild as gpu-hploc's: the terrain alone for it.
    for (const BvhBuilder builder : {BvhBuilder::GpuHploc, BvhBuilder::GpuPloc}) {
        for (const Scene& scene : scenes) {
            if (builder == BvhBuilder::GpuPloc && &scene != &scenes[0]) continue;
            SCOPED_TRACE(std::string(toString(builder)) + ", " + std::to_string(scene.triangleCount()) + " triangles");
            BvhBuildOptions options;
            options.builder = builder;
            options.leafSize = 2;
            std::optional<Bvh> previous;  // the last build at 16
            // 2: the whole tree rebuilt over its triangles; 16: a top over tens to hundreds of
            // subtrees (twice: the same tree again); beyond the scene: nothing rebuilt.
            for (const uint32_t threshold : {2u, 16u, 16u, 100000u}) {
                if (threshold > 16 && &scene != &scenes[0]) continue;
                SCOPED_TRACE("top rebuild " + std::to_string(threshold));
                options.topRebuild = threshold;
                const Bvh bvh = buildBvhOnDevice(validatedContext(), scene, options);
                expectValidTree(scene, bvh, 2);
                EXPECT_TRUE(std::isfinite(bvh.stats.sahCost));
                if (threshold > scene.triangleCount())
                    EXPECT_EQ(bvh.stats.topRebuildItems, 0u);
                else
                    EXPECT_GE(bvh.stats.topRebuildItems, 2u);
                if (threshold == 2) {
                    EXPECT_EQ(bvh.stats.topRebuildItems, scene.triangleCount());
                }
                if (threshold != 16) continue;
                if (previous) {
                    EXPECT_EQ(bvh.primIndices, previous->primIndices);
                    ASSERT_EQ(bvh.nodes.size(), previous->nodes.size());
                    EXPECT_EQ(
                        0, std::memcmp(bvh.nodes.data(), previous->nodes.data(), bvh.nodes.size() * sizeof(BvhNode)));
                }
                previous = bvh;
            }
            if (&scene != &scenes[0]) continue;
            options.topRebuild = 16;
            options.treeletRounds = 1;
            expectValidTree(scene, buildBvhOnDevice(validatedContext(), scene, options), 2);
        }
    }
    // 0: the builder's own, gpu-hploc's from kHplocLargeScene triangles only; 1: none.
    BvhBuildOptions own;
    own.builder = BvhBuilder::GpuHploc;
    EXPECT_EQ(topRebuildOf(own, kHplocLargeScene), kHplocTopRebuild);
    EXPECT_EQ(topRebuildOf(own, kHplocLargeScene - 1), 0u);
    EXPECT_EQ(buildBvhOnDevice(validatedContext(), scenes[0], own).stats.topRebuildItems, 0u);
    own.topRebuild = kNoTopRebuild;
    EXPECT_EQ(topRebuildOf(own, kHplocLargeScene), 0u);
    own.topRebuild = 5000;
    EXPECT_EQ(topRebuildOf(own, 10), 5000u);
    own.builder = BvhBuilder::GpuPloc;
    own.topRebuild = 0;
    EXPECT_EQ(topRebuildOf(own, kHplocLargeScene), 0u);
    test::expectNoValidationMessages();
}

INSTANTIATE_TEST_SUITE_P(Device, GpuBuilder,
                         ::testing::Values(BvhBuilder::GpuLbvh, BvhBuilder::GpuPloc, BvhBuilder::GpuHploc),
                         [](const ::testing::TestParamInfo<BvhBuilder>& info) {
                             return std::string(toString(info.param)).substr(4);  // "gpu-lbvh" -> "lbvh"
                         });

}  // namespace
}  // namespace raypack
