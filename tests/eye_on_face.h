#pragma once
// Issue 11, class 12: an eye placed exactly on a face. Every ray then starts in that face's plane,
// inside the face, so a test that accepts t = 0 hits it at t = 0 (or -0, by the sign of the
// determinant) for every direction and the image shows nothing beyond. A hit counts only at
// t > 0 (shaders/intersect.h, as Embree with tnear = 0): the rays must see the walls behind.
// Shared by the CPU tests (test_robust.cpp) and the GPU tests (test_robust_gpu.cpp).
#include "renderer/camera.h"
#include "renderer/frame.h"
#include "renderer/scene.h"
#include "shaders/frame_types.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

namespace raypack::test {

// The eye's face: a 2 x 2 quad at z = 0, triangles 0 and 1, split along its diagonal through the
// origin. Walls: 200 x 200 quads at z = 5 (triangles 2, 3) and z = -5 (4, 5), which every camera
// ray of eyeOnFaceViews() reaches well inside their edges.
inline Scene eyeOnFaceScene() {
    Scene scene;
    scene.source = "eye on a face (generated)";
    const auto quad = [&scene](float z, float half) {
        const uint32_t base = uint32_t(scene.positions.size());
        scene.positions.push_back(glm::vec3(-half, -half, z));
        scene.positions.push_back(glm::vec3(half, -half, z));
        scene.positions.push_back(glm::vec3(half, half, z));
        scene.positions.push_back(glm::vec3(-half, half, z));
        scene.triangles.emplace_back(base, base + 1, base + 2);
        scene.triangles.emplace_back(base, base + 2, base + 3);
    };
    quad(0.0f, 1.0f);
    quad(5.0f, 100.0f);
    quad(-5.0f, 100.0f);
    return scene;
}

struct EyeOnFaceView {
    const char* name;
    Camera camera;
    float wallZ;         // the wall every ray must hit
    uint32_t wallPrims;  // its first triangle (the other is wallPrims + 1)
};

// Eyes on the face's shared diagonal, inside it and on its corner; looking straight through it
// (along +z and -z: both signs of the determinant, so t = +-0 from either face before the fix) and
// obliquely through it (about 16 degrees off its normal, 30 degrees of field of view).
//
// Every ray's largest direction component is z, the face's normal: the watertight test then
// shears along z, the face's vertices lie at exactly 0 in sheared z, and its t is exactly +0 or
// -0, which t > 0 rejects. A ray whose largest component lies in the face's plane (more than 45
// degrees off the normal) shears along that axis instead; its t on the face is then the rounding
// of a sum of terms that cancel, of either sign and about 1e-8 of the face's size, and when
// positive it is still a hit (docs/robustness.md, "Hits at the ray origin").
inline std::vector<EyeOnFaceView> eyeOnFaceViews() {
    const auto camera = [](glm::vec3 eye, glm::vec3 at, float fov) {
        Camera c;
        c.eye = eye;
        c.at = at;
        c.up = glm::vec3(0.0f, 1.0f, 0.0f);
        c.fovYDegrees = fov;
        return c;
    };
    return {
        {"on the shared edge, along +z", camera({0, 0, 0}, {0, 0, 5}, 60.0f), 5.0f, 2},
        {"on the shared edge, along -z", camera({0, 0, 0}, {0, 0, -5}, 60.0f), -5.0f, 4},
        {"inside, obliquely forwards", camera({0.25f, 0.1f, 0}, {0.25f, 1.6f, 5}, 30.0f), 5.0f, 2},
        {"inside, obliquely backwards", camera({0.25f, 0.1f, 0}, {-1.25f, 0.1f, -5}, 30.0f), -5.0f, 4},
        {"on a corner, obliquely backwards", camera({-1, -1, 0}, {0, 0, -5}, 30.0f), -5.0f, 4},
    };
}

// Every ray of `frame` (width x height hits, shadows on) hits the wall of `view` at
// t = (wallZ - org.z) / dir.z, never the eye's face, with t > 0 and its sign bit clear.
inline void expectSeesBeyondTheFace(const Frame& frame, const EyeOnFaceView& view, const std::string& what) {
    ASSERT_EQ(frame.hits.size(), size_t(frame.width) * frame.height) << what;
    size_t wrong = 0;
    for (size_t i = 0; i < frame.hits.size(); ++i) {
        const HitRecord& h = frame.hits[i];
        // What eyeOnFaceViews() promises: z is every ray's largest component.
        ASSERT_GT(std::abs(h.dirZ), std::max(std::abs(h.dirX), std::abs(h.dirY))) << view.name << ", ray " << i;
        const float expected = (view.wallZ - h.orgZ) / h.dirZ;
        const bool right = (h.prim == view.wallPrims || h.prim == view.wallPrims + 1) && h.t > 0.0f &&
                           !std::signbit(h.t) && std::abs(h.t - expected) <= 1e-5f * expected;
        if (!right && wrong++ < 3)
            ADD_FAILURE() << what << ", " << view.name << ": ray " << i << " hit triangle " << h.prim << " at t " << h.t
                          << " (signbit " << std::signbit(h.t) << "), expected the wall at t " << expected;
    }
    EXPECT_EQ(wrong, 0u) << what << ", " << view.name << ": of " << frame.hits.size() << " rays";
}

// `frame` agrees with `reference` ray by ray: the same triangle, the same shadow state, t within
// `relative` of the reference's (0: the same bits).
inline void expectSameHits(const Frame& frame, const Frame& reference, float relative, const std::string& what) {
    ASSERT_EQ(frame.hits.size(), reference.hits.size()) << what;
    size_t differing = 0;
    for (size_t i = 0; i < frame.hits.size(); ++i) {
        const HitRecord& h = frame.hits[i];
        const HitRecord& r = reference.hits[i];
        const bool same = h.prim == r.prim && h.shadow == r.shadow &&
                          (relative == 0.0f ? std::memcmp(&h.t, &r.t, sizeof h.t) == 0
                                            : std::abs(h.t - r.t) <= relative * std::abs(r.t));
        if (!same && differing++ < 3)
            ADD_FAILURE() << what << ": ray " << i << " hit " << h.prim << " at t " << h.t << " (shadow " << h.shadow
                          << "), the CPU reference " << r.prim << " at t " << r.t << " (shadow " << r.shadow << ")";
    }
    EXPECT_EQ(differing, 0u) << what << ": rays differing from the CPU reference, of " << frame.hits.size();
}

}  // namespace raypack::test
