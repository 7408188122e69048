// The shared intersection and shading code (shaders/intersect.h, shaders/shading.h) on its own:
// watertightness on closed meshes, extreme scales, degenerate triangles, the slab test's handling
// of parallel rays, its conservativeness against the triangle test, and the shading helpers.
#include "shaders/frame_types.h"
#include "shaders/intersect.h"
#include "shaders/shading.h"

#include "random_geometry.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <tuple>
#include <vector>

namespace {

using namespace raypack::gpu;

struct Mesh {
    std::vector<vec3> positions;
    std::vector<uvec3> triangles;
};

// Vertex index of p, adding it when new (exact float equality: shared vertices are bit-identical).
uint32_t vertexIndex(Mesh& mesh, std::map<std::tuple<float, float, float>, uint32_t>& index, vec3 p) {
    const auto key = std::make_tuple(p.x, p.y, p.z);
    const auto it = index.find(key);
    if (it != index.end()) return it->second;
    const uint32_t i = uint32_t(mesh.positions.size());
    mesh.positions.push_back(p);
    index.emplace(key, i);
    return i;
}

// Closed UV sphere of radius `radius`: `rings` latitude bands, `segments` longitude slices, the
// poles single vertices. Every shared vertex is stored once.
Mesh makeSphere(int rings, int segments, float radius) {
    Mesh mesh;
    std::map<std::tuple<float, float, float>, uint32_t> index;
    auto point = [&](int ring, int segment) {
        if (ring == 0) return vec3(0.0f, radius, 0.0f);
        if (ring == rings) return vec3(0.0f, -radius, 0.0f);
        const double theta = M_PI * ring / rings;
        const double phi = 2.0 * M_PI * (segment % segments) / segments;
        return vec3(float(radius * std::sin(theta) * std::cos(phi)), float(radius * std::cos(theta)),
                    float(radius * std::sin(theta) * std::sin(phi)));
    };
    for (int r = 0; r < rings; ++r) {
        for (int s = 0; s < segments; ++s) {
            const uint32_t a = vertexIndex(mesh, index, point(r, s));
            const uint32_t b = vertexIndex(mesh, index, point(r, s + 1));
            const uint32_t c = vertexIndex(mesh, index, point(r + 1, s));
            const uint32_t d = vertexIndex(mesh, index, point(r + 1, s + 1));
            if (r != 0) mesh.triangles.push_back(uvec3(a, c, b));
            if (r != rings - 1) mesh.triangles.push_back(uvec3(b, c, d));
        }
    }
    return mesh;
}

// Closed cube [-1, 1]^3, each face an n x n grid of quads split along alternating diagonals.
Mesh makeCube(int n) {
    Mesh mesh;
    std::map<std::tuple<float, float, float>, uint32_t> index;
    auto grid = [&](int i) { return -1.0f + 2.0f * float(i) / float(n); };
    for (int axis = 0; axis < 3; ++axis) {
        for (int side = 0; side < 2; ++side) {
            const int u = (axis + 1) % 3, v = (axis + 2) % 3;
            for (int i = 0; i < n; ++i) {
                for (int j = 0; j < n; ++j) {
                    uint32_t corner[4];
                    const int di[4] = {0, 1, 0, 1}, dj[4] = {0, 0, 1, 1};
                    for (int k = 0; k < 4; ++k) {
                        vec3 p(0.0f);
                        p[axis] = side ? 1.0f : -1.0f;
                        p[u] = grid(i + di[k]);
                        p[v] = grid(j + dj[k]);
                        corner[k] = vertexIndex(mesh, index, p);
                    }
                    if ((i + j) % 2 == 0) {
                        mesh.triangles.push_back(uvec3(corner[0], corner[1], corner[3]));
                        mesh.triangles.push_back(uvec3(corner[0], corner[3], corner[2]));
                    } else {
                        mesh.triangles.push_back(uvec3(corner[0], corner[1], corner[2]));
                        mesh.triangles.push_back(uvec3(corner[1], corner[3], corner[2]));
                    }
                }
            }
        }
    }
    return mesh;
}

Mesh scaled(Mesh mesh, float scale) {
    for (vec3& p : mesh.positions) p *= scale;
    return mesh;
}

struct BruteHit {
    bool hit = false;
    float t = 0.0f;
    uint32_t prim = kNoHit;
};

// `fast`: intersectTriangleFast (Moller-Trumbore) instead of the watertight test.
BruteHit closestBrute(const Mesh& mesh, vec3 org, vec3 dir, bool fast = false) {
    const TraceRay ray = makeTraceRay(org, dir);
    BruteHit best;
    float bestT = kFloatHuge;
    for (uint32_t i = 0; i < mesh.triangles.size(); ++i) {
        const uvec3 tri = mesh.triangles[i];
        const vec3 v0 = mesh.positions[tri.x], v1 = mesh.positions[tri.y], v2 = mesh.positions[tri.z];
        float t;
        vec2 bary;
        const bool hit = fast ? intersectTriangleFast(ray, v0, v1, v2, bestT, t, bary)
                              : intersectTriangle(ray, v0, v1, v2, bestT, t, bary);
        if (hit && isCloserHit(t, i, bestT, best.prim)) {
            best = {true, t, i};
            bestT = t;
        }
    }
    return best;
}

// Points that lie exactly on the mesh's vertices and (up to rounding) on its edges.
std::vector<vec3> vertexAndEdgeTargets(const Mesh& mesh) {
    std::vector<vec3> targets = mesh.positions;
    const float fractions[] = {0.5f, 0.25f, 1.0f / 3.0f, 0.9f};
    for (const uvec3& tri : mesh.triangles) {
        for (int e = 0; e < 3; ++e) {
            const vec3 a = mesh.positions[tri[e]], b = mesh.positions[tri[(e + 1) % 3]];
            for (float f : fractions) targets.push_back(a + f * (b - a));
        }
    }
    return targets;
}

// Rays from interior points of a closed mesh through its vertices and edges: every one must hit
// (a miss is a leak through a crack), at t close to 1 (dir = target - origin).
void expectWatertight(const Mesh& mesh, const std::vector<vec3>& origins, float scale) {
    const std::vector<vec3> targets = vertexAndEdgeTargets(mesh);
    size_t rays = 0;
    for (const vec3& origin : origins) {
        for (const vec3& target : targets) {
            const vec3 dir = target - origin;
            const BruteHit hit = closestBrute(mesh, origin, dir);
            ASSERT_TRUE(hit.hit) << "ray from (" << origin.x << "," << origin.y << "," << origin.z << ") to ("
                                 << target.x << "," << target.y << "," << target.z << ") at scale " << scale
                                 << " leaked";
            // The target is on the surface (vertices exactly, edge points within rounding), so the
            // closest hit is at t = 1; a cube is flat there, a sphere chord is within rounding.
            EXPECT_NEAR(hit.t, 1.0f, 1e-4f) << "scale " << scale;
            ++rays;
        }
    }
    EXPECT_GT(rays, 1000u);
}

std::vector<vec3> interiorOrigins(float scale) {
    return {vec3(0.0f), vec3(0.1f, -0.2f, 0.05f) * scale, vec3(-0.31f, 0.27f, 0.4f) * scale,
            vec3(0.5f, 0.0f, 0.0f) * scale};
}

TEST(Watertight, SphereVerticesAndEdgesNeverLeak) {
    expectWatertight(makeSphere(12, 16, 1.0f), interiorOrigins(1.0f), 1.0f);
}

TEST(Watertight, CubeVerticesAndEdgesNeverLeak) { expectWatertight(makeCube(4), interiorOrigins(1.0f), 1.0f); }

TEST(Watertight, HugeAndTinyCoordinates) {
    for (float scale : {1e20f, 1e-20f}) {
        SCOPED_TRACE(scale);
        expectWatertight(scaled(makeSphere(8, 10, 1.0f), scale), interiorOrigins(scale), scale);
        expectWatertight(scaled(makeCube(3), scale), interiorOrigins(scale), scale);
    }
}

// Rays from interior points through every vertex and edge point: how many miss the mesh (leak).
size_t countLeaks(const Mesh& mesh, const std::vector<vec3>& origins, bool fast, size_t& rays) {
    size_t leaks = 0;
    rays = 0;
    for (const vec3& origin : origins) {
        for (const vec3& target : vertexAndEdgeTargets(mesh)) {
            leaks += closestBrute(mesh, origin, target - origin, fast).hit ? 0 : 1;
            ++rays;
        }
    }
    return leaks;
}

// The trade of IntersectMode::Fast is real: Moller-Trumbore lets rays through shared vertices and
// edges of closed meshes, where the watertight test lets none through, on the same rays.
TEST(FastIntersect, LeaksThroughSharedVerticesAndEdgesWhereRobustDoesNot) {
    size_t fastLeaks = 0, robustLeaks = 0, total = 0;
    for (const Mesh& mesh : {makeSphere(12, 16, 1.0f), makeCube(4), scaled(makeSphere(9, 13, 1.0f), 1e4f)}) {
        const float scale = mesh.positions[0].y;  // the sphere's pole, or the cube's corner (-1)
        std::vector<vec3> origins = interiorOrigins(std::abs(scale));
        size_t rays = 0;
        robustLeaks += countLeaks(mesh, origins, false, rays);
        fastLeaks += countLeaks(mesh, origins, true, rays);
        total += rays;
    }
    EXPECT_EQ(robustLeaks, 0u);
    EXPECT_GT(fastLeaks, 0u) << "over " << total << " rays";
    std::printf("fast intersection: %zu of %zu rays through vertices and edges leaked (robust: %zu)\n", fastLeaks,
                total, robustLeaks);
}

// Away from edges (barycentric weights in [0.05, 0.9]) the two tests agree: the same hits, t within
// 1e-5 (relative) of each other, and the same misses for rays aimed outside the triangle.
TEST(FastIntersect, AgreesWithRobustOnOrdinaryRays) {
    std::mt19937 rng(21);
    std::uniform_real_distribution<float> coord(-2.0f, 2.0f);
    std::uniform_real_distribution<float> weight(0.05f, 0.45f);
    size_t hits = 0;
    for (int i = 0; i < 20000; ++i) {
        const vec3 v0(coord(rng), coord(rng), coord(rng)), v1(coord(rng), coord(rng), coord(rng)),
            v2(coord(rng), coord(rng), coord(rng));
        const vec3 org = vec3(coord(rng), coord(rng), coord(rng)) * 4.0f;
        const float b1 = weight(rng), b2 = weight(rng);
        const bool inside = i % 2 == 0;
        // Outside: beyond the edge v1-v2 by a fifth of the triangle.
        const vec3 target = inside ? v0 + b1 * (v1 - v0) + b2 * (v2 - v0) : v0 + 0.6f * (v1 - v0) + 0.6f * (v2 - v0);
        const TraceRay ray = makeTraceRay(org, target - org);
        float tRobust, tFast;
        vec2 baryRobust, baryFast;
        const bool robust = intersectTriangle(ray, v0, v1, v2, kFloatHuge, tRobust, baryRobust);
        const bool fast = intersectTriangleFast(ray, v0, v1, v2, kFloatHuge, tFast, baryFast);
        // Ordinary: a well-shaped triangle (twice its area at least a tenth of its longest edge
        // squared) seen at more than about 6 degrees from edge-on.
        const vec3 n = cross(v1 - v0, v2 - v0);
        const float longest = std::max({length(v1 - v0), length(v2 - v1), length(v0 - v2)});
        if (length(n) < 0.1f * longest * longest) continue;
        if (std::abs(dot(normalize(n), normalize(target - org))) < 0.1f) continue;
        ASSERT_EQ(robust, inside) << i;
        ASSERT_EQ(fast, robust) << i;
        if (!robust) continue;
        ++hits;
        EXPECT_NEAR(tFast, tRobust, 1e-5f * tRobust) << i;
        EXPECT_NEAR(baryFast.x, baryRobust.x, 1e-4f) << i;
        EXPECT_NEAR(baryFast.y, baryRobust.y, 1e-4f) << i;
    }
    EXPECT_GT(hits, 3000u);
}

// The plain slab test is the conservative one without its widening: it accepts a subset.
TEST(FastIntersect, PlainSlabTestAcceptsASubsetOfTheConservativeOne) {
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> coord(-3.0f, 3.0f);
    size_t accepted = 0, differing = 0;
    for (int i = 0; i < 100000; ++i) {
        const vec3 a(coord(rng), coord(rng), coord(rng)), b(coord(rng), coord(rng), coord(rng));
        const vec3 lo = min(a, b), hi = max(a, b);
        const vec3 org(coord(rng) * 3.0f, coord(rng) * 3.0f, coord(rng) * 3.0f);
        // Aimed at a corner or a face point: on the box's boundary, where widening matters.
        const vec3 target =
            i % 2 ? vec3(lo.x, hi.y, coord(rng) > 0 ? lo.z : hi.z) : vec3(lo.x, hi.y, 0.5f * (lo.z + hi.z));
        const TraceRay ray = makeTraceRay(org, target - org);
        float tConservative, tPlain;
        const bool conservative = intersectBox(ray, lo, hi, kFloatHuge, tConservative);
        const bool plain = intersectBoxFast(ray, lo, hi, kFloatHuge, tPlain);
        ASSERT_TRUE(conservative || !plain) << i;
        if (plain) {
            EXPECT_EQ(tPlain, tConservative);
        }
        accepted += plain ? 1 : 0;
        differing += conservative != plain ? 1 : 0;
    }
    EXPECT_GT(accepted, 50000u);
    std::printf("plain slab test: %zu of 100000 boundary rays culled that the conservative test keeps\n", differing);
}

// Axis-parallel rays (two zero direction components) through the cube's grid lines and vertices,
// from inside and from outside.
TEST(Watertight, AxisParallelRaysThroughGridLines) {
    const Mesh cube = makeCube(4);
    const float coords[] = {-1.0f, -0.5f, 0.0f, 0.5f, 1.0f, 0.25f, -0.75f};
    size_t rays = 0;
    for (int axis = 0; axis < 3; ++axis) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        for (float cu : coords) {
            for (float cv : coords) {
                for (float sign : {1.0f, -1.0f}) {
                    for (float start : {0.0f, -3.0f * sign}) {
                        vec3 origin(0.0f), dir(0.0f);
                        origin[u] = cu;
                        origin[v] = cv;
                        origin[axis] = start;
                        dir[axis] = sign;
                        const BruteHit hit = closestBrute(cube, origin, dir);
                        // A ray inside the cube's cross-section (closed: the boundary counts) hits.
                        ASSERT_TRUE(hit.hit) << "axis " << axis << " at " << cu << "," << cv;
                        // Rays running along a face (|cu| or |cv| = 1) may first meet a
                        // perpendicular face's edge, otherwise the first face crossed.
                        const bool alongFace = std::abs(cu) == 1.0f || std::abs(cv) == 1.0f;
                        if (!alongFace) {
                            EXPECT_FLOAT_EQ(hit.t, start == 0.0f ? 1.0f : 2.0f);
                        }
                        ++rays;
                    }
                }
            }
        }
    }
    EXPECT_EQ(rays, 3u * 7u * 7u * 4u);
}

