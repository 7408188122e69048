#include "renderer/cpu_tracer.h"

#include "renderer/camera.h"
#include "renderer/cpu_box_pair.h"
#include "renderer/error.h"
#include "renderer/gpu_layout.h"  // gpuTexture
#include "renderer/measure/spread.h"
#include "shaders/camera.h"
#include "shaders/intersect.h"
#include "shaders/shading.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <limits>
#include <memory>
#include <type_traits>

namespace raypack {
namespace {

using Clock = SteadyClock;

// A node waiting on the stack, with the entry distance its box had when it was pushed.
struct StackEntry {
    uint32_t node;
    float tEntry;
};

// The tracing passes visit image tiles of at most kTile x kTile pixels.
constexpr uint32_t kTile = 16;

// Calls pixel(x, y) for each pixel of `tile` (at most kTile x kTile) in Morton (Z) order: rays
// that follow each other stay close together in both image directions, so they touch mostly the
// same nodes (warm in the cache) and take mostly the same branches. Measured single-threaded on
// Sponza: about 6% more primary rays per second than row order.
template <class PixelFunction>
void forEachPixelInZOrder(const tbb::blocked_range2d<uint32_t>& tile, PixelFunction pixel) {
    static_assert(kTile == 16, "the Morton index below has 4 bits per axis");
    RAYPACK_CHECK(tile.rows().size() <= kTile && tile.cols().size() <= kTile);
    const auto evenBits = [](uint32_t v) {  // bits 0, 2, 4, 6 of v -> bits 0..3
        v &= 0x55u;
        v = (v | (v >> 1)) & 0x33u;
        return (v | (v >> 2)) & 0x0Fu;
    };
    for (uint32_t morton = 0; morton < kTile * kTile; ++morton) {
        const uint32_t x = tile.cols().begin() + evenBits(morton);
        const uint32_t y = tile.rows().begin() + evenBits(morton >> 1);
        if (x < tile.cols().end() && y < tile.rows().end()) pixel(x, y);
    }
}

// One bilinear lookup in mip level `level` of `texture` (shaders/texture.h).
glm::vec4 sampleLevel(const Texture& texture, const gpu::GpuTexture& descriptor, uint32_t level, glm::vec2 uv) {
    const gpu::BilinearTaps taps = gpu::bilinearTaps(gpu::textureLevel(descriptor, level), uv);
    const std::vector<uint32_t>& t = texture.texels;
    return gpu::bilinearBlend(t[taps.texel.x], t[taps.texel.y], t[taps.texel.z], t[taps.texel.w], taps.weight);
}

// The diffuse colour at a hit on triangle `prim` (file order) at distance hitT along rayDir:
// material x texture (trilinear at the pixel's level of detail) x vertex colour, by
// shaders/texture.h as the GPU kernel computes it. Without materials the default material's grey,
// or white where vertex colours give the colour.
glm::vec3 diffuseAt(const Scene& scene, uint32_t prim, glm::vec2 bary, glm::vec3 rayDir, float hitT,
                    float pixelSpread) {
    const glm::uvec3 tri = scene.triangles[prim];
    glm::vec3 materialColor = gpu::defaultMaterialColor(scene.hasVertexColors());
    uint32_t texture = kNoTexture;
    if (scene.hasMaterials()) {
        const Material& material = scene.materials[scene.triangleMaterial[prim]];
        materialColor = material.diffuse;
        texture = material.texture;
    }
    glm::vec4 texel(1.0f);
    if (texture != kNoTexture && scene.hasUvs()) {  // as the kernel's kFrameHasUvs
        const Texture& t = scene.textures[texture];
        const gpu::GpuTexture descriptor = gpuTexture(t, 0);
        const glm::vec2 uv0 = scene.uvs[tri.x], uv1 = scene.uvs[tri.y], uv2 = scene.uvs[tri.z];
        const glm::vec2 uv = gpu::interpolateUv(uv0, uv1, uv2, bary);
        const float lod = gpu::textureLod(descriptor, scene.positions[tri.x], scene.positions[tri.y],
                                          scene.positions[tri.z], uv0, uv1, uv2, rayDir, hitT, pixelSpread);
        const uint32_t level = uint32_t(lod);
        texel = sampleLevel(t, descriptor, level, uv);
        if (level + 1 < t.levels)
            texel = gpu::lerpPrecise(texel, sampleLevel(t, descriptor, level + 1, uv), lod - float(level));
    }
    glm::vec3 vertexColor(1.0f);
    if (scene.hasVertexColors())
        vertexColor = gpu::interpolateColor(scene.vertexColors[tri.x], scene.vertexColors[tri.y],
                                            scene.vertexColors[tri.z], bary);
    return gpu::surfaceColor(materialColor, texel, vertexColor);
}

// Triangles of the gathered view: entry i of primIndices has its vertices at 3i, 3i+1, 3i+2.
struct GatheredTriangles {
    const glm::vec3* vertices;
    const uint32_t* primIndices;
    void fetch(uint32_t entry, glm::vec3& v0, glm::vec3& v1, glm::vec3& v2) const {
        const glm::vec3* v = vertices + 3 * size_t(entry);
        v0 = v[0];
        v1 = v[1];
        v2 = v[2];
    }
    uint32_t prim(uint32_t entry) const { return primIndices[entry]; }
};

// Triangles straight from the scene, through the index buffer.
struct SceneTriangles {
    const Scene* scene;
    const uint32_t* primIndices;
    void fetch(uint32_t entry, glm::vec3& v0, glm::vec3& v1, glm::vec3& v2) const {
        const glm::uvec3 tri = scene->triangles[primIndices[entry]];
        v0 = scene->positions[tri.x];
        v1 = scene->positions[tri.y];
        v2 = scene->positions[tri.z];
    }
    uint32_t prim(uint32_t entry) const { return primIndices[entry]; }
};

// One step of ordered traversal at an inner node whose children `left` and left + 1 were tested
// (hits): both hit, the nearer is visited next (the left one at equal entry distances) and the
// other is pushed with its entry distance; one hit, that one is next. Returns false when neither
// is hit. Branches, not selects: a predicted branch lets the core fetch the next node before the
// box test has finished; a branch-free select makes every step wait for it (measured slower).
__attribute__((always_inline)) inline bool descend(const ChildBoxHits& hits, uint32_t left, StackEntry* stack,
                                                   uint32_t& top, uint32_t stackEntries, uint32_t& nodeIndex) {
    const uint32_t right = left + 1;
    if (hits.mask == 3u) {
        RAYPACK_CHECK_MSG(top < stackEntries, "traversal stack deeper than the tree");
        if (hits.tRight < hits.tLeft) {
            stack[top++] = {left, hits.tLeft};
            nodeIndex = right;
        } else {
            stack[top++] = {right, hits.tRight};
            nodeIndex = left;
        }
        return true;
    }
    if (hits.mask == 0u) return false;
    nodeIndex = hits.mask == 1u ? left : right;
    return true;
}

// The box test of the root and the triangle test of IntersectMode::Fast (kFast) or Robust
// (shaders/intersect.h). A template parameter, so that neither traversal pays for the other's test.
template <bool kFast>
RP_HOT_FUNC bool rootBoxTest(const gpu::TraceRay& ray, const BvhNode& root, float tmax, float& tEntry) {
    if constexpr (kFast) return gpu::intersectBoxFast(ray, root.lo, root.hi, tmax, tEntry);
    return gpu::intersectBox(ray, root.lo, root.hi, tmax, tEntry);
}

template <bool kFast>
RP_HOT_FUNC bool triangleTest(const gpu::TraceRay& ray, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2, float tmax, float& t,
                              glm::vec2& bary, bool& inexactT) {
    if constexpr (kFast) {
        inexactT = false;  // the fast path keeps Moller-Trumbore's t
        return gpu::intersectTriangleFast(ray, v0, v1, v2, tmax, t, bary);
    }
    return gpu::intersectTriangle(ray, v0, v1, v2, tmax, t, bary, inexactT);
}

// Ordered closest-hit traversal. `stack` holds at least the tree's depth + 1 entries.
template <bool kFast, class Triangles>
ClosestHit closestHit(const BvhNode* nodes, const Triangles& triangles, const gpu::TraceRay& ray, float tmax,
                      StackEntry* stack, uint32_t stackEntries, TraversalCounts& counts) {
    ClosestHit best;
    float bestT = tmax;
    float tRoot;
    if (!rootBoxTest<kFast>(ray, nodes[0], bestT, tRoot)) return best;
    ChildBoxRay boxRay = makeChildBoxRay(ray, bestT, kFast);
    // Counted in locals: through the reference, every stack write might alias them.
    uint32_t visitedNodes = 0;
    uint32_t triangleTests = 0;
    uint32_t nodeIndex = 0;
    uint32_t top = 0;
    uint32_t bestEntry = 0;
    bool bestInexact = false;
    while (true) {
        const BvhNode& node = nodes[nodeIndex];
        ++visitedNodes;
        if (node.isLeaf()) {
            const uint32_t end = node.index + node.count;
            for (uint32_t entry = node.index; entry < end; ++entry) {
                glm::vec3 v0, v1, v2;
                triangles.fetch(entry, v0, v1, v2);
                ++triangleTests;
                float t;
                glm::vec2 bary;
                bool inexactT;
                if (!triangleTest<kFast>(ray, v0, v1, v2, bestT, t, bary, inexactT)) continue;
                const uint32_t prim = triangles.prim(entry);
                if (gpu::isCloserHit(t, prim, bestT, best.prim)) {
                    bestT = t;
                    boxRay.setTmax(t);
                    best.t = t;
                    best.prim = prim;
                    best.bary = bary;
                    bestEntry = entry;
                    bestInexact = inexactT;
                }
            }
        } else {
            const ChildBoxHits hits = intersectChildBoxes(boxRay, nodes + node.index);
            if (descend(hits, node.index, stack, top, stackEntries, nodeIndex)) continue;
        }
        // Pop the nearest waiting node that may still hold something closer than the best hit,
        // with the same margin the box test culls with (gpu::kBoxTmaxWiden): the entry distance
        // carries rounding, and a tie at equal t with a lower triangle index must still be found.
        while (true) {
            if (top == 0) {
                counts.nodes += visitedNodes;
                counts.tests += triangleTests;
                if (bestInexact) {
                    // The kept hit's distance from its plane (gpu::accurateHitDistanceF64), as the kernels do.
                    glm::vec3 v0, v1, v2;
                    triangles.fetch(bestEntry, v0, v1, v2);
                    best.t = gpu::accurateHitDistanceF64(ray.org, ray.dir, v0, v1, v2, best.t);
                }
                return best;
            }
            const StackEntry entry = stack[--top];
            if (entry.tEntry <= bestT * boxRay.tmaxWiden) {
                nodeIndex = entry.node;
                break;
            }
        }
    }
}

// Any-hit traversal for shadow rays: stops at the first triangle other than skipPrim.
template <bool kFast, class Triangles>
bool anyHit(const BvhNode* nodes, const Triangles& triangles, const gpu::TraceRay& ray, float tmax, uint32_t skipPrim,
            StackEntry* stack, uint32_t stackEntries, TraversalCounts& counts) {
    float tRoot;
    if (!rootBoxTest<kFast>(ray, nodes[0], tmax, tRoot)) return false;
    const ChildBoxRay boxRay = makeChildBoxRay(ray, tmax, kFast);
    uint32_t visitedNodes = 0;
    uint32_t triangleTests = 0;
    bool occluded = false;
    uint32_t nodeIndex = 0;
    uint32_t top = 0;
    while (true) {
        const BvhNode& node = nodes[nodeIndex];
        ++visitedNodes;
        if (node.isLeaf()) {
            const uint32_t end = node.index + node.count;
            for (uint32_t entry = node.index; entry < end; ++entry) {
                if (triangles.prim(entry) == skipPrim) continue;
                glm::vec3 v0, v1, v2;
                triangles.fetch(entry, v0, v1, v2);
                ++triangleTests;
                float t;
                glm::vec2 bary;
                bool inexactT;
                if (triangleTest<kFast>(ray, v0, v1, v2, tmax, t, bary, inexactT)) {
                    occluded = true;
                    break;
                }
            }
            if (occluded) break;
        } else {
            const ChildBoxHits hits = intersectChildBoxes(boxRay, nodes + node.index);
            if (descend(hits, node.index, stack, top, stackEntries, nodeIndex)) continue;
        }
        if (top == 0) break;
        nodeIndex = stack[--top].node;
    }
    counts.nodes += visitedNodes;
    counts.tests += triangleTests;
    return occluded;
}

// Calls body(std::true_type) for IntersectMode::Fast and body(std::false_type) for Robust, so that a
// mode chosen at run time selects one instantiation of the traversal (decltype(fast)::value).
template <class Body>
decltype(auto) withIntersectMode(IntersectMode mode, Body&& body) {
    if (mode == IntersectMode::Fast) return body(std::true_type{});
    return body(std::false_type{});
}

// Stack storage for the single-ray entry points: on the call stack for trees up to 255 levels.
class SmallStack {
public:
    explicit SmallStack(uint32_t entries) : entries_(entries) {
        if (entries > inline_.size()) heap_ = std::make_unique<StackEntry[]>(entries);
    }
    StackEntry* data() { return heap_ ? heap_.get() : inline_.data(); }
    uint32_t size() const { return entries_; }

private:
    std::array<StackEntry, 256> inline_;
    std::unique_ptr<StackEntry[]> heap_;
    uint32_t entries_;
};

uint32_t depthFromStatsOrWalk(const Bvh& bvh) {
    // The builder's statistics are trusted only when present and plausible; otherwise walk.
    if (bvh.stats.nodeCount == bvh.nodes.size() && bvh.stats.nodeCount > 0) return bvh.stats.maxLeafDepth;
    return bvhMaxDepth(bvh);
}

void checkRay(glm::vec3 dir) { RAYPACK_CHECK_MSG(dir != glm::vec3(0.0f), "a ray direction must not be zero"); }

}  // namespace

CpuSceneView makeCpuSceneView(const Scene& scene, const Bvh& bvh) {
    CpuSceneView view;
    view.scene = &scene;
    view.bvh = &bvh;
    view.stackEntries = bvhMaxDepth(bvh) + 1;
    const size_t entries = bvh.primIndices.size();
    view.leafVertices.resize(3 * entries);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, entries, 4096), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
            const uint32_t prim = bvh.primIndices[i];
            RAYPACK_CHECK_MSG(prim < scene.triangles.size(), "the Bvh was built for another scene");
            for (int c = 0; c < 3; ++c) view.leafVertices[3 * i + c] = scene.vertex(prim, c);
        }
    });
    view.nodeStorage.resize(bvh.nodes.size() / 2 + 1);
    std::copy(bvh.nodes.begin(), bvh.nodes.end(), &view.nodeStorage.front().nodes[1]);
    view.bounds.lo = bvh.nodes[0].lo;
    view.bounds.hi = bvh.nodes[0].hi;
    return view;
}

