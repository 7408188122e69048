// Packet shapes, padding, deep trees, counters, views and the viewer's recording path, each checked
// against the CPU reference on small images (lavapipe is slow). Validation is on throughout.
#include "test_gpu_common.h"

#include "renderer/error.h"
#include "scenes/generators.h"
#include "shaders/shading.h"

#include <cstdlib>
#include <cstring>
#include <memory>
#include <optional>
#include <string>

namespace raypack::test {
namespace {

class GpuShapes : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        scene_ = new LoadedScene(loadForTest("gen:default"));
        tracer_ = new GpuTracer(validatedContext());
        tracer_->upload(scene_->scene, scene_->bvh);
    }
    static void TearDownTestSuite() {
        delete tracer_;
        delete scene_;
        tracer_ = nullptr;
        scene_ = nullptr;
    }
    static RenderSettings smallSettings(uint32_t width, uint32_t height) {
        RenderSettings settings;
        settings.width = width;
        settings.height = height;
        settings.camera = scene_->camera;
        return settings;
    }
    static LoadedScene* scene_;
    static GpuTracer* tracer_;
};
LoadedScene* GpuShapes::scene_ = nullptr;
GpuTracer* GpuShapes::tracer_ = nullptr;

// 197 x 151 is a multiple of none of the shapes: every one pads at the right and bottom edges.
TEST_F(GpuShapes, EveryPacketShapeMatchesReference) {
    RenderSettings settings = smallSettings(197, 151);
    const FrameRequest request{true, true, false};
    const Frame cpu = renderCpu(scene_->scene, scene_->bvh, settings, request);
    // The single-ray kernel's workgroup (RenderSettings::singleGroup) takes the same shapes, plus
    // its default, 8x16.
    const PacketShape shapes[] = {{8, 4}, {1, 1}, {4, 8}, {5, 6}, {8, 8}, {16, 16}, {8, 16}};
    for (const KernelKind kernel : {KernelKind::Packet, KernelKind::Single}) {
        for (const PacketShape shape : shapes) {
            settings.kernel = kernel;
            (kernel == KernelKind::Single ? settings.singleGroup : settings.packet) = shape;
            // The shadow pass in another shape than the primary pass's.
            settings.singleShadowGroup = PacketShape{shape.height, shape.width};
            const Frame gpu = tracer_->render(settings, request);
            expectMatchesReference(
                gpu, cpu,
                std::string(toString(kernel)) + " " + std::to_string(shape.width) + "x" + std::to_string(shape.height));
        }
    }
    expectNoValidationMessages();
}

// Packets of exactly one subgroup take the vote's subgroup-only path (no shared memory, no
// barrier): 8 rays are one subgroup on lavapipe, 32 on NVIDIA. Shapes narrower than the subgroup
// (4x2, 2x4, 1x8) once gave wrong images on lavapipe, whose subgroups do not span rows there.
TEST_F(GpuShapes, PacketsOfOneSubgroupMatchReference) {
    RenderSettings settings = smallSettings(197, 151);
    const FrameRequest request{true, true, false};
    const Frame cpu = renderCpu(scene_->scene, scene_->bvh, settings, request);
    const PacketShape shapes[] = {{8, 1}, {4, 2}, {2, 4}, {1, 8}, {32, 1}, {16, 2}};
    settings.kernel = KernelKind::Packet;
    for (const PacketShape shape : shapes) {
        settings.packet = shape;
        const Frame gpu = tracer_->render(settings, request);
        expectMatchesReference(gpu, cpu, "packet " + std::to_string(shape.width) + "x" + std::to_string(shape.height));
    }
    expectNoValidationMessages();
}

TEST_F(GpuShapes, ShadowsOffAndImagesOfOneRowOrColumn) {
    for (const auto& [w, h] : {std::pair{64u, 1u}, std::pair{1u, 37u}, std::pair{33u, 17u}}) {
        RenderSettings settings = smallSettings(w, h);
        settings.shadows = false;
        const FrameRequest request{true, true, false};
        const Frame cpu = renderCpu(scene_->scene, scene_->bvh, settings, request);
        const Frame gpu = tracer_->render(settings, request);
        EXPECT_EQ(gpu.timings.shadowSeconds, 0.0);
        for (const HitRecord& hit : gpu.hits) EXPECT_EQ(hit.shadow, gpu::kShadowNone);
        expectMatchesReference(gpu, cpu, std::to_string(w) + "x" + std::to_string(h));
    }
    expectNoValidationMessages();
}