TEST(Triangle, HitDistanceAndBarycentrics) {
    const TraceRay ray = makeTraceRay(vec3(0.25f, 0.5f, 2.0f), vec3(0.0f, 0.0f, -1.0f));
    float t;
    vec2 bary;
    ASSERT_TRUE(
        intersectTriangle(ray, vec3(0.0f), vec3(1.0f, 0.0f, 0.0f), vec3(0.0f, 1.0f, 0.0f), kFloatHuge, t, bary));
    EXPECT_FLOAT_EQ(t, 2.0f);
    EXPECT_FLOAT_EQ(bary.x, 0.25f);
    EXPECT_FLOAT_EQ(bary.y, 0.5f);
    // Both faces: the reversed triangle is hit identically.
    ASSERT_TRUE(
        intersectTriangle(ray, vec3(0.0f), vec3(0.0f, 1.0f, 0.0f), vec3(1.0f, 0.0f, 0.0f), kFloatHuge, t, bary));
    EXPECT_FLOAT_EQ(t, 2.0f);
    EXPECT_FLOAT_EQ(bary.x, 0.5f);
    // tmax is inclusive and limits; behind the origin never hits.
    EXPECT_TRUE(intersectTriangle(ray, vec3(0.0f), vec3(1.0f, 0.0f, 0.0f), vec3(0.0f, 1.0f, 0.0f), 2.0f, t, bary));
    EXPECT_FALSE(intersectTriangle(ray, vec3(0.0f), vec3(1.0f, 0.0f, 0.0f), vec3(0.0f, 1.0f, 0.0f), 1.999f, t, bary));
    const TraceRay away = makeTraceRay(vec3(0.25f, 0.5f, 2.0f), vec3(0.0f, 0.0f, 1.0f));
    EXPECT_FALSE(
        intersectTriangle(away, vec3(0.0f), vec3(1.0f, 0.0f, 0.0f), vec3(0.0f, 1.0f, 0.0f), kFloatHuge, t, bary));
    // A ray in the triangle's plane does not hit it (det = 0).
    const TraceRay inPlane = makeTraceRay(vec3(-1.0f, 0.25f, 0.0f), vec3(1.0f, 0.0f, 0.0f));
    EXPECT_FALSE(
        intersectTriangle(inPlane, vec3(0.0f), vec3(1.0f, 0.0f, 0.0f), vec3(0.0f, 1.0f, 0.0f), kFloatHuge, t, bary));
}