ClosestHit traceClosestHit(const CpuSceneView& view, glm::vec3 origin, glm::vec3 dir, float tmax,
                           TraversalCounts* counts, IntersectMode mode) {
    checkRay(dir);
    SmallStack stack(view.stackEntries);
    TraversalCounts local;
    const GatheredTriangles triangles{view.leafVertices.data(), view.bvh->primIndices.data()};
    const ClosestHit hit = withIntersectMode(mode, [&](auto fast) {
        return closestHit<decltype(fast)::value>(view.nodes(), triangles, gpu::makeTraceRay(origin, dir), tmax,
                                                 stack.data(), stack.size(), local);
    });
    if (counts) *counts = local;
    return hit;
}

bool traceOccluded(const CpuSceneView& view, glm::vec3 origin, glm::vec3 dir, float tmax, uint32_t skipPrim,
                   TraversalCounts* counts, IntersectMode mode) {
    checkRay(dir);
    SmallStack stack(view.stackEntries);
    TraversalCounts local;
    const GatheredTriangles triangles{view.leafVertices.data(), view.bvh->primIndices.data()};
    const bool occluded = withIntersectMode(mode, [&](auto fast) {
        return anyHit<decltype(fast)::value>(view.nodes(), triangles, gpu::makeTraceRay(origin, dir), tmax, skipPrim,
                                             stack.data(), stack.size(), local);
    });
    if (counts) *counts = local;
    return occluded;
}