TEST_F(GpuShapes, CountersDoNotChangeTheImageAndCountWork) {
    RenderSettings settings = smallSettings(96, 80);
    const Frame plain = tracer_->render(settings, {true, true, false});
    const Frame counted = tracer_->render(settings, {true, true, true});
    ASSERT_EQ(counted.counters.size(), size_t(96 * 80));
    EXPECT_EQ(plain.rgba, counted.rgba);
    for (size_t i = 0; i < counted.counters.size(); ++i) {
        const RayCounters& c = counted.counters[i];
        const HitRecord& h = counted.hits[i];
        if (h.prim != gpu::kNoHit) {
            // A hit needs the root, at least one leaf and the hit triangle's test.
            EXPECT_GE(c.primaryNodes, 2u);
            EXPECT_GE(c.primaryTests, 1u);
        }
        if (h.shadow == gpu::kShadowNone) {
            EXPECT_EQ(c.shadowNodes, 0u);
            EXPECT_EQ(c.shadowTests, 0u);
        }
    }
    const CounterSummary summary = summarizeCounters(counted);
    EXPECT_GT(summary.primaryNodes, 1.0);
    EXPECT_GT(summary.shadowRays, 0u);
    expectNoValidationMessages();
}

// A shadow ray's child order (ShadowOrder) changes the work, never the answer: every order gives the
// reference's image and shadows, and tree order or larger-first visit other nodes than nearest-first.
TEST_F(GpuShapes, ShadowOrdersGiveTheSameShadowsWithOtherWork) {
    RenderSettings settings = smallSettings(197, 151);
    settings.kernel = KernelKind::Single;
    const FrameRequest request{true, true, true};
    const Frame cpu = renderCpu(scene_->scene, scene_->bvh, settings, request);
    double nearestNodes = 0.0;
    for (const ShadowOrder order : {ShadowOrder::Nearest, ShadowOrder::Tree, ShadowOrder::Larger}) {
        settings.shadowOrder = order;
        const Frame gpu = tracer_->render(settings, request);
        expectMatchesReference(gpu, cpu, std::string("shadow order ") + toString(order));
        const double nodes = summarizeCounters(gpu).shadowNodes;
        EXPECT_GT(nodes, 0.0);
        if (order == ShadowOrder::Nearest)
            nearestNodes = nodes;
        else
            EXPECT_NE(nodes, nearestNodes) << toString(order);
    }
    expectNoValidationMessages();
}

// Host-timed passes (the viewer's choice on CPU devices) split the frame into several submissions:
// the image and hits stay the same, and each pass gets a time that fits inside the frame's.
TEST_F(GpuShapes, HostTimedPassesKeepTheFrameAndTimeEachPass) {
    const RenderSettings settings = smallSettings(96, 80);
    const Frame byTimestamps = tracer_->render(settings, {true, true, false});
    tracer_->setHostTimedPasses(true);
    const Frame byHost = tracer_->render(settings, {true, true, false});
    RenderSettings noShadows = settings;
    noShadows.shadows = false;
    const Frame byHostNoShadows = tracer_->render(noShadows, {true, false, false});
    tracer_->setHostTimedPasses(false);
    EXPECT_EQ(byTimestamps.rgba, byHost.rgba);
    ASSERT_EQ(byTimestamps.hits.size(), byHost.hits.size());
    EXPECT_EQ(0, std::memcmp(byTimestamps.hits.data(), byHost.hits.data(), byHost.hits.size() * sizeof(HitRecord)));
    EXPECT_GT(byHost.timings.primarySeconds, 0.0);
    EXPECT_GT(byHost.timings.shadowSeconds, 0.0);
    EXPECT_LE(byHost.timings.primarySeconds + byHost.timings.shadowSeconds, byHost.timings.totalSeconds);
    EXPECT_GT(byHostNoShadows.timings.primarySeconds, 0.0);
    EXPECT_EQ(byHostNoShadows.timings.shadowSeconds, 0.0);
    expectNoValidationMessages();
}

TEST_F(GpuShapes, HeatViewsShowWork) {
    RenderSettings settings = smallSettings(64, 64);
    const Frame shaded = tracer_->render(settings);
    settings.view = ViewMode::HeatTraversal;
    const Frame heat = tracer_->render(settings, {true, false, true});
    // The heat view is the shared ramp of the GPU's own counts.
    ASSERT_EQ(heat.counters.size(), heat.rgba.size());
    for (size_t i = 0; i < heat.rgba.size(); ++i) {
        const RayCounters& c = heat.counters[i];
        const glm::vec3 color = gpu::heatColorForCount(c.primaryNodes + c.shadowNodes, gpu::kHeatFullScaleNodes);
        EXPECT_EQ(heat.rgba[i], gpu::packRgba8(glm::vec4(color, 1.0f))) << "pixel " << i;
    }
    EXPECT_NE(heat.rgba, shaded.rgba);
    expectNoValidationMessages();
}

