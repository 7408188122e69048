#pragma once
// What the GPU test programs share: one Vulkan context with validation on (tests fail on any
// validation message), scenes loaded once, and the comparisons against the CPU reference with the
// bars of issue 3.
#include "renderer/bvh.h"
#include "renderer/cpu_tracer.h"
#include "renderer/gpu_tracer.h"
#include "renderer/vk/context.h"
#include "scenes/load.h"
#include "shaders/frame_types.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

namespace raypack::test {

inline vk::VulkanContext& validatedContext() {
    static vk::VulkanContext* context = [] {
        setenv("XDG_RUNTIME_DIR", "/tmp", 0);
        vk::VulkanContextOptions options;
        options.validation = true;
        if (const char* device = std::getenv("RAYPACK_TEST_DEVICE")) options.device = device;
        auto* c = new vk::VulkanContext(vk::createVulkanContext(options));
        std::printf("GPU tests on %s\n", vk::describe(c->info).c_str());
        return c;
    }();
    return *context;
}

struct LoadedScene {
    Scene scene;
    Bvh bvh;
    Camera camera;
};

inline LoadedScene loadForTest(const std::string& spec) {
    LoadedScene s;
    s.scene = openScene(spec);
    s.bvh = buildBvh(s.scene, BvhBuildOptions{});
    s.camera = frameScene(s.scene.bounds());
    return s;
}

inline std::string sharedScene(const char* relative) { return std::string(RAYPACK_SHARED_SCENES) + "/" + relative; }

// Pixels whose RGBA8 values differ in any channel.
inline size_t differingPixels(const Frame& a, const Frame& b) {
    EXPECT_EQ(a.rgba.size(), b.rgba.size());
    size_t n = 0;
    for (size_t i = 0; i < std::min(a.rgba.size(), b.rgba.size()); ++i)
        if (a.rgba[i] != b.rgba[i]) ++n;
    return n;
}

// Hits identical byte for byte (two kernels that must agree exactly).
inline bool sameHits(const Frame& a, const Frame& b) {
    return a.hits.size() == b.hits.size() &&
           (a.hits.empty() || std::memcmp(a.hits.data(), b.hits.data(), a.hits.size() * sizeof(HitRecord)) == 0);
}

struct HitAgreement {
    size_t rays = 0;
    size_t agree = 0;        // same hit/miss, t within 1e-4 relative
    size_t shadowRays = 0;   // pixels where the reference traced a shadow ray
    size_t shadowAgree = 0;  // ... and the GPU reports the same lit/occluded state
};

inline HitAgreement compareHits(const Frame& gpu, const Frame& cpu) {
    HitAgreement h;
    EXPECT_EQ(gpu.hits.size(), cpu.hits.size());
    for (size_t i = 0; i < std::min(gpu.hits.size(), cpu.hits.size()); ++i) {
        const HitRecord& g = gpu.hits[i];
        const HitRecord& c = cpu.hits[i];
        ++h.rays;
        const bool gHit = g.prim != gpu::kNoHit, cHit = c.prim != gpu::kNoHit;
        if (gHit == cHit && (!cHit || std::abs(g.t - c.t) <= 1e-4f * std::max(std::abs(c.t), 1e-30f))) ++h.agree;
        if (c.shadow != gpu::kShadowNone) {
            ++h.shadowRays;
            if (g.shadow == c.shadow) ++h.shadowAgree;
        }
    }
    return h;
}

// The bars of issue 3: at most 0.01% of pixels differ; hits agree on >= 99.99% of rays; shadows on
// >= 99.9% of the pixels the reference traced a shadow ray for.
inline void expectMatchesReference(const Frame& gpu, const Frame& cpu, const std::string& what) {
    const size_t pixels = size_t(cpu.width) * cpu.height;
    const size_t differing = differingPixels(gpu, cpu);
    EXPECT_LE(double(differing), 1e-4 * double(pixels))
        << what << ": " << differing << " of " << pixels << " pixels differ";
    if (!cpu.hits.empty()) {
        const HitAgreement h = compareHits(gpu, cpu);
        EXPECT_GE(double(h.agree), 0.9999 * double(h.rays))
            << what << ": hits agree on " << h.agree << " of " << h.rays;
        EXPECT_GE(double(h.shadowAgree), 0.999 * double(h.shadowRays))
            << what << ": shadows agree on " << h.shadowAgree << " of " << h.shadowRays;
    }
    ::testing::Test::RecordProperty(what + " differing pixels", int(differing));
}

inline void expectNoValidationMessages() { EXPECT_EQ(vk::validationMessageCount(validatedContext()), 0u); }

}  // namespace raypack::test