bool traceShadowOccluded(const CpuSceneView& view, glm::vec3 light, glm::vec3 hitPoint, uint32_t hitPrim,
                         TraversalCounts* counts, IntersectMode mode) {
    const gpu::ShadowRay shadow = gpu::makeShadowRay(light, hitPoint, hitPrim);
    if (gpu::isDegenerateShadowRay(shadow)) {
        if (counts) *counts = {};
        return false;
    }
    return traceOccluded(view, shadow.org, shadow.dir, shadow.tmax, shadow.skipPrim, counts, mode);
}

HitRecord traceClosest(const Scene& scene, const Bvh& bvh, glm::vec3 origin, glm::vec3 dir, float tmax,
                       RayCounters* counters, IntersectMode mode) {
    checkRay(dir);
    SmallStack stack(depthFromStatsOrWalk(bvh) + 1);
    TraversalCounts counts;
    const SceneTriangles triangles{&scene, bvh.primIndices.data()};
    const ClosestHit hit = withIntersectMode(mode, [&](auto fast) {
        return closestHit<decltype(fast)::value>(bvh.nodes.data(), triangles, gpu::makeTraceRay(origin, dir), tmax,
                                                 stack.data(), stack.size(), counts);
    });
    if (counters) {
        counters->primaryNodes += counts.nodes;
        counters->primaryTests += counts.tests;
    }
    return gpu::makeHitRecord(origin, dir, hit.t, hit.prim, gpu::kShadowNone);
}