// The viewer's path: record into a command buffer the caller owns, copy outputBuffer() out, read
// kernel times afterwards. BGRA output is the RGBA image with red and blue swapped.
TEST_F(GpuShapes, RecordedFrameEqualsSynchronousRender) {
    const vk::VulkanContext& ctx = validatedContext();
    RenderSettings settings = smallSettings(120, 90);
    const Frame reference = tracer_->render(settings);

    VkCommandPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    poolInfo.queueFamilyIndex = ctx.queueFamily;
    VkCommandPool pool;
    ASSERT_EQ(vkCreateCommandPool(ctx.device, &poolInfo, nullptr, &pool), VK_SUCCESS);
    vk::Buffer host =
        vk::createBuffer(ctx, 120 * 90 * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                         VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, "read-back");
    for (const bool bgra : {false, true}) {
        vk::submitAndWait(ctx, pool, [&](VkCommandBuffer cmd) {
            tracer_->recordFrame(cmd, settings, {bgra});
            VkBufferCopy region{0, 0, tracer_->outputBytes()};
            vkCmdCopyBuffer(cmd, tracer_->outputBuffer(), host.buffer, 1, &region);
        });
        std::vector<uint32_t> pixels(120 * 90);
        std::memcpy(pixels.data(), host.mapped, pixels.size() * 4);
        for (size_t i = 0; i < pixels.size(); ++i) {
            uint32_t expected = reference.rgba[i];
            if (bgra) expected = (expected & 0xFF00FF00u) | ((expected & 0xFFu) << 16) | ((expected >> 16) & 0xFFu);
            ASSERT_EQ(pixels[i], expected) << "pixel " << i << (bgra ? " (BGRA)" : "");
        }
        const std::optional<FrameTimings> times = tracer_->lastKernelTimes();
        ASSERT_TRUE(times.has_value());
        EXPECT_GT(times->primarySeconds, 0.0);
        EXPECT_GT(times->shadowSeconds, 0.0);
    }
    vk::destroyBuffer(ctx, host);
    vkDestroyCommandPool(ctx.device, pool, nullptr);
    expectNoValidationMessages();
}

TEST_F(GpuShapes, PacketsBeyondTheDeviceLimitAreAClearError) {
    RenderSettings settings = smallSettings(64, 64);
    const uint32_t limit = validatedContext().info.maxWorkgroupInvocations;
    settings.packet = {limit, 2};
    EXPECT_THROW(tracer_->render(settings), Error);
    settings.packet = {0, 4};
    EXPECT_THROW(tracer_->render(settings), Error);
}

// A tree far deeper than the report's fixed 50-entry stack: the stacks are sized from it and the
// image still matches the reference.
TEST(GpuDeepTree, StackIsSizedFromTheTree) {
    LoadedScene s;
    s.scene = makeDeepScene(kDeepSceneMaxTriangles);
    BvhBuildOptions options;
    options.leafSize = 1;
    s.bvh = buildBvh(s.scene, options);
    ASSERT_GT(s.bvh.stats.maxLeafDepth, 50u);
    GpuTracer tracer(validatedContext());
    tracer.upload(s.scene, s.bvh);
    EXPECT_EQ(tracer.stackEntries(), s.bvh.stats.maxLeafDepth + 1);
    RenderSettings settings;
    settings.width = 96;
    settings.height = 96;
    settings.camera = frameScene(s.scene.bounds());
    const FrameRequest request{true, true, true};
    const Frame cpu = renderCpu(s.scene, s.bvh, settings, request);
    size_t hits = 0;
    for (const HitRecord& h : cpu.hits) hits += h.prim != gpu::kNoHit;
    EXPECT_GT(hits, 0u);
    for (const KernelKind kernel : {KernelKind::Packet, KernelKind::Single}) {
        settings.kernel = kernel;
        for (const PacketShape shape : {PacketShape{8, 4}, PacketShape{16, 16}}) {
            (kernel == KernelKind::Single ? settings.singleGroup : settings.packet) = shape;
            expectMatchesReference(tracer.render(settings, request), cpu, std::string("deep ") + toString(kernel));
        }
    }
    expectNoValidationMessages();
}

// A tracer made while RAYPACK_NODE_FETCH is `value` (unset for nullptr), which it reads once; the
// variable is as before afterwards, whether the tracer was made or threw.
std::unique_ptr<GpuTracer> tracerWithNodeFetch(const char* value) {
    struct Restore {
        std::optional<std::string> saved;
        ~Restore() { saved ? setenv("RAYPACK_NODE_FETCH", saved->c_str(), 1) : unsetenv("RAYPACK_NODE_FETCH"); }
    } restore;
    if (const char* before = std::getenv("RAYPACK_NODE_FETCH")) restore.saved = before;
    value ? setenv("RAYPACK_NODE_FETCH", value, 1) : unsetenv("RAYPACK_NODE_FETCH");
    return std::make_unique<GpuTracer>(validatedContext());
}

