// Every tracer of the registry (renderer/tracers/registry.h) that this machine has, on the same
// scene and the same rays, against the CPU reference with the bars the existing tests set:
//  - CPU packets: hits identical to the reference's to the bit (test_cpu_packet), the image too;
//  - the GPU kernels: at most 0.01% of pixels differ, hits agree on 99.99% of rays, shadows on
//    99.9% (issue 3, test_gpu_images);
//  - Embree: hits agree on 99.99%, shadows on 99.9% (test_bench's Embree test);
//  - the driver's ray tracing: 99.9% and 99.5% (test_rt_peer).
// A tracer this machine lacks is skipped with the registry's reason.
#include "renderer/bvh.h"
#include "renderer/cpu_tracer.h"
#include "renderer/measure/agreement.h"
#include "renderer/tracers/registry.h"
#include "renderer/vk/context.h"
#include "scenes/load.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <tuple>

namespace raypack {
namespace {

// One context with validation on and ray tracing enabled where offered; nullptr without Vulkan.
const vk::VulkanContext* testContext() {
    static const vk::VulkanContext* context = []() -> const vk::VulkanContext* {
        setenv("XDG_RUNTIME_DIR", "/tmp", 0);
        vk::VulkanContextOptions options;
        options.validation = true;
        options.enableRayTracing = true;
        if (const char* device = std::getenv("RAYPACK_TEST_DEVICE")) options.device = device;
        try {
            auto* c = new vk::VulkanContext(vk::createVulkanContext(options));
            std::printf("tracer tests on %s\n", vk::describe(c->info).c_str());
            return c;
        } catch (const Error& e) {
            std::printf("tracer tests without Vulkan: %s\n", e.what());
            return nullptr;
        }
    }();
    return context;
}

struct Bars {
    double rays;     // share of rays whose hits agree (renderer/measure/agreement.h)
    double shadows;  // share of the reference's shadow rays with the same lit/occluded state
    bool bitExact;   // hits identical to the reference's
};

Bars barsFor(const std::string& name) {
    static const std::map<std::string, Bars> bars = {
        {"cpu-reference", {1.0, 1.0, true}},    {"cpu-packet", {1.0, 1.0, true}},
        {"gpu-packet", {0.9999, 0.999, false}}, {"gpu-single", {0.9999, 0.999, false}},
        {"gpu-cwbvh", {0.9999, 0.999, false}},  {"gpu-hybrid", {0.9999, 0.999, false}},
        {"embree", {0.9999, 0.999, false}},     {"driver-rt", {0.999, 0.995, false}},
    };
    const auto it = bars.find(name);
    EXPECT_NE(it, bars.end()) << "no bar for tracer " << name << ": add one here";
    return it == bars.end() ? Bars{1.0, 1.0, true} : it->second;
}

struct SceneCase {
    const char* name;
    std::string spec;
    uint32_t width, height;
};

const SceneCase kScenes[] = {
    {"default", "gen:default", 160, 120},
    {"sibenik", std::string(RAYPACK_SHARED_SCENES) + "/sibenik/sibenik_geom_75284.ply", 128, 96},
};

std::vector<std::string> allTracerNames() {
    std::vector<std::string> names;
    for (const TracerInfo& info : listTracers(TracerEnvironment{})) names.push_back(info.name);
    return names;
}

// Why the registry cannot make `name` on this machine ("" when it can).
std::string unavailableReason(const std::string& name, const TracerEnvironment& environment) {
    for (const TracerInfo& info : listTracers(environment))
        if (info.name == name) return info.unavailable;
    return "";
}

class EveryTracer : public ::testing::TestWithParam<std::tuple<std::string, size_t>> {};

TEST_P(EveryTracer, AgreesWithTheCpuReference) {
    const auto& [name, sceneIndex] = GetParam();
    const SceneCase& c = kScenes[sceneIndex];
    TracerEnvironment environment;
    environment.vulkan = testContext();
    if (const std::string why = unavailableReason(name, environment); !why.empty()) GTEST_SKIP() << why;

    const Scene scene = openScene(c.spec);
    const Bvh bvh = buildBvh(scene, BvhBuildOptions{});
    RenderSettings settings;
    settings.width = c.width;
    settings.height = c.height;
    settings.camera = frameScene(scene.bounds());
    settings.shadows = true;

    const std::unique_ptr<Tracer> tracer = makeTracer(name, environment);
    EXPECT_EQ(tracer->name(), name);
    const TracerCapabilities caps = tracer->capabilities();
    ASSERT_TRUE(caps.hits) << name << ": every tracer gives hits";
    const Preparation preparation = tracer->prepare(scene, bvh);
    EXPECT_GE(preparation.seconds, 0.0);
    EXPECT_EQ(preparation.isUpload, tracer->device() == TracerDevice::Gpu && caps.image);

    FrameRequest request;
    request.image = caps.image;
    request.hits = true;
    request.counters = caps.counters;
    RenderSettings counting = settings;
    counting.collectCounters = caps.counters;
    const Frame frame = tracer->render(counting, request);
    const Frame reference = renderCpu(scene, bvh, counting, request);

    EXPECT_EQ(frame.width, c.width);
    EXPECT_EQ(frame.height, c.height);
    EXPECT_EQ(frame.light, reference.light);
    ASSERT_EQ(frame.hits.size(), reference.hits.size());
    for (size_t i = 0; i < reference.hits.size(); ++i) {
        // The same rays: every tracer compiles shaders/camera.h. A GPU's normalize() may round
        // differently from glm's, hence a few ulps on the direction.
        const HitRecord& p = frame.hits[i];
        const HitRecord& r = reference.hits[i];
        ASSERT_EQ(glm::vec3(p.orgX, p.orgY, p.orgZ), glm::vec3(r.orgX, r.orgY, r.orgZ)) << name << " pixel " << i;
        ASSERT_NEAR(p.dirX, r.dirX, 1e-6f) << name << " pixel " << i;
        ASSERT_NEAR(p.dirY, r.dirY, 1e-6f) << name << " pixel " << i;
        ASSERT_NEAR(p.dirZ, r.dirZ, 1e-6f) << name << " pixel " << i;
    }
    const Bars bars = barsFor(name);
    const HitAgreement a = compareHits(frame.hits, reference.hits);
    EXPECT_GT(a.comparedShadows, 0u);
    EXPECT_GE(a.rayShare(), bars.rays) << name << ": " << a.agreeingRays << " of " << a.comparedRays;
    EXPECT_GE(a.shadowShare(), bars.shadows) << name << ": " << a.agreeingShadows << " of " << a.comparedShadows;
    if (bars.bitExact) {
        EXPECT_EQ(identicalHitShare(frame.hits, reference.hits), 1.0) << name;
    }
    EXPECT_EQ(caps.bitExactWithReference, bars.bitExact && name != "cpu-reference") << name;

    if (caps.image) {
        ASSERT_EQ(frame.rgba.size(), reference.rgba.size());
        size_t differing = 0;
        for (size_t i = 0; i < frame.rgba.size(); ++i) differing += frame.rgba[i] != reference.rgba[i];
        EXPECT_LE(double(differing), (bars.bitExact ? 0.0 : 1e-4) * double(frame.rgba.size()))
            << name << ": " << differing << " pixels differ";
    }
    if (caps.counters) {
        const CounterSummary mine = summarizeCounters(frame), ref = summarizeCounters(reference);
        EXPECT_EQ(mine.primaryRays, ref.primaryRays);
        EXPECT_GT(mine.primaryNodes, 0.0);
        EXPECT_GT(mine.primaryTests, 0.0);
        // N_Q of shadow rays follows the hits, which agree within the bar.
        EXPECT_NEAR(double(mine.shadowRays), double(ref.shadowRays), (1.0 - bars.rays) * double(ref.primaryRays) + 0.5);
    }
    EXPECT_GT(frame.timings.primarySeconds, 0.0) << name;
    EXPECT_GT(frame.timings.shadowSeconds, 0.0) << name;
    if (environment.vulkan) {
        EXPECT_EQ(vk::validationMessageCount(*environment.vulkan), 0u);
    }
}

// IntersectMode::Fast on every tracer that honours it, against the reference's own fast path: the
// CPU packets to the bit, the GPU kernels within the GPU bars (GLSL may fuse the fast test's
// products, so rays through edges may decide differently). And it is another path than the robust
// one: on the CPU the hit distances differ in their last bits.
TEST_P(EveryTracer, FastIntersectionAgreesWithTheReferencesFastPath) {
    const auto& [name, sceneIndex] = GetParam();
    const SceneCase& c = kScenes[sceneIndex];
    TracerEnvironment environment;
    environment.vulkan = testContext();
    if (const std::string why = unavailableReason(name, environment); !why.empty()) GTEST_SKIP() << why;
    const std::unique_ptr<Tracer> tracer = makeTracer(name, environment);
    if (!tracer->capabilities().intersectModes) GTEST_SKIP() << name << " has its own intersection";

    const Scene scene = openScene(c.spec);
    const Bvh bvh = buildBvh(scene, BvhBuildOptions{});
    RenderSettings settings;
    settings.width = c.width;
    settings.height = c.height;
    settings.camera = frameScene(scene.bounds());
    settings.intersect = IntersectMode::Fast;
    tracer->prepare(scene, bvh);
    const FrameRequest request{.image = tracer->capabilities().image, .hits = true};
    const Frame frame = tracer->render(settings, request);
    const Frame reference = renderCpu(scene, bvh, settings, request);
    const Bars bars = barsFor(name);
    const HitAgreement a = compareHits(frame.hits, reference.hits);
    EXPECT_GE(a.rayShare(), bars.rays) << name << ": " << a.agreeingRays << " of " << a.comparedRays;
    EXPECT_GE(a.shadowShare(), bars.shadows) << name << ": " << a.agreeingShadows << " of " << a.comparedShadows;
    if (bars.bitExact) {
        EXPECT_EQ(identicalHitShare(frame.hits, reference.hits), 1.0) << name;
    }
    RenderSettings robust = settings;
    robust.intersect = IntersectMode::Robust;
    const Frame robustReference = renderCpu(scene, bvh, robust, request);
    EXPECT_LT(identicalHitShare(reference.hits, robustReference.hits), 1.0);
    // Away from edges the two paths see the same triangles.
    EXPECT_GE(compareHits(reference.hits, robustReference.hits).rayShare(), 0.999);
    if (environment.vulkan) {
        EXPECT_EQ(vk::validationMessageCount(*environment.vulkan), 0u);
    }
}

INSTANTIATE_TEST_SUITE_P(Registry, EveryTracer,
                         ::testing::Combine(::testing::ValuesIn(allTracerNames()), ::testing::Values(0u, 1u)),
                         [](const ::testing::TestParamInfo<EveryTracer::ParamType>& info) {
                             std::string name = std::get<0>(info.param) + "_" + kScenes[std::get<1>(info.param)].name;
                             for (char& ch : name)
                                 if (ch == '-') ch = '_';
                             return name;
                         });

TEST(Registry, ListsEveryTracerAndRefusesUnknownNames) {
    const std::vector<std::string> names = allTracerNames();
    EXPECT_EQ(names, (std::vector<std::string>{"cpu-reference", "cpu-packet", "embree", "gpu-packet", "gpu-single",
                                               "gpu-cwbvh", "gpu-hybrid", "driver-rt"}));
    const std::vector<std::string> cpuOnly = availableTracers(TracerEnvironment{});
    EXPECT_EQ(cpuOnly.front(), "cpu-reference");
    EXPECT_EQ(std::count(cpuOnly.begin(), cpuOnly.end(), "embree"), embreeAvailable() ? 1 : 0);
    EXPECT_EQ(std::count(cpuOnly.begin(), cpuOnly.end(), "gpu-packet"), 0);
    EXPECT_THROW(makeTracer("gpu-packet", TracerEnvironment{}), TracerUnavailable);
    try {
        makeTracer("cpu-refrence", TracerEnvironment{});
        FAIL() << "an unknown name made a tracer";
    } catch (const TracerUnavailable&) {
        FAIL() << "an unknown name is not an unavailable tracer";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("cpu-reference"), std::string::npos) << e.what();
    }
    const std::unique_ptr<Tracer> reference = makeTracer("cpu-reference", TracerEnvironment{});
    EXPECT_THROW(reference->render(RenderSettings{}, FrameRequest{}), Error);  // nothing prepared
}

}  // namespace
}  // namespace raypack