bool traceOccluded(const Scene& scene, const Bvh& bvh, glm::vec3 origin, glm::vec3 dir, float tmax, uint32_t skipPrim,
                   RayCounters* counters, IntersectMode mode) {
    checkRay(dir);
    SmallStack stack(depthFromStatsOrWalk(bvh) + 1);
    TraversalCounts counts;
    const SceneTriangles triangles{&scene, bvh.primIndices.data()};
    const bool occluded = withIntersectMode(mode, [&](auto fast) {
        return anyHit<decltype(fast)::value>(bvh.nodes.data(), triangles, gpu::makeTraceRay(origin, dir), tmax,
                                             skipPrim, stack.data(), stack.size(), counts);
    });
    if (counters) {
        counters->shadowNodes += counts.nodes;
        counters->shadowTests += counts.tests;
    }
    return occluded;
}

void shadeCpuFrame(const Scene& scene, const RenderSettings& settings, const gpu::GpuCamera& camera,
                   const std::vector<ClosestHit>& hits, const std::vector<uint32_t>& shadowState,
                   const std::vector<RayCounters>& counters, const FrameRequest& request, Frame& frame) {
    const uint32_t width = settings.width;
    const uint32_t height = settings.height;
    const size_t pixels = size_t(width) * height;
    RAYPACK_CHECK(hits.size() == pixels && shadowState.size() == pixels && counters.size() == pixels);
    const glm::vec3 eye = gpu::cameraEye(camera);
    const glm::vec3 light = frame.light;
    const bool heatView = settings.view != ViewMode::Shaded;
    const float pixelSpread = gpu::pixelSpread(camera);
    const tbb::blocked_range2d<uint32_t> tiles(0, height, kTile, 0, width, kTile);
    if (request.image) frame.rgba.resize(pixels);
    if (request.hits) frame.hits.resize(pixels);
    const glm::vec4 phong(settings.phong.ambient, settings.phong.diffuse, settings.phong.specular,
                          settings.phong.shininess);
    tbb::parallel_for(
        tiles,
        [&](const tbb::blocked_range2d<uint32_t>& tile) {
            for (uint32_t y = tile.rows().begin(); y != tile.rows().end(); ++y) {
                for (uint32_t x = tile.cols().begin(); x != tile.cols().end(); ++x) {
                    const size_t pixel = size_t(y) * width + x;
                    const ClosestHit& hit = hits[pixel];
                    const glm::vec3 dir = gpu::primaryRayDirection(camera, x, y);
                    if (request.hits)
                        frame.hits[pixel] = gpu::makeHitRecord(eye, dir, hit.t, hit.prim, shadowState[pixel]);
                    if (!request.image) continue;
                    glm::vec3 color;
                    if (heatView) {
                        color = gpu::heatViewColor(settings.view == ViewMode::HeatTraversal, counters[pixel],
                                                   settings.heatFullScale);
                    } else if (!hit.hit()) {
                        color = settings.background;
                    } else {
                        const glm::uvec3 tri = scene.triangles[hit.prim];
                        const glm::vec3 v0 = scene.positions[tri.x];
                        const glm::vec3 v1 = scene.positions[tri.y];
                        const glm::vec3 v2 = scene.positions[tri.z];
                        glm::vec3 normal = gpu::geometricNormal(v0, v1, v2, dir);
                        if (scene.hasNormals())
                            normal = gpu::interpolatedNormal(scene.normals[tri.x], scene.normals[tri.y],
                                                             scene.normals[tri.z], hit.bary, normal, dir);
                        const glm::vec3 diffuse = diffuseAt(scene, hit.prim, hit.bary, dir, hit.t, pixelSpread);
                        color = gpu::shadeHit(phong, eye, dir, hit.t, normal, diffuse, light,
                                              shadowState[pixel] == gpu::kShadowOccluded);
                    }
                    frame.rgba[pixel] = gpu::packRgba8(glm::vec4(color, 1.0f));
                }
            }
        },
        tbb::simple_partitioner());
}

