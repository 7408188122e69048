#pragma once
// The CPU reference tracer: what every faster path (GPU packet and single-ray kernels, Embree) is
// checked against. It traces the canonical Bvh (renderer/bvh.h) with the very intersection, shadow
// and shading code the GPU kernels compile (shaders/intersect.h, shaders/shading.h).
//
// Traversal is ordered (nearer child first, the other pushed with its entry distance and skipped at
// pop time when it now lies beyond the closest hit) on a fixed stack of the tree's depth + 1
// entries, allocated once per image tile, never per ray.
//
// Counters, as the report's Table 2 counts them for one ray:
//  N_TR (nodes): nodes the ray visits. The root is visited when its box is hit; an inner node's
//               visit tests both children's boxes, a leaf's visit tests its triangles.
//  N_IT (tests): ray/triangle tests. A shadow ray does not test the triangle it starts from.
#include "renderer/bvh.h"
#include "renderer/frame.h"
#include "renderer/scene.h"
#include "renderer/settings.h"

#include <glm/glm.hpp>

#include <cfloat>
#include <cstdint>
#include <limits>
#include <vector>

namespace raypack {

// Two BvhNodes on one 64-byte cache line.
struct alignas(64) CpuNodePair {
    BvhNode nodes[2];
};

// Scene + Bvh prepared for tracing: each leaf entry's three vertices gathered in leaf order, so a
// leaf's triangles are contiguous in memory, and a verbatim copy of the canonical nodes placed so
// that sibling pairs share a cache line. Refers to the scene and the tree, which must outlive it.
// Build it once per tree; it costs 36 bytes per triangle and 32 per node.
struct CpuSceneView {
    const Scene* scene = nullptr;
    const Bvh* bvh = nullptr;
    std::vector<glm::vec3> leafVertices;  // 3 per entry of bvh->primIndices
    // bvh->nodes, copied unchanged, one node slot in: the builders place siblings at (2k+1, 2k+2)
    // (the root alone at 0), so in bvh->nodes, whose start is 16-byte aligned, every pair the
    // traversal reads in one go straddles two cache lines; here each pair has a line of its own.
    std::vector<CpuNodePair> nodeStorage;
    uint32_t stackEntries = 1;  // maximal leaf depth + 1
    Aabb bounds;                // of the scene's triangles (the root's box)
    // The copy of bvh->nodes that is traced: nodes()[i] == bvh->nodes[i] for every i.
    const BvhNode* nodes() const { return &nodeStorage.front().nodes[1]; }
};

// Checks that the tree fits the scene (RAYPACK_CHECK: a Bvh built from another scene is a bug).
CpuSceneView makeCpuSceneView(const Scene& scene, const Bvh& bvh);

constexpr float kRayTmaxInfinite = FLT_MAX;

// The closest hit of one ray, with what shading needs.
struct ClosestHit {
    float t = std::numeric_limits<float>::infinity();  // +inf on a miss
    uint32_t prim = 0xFFFFFFFFu;                       // triangle index in file order, gpu::kNoHit on a miss
    glm::vec2 bary{0.0f};                              // barycentric weights of the triangle's vertices 1 and 2
    bool hit() const { return prim != 0xFFFFFFFFu; }
};

// Per-ray counts of one traversal.
struct TraversalCounts {
    uint32_t nodes = 0;  // N_TR
    uint32_t tests = 0;  // N_IT
};

// Closest hit along origin + t * dir for t in (0, tmax] (a hit at the origin,
// t = 0, is none: shaders/intersect.h); dir must be non-zero, need not be unit.
// Ties in t go to the lower triangle index (gpu::isCloserHit).
// `mode`: the box and triangle tests (renderer/settings.h, IntersectMode), here and below.
ClosestHit traceClosestHit(const CpuSceneView& view, glm::vec3 origin, glm::vec3 dir, float tmax = kRayTmaxInfinite,
                           TraversalCounts* counts = nullptr, IntersectMode mode = IntersectMode::Robust);
// Whether any triangle other than `skipPrim` lies on origin + t * dir for t in (0, tmax]; stops at
// the first one found.
bool traceOccluded(const CpuSceneView& view, glm::vec3 origin, glm::vec3 dir, float tmax,
                   uint32_t skipPrim = 0xFFFFFFFFu, TraversalCounts* counts = nullptr,
                   IntersectMode mode = IntersectMode::Robust);
// The shadow ray of a hit (gpu::makeShadowRay): true when the light does not reach the hit point.
bool traceShadowOccluded(const CpuSceneView& view, glm::vec3 light, glm::vec3 hitPoint, uint32_t hitPrim,
                         TraversalCounts* counts = nullptr, IntersectMode mode = IntersectMode::Robust);

// Single rays straight on Scene + Bvh, for tests and tools (no gathering, no allocation unless
// the tree is deeper than 255 levels). traceClosest fills record.shadow = kShadowNone and adds its
// counts to counters->primary*, traceOccluded to counters->shadow*.
HitRecord traceClosest(const Scene& scene, const Bvh& bvh, glm::vec3 origin, glm::vec3 dir,
                       float tmax = kRayTmaxInfinite, RayCounters* counters = nullptr,
                       IntersectMode mode = IntersectMode::Robust);
bool traceOccluded(const Scene& scene, const Bvh& bvh, glm::vec3 origin, glm::vec3 dir, float tmax,
                   uint32_t skipPrim = 0xFFFFFFFFu, RayCounters* counters = nullptr,
                   IntersectMode mode = IntersectMode::Robust);

// The last pass of a CPU frame, shared by every CPU tracer: from each pixel's closest hit, its
// shadow state (gpu::kShadowNone/Lit/Occluded) and its counters, the shaded or heat-map image,
// the HitRecords and the counters that `request` asks for, into `frame` (whose width, height and
// light are set). `camera` is makeGpuCamera of settings; the vectors hold one entry per pixel.
void shadeCpuFrame(const Scene& scene, const RenderSettings& settings, const gpu::GpuCamera& camera,
                   const std::vector<ClosestHit>& hits, const std::vector<uint32_t>& shadowState,
                   const std::vector<RayCounters>& counters, const FrameRequest& request, Frame& frame);

// One frame: a primary ray through each pixel centre (shaders/camera.h), the closest hit, a shadow
// ray to the light (lightPosition over the scene's bounds) when settings.shadows, Phong shading or
// the heat view settings.view asks for. Multithreaded over 16x16 tiles with TBB (the caller's
// arena decides the thread count). Timings: primarySeconds, shadowSeconds, shadeSeconds per pass,
// totalSeconds for the call (including building the view in the Scene + Bvh overload).
// Throws raypack::Error for a degenerate camera or an empty image.
Frame renderCpu(const CpuSceneView& view, const RenderSettings& settings, const FrameRequest& request = {});
Frame renderCpu(const Scene& scene, const Bvh& bvh, const RenderSettings& settings, const FrameRequest& request = {});

}  // namespace raypack