TEST(Triangle, OriginOnTheTriangleIsNoHit) {
    // Issue 11, class 12: a hit counts only at t > 0. An origin inside the triangle, on an edge or
    // on a vertex meets it at t = 0, or -0 by the sign of det (both faces, both directions, straight
    // and oblique); before the fix each of these was a hit with t = +-0. The directions' largest
    // component is the triangle's normal (z): then the sheared vertices lie at exactly z = 0 and t
    // is exactly +-0 (tests/eye_on_face.h says what happens otherwise).
    const vec3 v0(0.0f), v1(1.0f, 0.0f, 0.0f), v2(0.0f, 1.0f, 0.0f);
    for (const vec3 origin : {vec3(0.25f, 0.25f, 0.0f), vec3(0.5f, 0.0f, 0.0f), vec3(0.5f, 0.5f, 0.0f), vec3(0.0f)})
        for (const vec3 dir :
             {vec3(0.0f, 0.0f, 1.0f), vec3(0.0f, 0.0f, -1.0f), vec3(0.3f, -0.2f, 1.0f), vec3(-0.7f, 0.1f, -0.9f)}) {
            const TraceRay ray = makeTraceRay(origin, dir);
            float t = 1.0f;
            vec2 bary;
            EXPECT_FALSE(intersectTriangle(ray, v0, v1, v2, kFloatHuge, t, bary))
                << origin.x << "," << origin.y << " dir " << dir.x << "," << dir.y << "," << dir.z << ": t " << t;
            EXPECT_FALSE(intersectTriangle(ray, v0, v2, v1, kFloatHuge, t, bary))
                << origin.x << "," << origin.y << " dir " << dir.x << "," << dir.y << "," << dir.z << ": t " << t;
        }
    // An origin 1e-30 above the face still hits it, at that tiny positive t.
    const TraceRay above = makeTraceRay(vec3(0.25f, 0.25f, 1.0e-30f), vec3(0.0f, 0.0f, -1.0f));
    float t;
    vec2 bary;
    ASSERT_TRUE(intersectTriangle(above, v0, v1, v2, kFloatHuge, t, bary));
    EXPECT_GT(t, 0.0f);
    EXPECT_FLOAT_EQ(t, 1.0e-30f);
}