Frame renderCpu(const CpuSceneView& view, const RenderSettings& settings, const FrameRequest& request) {
    const Clock::time_point frameStart = Clock::now();
    RAYPACK_CHECK_MSG(view.scene && view.bvh, "a CpuSceneView made by makeCpuSceneView");
    const Scene& scene = *view.scene;
    const BvhNode* nodes = view.nodes();
    const GatheredTriangles triangles{view.leafVertices.data(), view.bvh->primIndices.data()};
    const uint32_t width = settings.width;
    const uint32_t height = settings.height;
    const gpu::GpuCamera camera = makeGpuCamera(settings.camera, width, height, settings.pixelJitter);
    const glm::vec3 eye = gpu::cameraEye(camera);
    const glm::vec3 light = lightPosition(settings.camera, view.bounds, settings.lightHeight);
    const size_t pixels = size_t(width) * height;

    Frame frame;
    frame.width = width;
    frame.height = height;
    frame.light = light;

    std::vector<ClosestHit> hits(pixels);
    std::vector<RayCounters> counters(pixels, RayCounters{0, 0, 0, 0});
    std::vector<uint32_t> shadowState(pixels, gpu::kShadowNone);

    const tbb::blocked_range2d<uint32_t> tiles(0, height, kTile, 0, width, kTile);
    const uint32_t stackEntries = view.stackEntries;

    // Pass 1: primary rays.
    Clock::time_point passStart = Clock::now();
    withIntersectMode(settings.intersect, [&](auto fast) {
        tbb::parallel_for(
            tiles,
            [&](const tbb::blocked_range2d<uint32_t>& tile) {
                std::vector<StackEntry> stack(stackEntries);
                forEachPixelInZOrder(tile, [&](uint32_t x, uint32_t y) {
                    const size_t pixel = size_t(y) * width + x;
                    const glm::vec3 dir = gpu::primaryRayDirection(camera, x, y);
                    TraversalCounts counts;
                    hits[pixel] =
                        closestHit<decltype(fast)::value>(nodes, triangles, gpu::makeTraceRay(eye, dir),
                                                          kRayTmaxInfinite, stack.data(), stackEntries, counts);
                    counters[pixel].primaryNodes = counts.nodes;
                    counters[pixel].primaryTests = counts.tests;
                });
            },
            tbb::simple_partitioner());
    });
    frame.timings.primarySeconds = secondsSince(passStart);

    // Pass 2: shadow rays from the light towards each hit point (report 2.3, 3.5).
    if (settings.shadows) {
        passStart = Clock::now();
        withIntersectMode(settings.intersect, [&](auto fast) {
            tbb::parallel_for(
                tiles,
                [&](const tbb::blocked_range2d<uint32_t>& tile) {
                    std::vector<StackEntry> stack(stackEntries);
                    forEachPixelInZOrder(tile, [&](uint32_t x, uint32_t y) {
                        const size_t pixel = size_t(y) * width + x;
                        const ClosestHit& hit = hits[pixel];
                        if (!hit.hit()) return;
                        const glm::vec3 dir = gpu::primaryRayDirection(camera, x, y);
                        const glm::vec3 point = gpu::hitPosition(eye, dir, hit.t);
                        const gpu::ShadowRay shadow = gpu::makeShadowRay(light, point, hit.prim);
                        bool occluded = false;
                        TraversalCounts counts;
                        if (!gpu::isDegenerateShadowRay(shadow))
                            occluded = anyHit<decltype(fast)::value>(
                                nodes, triangles, gpu::makeTraceRay(shadow.org, shadow.dir), shadow.tmax,
                                shadow.skipPrim, stack.data(), stackEntries, counts);
                        shadowState[pixel] = occluded ? gpu::kShadowOccluded : gpu::kShadowLit;
                        counters[pixel].shadowNodes = counts.nodes;
                        counters[pixel].shadowTests = counts.tests;
                    });
                },
                tbb::simple_partitioner());
        });
        frame.timings.shadowSeconds = secondsSince(passStart);
    }

    // Pass 3: shading (or heat map), hits and counters out.
    passStart = Clock::now();
    shadeCpuFrame(scene, settings, camera, hits, shadowState, counters, request, frame);
    frame.timings.shadeSeconds = secondsSince(passStart);
    if (request.counters) frame.counters = std::move(counters);
    frame.timings.totalSeconds = secondsSince(frameStart);
    return frame;
}

Frame renderCpu(const Scene& scene, const Bvh& bvh, const RenderSettings& settings, const FrameRequest& request) {
    const Clock::time_point start = Clock::now();
    const CpuSceneView view = makeCpuSceneView(scene, bvh);
    Frame frame = renderCpu(view, settings, request);
    frame.timings.totalSeconds = secondsSince(start);
    return frame;
}

}  // namespace raypack