// Nodes read through the texel buffer (NodeFetch::Texel, the default on CPU devices) and through
// the storage buffer are the same nodes: every binary kernel gives the same hits and counts, ray
// for ray, over a host tree and over a device-built one, and both match the CPU reference. Auto
// takes texels on a CPU device only; the 8-wide tree reads storage whatever is asked; a bad value
// is an error that names the variable.
TEST(GpuNodeFetch, TexelAndStorageNodesTraceTheSame) {
    const LoadedScene s = loadForTest(sharedScene("sibenik/sibenik_geom_75284.ply"));
    const std::unique_ptr<GpuTracer> storage = tracerWithNodeFetch("storage");
    const std::unique_ptr<GpuTracer> texel = tracerWithNodeFetch("texel");
    const std::unique_ptr<GpuTracer> automatic = tracerWithNodeFetch(nullptr);
    EXPECT_EQ(storage->nodeFetch(), NodeFetch::Storage);  // before any upload
    RenderSettings settings;
    settings.width = 96;
    settings.height = 64;
    settings.camera = s.camera;
    const FrameRequest request{true, true, true};
    const Frame cpu = renderCpu(s.scene, s.bvh, settings, request);

    BvhBuildOptions deviceBuild;
    deviceBuild.builder = BvhBuilder::GpuPloc;
    deviceBuild.leafSize = 2;
    for (const bool onDevice : {false, true}) {
        SCOPED_TRACE(onDevice ? "device-built tree" : "host tree");
        for (GpuTracer* tracer : {storage.get(), texel.get(), automatic.get()}) {
            if (onDevice)
                tracer->buildOnDevice(s.scene, deviceBuild);
            else
                tracer->upload(s.scene, s.bvh);
        }
        EXPECT_EQ(storage->nodeFetch(), NodeFetch::Storage);
        EXPECT_EQ(texel->nodeFetch(), NodeFetch::Texel) << texel->nodeFetchReason();
        const bool cpuDevice = validatedContext().info.type == VK_PHYSICAL_DEVICE_TYPE_CPU;
        EXPECT_EQ(automatic->nodeFetch(), cpuDevice ? NodeFetch::Texel : NodeFetch::Storage)
            << automatic->nodeFetchReason();
        for (const KernelKind kernel : {KernelKind::Packet, KernelKind::Single, KernelKind::Hybrid}) {
            settings.kernel = kernel;
            const Frame a = storage->render(settings, request);
            const Frame b = texel->render(settings, request);
            EXPECT_TRUE(sameHits(a, b)) << toString(kernel);
            ASSERT_EQ(a.counters.size(), b.counters.size());
            EXPECT_EQ(0, std::memcmp(a.counters.data(), b.counters.data(), a.counters.size() * sizeof(RayCounters)))
                << toString(kernel);
            EXPECT_EQ(a.rgba, b.rgba) << toString(kernel);
            EXPECT_GT(summarizeCounters(b).primaryNodes, 0.0) << toString(kernel);
            if (!onDevice) expectMatchesReference(b, cpu, std::string("texel nodes, ") + toString(kernel));
        }
    }

    texel->upload(s.scene, s.bvh, 8);
    EXPECT_EQ(texel->nodeFetch(), NodeFetch::Storage);
    EXPECT_NE(texel->nodeFetchReason().find("8-wide"), std::string::npos) << texel->nodeFetchReason();
    settings.kernel = KernelKind::Single;
    settings.bvhWidth = 8;
    expectMatchesReference(texel->render(settings, request), cpu, "8-wide tree, texels asked for");

    try {
        tracerWithNodeFetch("textures");
        ADD_FAILURE() << "RAYPACK_NODE_FETCH=textures was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("RAYPACK_NODE_FETCH"), std::string::npos) << e.what();
    }
    expectNoValidationMessages();
}

TEST(GpuEmptyScene, EveryRayMisses) {
    LoadedScene s;
    s.bvh = buildBvh(s.scene, BvhBuildOptions{});
    GpuTracer tracer(validatedContext());
    tracer.upload(s.scene, s.bvh);
    RenderSettings settings;
    settings.width = 16;
    settings.height = 16;
    // Every kernel (the single-ray kernel looped on the empty root until 2026-12-02).
    for (const KernelKind kernel : {KernelKind::Packet, KernelKind::Single, KernelKind::Hybrid}) {
        settings.kernel = kernel;
        const Frame gpu = tracer.render(settings, {true, true, false});
        for (const HitRecord& h : gpu.hits) {
            EXPECT_EQ(h.prim, gpu::kNoHit) << toString(kernel);
            EXPECT_TRUE(std::isinf(h.t)) << toString(kernel);
        }
    }
    expectNoValidationMessages();
}

}  // namespace
}  // namespace raypack::test
