// The CPU reference tracer against brute force (every triangle tested), on generated and real
// scenes; no leaks through shared edges and vertices through the BVH; shadows on a scene whose
// shadow can be computed by hand; and the frame renderCpu hands back.
#include "renderer/bvh.h"
#include "renderer/camera.h"
#include "renderer/cpu_box_pair.h"
#include "renderer/cpu_tracer.h"
#include "renderer/error.h"
#include "scenes/generators.h"
#include "scenes/load.h"
#include "shaders/camera.h"
#include "shaders/intersect.h"
#include "shaders/shading.h"

#include "random_geometry.h"

#include <gtest/gtest.h>

#include <bit>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

namespace {

using namespace raypack;
using raypack::test::bruteClosest;
using raypack::test::BruteHit;
using raypack::test::bruteOccluded;
using raypack::test::keptT;
using raypack::test::randomDirection;
using raypack::test::randomTriangleSoup;
using raypack::test::tessellatedCube;

Bvh build(const Scene& scene, uint32_t leafSize = 2) {
    std::vector<Aabb> bounds(scene.triangleCount());
    for (uint32_t i = 0; i < bounds.size(); ++i) bounds[i] = scene.triangleBounds(i);
    BvhBuildOptions options;
    options.leafSize = leafSize;
    return buildBvh(bounds, options);
}

// Coplanar, overlapping and duplicated triangles in z = 0 and z = 1: closest-hit ties everywhere.
Scene coplanarTies() {
    Scene scene;
    scene.source = "coplanar ties";
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> coord(-4.0f, 4.0f);
    for (uint32_t i = 0; i < 300; ++i) {
        const float z = (i % 3 == 0) ? 1.0f : 0.0f;
        const uint32_t base = uint32_t(scene.positions.size());
        for (int k = 0; k < 3; ++k) scene.positions.push_back(glm::vec3(coord(rng), coord(rng), z));
        scene.triangles.push_back(glm::uvec3(base, base + 1, base + 2));
        if (i % 10 == 0) scene.triangles.push_back(glm::uvec3(base + 2, base, base + 1));  // twin
    }
    return scene;
}

// Random rays (random origins and directions, rays aimed at vertices and edge points, and
// axis-parallel rays) through the tracer and through brute force: same triangle, same t.
void expectMatchesBruteForce(const Scene& scene, const Bvh& bvh, int rays, uint32_t seed) {
    const CpuSceneView view = makeCpuSceneView(scene, bvh);
    const Aabb bounds = scene.bounds();
    const glm::vec3 margin = 0.2f * bounds.extent() + glm::vec3(1e-3f);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::uniform_int_distribution<uint32_t> anyTriangle(0, uint32_t(scene.triangleCount() - 1));
    int hits = 0, ties = 0;
    for (int i = 0; i < rays; ++i) {
        const glm::vec3 origin =
            bounds.lo - margin + glm::vec3(unit(rng), unit(rng), unit(rng)) * (bounds.extent() + 2.0f * margin);
        glm::vec3 dir;
        const uint32_t tri = anyTriangle(rng);
        switch (i % 4) {
        case 0: dir = randomDirection(rng); break;
        case 1: dir = scene.vertex(tri, i % 3) - origin; break;  // exactly at a vertex
        case 2: {                                                // at an edge point
            const glm::vec3 a = scene.vertex(tri, 0), b = scene.vertex(tri, 1);
            dir = a + unit(rng) * (b - a) - origin;
            break;
        }
        default: {  // axis-parallel, towards the triangle's first vertex on that axis
            const int axis = i % 3;
            dir = glm::vec3(0.0f);
            dir[axis] = scene.vertex(tri, 0)[axis] > origin[axis] ? 1.0f : -1.0f;
        }
        }
        if (dir == glm::vec3(0.0f)) continue;
        const BruteHit expected = bruteClosest(scene, origin, dir);
        RayCounters counters{};
        const HitRecord record = traceClosest(scene, bvh, origin, dir, kRayTmaxInfinite, &counters);
        const ClosestHit viewHit = traceClosestHit(view, origin, dir);
        ASSERT_EQ(viewHit.prim, record.prim) << scene.source << " ray " << i;
        ASSERT_EQ(record.prim == gpu::kNoHit, expected.prim == gpu::kNoHit) << scene.source << " ray " << i;
        if (record.prim != expected.prim) {
            // A tie: two triangles meet the ray at the same point (shared edge, coplanar
            // overlap), their t differing by the triangle test's rounding. A box is culled only
            // beyond gpu::kBoxTmaxWiden, but a t rounded further down than that can still be
            // skipped; then the traced triangle must really be hit at (almost) the same t.
            const gpu::TraceRay ray = gpu::makeTraceRay(origin, dir);
            float ownT;
            glm::vec2 bary;
            ASSERT_TRUE(gpu::intersectTriangle(ray, scene.vertex(record.prim, 0), scene.vertex(record.prim, 1),
                                               scene.vertex(record.prim, 2), kRayTmaxInfinite, ownT, bary));
            EXPECT_EQ(keptT(scene, record.prim, origin, dir, ownT), record.t);
            // The test's t error grows with the triangles' distance from the origin relative to
            // t (cancellation in Woop's t = T / det): allow 1e-5 of the larger of the two.
            float farthest = 0.0f;
            for (uint32_t prim : {record.prim, expected.prim})
                for (int c = 0; c < 3; ++c) farthest = std::max(farthest, glm::length(scene.vertex(prim, c) - origin));
            const float scale = std::max(expected.t, farthest / glm::length(dir));
            EXPECT_NEAR(record.t, expected.t, 1e-5f * scale) << scene.source << " ray " << i;
            ++ties;
        }
        if (expected.prim != gpu::kNoHit) {
            ++hits;
            // The same triangle through the same test: the same t, not merely within 1e-5.
            if (record.prim == expected.prim) {
                EXPECT_EQ(record.t, expected.t);
            }
            EXPECT_EQ(viewHit.t, record.t);
            EXPECT_GE(counters.primaryNodes, 1u);
            EXPECT_GE(counters.primaryTests, 1u);
        } else {
            EXPECT_TRUE(std::isinf(record.t));
        }
        EXPECT_EQ(record.shadow, gpu::kShadowNone);
        // Occlusion of the segment up to half the hit distance (or 10 units on a miss), skipping
        // some triangle: the same as brute force.
        const float tmax = expected.prim != gpu::kNoHit ? 0.5f * expected.t : 10.0f;
        const uint32_t skip = tri;
        EXPECT_EQ(traceOccluded(scene, bvh, origin, dir, tmax, skip), bruteOccluded(scene, origin, dir, tmax, skip))
            << scene.source << " ray " << i;
        EXPECT_EQ(traceOccluded(view, origin, dir, tmax, skip), bruteOccluded(scene, origin, dir, tmax, skip));
    }
    EXPECT_GT(hits, rays / 10) << scene.source;
    EXPECT_LE(ties, rays / 100) << scene.source << ": ties should be rare";
}

TEST(ClosestHit, MatchesBruteForceOnGeneratedScenes) {
    const Scene soup = randomTriangleSoup(3000, 1);
    expectMatchesBruteForce(soup, build(soup), 2000, 11);
    expectMatchesBruteForce(soup, build(soup, 8), 500, 12);
    const Scene ties = coplanarTies();
    expectMatchesBruteForce(ties, build(ties), 2000, 13);
    const Scene cube = tessellatedCube(6);
    expectMatchesBruteForce(cube, build(cube), 2000, 14);
    const Scene flake = makeSphereFlake(5000);
    expectMatchesBruteForce(flake, build(flake), 1000, 15);
    const Scene deep = makeDeepScene(kDeepSceneMaxTriangles);
    const Bvh deepBvh = build(deep);
    EXPECT_GE(makeCpuSceneView(deep, deepBvh).stackEntries, 20u);
    expectMatchesBruteForce(deep, deepBvh, 1000, 16);
}

TEST(ClosestHit, MatchesBruteForceOnSharedScenes) {
    const std::filesystem::path root = RAYPACK_SHARED_SCENES;
    for (const char* file : {"stanford/bun_zipper.ply", "sibenik/sibenik_geom_75284.ply"}) {
        const Scene scene = loadScene(root / file);
        expectMatchesBruteForce(scene, build(scene), 200, 17);
    }
}

TEST(ClosestHit, EmptyAndSingleTriangleScenes) {
    Scene empty;
    const Bvh emptyBvh = build(empty);
    EXPECT_EQ(traceClosest(empty, emptyBvh, glm::vec3(0.0f), glm::vec3(0, 0, 1)).prim, gpu::kNoHit);
    EXPECT_FALSE(traceOccluded(empty, emptyBvh, glm::vec3(0.0f), glm::vec3(0, 0, 1), 1.0f));
    Scene one;
    one.positions = {glm::vec3(-1, -1, 5), glm::vec3(1, -1, 5), glm::vec3(0, 1, 5)};
    one.triangles = {glm::uvec3(0, 1, 2)};
    const Bvh oneBvh = build(one);
    const HitRecord hit = traceClosest(one, oneBvh, glm::vec3(0.0f), glm::vec3(0, 0, 1));
    EXPECT_EQ(hit.prim, 0u);
    EXPECT_FLOAT_EQ(hit.t, 5.0f);
    EXPECT_TRUE(traceOccluded(one, oneBvh, glm::vec3(0.0f), glm::vec3(0, 0, 1), 6.0f));
    EXPECT_FALSE(traceOccluded(one, oneBvh, glm::vec3(0.0f), glm::vec3(0, 0, 1), 6.0f, 0u));
    EXPECT_FALSE(traceOccluded(one, oneBvh, glm::vec3(0.0f), glm::vec3(0, 0, 1), 4.0f));
}

// Closed UV sphere around `centre`, poles single vertices, shared vertices stored once.
Scene uvSphere(glm::vec3 centre, float radius, int rings, int segments) {
    Scene scene;
    scene.source = "uv sphere";
    auto index = [&](int ring, int segment) -> uint32_t {
        if (ring == 0) return 0;
        if (ring == rings) return 1;
        return 2 + uint32_t((ring - 1) * segments + segment % segments);
    };
    scene.positions.push_back(centre + glm::vec3(0.0f, radius, 0.0f));
    scene.positions.push_back(centre - glm::vec3(0.0f, radius, 0.0f));
    for (int r = 1; r < rings; ++r) {
        for (int s = 0; s < segments; ++s) {
            const double theta = M_PI * r / rings, phi = 2.0 * M_PI * s / segments;
            scene.positions.push_back(centre + radius * glm::vec3(float(std::sin(theta) * std::cos(phi)),
                                                                  float(std::cos(theta)),
                                                                  float(std::sin(theta) * std::sin(phi))));
        }
    }
    for (int r = 0; r < rings; ++r) {
        for (int s = 0; s < segments; ++s) {
            if (r != 0) scene.triangles.push_back(glm::uvec3(index(r, s), index(r + 1, s), index(r, s + 1)));
            if (r != rings - 1)
                scene.triangles.push_back(glm::uvec3(index(r, s + 1), index(r + 1, s), index(r + 1, s + 1)));
        }
    }
    return scene;
}

// Rays from inside closed meshes through every vertex and edge, through the BVH: none may escape.
TEST(ClosestHit, NoLeaksThroughSharedEdgesAndVertices) {
    const glm::vec3 centre(3.0f, -2.0f, 7.5f);
    const std::vector<std::pair<Scene, std::vector<glm::vec3>>> cases = {
        {tessellatedCube(5), {glm::vec3(0.0f), glm::vec3(0.3f, -0.45f, 0.1f), glm::vec3(0.9f, 0.9f, -0.9f)}},
        {uvSphere(centre, 2.0f, 24, 32), {centre, centre + glm::vec3(0.5f, 0.7f, -0.2f)}},
    };
    for (const auto& [scene, origins] : cases) {
        const Bvh bvh = build(scene);
        size_t rays = 0;
        for (const glm::vec3& origin : origins) {
            for (uint32_t tri = 0; tri < scene.triangleCount(); ++tri) {
                for (int e = 0; e < 3; ++e) {
                    const glm::vec3 a = scene.vertex(tri, e), b = scene.vertex(tri, (e + 1) % 3);
                    for (float f : {0.0f, 0.5f, 0.3f}) {
                        const glm::vec3 dir = a + f * (b - a) - origin;
                        const HitRecord hit = traceClosest(scene, bvh, origin, dir);
                        ASSERT_NE(hit.prim, gpu::kNoHit)
                            << scene.source << ": a ray through triangle " << tri << " edge " << e << " escaped";
                        ++rays;
                    }
                }
            }
        }
        EXPECT_GT(rays, 3000u);
    }
}

// A ground square y = 0, x, z in [-4, 4], and an occluding square y = 1, x, z in [-0.5, 0.5].
Scene plateOverGround() {
    Scene scene;
    scene.source = "plate over ground";
    scene.positions = {glm::vec3(-4, 0, -4),     glm::vec3(4, 0, -4),        glm::vec3(4, 0, 4),
                       glm::vec3(-4, 0, 4),      glm::vec3(-0.5f, 1, -0.5f), glm::vec3(0.5f, 1, -0.5f),
                       glm::vec3(0.5f, 1, 0.5f), glm::vec3(-0.5f, 1, 0.5f)};
    scene.triangles = {glm::uvec3(0, 1, 2), glm::uvec3(0, 2, 3), glm::uvec3(4, 5, 6), glm::uvec3(4, 6, 7)};
    return scene;
}

TEST(Shadows, MatchTheShadowComputedByHand) {
    const Scene scene = plateOverGround();
    const Bvh bvh = build(scene);
    RenderSettings settings;
    settings.width = 160;
    settings.height = 120;
    settings.camera.eye = glm::vec3(0.0f, 2.5f, 6.0f);
    settings.camera.at = glm::vec3(0.0f, 0.0f, 0.0f);
    settings.camera.up = glm::vec3(0.0f, 1.0f, 0.0f);
    settings.camera.fovYDegrees = 60.0f;
    settings.lightHeight = 1.5f;  // scene height 1: the light is 1.5 above the eye
    const Frame frame = renderCpu(scene, bvh, settings, {.image = true, .hits = true});
    const glm::vec3 light = frame.light;
    EXPECT_NEAR(light.y, 4.0f, 1e-6f);
    EXPECT_NEAR(light.z, 6.0f, 1e-6f);

    int lit = 0, shadowed = 0, plateLit = 0;
    for (const HitRecord& r : frame.hits) {
        if (r.prim == gpu::kNoHit) {
            EXPECT_EQ(r.shadow, gpu::kShadowNone);
            continue;
        }
        const glm::vec3 p = glm::vec3(r.orgX, r.orgY, r.orgZ) + r.t * glm::vec3(r.dirX, r.dirY, r.dirZ);
        if (r.prim >= 2) {  // the plate's top faces the light: lit, no acne
            EXPECT_EQ(r.shadow, gpu::kShadowLit) << "acne on the plate at " << p.x << "," << p.z;
            ++plateLit;
            continue;
        }
        // Where the segment from the light to p crosses y = 1.
        const float s = (light.y - 1.0f) / (light.y - p.y);
        const glm::vec3 q = light + s * (p - light);
        const float inside = std::max(std::abs(q.x), std::abs(q.z)) - 0.5f;
        if (std::abs(inside) < 2e-3f) continue;  // on the shadow's border: rounding decides
        const uint32_t expected = inside < 0.0f ? gpu::kShadowOccluded : gpu::kShadowLit;
        EXPECT_EQ(r.shadow, expected) << "ground point " << p.x << "," << p.z;
        (expected == gpu::kShadowLit ? lit : shadowed) += 1;
    }
    EXPECT_GT(lit, 1000);
    EXPECT_GT(shadowed, 50);
    EXPECT_GT(plateLit, 50);

    // The single-ray shadow entry point agrees, and ignores occluders at or beyond the point.
    const CpuSceneView view = makeCpuSceneView(scene, bvh);
    EXPECT_TRUE(traceShadowOccluded(view, glm::vec3(0, 3, 0), glm::vec3(0.1f, 0, 0.2f), 0u));
    EXPECT_FALSE(traceShadowOccluded(view, glm::vec3(0, 3, 0), glm::vec3(2.0f, 0, 0.2f), 0u));
    // A point on the plate seen from below the ground: the ground lies beyond it, not between.
    EXPECT_FALSE(traceShadowOccluded(view, glm::vec3(0, 3, 0), glm::vec3(0.1f, 1, 0.1f), 2u));
    EXPECT_FALSE(traceShadowOccluded(view, glm::vec3(0, 3, 0), glm::vec3(0, 3, 0), 2u));
}

// Inside a closed, tessellated room with the light inside: every visible point is lit. Hit points
// next to the room's concave edges and corners are where acne would show.
TEST(Shadows, NoAcneInsideAClosedRoom) {
    const Scene room = tessellatedCube(8);
    const Bvh bvh = build(room);
    RenderSettings settings;
    settings.width = 96;
    settings.height = 96;
    settings.camera.eye = glm::vec3(0.2f, -0.4f, 0.7f);
    settings.camera.at = glm::vec3(-1.0f, -1.0f, -1.0f);  // into a corner
    settings.camera.fovYDegrees = 100.0f;
    settings.lightHeight = 0.3f;  // 0.6 above the eye, still inside
    const Frame frame = renderCpu(room, bvh, settings, {.image = false, .hits = true});
    for (const HitRecord& r : frame.hits) {
        ASSERT_NE(r.prim, gpu::kNoHit);  // closed room: every ray hits
        EXPECT_EQ(r.shadow, gpu::kShadowLit);
    }
}

TEST(Render, FrameContents) {
    const Scene scene = makeSphereFlake(4000);
    const Bvh bvh = build(scene);
    RenderSettings settings;
    settings.width = 64;
    settings.height = 48;
    settings.camera = frameScene(scene.bounds());
    const Frame frame = renderCpu(scene, bvh, settings, {.image = true, .hits = true, .counters = true});
    ASSERT_EQ(frame.rgba.size(), 64u * 48u);
    ASSERT_EQ(frame.hits.size(), 64u * 48u);
    ASSERT_EQ(frame.counters.size(), 64u * 48u);
    EXPECT_EQ(frame.light, lightPosition(settings.camera, scene.bounds(), settings.lightHeight));
    const gpu::GpuCamera camera = makeGpuCamera(settings.camera, 64, 48);
    size_t hits = 0;
    const uint32_t background = gpu::packRgba8(glm::vec4(settings.background, 1.0f));
    for (uint32_t y = 0; y < 48; ++y) {
        for (uint32_t x = 0; x < 64; ++x) {
            const size_t i = size_t(y) * 64 + x;
            const HitRecord& r = frame.hits[i];
            const glm::vec3 dir = gpu::primaryRayDirection(camera, x, y);
            EXPECT_EQ(glm::vec3(r.dirX, r.dirY, r.dirZ), dir);
            EXPECT_EQ(glm::vec3(r.orgX, r.orgY, r.orgZ), settings.camera.eye);
            EXPECT_EQ(frame.rgba[i] >> 24, 255u);
            // Each pixel's hit is what a single ray finds.
            const HitRecord single = traceClosest(scene, bvh, settings.camera.eye, dir);
            EXPECT_EQ(single.prim, r.prim);
            if (r.prim == gpu::kNoHit) {
                EXPECT_EQ(frame.rgba[i], background);
                EXPECT_EQ(frame.counters[i].shadowNodes, 0u);
            } else {
                ++hits;
                EXPECT_NE(r.shadow, gpu::kShadowNone);
            }
        }
    }
    EXPECT_GT(hits, 200u);
    const CounterSummary summary = summarizeCounters(frame);
    EXPECT_EQ(summary.primaryRays, 64u * 48u);
    EXPECT_EQ(summary.shadowRays, hits);
    EXPECT_GT(summary.primaryNodes, 1.0);
    EXPECT_GT(summary.shadowNodes, 1.0);
    EXPECT_GE(frame.timings.totalSeconds, frame.timings.primarySeconds);

    // Deterministic, whatever the threads did.
    const Frame again = renderCpu(scene, bvh, settings, {.image = true});
    EXPECT_EQ(again.rgba, frame.rgba);
    // Shadows off: no shadow rays, nothing darker than with shadows.
    RenderSettings noShadows = settings;
    noShadows.shadows = false;
    const Frame unshadowed = renderCpu(scene, bvh, noShadows, {.image = true, .hits = true});
    for (size_t i = 0; i < unshadowed.hits.size(); ++i) {
        EXPECT_EQ(unshadowed.hits[i].shadow, gpu::kShadowNone);
        for (int c = 0; c < 3; ++c)
            EXPECT_GE((unshadowed.rgba[i] >> (8 * c)) & 255u, (frame.rgba[i] >> (8 * c)) & 255u);
    }
    // Heat views colour by the counters.
    RenderSettings heat = settings;
    heat.view = ViewMode::HeatTraversal;
    const Frame heatFrame = renderCpu(scene, bvh, heat, {.image = true, .counters = true});
    for (size_t i = 0; i < heatFrame.rgba.size(); ++i) {
        const RayCounters& c = heatFrame.counters[i];
        EXPECT_EQ(heatFrame.rgba[i],
                  gpu::packRgba8(glm::vec4(
                      gpu::heatColorForCount(c.primaryNodes + c.shadowNodes, gpu::kHeatFullScaleNodes), 1.0f)));
    }
}

// Every pixel traced exactly once whatever the image size (tiles cut at the edges, pixels visited
// in Z order within a tile): hits, shadows and counters as single rays give them.
TEST(Render, EveryPixelOnceAtOddSizes) {
    const Scene scene = makeSphereFlake(3000);
    const Bvh bvh = build(scene, 1);
    const CpuSceneView view = makeCpuSceneView(scene, bvh);
    for (const auto& [width, height] : {std::pair{37u, 29u}, {1u, 1u}, {17u, 3u}, {5u, 40u}}) {
        RenderSettings settings;
        settings.width = width;
        settings.height = height;
        settings.camera = frameScene(scene.bounds());
        const Frame frame = renderCpu(view, settings, {.image = false, .hits = true, .counters = true});
        ASSERT_EQ(frame.hits.size(), size_t(width) * height);
        const gpu::GpuCamera camera = makeGpuCamera(settings.camera, width, height);
        const glm::vec3 eye = gpu::cameraEye(camera);
        int hits = 0;
        for (uint32_t y = 0; y < height; ++y) {
            for (uint32_t x = 0; x < width; ++x) {
                const size_t i = size_t(y) * width + x;
                const glm::vec3 dir = gpu::primaryRayDirection(camera, x, y);
                TraversalCounts counts;
                const ClosestHit single = traceClosestHit(view, eye, dir, kRayTmaxInfinite, &counts);
                ASSERT_EQ(frame.hits[i].prim, single.prim) << width << "x" << height << " pixel " << x << "," << y;
                ASSERT_EQ(std::bit_cast<uint32_t>(frame.hits[i].t), std::bit_cast<uint32_t>(single.t));
                ASSERT_EQ(frame.counters[i].primaryNodes, counts.nodes);
                ASSERT_EQ(frame.counters[i].primaryTests, counts.tests);
                if (!single.hit()) {
                    ASSERT_EQ(frame.hits[i].shadow, gpu::kShadowNone);
                    continue;
                }
                ++hits;
                TraversalCounts shadowCounts;
                const bool occluded = traceShadowOccluded(view, frame.light, gpu::hitPosition(eye, dir, single.t),
                                                          single.prim, &shadowCounts);
                ASSERT_EQ(frame.hits[i].shadow, occluded ? gpu::kShadowOccluded : gpu::kShadowLit);
                ASSERT_EQ(frame.counters[i].shadowNodes, shadowCounts.nodes);
                ASSERT_EQ(frame.counters[i].shadowTests, shadowCounts.tests);
            }
        }
        if (width * height > 100) {
            EXPECT_GT(hits, 0) << width << "x" << height;
        }
    }
}

TEST(Render, BadCameraThrows) {
    const Scene scene = plateOverGround();
    const Bvh bvh = build(scene);
    RenderSettings settings;
    settings.camera.eye = settings.camera.at = glm::vec3(1.0f);
    EXPECT_THROW(renderCpu(scene, bvh, settings), Error);
    settings = RenderSettings{};
    settings.width = 0;
    EXPECT_THROW(renderCpu(scene, bvh, settings), Error);
    settings = RenderSettings{};
    settings.camera.up = glm::vec3(0.0f, 0.0f, -1.0f);  // parallel to the default view direction
    EXPECT_THROW(renderCpu(scene, bvh, settings), Error);
}

TEST(Camera, FrameSceneAndLight) {
    Aabb box;
    box.grow(glm::vec3(-1.0f, 0.0f, -2.0f));
    box.grow(glm::vec3(3.0f, 2.0f, 2.0f));
    const Camera camera = frameScene(box);
    EXPECT_EQ(camera.at, box.center());
    EXPECT_EQ(camera.up, glm::vec3(0.0f, 1.0f, 0.0f));
    EXPECT_EQ(camera.fovYDegrees, 60.0f);
    const float radius = 0.5f * glm::length(box.extent());
    const glm::vec3 offset = camera.eye - camera.at;
    EXPECT_NEAR(glm::length(offset), 1.1f * radius / std::sin(glm::radians(30.0f)), 1e-4f);
    const glm::vec3 expectedDir = glm::normalize(glm::vec3(0.5f, 0.4f, 1.0f));
    EXPECT_NEAR(glm::dot(glm::normalize(offset), expectedDir), 1.0f, 1e-6f);
    EXPECT_EQ(frameScene(Aabb{}).at, glm::vec3(0.0f));
    // The light: up by lightHeight times the box's extent along up (here y: 2).
    const glm::vec3 light = lightPosition(camera, box, 0.5f);
    EXPECT_NEAR(glm::distance(light, camera.eye + glm::vec3(0.0f, 1.0f, 0.0f)), 0.0f, 1e-5f);
    // The GPU camera: orthonormal basis and the documented scales.
    const gpu::GpuCamera gpuCamera = makeGpuCamera(camera, 200, 100);
    const float tan30 = std::tan(glm::radians(30.0f));
    EXPECT_NEAR(gpuCamera.eye.w, 2.0f * tan30 / 100.0f, 1e-8f);  // the step of u, and of v
    EXPECT_EQ(gpuCamera.forward.w, gpuCamera.eye.w);
    EXPECT_NEAR(gpuCamera.right.w, (1.0f / 200.0f - 1.0f) * 2.0f * tan30, 1e-6f);  // u of column 0
    EXPECT_NEAR(gpuCamera.up.w, (1.0f - 1.0f / 100.0f) * tan30, 1e-6f);            // v of row 0
    // The last column's u and row's v are the first's, negated (to the rounding of the sum).
    EXPECT_NEAR(199.0f * gpuCamera.eye.w + gpuCamera.right.w, -gpuCamera.right.w, 1e-6f);
    EXPECT_NEAR(gpuCamera.up.w - 99.0f * gpuCamera.forward.w, -gpuCamera.up.w, 1e-6f);
    const glm::vec3 f(gpuCamera.forward), r(gpuCamera.right), u(gpuCamera.up);
    EXPECT_NEAR(glm::dot(f, r), 0.0f, 1e-6f);
    EXPECT_NEAR(glm::dot(f, u), 0.0f, 1e-6f);
    EXPECT_GT(u.y, 0.0f);
    // The centre of the image looks along forward (pixel centres straddle it).
    const glm::vec3 centre = gpu::primaryRayDirection(gpuCamera, 100, 50);
    EXPECT_GT(glm::dot(centre, f), 0.9999f);
    EXPECT_THROW(makeGpuCamera(camera, 0, 10), Error);
    Camera badFov = camera;
    badFov.fovYDegrees = 180.0f;
    EXPECT_THROW(makeGpuCamera(badFov, 10, 10), Error);
}

// ---- The fast paths of the reference against the plain code they replace (cpuopt).

// intersectChildBoxes must give, bit for bit, what gpu::intersectBox gives for each child: the
// same hit decision and the same entry distance (the traversal orders and culls with it).
void expectChildBoxesMatch(const gpu::TraceRay& ray, const BvhNode* children, float tmax, const char* what) {
    const ChildBoxHits pair = intersectChildBoxes(makeChildBoxRay(ray, tmax), children);
    for (int child = 0; child < 2; ++child) {
        float tEntry = -1.0f;
        const bool hit = gpu::intersectBox(ray, children[child].lo, children[child].hi, tmax, tEntry);
        const float pairEntry = child == 0 ? pair.tLeft : pair.tRight;
        ASSERT_EQ(((pair.mask >> child) & 1u) != 0, hit) << what << ": child " << child << " dir " << ray.dir.x << ","
                                                         << ray.dir.y << "," << ray.dir.z << " tmax " << tmax;
        ASSERT_EQ(std::bit_cast<uint32_t>(pairEntry), std::bit_cast<uint32_t>(tEntry))
            << what << ": child " << child << " entry " << pairEntry << " vs " << tEntry;
    }
}

TEST(ChildBoxes, BitIdenticalToIntersectBoxOnAdversarialBoxes) {
    std::mt19937 rng(21);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_int_distribution<uint32_t> word;
    std::uniform_int_distribution<int> pick(0, 9);
    // Coordinates of every scale, with exact zeros, signed zeros and values equal to the origin.
    const float scales[] = {1.0f, 1e-3f, 1e3f, 1e-30f, 1e30f, 3.0e38f};
    const auto coordinate = [&](float origin) {
        switch (pick(rng)) {
        case 0: return 0.0f;
        case 1: return -0.0f;
        case 2: return origin;  // a face through the ray origin
        default: return unit(rng) * scales[pick(rng) % 6];
        }
    };
    const auto directionComponent = [&]() {
        switch (pick(rng)) {
        case 0: return 0.0f;                // parallel
        case 1: return -0.0f;               // parallel, negative zero
        case 2: return 1e-39f;              // denormal: parallel by kParallelEpsilon
        case 3: return unit(rng) * 1e-30f;  // 1/d overflows the box distances to inf
        default: return unit(rng);
        }
    };
    int tested = 0;
    for (int i = 0; i < 200000; ++i) {
        const glm::vec3 origin(coordinate(0.0f), coordinate(0.0f), coordinate(0.0f));
        glm::vec3 dir(directionComponent(), directionComponent(), directionComponent());
        if (dir == glm::vec3(0.0f)) dir.x = 1.0f;
        const gpu::TraceRay ray = gpu::makeTraceRay(origin, dir);
        BvhNode children[2];
        for (BvhNode& node : children) {
            if (pick(rng) == 0) {  // the empty box of an empty scene's root
                node.lo = glm::vec3(FLT_MAX);
                node.hi = glm::vec3(-FLT_MAX);
            } else {
                for (int axis = 0; axis < 3; ++axis) {
                    const float a = coordinate(origin[axis]);
                    const float b = pick(rng) < 2 ? a : coordinate(origin[axis]);  // flat box
                    node.lo[axis] = std::min(a, b);
                    node.hi[axis] = std::max(a, b);
                }
            }
            // Index and count words that read as NaN, infinity or denormals must not matter.
            node.index = word(rng);
            node.count = word(rng);
        }
        const float tmaxes[] = {kRayTmaxInfinite, std::numeric_limits<float>::infinity(), 0.0f,
                                std::abs(unit(rng)) * scales[pick(rng) % 6]};
        for (float tmax : tmaxes) expectChildBoxesMatch(ray, children, tmax, "adversarial");
        if (HasFatalFailure()) return;
        ++tested;
    }
    EXPECT_EQ(tested, 200000);
}

TEST(ChildBoxes, BitIdenticalToIntersectBoxOnATree) {
    const Scene scene = loadScene(std::filesystem::path(RAYPACK_SHARED_SCENES) / "sibenik/sibenik_geom_75284.ply");
    const Bvh bvh = build(scene, 1);
    const Aabb bounds = scene.bounds();
    std::mt19937 rng(22);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (int i = 0; i < 48; ++i) {
        const glm::vec3 origin = bounds.lo + glm::vec3(unit(rng), unit(rng), unit(rng)) * bounds.extent();
        glm::vec3 dir = randomDirection(rng);
        if (i % 8 == 0) dir = glm::vec3(0.0f, i % 16 == 0 ? 1.0f : -1.0f, 0.0f);  // parallel
        const gpu::TraceRay ray = gpu::makeTraceRay(origin, dir);
        const float tmax = i % 2 ? kRayTmaxInfinite : 0.1f * glm::length(bounds.extent());
        for (const BvhNode& node : bvh.nodes) {
            if (node.isLeaf()) continue;
            expectChildBoxesMatch(ray, &bvh.nodes[node.index], tmax, "Sibenik");
            if (HasFatalFailure()) return;
        }
    }
}

// The view traces a copy of the canonical nodes, unchanged, with each sibling pair on one
// 64-byte line (the layout the builders produce makes every pair start at an odd index).
TEST(CpuSceneView, NodesAreAVerbatimCopyWithSiblingsOnOneLine) {
    const Scene scene = makeSphereFlake(20000);
    for (BvhBuilder builder : kCpuBvhBuilders) {
        for (uint32_t leafSize : {1u, 4u}) {
            BvhBuildOptions options;
            options.builder = builder;
            options.leafSize = leafSize;
            const Bvh bvh = buildBvh(scene, options);
            const CpuSceneView view = makeCpuSceneView(scene, bvh);
            ASSERT_EQ(std::memcmp(view.nodes(), bvh.nodes.data(), bvh.nodes.size() * sizeof(BvhNode)), 0);
            for (const BvhNode& node : bvh.nodes) {
                if (node.isLeaf()) continue;
                EXPECT_EQ(reinterpret_cast<uintptr_t>(view.nodes() + node.index) % 64, 0u)
                    << toString(builder) << " leaf size " << leafSize;
            }
        }
    }
}

// The traversal as first written, before the pair test and branch changes: gpu::intersectBox per
// child, nearer child first, the other pushed with its entry distance and skipped at pop time
// beyond the widened closest hit. The tracer must visit the same nodes in the same order, so it
// gives the same hit (t and barycentrics to the bit) and the same N_TR and N_IT.
struct PlainTrace {
    ClosestHit hit;
    bool occluded = false;
    TraversalCounts counts;
};

PlainTrace plainTraversal(const Scene& scene, const Bvh& bvh, glm::vec3 origin, glm::vec3 dir, float tmax, bool anyHit,
                          uint32_t skipPrim) {
    const gpu::TraceRay ray = gpu::makeTraceRay(origin, dir);
    PlainTrace out;
    float bestT = tmax;
    float tRoot;
    if (!gpu::intersectBox(ray, bvh.nodes[0].lo, bvh.nodes[0].hi, bestT, tRoot)) return out;
    std::vector<std::pair<uint32_t, float>> stack;
    uint32_t nodeIndex = 0;
    while (true) {
        const BvhNode& node = bvh.nodes[nodeIndex];
        ++out.counts.nodes;
        bool descended = false;
        if (node.isLeaf()) {
            for (uint32_t entry = node.index; entry < node.index + node.count; ++entry) {
                const uint32_t prim = bvh.primIndices[entry];
                if (anyHit && prim == skipPrim) continue;
                ++out.counts.tests;
                float t;
                glm::vec2 bary;
                if (!gpu::intersectTriangle(ray, scene.vertex(prim, 0), scene.vertex(prim, 1), scene.vertex(prim, 2),
                                            bestT, t, bary))
                    continue;
                if (anyHit) {
                    out.occluded = true;
                    return out;
                }
                if (gpu::isCloserHit(t, prim, bestT, out.hit.prim)) {
                    bestT = t;
                    out.hit = {t, prim, bary};
                }
            }
        } else {
            const uint32_t left = node.index, right = node.index + 1;
            float tLeft, tRight;
            const bool hitLeft = gpu::intersectBox(ray, bvh.nodes[left].lo, bvh.nodes[left].hi, bestT, tLeft);
            const bool hitRight = gpu::intersectBox(ray, bvh.nodes[right].lo, bvh.nodes[right].hi, bestT, tRight);
            if (hitLeft && hitRight) {
                if (tRight < tLeft) {
                    stack.push_back({left, tLeft});
                    nodeIndex = right;
                } else {
                    stack.push_back({right, tRight});
                    nodeIndex = left;
                }
                descended = true;
            } else if (hitLeft || hitRight) {
                nodeIndex = hitLeft ? left : right;
                descended = true;
            }
        }
        if (descended) continue;
        while (true) {
            if (stack.empty()) {
                if (out.hit.hit()) out.hit.t = keptT(scene, out.hit.prim, origin, dir, out.hit.t);
                return out;
            }
            const auto [next, tEntry] = stack.back();
            stack.pop_back();
            if (anyHit || tEntry <= bestT * gpu::kBoxTmaxWiden) {
                nodeIndex = next;
                break;
            }
        }
    }
}

void expectSameTraversal(const Scene& scene, const Bvh& bvh, int rays, uint32_t seed) {
    const CpuSceneView view = makeCpuSceneView(scene, bvh);
    const Aabb bounds = scene.bounds();
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::uniform_int_distribution<uint32_t> anyTriangle(0, uint32_t(scene.triangleCount() - 1));
    int hits = 0, occlusions = 0;
    uint64_t nodes = 0;
    for (int i = 0; i < rays; ++i) {
        const glm::vec3 origin =
            bounds.lo - 0.1f * bounds.extent() + glm::vec3(unit(rng), unit(rng), unit(rng)) * 1.2f * bounds.extent();
        const uint32_t tri = anyTriangle(rng);
        glm::vec3 dir = i % 2 ? randomDirection(rng) : scene.vertex(tri, i % 3) - origin;
        if (i % 10 == 0) dir = glm::vec3(0.0f);
        if (i % 10 == 0) dir[i % 3] = 1.0f;  // axis-parallel
        if (dir == glm::vec3(0.0f)) continue;
        TraversalCounts counts;
        const ClosestHit hit = traceClosestHit(view, origin, dir, kRayTmaxInfinite, &counts);
        const PlainTrace plain = plainTraversal(scene, bvh, origin, dir, kRayTmaxInfinite, false, 0);
        ASSERT_EQ(hit.prim, plain.hit.prim) << scene.source << " ray " << i;
        ASSERT_EQ(std::bit_cast<uint32_t>(hit.t), std::bit_cast<uint32_t>(plain.hit.t));
        ASSERT_EQ(std::bit_cast<uint32_t>(hit.bary.x), std::bit_cast<uint32_t>(plain.hit.bary.x));
        ASSERT_EQ(std::bit_cast<uint32_t>(hit.bary.y), std::bit_cast<uint32_t>(plain.hit.bary.y));
        ASSERT_EQ(counts.nodes, plain.counts.nodes) << scene.source << " ray " << i;
        ASSERT_EQ(counts.tests, plain.counts.tests) << scene.source << " ray " << i;
        // An any-hit query that ends just before the closest hit (never occluded) or beyond it
        // (occluded unless the hit triangle is the one skipped), skipping some triangle.
        const float tmax = !hit.hit() ? 1.0f : i % 3 == 0 ? hit.t * 0.999f : hit.t * 2.0f;
        const uint32_t skip = i % 5 == 0 ? hit.prim : tri;
        TraversalCounts occludedCounts;
        const bool occluded = traceOccluded(view, origin, dir, tmax, skip, &occludedCounts);
        const PlainTrace plainOccluded = plainTraversal(scene, bvh, origin, dir, tmax, true, skip);
        ASSERT_EQ(occluded, plainOccluded.occluded) << scene.source << " ray " << i;
        ASSERT_EQ(occludedCounts.nodes, plainOccluded.counts.nodes);
        ASSERT_EQ(occludedCounts.tests, plainOccluded.counts.tests);
        hits += hit.hit() ? 1 : 0;
        occlusions += occluded ? 1 : 0;
        nodes += counts.nodes;
    }
    // Enough hits, occluded segments and depth for the comparison to mean something.
    EXPECT_GT(hits, rays / 4) << scene.source;
    EXPECT_GT(occlusions, rays / 100) << scene.source;
    EXPECT_GT(nodes, uint64_t(rays) * 4) << scene.source;
}

TEST(ClosestHit, SameVisitsAsThePlainTraversal) {
    const Scene soup = randomTriangleSoup(3000, 5);
    expectSameTraversal(soup, build(soup, 1), 3000, 31);
    expectSameTraversal(soup, build(soup, 8), 1000, 32);
    const Scene ties = coplanarTies();
    expectSameTraversal(ties, build(ties, 1), 2000, 33);
    const Scene cube = tessellatedCube(6);
    expectSameTraversal(cube, build(cube, 1), 2000, 34);
    const Scene sibenik = loadScene(std::filesystem::path(RAYPACK_SHARED_SCENES) / "sibenik/sibenik_geom_75284.ply");
    expectSameTraversal(sibenik, build(sibenik, 1), 3000, 35);
}

}  // namespace
