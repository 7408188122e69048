#pragma once
// Everything that decides what a frame looks like and how it is traced, as one value: the CLI fills
// it from flags, the viewer's panel edits it, the tracers read it. No file-scope toggles.
#include "renderer/camera.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <string>

namespace raypack {

struct PhongParams {
    float ambient = 0.15f;
    float diffuse = 0.75f;
    float specular = 0.25f;
    float shininess = 32.0f;
};

// Packet: the report's shared-stack packet traversal; Single: one ray per invocation (Aila and
// Laine 2009); Hybrid: the packet while it is coherent, then each ray alone (Benthin et al. 2012,
// docs/gpu.md), split by HybridParams.
enum class KernelKind { Packet, Single, Hybrid };
enum class ViewMode { Shaded, HeatTraversal, HeatIntersections };
// Which ray/triangle and ray/box tests every tracer runs (issue 15, docs/trade.md). Robust: the
// watertight triangle test of Woop et al. 2013 with accurate hit distances and the conservative
// slab test of Ize 2013; no ray leaks through a closed mesh. Fast: Moller-Trumbore 1997 and the
// plain slab test, which can let a ray through a shared edge or vertex.
enum class IntersectMode { Robust, Fast };
// Which child a shadow ray (any hit) of the single-ray Vulkan kernel enters first when it hits
// both (issue 14, docs/gpu.md): the nearer (as primary rays), the left one in tree order (no
// comparison), or the one of larger surface area (more likely to hold an occluder). The answer,
// lit or occluded, is the same; only the work differs.
enum class ShadowOrder { Nearest, Tree, Larger };
// The arithmetic of the robust path's accurate hit distance in the Vulkan kernels (the kept hit's t
// from its plane, shaders/intersect.h; docs/trade.md): 64-bit floats (accurateHitDistanceF64, some
// 45 double operations; needs shaderFloat64), float pairs (accurateHitDistance, about 400 float
// operations; every device), or Auto: doubles where the device has them at a useful rate
// (GpuTracer measures it), else float pairs. The two agree to an ulp; only the speed differs. The
// CPU tracers always take doubles.
enum class HitDistanceMath { Auto, Float64, FloatPair };

struct PacketShape {
    uint32_t width = 8;
    uint32_t height = 4;
    uint32_t rays() const { return width * height; }
    bool operator==(const PacketShape&) const = default;
};

// When the hybrid kernel's packet splits into single rays (shaders/trace.comp, traceHybrid): at the
// first inner node that fewer than `minRays` of its active rays want (0: never by this rule), or
// once its inner-node visits summed over its active rays pass `visitRatio` times the visits those
// rays wanted (0: the rule is off; at most kMaxHybridVisitRatio). Both are specialization constants.
// Defaults: K = 32, the default 8x4 packet's every ray (split at the first node that not all of them
// want), visit rule off. This is the K sweep on an H100 (docs/gpu.md, "The hybrid kernel by triangle
// density"). There, splitting that early was the fastest hybrid in 13 of the 16 scene and ray-kind
// cells of the report and scaling suites, and within 0.02 of it in two more. Conference's primary
// rays prefer K = 2 (0.96 of the single-ray kernel against 0.89). It beat or tied the earlier
// default, a quarter of the packet, in 15 of the 16 cells. A K above the packet's ray count splits
// every packet at the root: the kernel without its packet phase, which measured 0.964-1.034 of the
// single-ray kernel in the same workgroup, and ahead of K = 32 in 31 of 32 cells, the other within
// 0.4% (docs/gpu.md, "The hybrid kernel's gap in steps"): the packet phase is what costs.
// `packetsPerGroup` packets share one workgroup, stacked in y (1: one packet a workgroup, as the
// packet kernel); more than one needs packets of exactly one subgroup. The default,
// kAutoPacketsPerGroup, lets the device choose (GpuTracer::deviceSettings): four where each packet
// fills exactly one subgroup (8x4 on NVIDIA, an 8x1 row on lavapipe), which measured 0.98-1.09x one
// a workgroup on an H100, ahead in 13 of 16 cells of the report and scaling suites, and 0.98-3.4x
// on lavapipe (docs/gpu.md, "The hybrid kernel's packets per workgroup"); one elsewhere.
inline constexpr uint32_t kAutoPacketsPerGroup = 0;
struct HybridParams {
    uint32_t minRays = 32;
    float visitRatio = 0.0f;
    uint32_t packetsPerGroup = kAutoPacketsPerGroup;
    bool operator==(const HybridParams&) const = default;
};
inline constexpr float kMaxHybridVisitRatio = 1000.0f;
inline constexpr uint32_t kMaxHybridPacketsPerGroup = 64;

struct RenderSettings {
    uint32_t width = 800;
    uint32_t height = 800;
    Camera camera;
    float lightHeight = 0.25f;  // multiple of the scene's height above the camera (report 2.3)
    bool shadows = true;
    PhongParams phong;
    IntersectMode intersect = IntersectMode::Robust;
    ShadowOrder shadowOrder = ShadowOrder::Nearest;
    HitDistanceMath hitDistance = HitDistanceMath::Auto;  // GPU path only
    glm::vec3 background{0.08f, 0.09f, 0.11f};
    // Offset of every primary ray from its pixel's centre, in pixels (each component in
    // [-0.5, 0.5)): one sample of an anti-aliasing pattern (renderer/accumulate.h). Zero: centres.
    glm::vec2 pixelJitter{0.0f};
    // GPU path only.
    KernelKind kernel = KernelKind::Packet;
    PacketShape packet;  // the packet and hybrid kernels' packet (one workgroup)
    // The single-ray kernel's workgroups, of the primary pass and of the shadow pass: each ray
    // traces alone, the shape only groups pixels. An SM of the H200 holds at most 32 workgroups, so
    // 32-ray workgroups capped it at 32 warps; 8x16 (each 32-lane subgroup an 8x4 tile) traced
    // primary rays 1.03-1.12x faster there. Shadow rays run in rows (32x4: a subgroup is one row of
    // 32 pixels): 1.14-1.32x faster than 8x16 on the scans, where they trailed the driver's ray
    // tracing, 0.83-0.89x on Sibenik and 0.92-0.94x on Sponza, which stay far ahead of it (docs/gpu.md).
    PacketShape singleGroup{8, 16};
    PacketShape singleShadowGroup{32, 4};
    HybridParams hybrid;
    // The tree the single-ray kernel traces: 2, the binary BVH as built, or 8, the compressed 8-wide
    // tree made from it at upload (Ylitie et al. 2017; the tracer gpu-cwbvh, docs/gpu.md). The
    // packet and hybrid kernels trace the binary tree.
    uint32_t bvhWidth = 2;
    bool collectCounters = false;  // per-ray N_TR / N_IT (statistics variant of the kernel)
    ViewMode view = ViewMode::Shaded;
    // The count shown as full red in the heat maps; 0: the view's default (256 nodes, 128 tests;
    // shaders/shading.h). The viewer's "auto" sets the frame's 99th percentile.
    float heatFullScale = 0.0f;
};

// The workgroup a GPU kernel of `settings` runs its primary or shadow pass in: the packet (the
// hybrid kernel's packets per group stacked in y), or the single-ray kernel's group of that pass.
// The hybrid kernel's packets per group must have been resolved (GpuTracer::deviceSettings).
inline PacketShape gpuWorkgroup(const RenderSettings& settings, bool shadowPass = false) {
    if (settings.kernel == KernelKind::Hybrid)
        return PacketShape{settings.packet.width, settings.packet.height * settings.hybrid.packetsPerGroup};
    if (settings.kernel != KernelKind::Single) return settings.packet;
    return shadowPass ? settings.singleShadowGroup : settings.singleGroup;
}

const char* toString(KernelKind kind);
const char* toString(ViewMode mode);
const char* toString(IntersectMode mode);
const char* toString(ShadowOrder order);
const char* toString(HitDistanceMath math);

}  // namespace raypack
