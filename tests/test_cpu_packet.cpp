// The CPU packet tracer (renderer/cpu_packet_tracer.h) against the CPU reference: every pixel's
// closest hit (triangle, t to the bit), shadow flag and shaded colour must be the reference's, for
// each SIMD width this CPU has (scalar, SSE4.1, AVX2), many packet shapes and odd image sizes.
#include "renderer/bvh.h"
#include "renderer/camera.h"
#include "renderer/cpu_packet_tracer.h"
#include "renderer/cpu_tracer.h"
#include "renderer/error.h"
#include "renderer/hits_io.h"
#include "scenes/generators.h"
#include "scenes/load.h"
#include "shaders/camera.h"
#include "shaders/shading.h"

#include "cli_runner.h"

#include "random_geometry.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>

namespace {

using namespace raypack;
using raypack::test::randomTriangleSoup;
using raypack::test::tessellatedCube;

Bvh build(const Scene& scene, uint32_t leafSize = 2) {
    std::vector<Aabb> bounds(scene.triangleCount());
    for (uint32_t i = 0; i < bounds.size(); ++i) bounds[i] = scene.triangleBounds(i);
    BvhBuildOptions options;
    options.leafSize = leafSize;
    return buildBvh(bounds, options);
}

// Every width this CPU has: scalar always, SSE4.1 and AVX2 where CPUID has them.
std::vector<CpuSimd> widths() {
    std::vector<CpuSimd> list{CpuSimd::Scalar};
    const CpuSimd widest = cpuSimdSupported();
    if (widest != CpuSimd::Scalar) list.push_back(CpuSimd::Sse41);
    if (widest == CpuSimd::Avx2) list.push_back(CpuSimd::Avx2);
    return list;
}

Scene translated(Scene scene, glm::vec3 offset) {
    for (glm::vec3& p : scene.positions) p += offset;
    return scene;
}

std::string describe(const RenderSettings& s, CpuSimd simd) {
    std::ostringstream out;
    out << s.width << "x" << s.height << " packet " << s.packet.width << "x" << s.packet.height << " " << toString(simd)
        << (s.shadows ? "" : " no shadows");
    return out.str();
}

// Every pixel as the reference has it: hit triangle, t bit for bit, shadow state, colour. Returns
// the number of pixels whose primary ray hit.
size_t expectSameFrame(const CpuSceneView& view, const RenderSettings& settings, CpuSimd simd) {
    const FrameRequest request{.image = true, .hits = true, .counters = true};
    const Frame reference = renderCpu(view, settings, request);
    const Frame packets = renderCpuPackets(view, settings, request, simd);
    const size_t pixels = size_t(settings.width) * settings.height;
    EXPECT_EQ(packets.hits.size(), pixels);
    EXPECT_EQ(packets.counters.size(), pixels);
    EXPECT_EQ(packets.light, reference.light);
    size_t hits = 0;
    for (size_t i = 0; i < pixels; ++i) {
        const HitRecord& a = reference.hits[i];
        const HitRecord& b = packets.hits[i];
        const std::string where = describe(settings, simd) + " pixel " + std::to_string(i % settings.width) + "," +
                                  std::to_string(i / settings.width);
        EXPECT_EQ(b.prim, a.prim) << where;
        EXPECT_EQ(std::bit_cast<uint32_t>(b.t), std::bit_cast<uint32_t>(a.t)) << where;
        EXPECT_EQ(b.shadow, a.shadow) << where;
        EXPECT_EQ(b.dirX, a.dirX) << where;
        if (a.prim != gpu::kNoHit) {
            ++hits;
            // A hit was found in a leaf the ray visited: it counted a node and a test.
            EXPECT_GE(packets.counters[i].primaryNodes, 1u) << where;
            EXPECT_GE(packets.counters[i].primaryTests, 1u) << where;
        } else {
            EXPECT_EQ(packets.counters[i].shadowNodes, 0u) << where;
        }
        if (::testing::Test::HasFailure()) return hits;  // one pixel's report is enough
    }
    EXPECT_EQ(packets.rgba, reference.rgba) << describe(settings, simd);
    return hits;
}

TEST(CpuPacket, SimdSelection) {
    const CpuSimd supported = cpuSimdSupported();
    ::unsetenv("RAYPACK_CPU_SIMD");
    EXPECT_EQ(cpuSimdSelected(), supported);
    ::setenv("RAYPACK_CPU_SIMD", "scalar", 1);
    EXPECT_EQ(cpuSimdSelected(), CpuSimd::Scalar);
    if (supported != CpuSimd::Scalar) {
        ::setenv("RAYPACK_CPU_SIMD", "sse", 1);
        EXPECT_EQ(cpuSimdSelected(), CpuSimd::Sse41);
    }
    ::setenv("RAYPACK_CPU_SIMD", "avx2", 1);
    if (supported == CpuSimd::Avx2)
        EXPECT_EQ(cpuSimdSelected(), CpuSimd::Avx2);
    else
        EXPECT_THROW(cpuSimdSelected(), Error);
    ::setenv("RAYPACK_CPU_SIMD", "avx512", 1);
    try {
        cpuSimdSelected();
        ADD_FAILURE() << "RAYPACK_CPU_SIMD=avx512 accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("avx512"), std::string::npos) << e.what();
    }
    ::unsetenv("RAYPACK_CPU_SIMD");
    std::printf("this CPU runs %s\n", toString(supported));
}

TEST(CpuPacket, SameHitsOnRandomScenesShapesAndOddSizes) {
    const Scene soup = randomTriangleSoup(4000, 7);
    const Bvh bvh = build(soup);
    const CpuSceneView view = makeCpuSceneView(soup, bvh);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> coord(-12.0f, 12.0f);
    const std::vector<PacketShape> shapes = {{1, 1}, {3, 5}, {4, 4}, {8, 4}, {16, 16}, {7, 1}, {32, 32}, {1, 9}};
    const std::vector<std::pair<uint32_t, uint32_t>> sizes = {{37, 29}, {1, 1}, {17, 3}, {5, 40}, {64, 48}};
    int run = 0;
    for (const CpuSimd simd : widths()) {
        for (const PacketShape& shape : shapes) {
            for (const auto& [width, height] : sizes) {
                RenderSettings settings;
                settings.width = width;
                settings.height = height;
                settings.packet = shape;
                settings.shadows = run % 5 != 4;
                // Inside the soup (rays leave in every direction) or framing it from outside.
                if (run % 2 == 0) {
                    settings.camera.eye = glm::vec3(coord(rng), coord(rng), coord(rng));
                    settings.camera.at = glm::vec3(coord(rng), coord(rng), coord(rng));
                    settings.camera.fovYDegrees = 100.0f;
                } else {
                    settings.camera = frameScene(soup.bounds());
                }
                expectSameFrame(view, settings, simd);
                if (HasFailure()) return;
                ++run;
            }
        }
    }
}

// IntersectMode::Fast: the packet kernel's Moller-Trumbore and plain slab test, lane by lane, are
// the reference's fast path bit for bit, inside and outside a random soup and on Sibenik.
TEST(CpuPacket, FastIntersectionSameAsTheReferencesFastPath) {
    const Scene soup = randomTriangleSoup(3000, 17);
    const Bvh bvh = build(soup);
    const CpuSceneView view = makeCpuSceneView(soup, bvh);
    const Scene sibenik = loadScene(std::filesystem::path(RAYPACK_SHARED_SCENES) / "sibenik/sibenik_geom_75284.ply");
    const Bvh sibenikBvh = build(sibenik);
    const CpuSceneView sibenikView = makeCpuSceneView(sibenik, sibenikBvh);
    for (const CpuSimd simd : widths()) {
        for (int run = 0; run < 3; ++run) {
            RenderSettings settings;
            settings.intersect = IntersectMode::Fast;
            settings.width = 53;
            settings.height = 41;
            settings.packet = run == 1 ? PacketShape{16, 16} : PacketShape{8, 8};
            settings.camera = frameScene(soup.bounds());
            if (run == 1) {
                settings.camera.eye = glm::vec3(0.5f, -1.0f, 2.0f);
                settings.camera.fovYDegrees = 110.0f;
            }
            if (run == 2) {
                settings.camera.eye = glm::vec3(-18.0f, -11.0f, 0.0f);
                settings.camera.at = glm::vec3(0.0f, -8.0f, 0.0f);
                settings.camera.fovYDegrees = 70.0f;
            }
            EXPECT_GT(expectSameFrame(run == 2 ? sibenikView : view, settings, simd), size_t(53 * 41 / 10));
            if (HasFailure()) return;
            // And it is another path than the robust one: its distances differ in the last bits.
            RenderSettings robust = settings;
            robust.intersect = IntersectMode::Robust;
            const FrameRequest request{.hits = true};
            const Frame a = renderCpu(run == 2 ? sibenikView : view, settings, request);
            const Frame b = renderCpu(run == 2 ? sibenikView : view, robust, request);
            size_t differ = 0;
            for (size_t i = 0; i < a.hits.size(); ++i) differ += a.hits[i].t != b.hits[i].t ? 1 : 0;
            EXPECT_GT(differ, 0u);
        }
    }
}

// Slivers 1e-3 wide in random orientations: most kept hits have their t recomputed from the plane
// (gpu::accurateHitDistanceF64), which the packet kernel does for each such lane; the same bits.
TEST(CpuPacket, SameHitsOnSlivers) {
    const Scene scene = test::randomSliverSoup(40000, 1e-3f, 3.0f, 9);
    const Bvh bvh = build(scene);
    const CpuSceneView view = makeCpuSceneView(scene, bvh);
    RenderSettings settings;
    settings.width = 96;
    settings.height = 80;
    settings.camera = frameScene(scene.bounds());
    for (const CpuSimd simd : widths()) {
        EXPECT_GT(expectSameFrame(view, settings, simd), 150u);
        if (HasFailure()) return;
    }
}

TEST(CpuPacket, SameHitsOnSharedScenes) {
    const std::filesystem::path root = RAYPACK_SHARED_SCENES;
    for (const char* file : {"sibenik/sibenik_geom_75284.ply", "stanford/bun_zipper.ply"}) {
        const Scene scene = loadScene(root / file);
        const Bvh bvh = build(scene);
        const CpuSceneView view = makeCpuSceneView(scene, bvh);
        for (const CpuSimd simd : widths()) {
            for (const PacketShape shape : {PacketShape{16, 16}, PacketShape{8, 8}, PacketShape{13, 6}}) {
                RenderSettings settings;
                settings.width = 121;
                settings.height = 87;
                settings.packet = shape;
                settings.camera = frameScene(scene.bounds());
                if (std::string(file).find("sibenik") != std::string::npos) {
                    settings.camera.eye = glm::vec3(-18.0f, -11.0f, 0.0f);
                    settings.camera.at = glm::vec3(0.0f, -8.0f, 0.0f);
                    settings.camera.fovYDegrees = 70.0f;
                }
                EXPECT_GT(expectSameFrame(view, settings, simd), size_t(121 * 87 / 10)) << file;
                if (HasFailure()) return;
            }
        }
    }
}

// A camera inside closed meshes with its central row and column of rays in the planes of mesh
// edges and its central ray through a vertex (and parallel to two axes): no ray may escape, and
// each must find the reference's triangle.
TEST(CpuPacket, NoLeaksThroughSharedEdgesAndVertices) {
    for (const int n : {4, 6}) {
        const Scene cube = tessellatedCube(n);
        const Bvh bvh = build(cube);
        const CpuSceneView view = makeCpuSceneView(cube, bvh);
        for (const CpuSimd simd : widths()) {
            for (const auto& [at, up] : {std::pair{glm::vec3(0.0f, 0.0f, 1.0f), glm::vec3(0.0f, 1.0f, 0.0f)},
                                         {glm::vec3(1.0f, 0.0f, 0.0f), glm::vec3(0.0f, 0.0f, 1.0f)},
                                         {glm::vec3(0.3f, 0.4f, -0.5f), glm::vec3(0.0f, 1.0f, 0.0f)}}) {
                RenderSettings settings;
                settings.width = 65;  // odd: the central column and row have u = 0 and v = 0
                settings.height = 33;
                settings.packet = {8, 8};
                settings.camera.eye = glm::vec3(0.0f);
                settings.camera.at = at;
                settings.camera.up = up;
                settings.camera.fovYDegrees = 120.0f;
                EXPECT_EQ(expectSameFrame(view, settings, simd), size_t(65 * 33))
                    << "rays escaped the closed cube, n = " << n << " " << toString(simd);
                if (HasFailure()) return;
            }
        }
    }
}

// The nested scene's tree is a spine as deep as it has triangles: the stack comes from the tree.
TEST(CpuPacket, DeepTree) {
    const Scene deep = makeDeepScene(kDeepSceneMaxTriangles);
    const Bvh bvh = build(deep, 1);
    const CpuSceneView view = makeCpuSceneView(deep, bvh);
    EXPECT_GE(view.stackEntries, 20u);
    for (const CpuSimd simd : widths()) {
        RenderSettings settings;
        settings.width = 97;
        settings.height = 61;
        settings.packet = {16, 16};
        settings.camera = frameScene(deep.bounds());
        EXPECT_GT(expectSameFrame(view, settings, simd), 0u);
    }
}

// Coordinates far from the origin: the scene and the camera moved by 1e5..3e5.
TEST(CpuPacket, FarFromTheOrigin) {
    const glm::vec3 offset(1.0e5f, -2.0e5f, 3.0e5f);
    const Scene flake = translated(makeSphereFlake(4000), offset);
    const Bvh bvh = build(flake);
    const CpuSceneView view = makeCpuSceneView(flake, bvh);
    for (const CpuSimd simd : widths()) {
        RenderSettings settings;
        settings.width = 80;
        settings.height = 75;
        settings.packet = {8, 8};
        settings.camera = frameScene(flake.bounds());
        EXPECT_GT(expectSameFrame(view, settings, simd), 0u);
    }
}

// The heat views draw the packet tracer's own counters; the shading and heat views shade the same
// hits, so only the counters may differ from the reference's.
TEST(CpuPacket, HeatViewsAndTimings) {
    const Scene flake = makeSphereFlake(3000);
    const Bvh bvh = build(flake);
    const CpuSceneView view = makeCpuSceneView(flake, bvh);
    RenderSettings settings;
    settings.width = 50;
    settings.height = 40;
    settings.camera = frameScene(flake.bounds());
    for (const CpuSimd simd : widths()) {
        const Frame shaded = renderCpuPackets(view, settings, {.image = true, .counters = true}, simd);
        EXPECT_GT(shaded.timings.primarySeconds, 0.0);
        EXPECT_GT(shaded.timings.shadowSeconds, 0.0);
        EXPECT_GE(shaded.timings.totalSeconds, shaded.timings.primarySeconds + shaded.timings.shadowSeconds);
        settings.view = ViewMode::HeatTraversal;
        const Frame nodes = renderCpuPackets(view, settings, {}, simd);
        settings.view = ViewMode::HeatIntersections;
        const Frame tests = renderCpuPackets(view, settings, {}, simd);
        settings.view = ViewMode::Shaded;
        ASSERT_EQ(nodes.rgba.size(), shaded.rgba.size());
        EXPECT_NE(nodes.rgba, shaded.rgba);
        EXPECT_NE(nodes.rgba, tests.rgba);
        // Each pixel's heat colour is the one of its counters.
        for (size_t i = 0; i < shaded.counters.size(); ++i) {
            const RayCounters& c = shaded.counters[i];
            const glm::vec3 colour = gpu::heatColorForCount(c.primaryNodes + c.shadowNodes, gpu::kHeatFullScaleNodes);
            ASSERT_EQ(nodes.rgba[i], gpu::packRgba8(glm::vec4(colour, 1.0f))) << i;
        }
    }
    settings.packet = {0, 4};
    EXPECT_THROW(renderCpuPackets(view, settings), Error);
}

// The CLI: `render --device cpu --kernel packet` writes the reference's hits file byte for byte,
// reports the packet tracer as its device, and flags that do not apply are errors.
TEST(CpuPacket, RenderCommand) {
    using raypack::test::quoted;
    using raypack::test::runCli;
    const raypack::test::ScratchDir scratch("raypack-test-cpu-packet");
    const std::string scene = "gen:sphereflake:3k --width 71 --height 45";
    const std::filesystem::path single = scratch.path() / "single.hits";
    const std::filesystem::path packets = scratch.path() / "packets.hits";
    const auto r1 = runCli("render " + scene + " --hits " + quoted(single));
    ASSERT_EQ(r1.exitCode, 0) << r1.output;
    EXPECT_NE(r1.output.find("CPU reference"), std::string::npos) << r1.output;
    const auto r2 = runCli("render " + scene + " --kernel packet --packet 5x3 --hits " + quoted(packets));
    ASSERT_EQ(r2.exitCode, 0) << r2.output;
    EXPECT_NE(r2.output.find("CPU packets 5x3"), std::string::npos) << r2.output;
    const auto read = [](const std::filesystem::path& path) {
        std::ifstream in(path, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(in), {});
    };
    EXPECT_FALSE(read(single).empty());
    EXPECT_EQ(read(single), read(packets));
    // Without --packet the CPU packet tracer takes its own default shape.
    const auto r3 = runCli("render " + scene + " --kernel packet");
    ASSERT_EQ(r3.exitCode, 0) << r3.output;
    EXPECT_NE(r3.output.find("CPU packets " + std::to_string(kDefaultCpuPacket.width) + "x" +
                             std::to_string(kDefaultCpuPacket.height)),
              std::string::npos)
        << r3.output;
    for (const auto& [args, mentions] : {std::pair<std::string, std::string>{"--packet 8x8", "--packet"},
                                         {"--kernel single --packet 8x8", "--packet"},
                                         {"--gpu 0", "--gpu"},
                                         {"--validation", "--validation"}}) {
        const auto r = runCli("render " + scene + " " + args);
        EXPECT_EQ(r.exitCode, 2) << args << ":\n" << r.output;
        EXPECT_NE(r.output.find(mentions), std::string::npos) << args << ":\n" << r.output;
    }
    ::setenv("RAYPACK_CPU_SIMD", "sse4", 1);
    const auto bad = runCli("render " + scene + " --kernel packet");
    ::unsetenv("RAYPACK_CPU_SIMD");
    EXPECT_EQ(bad.exitCode, 2) << bad.output;
    EXPECT_NE(bad.output.find("RAYPACK_CPU_SIMD"), std::string::npos) << bad.output;
}

}  // namespace
