// GPU against the CPU reference at the report's 800x800 (issue 3's correctness bars): the default
// scene with the packet and the single-ray kernel, and the Sibenik cathedral with the packet kernel,
// shadows on. Images: at most 0.01% of pixels differ; hits: same hit/miss and t within 1e-4
// relative on 99.99% of rays; shadows agree on 99.9% of the pixels with a shadow ray.
#include "test_gpu_common.h"

namespace raypack::test {
namespace {

void compareAt800(const LoadedScene& s, const Camera& camera, KernelKind kernel, const std::string& what) {
    GpuTracer tracer(validatedContext());
    const double uploadSeconds = tracer.upload(s.scene, s.bvh);
    EXPECT_GT(uploadSeconds, 0.0);
    RenderSettings settings;
    settings.width = 800;
    settings.height = 800;
    settings.camera = camera;
    settings.kernel = kernel;
    const FrameRequest request{true, true, false};
    const Frame gpu = tracer.render(settings, request);
    const Frame cpu = renderCpu(s.scene, s.bvh, settings, request);
    EXPECT_EQ(gpu.light, cpu.light);
    EXPECT_GT(gpu.timings.primarySeconds, 0.0);
    EXPECT_GT(gpu.timings.shadowSeconds, 0.0);
    expectMatchesReference(gpu, cpu, what);
    std::printf("%s: T_CU %.3f s, T_K primary %.3f s, shadow %.3f s (%s)\n", what.c_str(), uploadSeconds,
                gpu.timings.primarySeconds, gpu.timings.shadowSeconds, tracer.device().name.c_str());
    expectNoValidationMessages();
}

TEST(GpuImages, DefaultScenePacketKernelMatchesReference) {
    const LoadedScene s = loadForTest("gen:default");
    compareAt800(s, s.camera, KernelKind::Packet, "default/packet 8x4");
}

TEST(GpuImages, DefaultSceneSingleKernelMatchesReference) {
    const LoadedScene s = loadForTest("gen:default");
    compareAt800(s, s.camera, KernelKind::Single, "default/single");
}

TEST(GpuImages, SibenikPacketKernelMatchesReference) {
    const LoadedScene s = loadForTest(sharedScene("sibenik/sibenik_geom_75284.ply"));
    // The benchmark's view from inside the nave (issue 3).
    Camera inside;
    inside.eye = {-18.0f, -11.0f, 0.0f};
    inside.at = {0.0f, -8.0f, 0.0f};
    inside.up = {0.0f, 1.0f, 0.0f};
    inside.fovYDegrees = 70.0f;
    compareAt800(s, inside, KernelKind::Packet, "sibenik/packet 8x4");
}

}  // namespace
}  // namespace raypack::test