// ---- Accurate hit distances (issue 15): the watertight decision of Woop et al. 2013 with t from
// the triangle's plane. The decision's own t is a weighted mean of the vertices' distances with
// the edge functions as weights; on a sliver those weights cancel (two long, nearly parallel
// edges), so t carried errors up to 1e-3 relative. The oracle: the same intersection in double,
// where the differences of float vertices are exact.

using raypack::test::exactPlaneDistance;

// The two forms of the kept hit's plane distance: float pairs (the GPU kernels' where 64-bit floats
// are slow or missing) and doubles (the CPU tracers', and the kernels' elsewhere).
using Refine = float (*)(vec3, vec3, vec3, vec3, vec3, float);
struct RefineForm {
    const char* name;
    Refine refine;
};
const RefineForm kRefineForms[] = {{"float pairs", accurateHitDistance}, {"doubles", accurateHitDistanceF64}};

struct SliverErrors {
    uint32_t hits = 0;
    double worst = 0.0;
};

// Random slivers `width` wide and 0.2-3 long: needles (one short edge) and caps (a vertex
// `width` off the long edge's middle), anywhere in [-offset - 10, -offset + 10]^3, in any
// orientation, each hit by rays from random origins 1-20 away aimed at a random point inside it.
// `always`: every hit's t from `refine`; otherwise as the tracers do, where intersectTriangle calls
// its own t inexact.
SliverErrors sliverErrors(float width, float offset, uint32_t triangles, uint32_t seed, bool always, Refine refine) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), lengthOf(0.2f, 3.0f), far(1.0f, 20.0f), in(0.0f, 1.0f);
    const auto direction = [&] { return raypack::test::randomDirection(rng); };
    SliverErrors errors;
    for (uint32_t i = 0; i < triangles; ++i) {
        const glm::vec3 centre = glm::vec3(unit(rng), unit(rng), unit(rng)) * 10.0f + offset;
        const glm::vec3 axis = direction();
        const glm::vec3 across = glm::normalize(glm::cross(axis, direction()));
        const float length = lengthOf(rng);
        const vec3 v0 = centre - 0.5f * length * axis;
        const vec3 v1 = centre + 0.5f * length * axis;
        const vec3 v2 = i % 2 ? v0 + width * across                              // needle
                              : centre + 0.1f * length * axis + width * across;  // cap
        for (int k = 0; k < 8; ++k) {
            float b1 = in(rng), b2 = in(rng);
            if (b1 + b2 > 1.0f) b1 = 1.0f - b1, b2 = 1.0f - b2;
            const glm::vec3 target = v0 + b1 * (v1 - v0) + b2 * (v2 - v0);
            const vec3 org = target - far(rng) * direction();
            const vec3 dir = target - glm::vec3(org);
            float t = 0.0f;
            vec2 bary;
            bool inexactT = false;
            if (!intersectTriangle(makeTraceRay(org, dir), v0, v1, v2, kFloatHuge, t, bary, inexactT)) continue;
            if (inexactT || always) t = refine(org, dir, v0, v1, v2, t);
            const double exact = exactPlaneDistance(org, dir, v0, v1, v2);
            ++errors.hits;
            errors.worst = std::max(errors.worst, std::abs(double(t) - exact) / std::abs(exact));
        }
    }
    return errors;
}

