// The driver ray tracing peer (renderer/vk/rt_peer.h). Where the test device lacks
// VK_KHR_ray_tracing_pipeline / VK_KHR_acceleration_structure (lavapipe here), the peer must say so
// in one line, through its typed error, without a validation message. Where the device has them
// (RAYPACK_TEST_DEVICE=H100 on the device machine), it must trace the same rays as the CPU
// reference and agree with its hits. The shader binding table layout, the hit comparison and the
// bench records are checked on the CPU.
#include "renderer/bvh.h"
#include "renderer/cpu_tracer.h"
#include "renderer/measure/agreement.h"
#include "renderer/tracers/registry.h"
#include "renderer/vk/context.h"
#include "renderer/vk/rt_peer.h"
#include "scenes/load.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>

namespace raypack {
namespace {

vk::VulkanContextOptions testOptions(bool enableRayTracing) {
    setenv("XDG_RUNTIME_DIR", "/tmp", 0);
    vk::VulkanContextOptions options;
    options.validation = true;
    options.enableRayTracing = enableRayTracing;
    if (const char* device = std::getenv("RAYPACK_TEST_DEVICE")) options.device = device;
    return options;
}

// One context with ray tracing requested, validation on, for the whole program.
vk::VulkanContext& rayTracingContext() {
    static vk::VulkanContext* context = [] {
        auto* c = new vk::VulkanContext(vk::createVulkanContext(testOptions(true)));
        std::printf("rt peer tests on %s (ray tracing %s)\n", vk::describe(c->info).c_str(),
                    c->rayTracing ? "enabled" : "not offered");
        return c;
    }();
    return *context;
}

RenderSettings smallSettings(const Scene& scene, uint32_t size) {
    RenderSettings settings;
    settings.width = size;
    settings.height = size;
    settings.camera = frameScene(scene.bounds());
    settings.shadows = true;
    return settings;
}

TEST(RtPeer, UnsupportedDeviceGivesOneLineReasonWithoutValidationMessages) {
    vk::VulkanContext& context = rayTracingContext();
    if (context.rayTracing) GTEST_SKIP() << context.info.name << " offers ray tracing";
    const std::string missing = vk::rayTracingMissing(context.physicalDevice);
    EXPECT_FALSE(missing.empty());
    const std::string reason = rtPeerUnsupportedReason(context);
    EXPECT_NE(reason.find(context.info.name), std::string::npos) << reason;
    EXPECT_NE(reason.find("lacks " + missing), std::string::npos) << reason;
    EXPECT_EQ(reason.find('\n'), std::string::npos) << reason;

    const Scene scene = openScene("gen:default");
    try {
        runRtPeer(context, scene, smallSettings(scene, 64), 3);
        FAIL() << "runRtPeer ran on a device without ray tracing";
    } catch (const RtPeerUnsupported& e) {
        EXPECT_EQ(std::string(e.what()), reason);
    }
    EXPECT_EQ(vk::validationMessageCount(context), 0u);
}

TEST(RtPeer, ContextWithoutRayTracingIsRefused) {
    vk::VulkanContext context = vk::createVulkanContext(testOptions(false));
    EXPECT_FALSE(context.rayTracing);
    const std::string reason = rtPeerUnsupportedReason(context);
    const bool offered = vk::rayTracingMissing(context.physicalDevice).empty();
    EXPECT_NE(reason.find(offered ? "without enableRayTracing" : "lacks"), std::string::npos) << reason;
    const Scene scene = openScene("gen:default");
    EXPECT_THROW(runRtPeer(context, scene, smallSettings(scene, 32), 1), RtPeerUnsupported);
    EXPECT_EQ(vk::validationMessageCount(context), 0u);
    vk::destroyVulkanContext(context);
}

// The registry offers "driver-rt" exactly where the context can run it, and its frames hold one
// hit per pixel.
TEST(RtPeer, RegistryOffersDriverRtWhereTheDeviceHasIt) {
    const Scene scene = openScene("gen:default");
    const Bvh bvh = buildBvh(scene, BvhBuildOptions{});
    vk::VulkanContext& context = rayTracingContext();
    TracerEnvironment environment;
    environment.vulkan = &context;
    const std::vector<std::string> names = availableTracers(environment);
    const bool listed = std::find(names.begin(), names.end(), "driver-rt") != names.end();
    EXPECT_EQ(listed, context.rayTracing);
    if (!context.rayTracing) {
        EXPECT_THROW(makeTracer("driver-rt", environment), TracerUnavailable);
        return;
    }
    const std::unique_ptr<Tracer> tracer = makeTracer("driver-rt", environment);
    tracer->prepare(scene, bvh);
    FrameRequest request;
    request.image = false;
    request.hits = true;
    EXPECT_EQ(tracer->render(smallSettings(scene, 32), request).hits.size(), 32u * 32u);
}

// On a device with ray tracing: the peer's hits against the CPU reference's, same rays.
void expectAgreesWithReference(const std::string& spec, uint32_t size) {
    vk::VulkanContext& context = rayTracingContext();
    if (!context.rayTracing) GTEST_SKIP() << rtPeerUnsupportedReason(context);
    const Scene scene = openScene(spec);
    const Bvh bvh = buildBvh(scene, BvhBuildOptions{});
    const RenderSettings settings = smallSettings(scene, size);
    const RtPeerResult result = runRtPeer(context, scene, settings, 3);
    FrameRequest request;
    request.image = false;
    request.hits = true;
    const Frame reference = renderCpu(scene, bvh, settings, request);

    ASSERT_EQ(result.frame.hits.size(), reference.hits.size());
    EXPECT_EQ(result.frame.light, reference.light);
    for (size_t i = 0; i < reference.hits.size(); ++i) {
        // The same rays: the raygen shader compiles shaders/camera.h as the reference does. Its
        // directions use only correctly rounded operations since 2026-12-08 and should be the
        // reference's bits; the tolerance of a few ulps, which the GPU's normalize() needed
        // before, stays until a GPU run has shown that.
        const HitRecord& p = result.frame.hits[i];
        const HitRecord& r = reference.hits[i];
        ASSERT_EQ(glm::vec3(p.orgX, p.orgY, p.orgZ), glm::vec3(r.orgX, r.orgY, r.orgZ));
        ASSERT_NEAR(p.dirX, r.dirX, 1e-6f);
        ASSERT_NEAR(p.dirY, r.dirY, 1e-6f);
        ASSERT_NEAR(p.dirZ, r.dirZ, 1e-6f);
    }
    const HitAgreement a = compareHits(result.frame.hits, reference.hits);
    std::printf("%s\n%s: %.4f%% of rays agree (max rel t error %.2e), %.4f%% of shadows\n",
                describeRtPeer(result).c_str(), spec.c_str(), 100.0 * a.rayShare(), a.maxRelativeTError,
                100.0 * a.shadowShare());
    EXPECT_GE(a.rayShare(), 0.999);
    EXPECT_GE(a.shadowShare(), 0.995);
    EXPECT_EQ(result.primaryRays, uint64_t(size) * size);
    EXPECT_GT(result.primarySeconds.median, 0.0);
    EXPECT_GT(result.shadowSeconds.median, 0.0);
    EXPECT_GT(result.blasBytes, 0u);
    EXPECT_EQ(vk::validationMessageCount(context), 0u);
}

TEST(RtPeer, DefaultSceneAgreesWithCpuReference) { expectAgreesWithReference("gen:default", 128); }

TEST(RtPeer, SibenikAgreesWithCpuReference) {
    expectAgreesWithReference(std::string(RAYPACK_SHARED_SCENES) + "/sibenik/sibenik_geom_75284.ply", 256);
}

// The spec's rules for the table (vkCmdTraceRaysKHR): every region's address a multiple of
// shaderGroupBaseAlignment, strides multiples of shaderGroupHandleAlignment holding a handle, the
// raygen region's size equal to its stride, regions apart.
TEST(RtPeer, ShaderBindingTableLayoutFollowsTheAlignmentRules) {
    struct Device {
        uint32_t handleSize, handleAlignment, baseAlignment;
    };
    // NVIDIA's values (32, 32, 64), and unusual ones: a handle smaller than its alignment, a large
    // base alignment.
    for (const Device d : {Device{32, 32, 64}, Device{16, 8, 256}, Device{32, 64, 64}, Device{48, 16, 32}}) {
        const ShaderBindingTableLayout l =
            layoutShaderBindingTable(d.handleSize, d.handleAlignment, d.baseAlignment, 4096, 2, 1);
        for (const ShaderBindingTableRegion& r : {l.raygen, l.miss, l.hit}) {
            EXPECT_EQ(r.offset % d.baseAlignment, 0u);
            EXPECT_EQ(r.stride % d.handleAlignment, 0u);
            EXPECT_GE(r.stride, d.handleSize);
        }
        EXPECT_EQ(l.raygen.size, l.raygen.stride);
        EXPECT_EQ(l.miss.size, 2 * l.miss.stride);
        EXPECT_EQ(l.hit.size, l.hit.stride);
        EXPECT_GE(l.miss.offset, l.raygen.offset + l.raygen.size);
        EXPECT_GE(l.hit.offset, l.miss.offset + l.miss.size);
        EXPECT_EQ(l.bytes, l.hit.offset + l.hit.size);
    }
    const ShaderBindingTableLayout nvidia = layoutShaderBindingTable(32, 32, 64, 4096, 2, 1);
    EXPECT_EQ(nvidia.miss.offset, 64u);
    EXPECT_EQ(nvidia.hit.offset, 128u);
    EXPECT_EQ(nvidia.bytes, 160u);
    EXPECT_THROW(layoutShaderBindingTable(64, 64, 64, 32, 2, 1), Error);
}

HitRecord hitAt(float t, uint32_t prim, uint32_t shadow) {
    HitRecord h{};
    h.dirZ = -1.0f;
    h.t = t;
    h.prim = prim;
    h.shadow = shadow;
    return h;
}

TEST(RtPeer, HitComparisonUsesTheEmbreeBar) {
    const float inf = INFINITY;
    const std::vector<HitRecord> reference = {hitAt(10.0f, 1, gpu::kShadowLit), hitAt(10.0f, 2, gpu::kShadowOccluded),
                                              hitAt(inf, gpu::kNoHit, gpu::kShadowNone),
                                              hitAt(5.0f, 3, gpu::kShadowLit), hitAt(5.0f, 4, gpu::kShadowLit)};
    const std::vector<HitRecord> peer = {
        hitAt(10.0005f, 7, gpu::kShadowLit),  // t within 1e-4, another triangle (a tie)
        hitAt(10.0f, 2, gpu::kShadowLit),     // shadow differs
        hitAt(inf, gpu::kNoHit, gpu::kShadowNone), hitAt(5.002f, 3, gpu::kShadowLit),  // t off by 4e-4
        hitAt(inf, gpu::kNoHit, gpu::kShadowNone)};                                    // missed
    const HitAgreement a = compareHits(peer, reference);
    EXPECT_EQ(a.comparedRays, 5u);
    EXPECT_EQ(a.agreeingRays, 3u);
    EXPECT_EQ(a.samePrim, 2u);
    EXPECT_NEAR(a.maxRelativeTError, 4e-4, 1e-6);
    EXPECT_EQ(a.comparedShadows, 3u);
    EXPECT_EQ(a.agreeingShadows, 2u);
    EXPECT_THROW(compareHits(peer, std::vector<HitRecord>(2)), Error);
}

TEST(RtPeer, BenchRecordsCarryEveryFigure) {
    RtPeerResult r;
    r.device = "test device";
    r.triangles = 1000;
    r.width = 100;
    r.height = 50;
    r.repeats = 5;
    r.uploadSeconds = 0.001;
    r.blasBuildSeconds = 0.002;
    r.tlasBuildSeconds = 0.0001;
    r.blasBytes = 64000;
    r.primaryRays = 5000;
    r.shadowsTraced = true;
    r.shadowRays = 4000;
    r.primarySeconds = {0.0005, 0.0004, 0.0007};
    r.shadowSeconds = {0.0002, 0.0002, 0.0003};
    HitAgreement a;
    a.comparedRays = 5000;
    a.agreeingRays = 5000;
    const nlohmann::json records = rtPeerRecords(r, &a);
    ASSERT_EQ(records.size(), 2u);
    EXPECT_EQ(records[0]["ray_kind"], "primary");
    EXPECT_EQ(records[1]["ray_kind"], "shadow");
    EXPECT_DOUBLE_EQ(records[0]["perf_mrays_s"].get<double>(), 5000 / 0.0005 / 1e6);
    EXPECT_DOUBLE_EQ(records[1]["perf_mrays_s"].get<double>(), 4000 / 0.0002 / 1e6);
    EXPECT_DOUBLE_EQ(records[0]["t_b_s"].get<double>(), 0.0021);
    EXPECT_DOUBLE_EQ(records[0]["hits_agree_share"].get<double>(), 1.0);
    for (const auto& record : records)
        for (const char* key :
             {"t_k_s", "t_k_min_s", "t_k_max_s", "t_r_us_per_ray", "t_cu_s", "bytes_per_triangle", "n_q_rays"}) {
            ASSERT_TRUE(record.contains(key)) << key;
            EXPECT_TRUE(std::isfinite(record[key].get<double>())) << key;
        }
    r.shadowsTraced = false;
    r.shadowRays = 0;
    r.shadowSeconds = {};
    EXPECT_EQ(rtPeerRecords(r, nullptr).size(), 1u);
    EXPECT_FALSE(rtPeerRecords(r, nullptr)[0].contains("hits_compared"));
    EXPECT_NE(describeRtPeer(r).find("test device"), std::string::npos);
}

}  // namespace
}  // namespace raypack
