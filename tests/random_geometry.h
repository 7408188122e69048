#pragma once
// Geometry the tests share: random directions, random triangle soups, the sliver soups of issue 15,
// the exact hit distance they are checked against, and brute-force closest hits and occlusion.
#include "renderer/cpu_tracer.h"
#include "renderer/measure/accuracy.h"
#include "renderer/scene.h"
#include "shaders/intersect.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <cstdlib>
#include <limits>
#include <map>
#include <random>
#include <tuple>

namespace raypack::test {

// A uniformly distributed unit vector (a normalised Gaussian triple).
inline glm::vec3 randomDirection(std::mt19937& rng) {
    std::normal_distribution<float> normal;
    glm::vec3 d;
    do d = glm::vec3(normal(rng), normal(rng), normal(rng));
    while (glm::dot(d, d) < 1e-6f);
    return glm::normalize(d);
}

// `count` slivers 0.2-3 long and `width` wide in random orientations, centred within
// [-halfExtent, halfExtent]^3: needles (one short edge) and caps (a vertex `width` off the long
// edge, a tenth of its length from the middle), alternately.
inline Scene randomSliverSoup(uint32_t count, float width, float halfExtent, uint32_t seed) {
    Scene scene;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), length(0.2f, 3.0f);
    for (uint32_t i = 0; i < count; ++i) {
        const glm::vec3 centre = halfExtent * glm::vec3(unit(rng), unit(rng), unit(rng));
        const glm::vec3 axis = randomDirection(rng);
        const glm::vec3 across = glm::normalize(glm::cross(axis, randomDirection(rng)));
        const float l = length(rng);
        const glm::vec3 v0 = centre - 0.5f * l * axis, v1 = centre + 0.5f * l * axis;
        const glm::vec3 v2 = i % 2 ? v0 + width * across : centre + 0.1f * l * axis + width * across;
        const uint32_t base = uint32_t(scene.positions.size());
        scene.positions.insert(scene.positions.end(), {v0, v1, v2});
        scene.triangles.emplace_back(base, base + 1, base + 2);
    }
    return scene;
}

// Closed cube [-1, 1]^3 of n x n quads per face, vertices shared (exactly equal floats).
inline Scene tessellatedCube(int n) {
    Scene scene;
    scene.source = "tessellated cube";
    std::map<std::tuple<float, float, float>, uint32_t> index;
    auto vertex = [&](glm::vec3 p) {
        const auto key = std::make_tuple(p.x, p.y, p.z);
        auto it = index.find(key);
        if (it != index.end()) return it->second;
        const uint32_t i = uint32_t(scene.positions.size());
        scene.positions.push_back(p);
        index.emplace(key, i);
        return i;
    };
    auto grid = [&](int i) { return -1.0f + 2.0f * float(i) / float(n); };
    for (int axis = 0; axis < 3; ++axis) {
        for (int side = 0; side < 2; ++side) {
            const int u = (axis + 1) % 3, v = (axis + 2) % 3;
            for (int i = 0; i < n; ++i) {
                for (int j = 0; j < n; ++j) {
                    uint32_t c[4];
                    for (int k = 0; k < 4; ++k) {
                        glm::vec3 p(0.0f);
                        p[axis] = side ? 1.0f : -1.0f;
                        p[u] = grid(i + (k & 1));
                        p[v] = grid(j + (k >> 1));
                        c[k] = vertex(p);
                    }
                    scene.triangles.push_back(glm::uvec3(c[0], c[1], c[3]));
                    scene.triangles.push_back(glm::uvec3(c[0], c[3], c[2]));
                }
            }
        }
    }
    return scene;
}

// The double-precision oracle of issue 15's t accuracy: the library's one definition
// (renderer/measure/accuracy.h), which the trade suite measures with too.
using raypack::exactPlaneDistance;

// How many floats lie between two non-negative finite floats (0: equal, 1: adjacent): their bit
// patterns order as they do.
// `triangles` unconnected triangles with vertices up to 1 from random centres in [-10, 10]^3.
inline Scene randomTriangleSoup(uint32_t triangles, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> centre(-10.0f, 10.0f), offset(-1.0f, 1.0f);
    Scene scene;
    scene.source = "random soup";
    for (uint32_t i = 0; i < triangles; ++i) {
        const glm::vec3 c(centre(rng), centre(rng), centre(rng));
        for (int k = 0; k < 3; ++k) scene.positions.push_back(c + glm::vec3(offset(rng), offset(rng), offset(rng)));
        scene.triangles.push_back(glm::uvec3(3 * i, 3 * i + 1, 3 * i + 2));
    }
    return scene;
}

struct BruteHit {
    float t = std::numeric_limits<float>::infinity();
    uint32_t prim = gpu::kNoHit;
};

// The distance a tracer reports for the hit it keeps: the triangle test's t, or where that test
// calls its t inexact the plane distance of that triangle (gpu::accurateHitDistanceF64; issue 15).
inline float keptT(const Scene& scene, uint32_t prim, glm::vec3 org, glm::vec3 dir, float t) {
    const glm::vec3 v0 = scene.vertex(prim, 0), v1 = scene.vertex(prim, 1), v2 = scene.vertex(prim, 2);
    float ownT;
    glm::vec2 bary;
    bool inexactT = false;
    gpu::intersectTriangle(gpu::makeTraceRay(org, dir), v0, v1, v2, kRayTmaxInfinite, ownT, bary, inexactT);
    return inexactT ? gpu::accurateHitDistanceF64(org, dir, v0, v1, v2, t) : t;
}

// The closest hit over every triangle, ties to the lower file index (gpu::isCloserHit), at the
// distance the tracers report (keptT).
inline BruteHit bruteClosest(const Scene& scene, glm::vec3 org, glm::vec3 dir) {
    const gpu::TraceRay ray = gpu::makeTraceRay(org, dir);
    BruteHit best;
    float bestT = kRayTmaxInfinite;
    for (uint32_t i = 0; i < scene.triangleCount(); ++i) {
        float t;
        glm::vec2 bary;
        if (gpu::intersectTriangle(ray, scene.vertex(i, 0), scene.vertex(i, 1), scene.vertex(i, 2), bestT, t, bary) &&
            gpu::isCloserHit(t, i, bestT, best.prim)) {
            best = {t, i};
            bestT = t;
        }
    }
    if (best.prim != gpu::kNoHit) best.t = keptT(scene, best.prim, org, dir, best.t);
    return best;
}

// Whether any triangle but `skip` lies on the ray within (0, tmax], every triangle tested (the
// brute-force answer for the tracers' shadow rays).
inline bool bruteOccluded(const Scene& scene, glm::vec3 org, glm::vec3 dir, float tmax, uint32_t skip) {
    const gpu::TraceRay ray = gpu::makeTraceRay(org, dir);
    for (uint32_t i = 0; i < scene.triangleCount(); ++i) {
        if (i == skip) continue;
        float t;
        glm::vec2 bary;
        if (gpu::intersectTriangle(ray, scene.vertex(i, 0), scene.vertex(i, 1), scene.vertex(i, 2), tmax, t, bary))
            return true;
    }
    return false;
}

inline int64_t ulpsApart(float a, float b) {
    return std::abs(int64_t(glm::floatBitsToUint(a)) - int64_t(glm::floatBitsToUint(b)));
}

}  // namespace raypack::test