// Before (Woop's t for every hit), the worst relative errors were 0.095 and 0.61 (1e-4 and 1e-6
// wide, at the origin) and 0.006 (at 1000); ordinary triangles hit at grazing angles 1.3e-3.
// Now: within 5e-6 (measured: 2.0e-6) where the tracers keep the triangle test's t, within two
// ulps where they recompute it (issue 15's bar is 1e-5).
TEST(Triangle, HitDistanceOnSliversIsAccurate) {
    for (const RefineForm& form : kRefineForms) {
        for (const bool always : {false, true}) {
            for (const float width : {1e-4f, 1e-6f}) {
                for (const float offset : {0.0f, 1000.0f}) {
                    const SliverErrors errors = sliverErrors(width, offset, 20000, 7, always, form.refine);
                    // Rays aimed at a point inside a sliver can miss it (the aim point rounds off it).
                    EXPECT_GT(errors.hits, 10000u);
                    EXPECT_LE(errors.worst, always ? 2.4e-7 : 5e-6)
                        << form.name << ", width " << width << ", offset " << offset << ": " << errors.hits << " hits";
                    std::printf("slivers %g wide at offset %g, %s%s: %u hits, worst relative t error %.3g\n", width,
                                offset, form.name, always ? ", every t recomputed" : "", errors.hits, errors.worst);
                }
            }
        }
    }
}

// Triangles of size about 1 whose plane meets the ray at a grazing angle (cos 1e-4 to 1e-1), at
// distances 2-5 and 100-1000 from the ray origin.
TEST(Triangle, HitDistanceAtGrazingAnglesIsAccurate) {
    for (const RefineForm& form : kRefineForms) {
        std::mt19937 rng(3);
        std::uniform_real_distribution<float> unit(-1.0f, 1.0f), in(0.0f, 1.0f);
        const auto direction = [&] { return raypack::test::randomDirection(rng); };
        for (const bool farAway : {false, true}) {
            for (const bool always : {false, true}) {
                double worst = 0.0;
                uint32_t hits = 0;
                for (int i = 0; i < 20000; ++i) {
                    const float distance = farAway ? std::pow(10.0f, 2.0f + in(rng)) : 2.0f + 3.0f * in(rng);
                    const glm::vec3 towards = direction();
                    const vec3 org(unit(rng), unit(rng), unit(rng));
                    const glm::vec3 target = glm::vec3(org) + distance * towards;
                    const float cosine = std::pow(10.0f, -4.0f + 3.0f * in(rng));
                    const glm::vec3 side = glm::normalize(glm::cross(towards, direction()));
                    const glm::vec3 normal =
                        glm::normalize(cosine * towards + std::sqrt(1.0f - cosine * cosine) * side);
                    const glm::vec3 p1 = glm::normalize(glm::cross(normal, direction())), p2 = glm::cross(normal, p1);
                    const float phase = 6.2831853f * in(rng);
                    vec3 v[3];
                    for (int k = 0; k < 3; ++k)
                        v[k] = target + 0.6f * (std::cos(phase + 2.1f * k) * p1 + std::sin(phase + 2.1f * k) * p2);
                    float b1 = in(rng), b2 = in(rng);
                    if (b1 + b2 > 1.0f) b1 = 1.0f - b1, b2 = 1.0f - b2;
                    const vec3 dir = v[0] + b1 * (v[1] - v[0]) + b2 * (v[2] - v[0]) - org;
                    float t = 0.0f;
                    vec2 bary;
                    bool inexactT = false;
                    if (!intersectTriangle(makeTraceRay(org, dir), v[0], v[1], v[2], kFloatHuge, t, bary, inexactT))
                        continue;
                    if (inexactT || always) t = form.refine(org, dir, v[0], v[1], v[2], t);
                    const double exact = exactPlaneDistance(org, dir, v[0], v[1], v[2]);
                    worst = std::max(worst, std::abs(double(t) - exact) / std::abs(exact));
                    ++hits;
                }
                EXPECT_GT(hits, 15000u);
                EXPECT_LE(worst, always ? 2.4e-7 : 5e-6) << form.name << (farAway ? ", far" : ", near");
                std::printf("grazing, %s, %s%s: %u hits, worst relative t error %.3g\n", farAway ? "far" : "near",
                            form.name, always ? ", every t recomputed" : "", hits, worst);
            }
        }
    }
}

// The two forms agree: on slivers and grazing rays, from scenes of 1e-30 to 1e30 units, the float
// pairs' and the doubles' plane distances of every hit are equal or adjacent floats (each is the
// exact distance rounded, to within its own error far below an ulp).
TEST(Triangle, HitDistanceFormsAgree) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), in(0.0f, 1.0f);
    const auto direction = [&] { return raypack::test::randomDirection(rng); };
    uint32_t hits = 0, equal = 0;
    for (const float scale : {1e-30f, 1e-3f, 1.0f, 1e3f, 1e30f}) {
        for (int i = 0; i < 20000; ++i) {
            const glm::vec3 axis = direction();
            const glm::vec3 across = glm::normalize(glm::cross(axis, direction()));
            const float width = i % 3 == 0 ? 1e-6f : i % 3 == 1 ? 1e-3f : 0.5f;
            const glm::vec3 centre = glm::vec3(unit(rng), unit(rng), unit(rng)) * 10.0f;
            const vec3 v0 = scale * (centre - axis), v1 = scale * (centre + axis),
                       v2 = scale * (centre + width * across);
            float b1 = in(rng), b2 = in(rng);
            if (b1 + b2 > 1.0f) b1 = 1.0f - b1, b2 = 1.0f - b2;
            const glm::vec3 target = glm::vec3(v0) + b1 * glm::vec3(v1 - v0) + b2 * glm::vec3(v2 - v0);
            const vec3 org = target - scale * (1.0f + 20.0f * in(rng)) * direction();
            const vec3 dir = target - glm::vec3(org);
            float t = 0.0f;
            vec2 bary;
            if (!intersectTriangle(makeTraceRay(org, dir), v0, v1, v2, kFloatHuge, t, bary)) continue;
            const float pair = accurateHitDistance(org, dir, v0, v1, v2, t);
            const float dbl = accurateHitDistanceF64(org, dir, v0, v1, v2, t);
            ++hits;
            equal += pair == dbl ? 1 : 0;
            EXPECT_LE(raypack::test::ulpsApart(pair, dbl), 1)
                << "scale " << scale << ", ray " << i << ": " << pair << " against " << dbl;
        }
    }
    EXPECT_GT(hits, 60000u);
    std::printf("%u hits: the two forms equal on %u, one ulp apart on the rest\n", hits, equal);
}

TEST(Triangle, DegenerateTrianglesAreNeverHit) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> coord(-2.0f, 2.0f);
    size_t rays = 0;
    for (int trial = 0; trial < 200; ++trial) {
        const vec3 a(coord(rng), coord(rng), coord(rng));
        const vec3 b(coord(rng), coord(rng), coord(rng));
        // Two or three equal corners, in every position.
        const vec3 corners[][3] = {{a, a, b}, {a, b, a}, {b, a, a}, {a, a, a}};
        const vec3 targets[] = {a, b, 0.5f * (a + b), a + 0.3f * (b - a)};
        for (const auto& tri : corners) {
            for (const vec3& target : targets) {
                for (const vec3& origin : {vec3(0.0f, 0.0f, 5.0f), vec3(3.0f, -4.0f, 1.0f)}) {
                    const TraceRay ray = makeTraceRay(origin, target - origin);
                    float t;
                    vec2 bary;
                    EXPECT_FALSE(intersectTriangle(ray, tri[0], tri[1], tri[2], kFloatHuge, t, bary))
                        << "degenerate triangle hit at trial " << trial;
                    ++rays;
                }
            }
        }
    }
    // Collinear, distinct corners (0,0,0), (1,1,1), (2,2,2): the shear rounds the projected
    // triangle to a sliver, so a ray that passes exactly through the segment may be reported hit;
    // then the hit must lie on the segment. Rays that pass beside it never hit.
    const vec3 p0(0.0f), p1(1.0f), p2(2.0f);
    for (const vec3& origin : {vec3(0.0f, 0.0f, 5.0f), vec3(3.0f, -4.0f, 1.0f), vec3(1.0f, 0.0f, 0.0f)}) {
        for (const vec3& target : {p0, p1, p2, vec3(0.5f), vec3(1.5f)}) {
            float t;
            vec2 bary;
            const TraceRay through = makeTraceRay(origin, target - origin);
            if (intersectTriangle(through, p0, p1, p2, kFloatHuge, t, bary)) {
                const vec3 hit = hitPosition(origin, target - origin, t);
                EXPECT_NEAR(hit.x, target.x, 1e-5f);
                EXPECT_NEAR(hit.y, target.y, 1e-5f);
                EXPECT_NEAR(hit.z, target.z, 1e-5f);
            }
            for (const vec3& offset : {vec3(1e-3f, 0.0f, 0.0f), vec3(0.0f, -1e-3f, 2e-3f)}) {
                const TraceRay beside = makeTraceRay(origin, target + offset - origin);
                EXPECT_FALSE(intersectTriangle(beside, p0, p1, p2, kFloatHuge, t, bary));
            }
            ++rays;
        }
    }
    EXPECT_GT(rays, 3000u);
}

TEST(Box, RaysInFacePlanesAndParallelRays) {
    const vec3 lo(0.0f), hi(1.0f);
    float tEntry;
    // In the face planes x = 0 and x = 1, moving along +z and -z (also with -0.0 components).
    for (float x : {0.0f, 1.0f}) {
        for (float dz : {1.0f, -1.0f}) {
            for (float zeroSign : {0.0f, -0.0f}) {
                const TraceRay ray = makeTraceRay(vec3(x, 0.5f, dz > 0 ? -1.0f : 2.0f), vec3(zeroSign, zeroSign, dz));
                EXPECT_TRUE(intersectBox(ray, lo, hi, kFloatHuge, tEntry)) << x << " " << dz;
                EXPECT_FLOAT_EQ(tEntry, 1.0f);
            }
        }
    }
    // Along an edge of the box (two face planes at once) and through a corner.
    EXPECT_TRUE(
        intersectBox(makeTraceRay(vec3(1.0f, 1.0f, -1.0f), vec3(0.0f, 0.0f, 1.0f)), lo, hi, kFloatHuge, tEntry));
    EXPECT_TRUE(
        intersectBox(makeTraceRay(vec3(1.0f, 0.0f, -5.0f), vec3(0.0f, 0.0f, 1.0f)), lo, hi, kFloatHuge, tEntry));
    // One ulp outside the slab: miss, on either side.
    const float justAbove = std::nextafter(1.0f, 2.0f), justBelow = std::nextafter(0.0f, -1.0f);
    EXPECT_FALSE(
        intersectBox(makeTraceRay(vec3(justAbove, 0.5f, -1.0f), vec3(0.0f, 0.0f, 1.0f)), lo, hi, kFloatHuge, tEntry));
    EXPECT_FALSE(
        intersectBox(makeTraceRay(vec3(justBelow, 0.5f, -1.0f), vec3(0.0f, 0.0f, 1.0f)), lo, hi, kFloatHuge, tEntry));
    // Origin inside: entry 0. Box behind the ray, or beyond tmax: miss.
    EXPECT_TRUE(intersectBox(makeTraceRay(vec3(0.5f), vec3(1.0f, 0.0f, 0.0f)), lo, hi, kFloatHuge, tEntry));
    EXPECT_EQ(tEntry, 0.0f);
    EXPECT_FALSE(
        intersectBox(makeTraceRay(vec3(0.5f, 0.5f, 2.0f), vec3(0.0f, 0.0f, 1.0f)), lo, hi, kFloatHuge, tEntry));
    EXPECT_FALSE(intersectBox(makeTraceRay(vec3(0.5f, 0.5f, -2.0f), vec3(0.0f, 0.0f, 1.0f)), lo, hi, 0.5f, tEntry));
    // A flat box (zero thickness in z), as a leaf of coplanar triangles has: hit head on.
    EXPECT_TRUE(intersectBox(makeTraceRay(vec3(0.5f, 0.5f, -2.0f), vec3(0.0f, 0.0f, 1.0f)), vec3(0.0f, 0.0f, 0.0f),
                             vec3(1.0f, 1.0f, 0.0f), kFloatHuge, tEntry));
    EXPECT_FLOAT_EQ(tEntry, 2.0f);
    // A denormal direction component counts as parallel: no NaN, the slab decides.
    const TraceRay denormal = makeTraceRay(vec3(1.0f, 0.5f, -1.0f), vec3(1e-40f, 0.0f, 1.0f));
    EXPECT_TRUE(intersectBox(denormal, lo, hi, kFloatHuge, tEntry));
    EXPECT_FALSE(std::isnan(tEntry));
}

// Conservativeness: whenever the triangle test hits, the slab test on the triangle's bounds hits
// with an entry distance no larger than the hit's. Rays aim at vertices and edges, where a box face
// and the hit point coincide and rounding decides.
TEST(Box, NeverCullsATriangleHit) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> coord(-1.0f, 1.0f);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    size_t hits = 0;
    for (int trial = 0; trial < 20000; ++trial) {
        const float scale = std::pow(10.0f, float(trial % 7) - 3.0f);
        const vec3 v0 = vec3(coord(rng), coord(rng), coord(rng)) * scale;
        vec3 v1 = vec3(coord(rng), coord(rng), coord(rng)) * scale;
        vec3 v2 = vec3(coord(rng), coord(rng), coord(rng)) * scale;
        if (trial % 5 == 0) v2.z = v1.z = v0.z;  // axis-aligned triangle: a flat box
        vec3 target;
        switch (trial % 3) {
        case 0: target = trial % 2 ? v1 : v2; break;
        case 1: target = v0 + unit(rng) * (v1 - v0); break;
        default: {
            const float a = unit(rng), b = unit(rng) * (1.0f - a);
            target = v0 + a * (v1 - v0) + b * (v2 - v0);
        }
        }
        vec3 origin = vec3(coord(rng), coord(rng), coord(rng)) * (3.0f * scale);
        if (trial % 4 == 0) origin.x = target.x;  // axis-parallel components
        if (trial % 8 == 0) origin.y = target.y;
        if (origin == target) continue;
        const TraceRay ray = makeTraceRay(origin, target - origin);
        float t;
        vec2 bary;
        if (!intersectTriangle(ray, v0, v1, v2, kFloatHuge, t, bary)) continue;
        ++hits;
        const vec3 lo = min(v0, min(v1, v2)), hi = max(v0, max(v1, v2));
        float tEntry;
        ASSERT_TRUE(intersectBox(ray, lo, hi, t, tEntry)) << "trial " << trial;
        // The entry distance may exceed t by rounding, never by more than the cull margin.
        EXPECT_LE(tEntry, t * kBoxTmaxWiden) << "trial " << trial;
    }
    EXPECT_GT(hits, 10000u);
}

TEST(ShadowRay, FromTheLightToThePoint) {
    const ShadowRay s = makeShadowRay(vec3(0.0f, 10.0f, 0.0f), vec3(1.0f, 0.0f, 2.0f), 42u);
    EXPECT_EQ(s.org, vec3(0.0f, 10.0f, 0.0f));
    EXPECT_EQ(s.dir, vec3(1.0f, -10.0f, 2.0f));
    EXPECT_EQ(s.skipPrim, 42u);
    EXPECT_FLOAT_EQ(s.tmax, 1.0f - kShadowRayGap);
    EXPECT_FALSE(isDegenerateShadowRay(s));
    EXPECT_TRUE(isDegenerateShadowRay(makeShadowRay(vec3(1.0f), vec3(1.0f), 0u)));
}

TEST(ClosestHitOrder, NearerFirstThenLowerIndex) {
    EXPECT_TRUE(isCloserHit(1.0f, 9u, 2.0f, 0u));
    EXPECT_FALSE(isCloserHit(2.0f, 0u, 1.0f, 9u));
    EXPECT_TRUE(isCloserHit(1.0f, 3u, 1.0f, 4u));
    EXPECT_FALSE(isCloserHit(1.0f, 4u, 1.0f, 3u));
    EXPECT_TRUE(isCloserHit(5.0f, 0u, kFloatHuge, kNoHit));
}

TEST(Shading, PackingRoundsHalfUpWithRInTheLowByte) {
    EXPECT_EQ(packRgba8(vec4(1.0f, 0.0f, 0.0f, 0.0f)), 0x000000FFu);
    EXPECT_EQ(packRgba8(vec4(0.0f, 0.0f, 0.0f, 1.0f)), 0xFF000000u);
    EXPECT_EQ(packRgba8(vec4(-3.0f, 7.0f, 0.0f, 1.0f)), 0xFF00FF00u);  // clamped
    for (uint32_t byte = 0; byte < 256; ++byte) {
        const float exact = float(byte) / 255.0f;
        EXPECT_EQ(packChannel(exact), byte);
        // Just below the midpoint to the next byte rounds down, at or above it rounds up.
        if (byte < 255) {
            EXPECT_EQ(packChannel((float(byte) + 0.49f) / 255.0f), byte);
            EXPECT_EQ(packChannel((float(byte) + 0.51f) / 255.0f), byte + 1);
        }
        EXPECT_EQ(packRgba8(unpackRgba8(byte * 0x01010101u)), byte * 0x01010101u);
    }
}

TEST(Shading, PhongByHand) {
    const vec4 phong(0.1f, 0.5f, 0.2f, 8.0f);
    const vec3 grey(0.5f);
    const vec3 n(0.0f, 0.0f, 1.0f);
    // Light and viewer along the normal: ambient + diffuse + full specular.
    vec3 c = shadePhong(phong, grey, n, n, n, true);
    EXPECT_NEAR(c.x, 0.1f * 0.5f + 0.5f * 0.5f + 0.2f, 1e-6f);
    // Shadowed: ambient only.
    c = shadePhong(phong, grey, n, n, n, false);
    EXPECT_NEAR(c.x, 0.05f, 1e-6f);
    // Light at 60 degrees, viewer along the mirror direction: diffuse * cos 60, full specular.
    const vec3 toLight = normalize(vec3(std::sqrt(3.0f), 0.0f, 1.0f));
    const vec3 mirror = normalize(vec3(-std::sqrt(3.0f), 0.0f, 1.0f));
    c = shadePhong(phong, grey, n, mirror, toLight, true);
    EXPECT_NEAR(c.x, 0.05f + 0.5f * 0.5f * 0.5f + 0.2f, 1e-5f);
    // Light behind the surface: ambient only.
    c = shadePhong(phong, grey, n, n, -toLight, true);
    EXPECT_NEAR(c.x, 0.05f, 1e-6f);
}

TEST(Shading, NormalsFaceTheViewer) {
    const vec3 v0(0.0f), v1(1.0f, 0.0f, 0.0f), v2(0.0f, 1.0f, 0.0f);
    // Seen from +z (ray going -z) the normal is +z, from -z it is -z, whatever the winding.
    EXPECT_EQ(geometricNormal(v0, v1, v2, vec3(0.0f, 0.0f, -1.0f)), vec3(0.0f, 0.0f, 1.0f));
    EXPECT_EQ(geometricNormal(v0, v2, v1, vec3(0.0f, 0.0f, -1.0f)), vec3(0.0f, 0.0f, 1.0f));
    EXPECT_EQ(geometricNormal(v0, v1, v2, vec3(0.0f, 0.0f, 1.0f)), vec3(0.0f, 0.0f, -1.0f));
    // Interpolated: the weights blend the vertex normals, then it is flipped to face the viewer.
    const vec3 nx(1.0f, 0.0f, 0.0f), ny(0.0f, 1.0f, 0.0f), nz(0.0f, 0.0f, 1.0f);
    const vec3 g(0.0f, 0.0f, 1.0f);
    EXPECT_EQ(interpolatedNormal(nx, ny, nz, vec2(0.0f, 1.0f), g, vec3(0.0f, 0.0f, -1.0f)), nz);
    EXPECT_EQ(interpolatedNormal(nx, ny, nz, vec2(0.0f, 1.0f), g, vec3(0.0f, 0.0f, 1.0f)), -nz);
    const vec3 mid = interpolatedNormal(nx, ny, nz, vec2(0.5f, 0.0f), g, vec3(-1.0f, -1.0f, 0.0f));
    EXPECT_NEAR(mid.x, std::sqrt(0.5f), 1e-6f);
    EXPECT_NEAR(mid.y, std::sqrt(0.5f), 1e-6f);
    // Opposite vertex normals cancelling: the geometric normal.
    EXPECT_EQ(interpolatedNormal(nz, -nz, nz, vec2(0.5f, 0.0f), g, vec3(0.0f, 0.0f, -1.0f)), g);
}

TEST(Shading, HeatRampEndsAndMonotoneRed) {
    EXPECT_EQ(heatColor(0.0f), vec3(0.0f, 0.0f, 0.25f));
    EXPECT_EQ(heatColor(1.0f), vec3(1.0f, 0.0f, 0.0f));
    EXPECT_EQ(heatColor(-5.0f), heatColor(0.0f));
    EXPECT_EQ(heatColor(7.0f), heatColor(1.0f));
    float previousRed = -1.0f;
    for (int i = 0; i <= 100; ++i) {
        const vec3 c = heatColor(float(i) / 100.0f);
        EXPECT_GE(c.x, previousRed);
        previousRed = c.x;
        for (int k = 0; k < 3; ++k) {
            EXPECT_GE(c[k], 0.0f);
            EXPECT_LE(c[k], 1.0f);
        }
    }
    EXPECT_EQ(heatColorForCount(128u, 256.0f), heatColor(0.5f));
}

// The same headers must compile as GLSL (the GPU kernels include them): compile a compute shader
// calling every function with glslangValidator.
TEST(Glsl, HeadersCompileAsGlsl) {
    const std::filesystem::path dir =
        std::filesystem::temp_directory_path() / ("raypack_glsl_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::filesystem::path shader = dir / "headers.comp";
    std::ofstream(shader) << R"(#version 460
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 8, local_size_y = 4) in;
#include "intersect.h"
#include "shading.h"
layout(std430, binding = 0) buffer Data { vec4 v[8]; uint pixels[]; };
void main() {
    TraceRay r = makeTraceRay(v[0].xyz, v[1].xyz);
    float tEntry;
    bool box = intersectBox(r, v[2].xyz, v[3].xyz, kFloatHuge, tEntry);
    float t;
    vec2 bary;
    bool tri = intersectTriangle(r, v[4].xyz, v[5].xyz, v[6].xyz, kFloatHuge, t, bary);
    ShadowRay s = makeShadowRay(v[7].xyz, hitPosition(r.org, r.dir, t), 1u);
    bool ok = box && tri && isCloserHit(t, 0u, tEntry, 1u) && !isDegenerateShadowRay(s);
    vec3 g = geometricNormal(v[4].xyz, v[5].xyz, v[6].xyz, r.dir);
    vec3 n = interpolatedNormal(g, g, g, bary, g, r.dir);
    vec3 c = shadePhong(vec4(0.1f, 0.7f, 0.2f, 32.0f), vec3(1.0f), n, -r.dir, normalize(s.dir), ok);
    c = c + heatColorForCount(3u, kHeatFullScaleNodes) + heatColor(0.5f);
    pixels[gl_GlobalInvocationID.x] = packRgba8(vec4(c, 1.0f)) + packChannel(unpackRgba8(7u).x);
}
)";
    const std::string command = "glslangValidator -V --target-env vulkan1.2 -I\"" + std::string(RAYPACK_SOURCE_DIR) +
                                "/shaders\" -o \"" + (dir / "headers.spv").string() + "\" \"" + shader.string() +
                                "\" > \"" + (dir / "log.txt").string() + "\" 2>&1";
    const int status = std::system(command.c_str());
    std::ifstream logFile(dir / "log.txt");
    const std::string log((std::istreambuf_iterator<char>(logFile)), std::istreambuf_iterator<char>());
    std::filesystem::remove_all(dir);
    EXPECT_EQ(status, 0) << log;
}

}  // namespace
