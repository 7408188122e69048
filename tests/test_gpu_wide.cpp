// The compressed 8-wide tree (issue 14; renderer/gpu_wide.h, shaders/wide_node.h, trace.comp's
// traceWide; docs/gpu.md): on the CPU, the tree itself (every reference in exactly one leaf slot,
// each node's triangles within its 24, each decoded child box containing everything below it, both
// as the float decoding and as the exact real planes the fused slab test uses); on lavapipe, the
// single-ray kernel over it gives the binary tree's hits and images byte for byte, on coherent,
// incoherent, deep, extreme-coordinate and axis-parallel rays, with every builder and leaf size.
#include "random_geometry.h"
#include "test_gpu_common.h"

#include "renderer/error.h"
#include "renderer/gpu_wide.h"
#include "scenes/generators.h"
#include "shaders/wide_node.h"

#include <oneapi/tbb/global_control.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <vector>

namespace raypack::test {
namespace {

Scene scaled(Scene scene, int exponent) {
    for (glm::vec3& p : scene.positions)
        p = glm::vec3(std::ldexp(p.x, exponent), std::ldexp(p.y, exponent), std::ldexp(p.z, exponent));
    return scene;
}

Scene firstTriangles(const Scene& from, uint32_t count) {
    Scene scene;
    for (uint32_t t = 0; t < count; ++t) {
        const uint32_t base = uint32_t(scene.positions.size());
        for (int c = 0; c < 3; ++c) scene.positions.push_back(from.vertex(t, c));
        scene.triangles.emplace_back(base, base + 1, base + 2);
    }
    return scene;
}

BvhBuildOptions options(BvhBuilder builder, uint32_t leafSize) {
    BvhBuildOptions o;
    o.builder = builder;
    o.leafSize = leafSize;
    return o;
}

// The exact real plane origin + scale * q, in double (exact for these operands' exponent ranges in
// the tests' scenes, and compared with a margin far below a grid step otherwise).
double realPlane(float origin, float scale, uint32_t q) { return double(origin) + double(scale) * double(q); }

uint32_t quantByte(const gpu::GpuWideNode& n, int plane, uint32_t slot) {
    const glm::uvec4& v = n.quant[plane / 2];
    const int pair = 2 * (plane % 2);
    return gpu::wideSlotValue(v[pair], v[pair + 1], slot);
}

// Walks the wide tree: every node reached once, each leaf slot's triangles within the node's 24 and
// counted once, and (for trees whose leaf boxes bound whole triangles) each child's decoded box
// containing the triangles below it. Returns the leaf-order slots reached, in the order found.
struct WalkResult {
    std::vector<uint32_t> slotsReached;
    uint32_t deepest = 0;
    uint64_t innerSlots = 0, leafSlots = 0;
};

void walk(const Scene& scene, const GpuWideTree& tree, uint32_t node, uint32_t depth, bool checkBoxes, Aabb* below,
          WalkResult& result) {
    ASSERT_LT(node, tree.nodes.size());
    result.deepest = std::max(result.deepest, depth);
    const gpu::GpuWideNode& n = tree.nodes[node];
    const glm::vec3 scale = gpu::wideScales(n);
    const uint32_t innerMask = glm::floatBitsToUint(n.origin.w) >> 24u;
    uint32_t innerSeen = 0;
    for (uint32_t slot = 0; slot < 8; ++slot) {
        const uint32_t meta = gpu::wideMeta(n, slot);
        if (meta == 0) {
            ASSERT_EQ(innerMask & (1u << slot), 0u) << "node " << node << ": an empty slot is not inner";
            continue;
        }
        Aabb content;
        if (innerMask & (1u << slot)) {
            ASSERT_EQ(meta, gpu::kWideInnerMeta | (24u + slot)) << "node " << node << " slot " << slot;
            ++result.innerSlots;
            walk(scene, tree, n.index.x + innerSeen++, depth + 1, checkBoxes, &content, result);
        } else {
            const uint32_t count = std::popcount(meta >> 5u), offset = meta & 31u;
            ASSERT_EQ(meta >> 5u, (1u << count) - 1u) << "node " << node << ": a leaf's count is unary";
            ASSERT_GE(count, 1u);
            ASSERT_LE(offset + count, gpu::kWideNodeTriangles) << "node " << node << " slot " << slot;
            ++result.leafSlots;
            for (uint32_t k = 0; k < count; ++k) {
                const uint32_t leafSlot = n.index.y + offset + k;
                ASSERT_LT(leafSlot, tree.order.size());
                result.slotsReached.push_back(leafSlot);
                content.grow(scene.triangleBounds(tree.order[leafSlot]));
            }
        }
        if (below) below->grow(content);
        if (!checkBoxes) continue;
        glm::vec3 lo, hi;
        gpu::wideChildBox(n, scale, slot, lo, hi);
        for (int axis = 0; axis < 3; ++axis) {
            SCOPED_TRACE("node " + std::to_string(node) + " slot " + std::to_string(slot) + " axis " +
                         std::to_string(axis));
            EXPECT_LE(lo[axis], content.lo[axis]);
            EXPECT_GE(hi[axis], content.hi[axis]);
            EXPECT_LE(realPlane(n.origin[axis], scale[axis], quantByte(n, axis, slot)), double(content.lo[axis]));
            EXPECT_GE(realPlane(n.origin[axis], scale[axis], quantByte(n, 3 + axis, slot)), double(content.hi[axis]));
        }
    }
    EXPECT_EQ(std::popcount(innerMask), int(innerSeen));
}

void expectValidWideTree(const Scene& scene, const BvhBuildOptions& o, const std::string& what) {
    SCOPED_TRACE(what + ", builder " + toString(o.builder) + ", leaf size " + std::to_string(o.leafSize));
    const Bvh bvh = buildBvh(scene, o);
    const GpuWideTree tree = makeGpuWideTree(scene, bvh);
    // The order is a permutation of the tree's references.
    std::vector<uint32_t> a = tree.order, b(bvh.primIndices.begin(), bvh.primIndices.end());
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    EXPECT_EQ(a, b);
    WalkResult result;
    // A spatial split's leaf bounds only the parts of its triangles inside it: boxes there are
    // checked by the hits (below), not against whole triangles.
    walk(scene, tree, 0, 0, o.builder != BvhBuilder::SahSplit, nullptr, result);
    std::vector<uint32_t> reached = result.slotsReached;
    std::sort(reached.begin(), reached.end());
    std::vector<uint32_t> every(tree.order.size());
    for (uint32_t i = 0; i < every.size(); ++i) every[i] = i;
    EXPECT_EQ(reached, every) << "every leaf-order slot in exactly one leaf";
    EXPECT_EQ(result.deepest, tree.maxDepth);
    EXPECT_EQ(result.innerSlots, tree.innerSlots);
    EXPECT_EQ(result.leafSlots, tree.leafSlots);
}

TEST(WideTree, EveryReferenceInOneLeafAndEveryBoxContainsItsChild) {
    const Scene base = makeDefaultScene();
    expectValidWideTree(base, options(BvhBuilder::SahExact, 1), "default scene");
    expectValidWideTree(base, options(BvhBuilder::SahBinned, 8), "default scene");  // leaves split in ranges
    expectValidWideTree(base, options(BvhBuilder::SahSplit, 2), "default scene");
    expectValidWideTree(scaled(base, 100), options(BvhBuilder::SahExact, 1), "default scene x 2^100");
    expectValidWideTree(scaled(base, -100), options(BvhBuilder::SahExact, 1), "default scene x 2^-100");
    expectValidWideTree(randomSliverSoup(3000, 0.2f, 2.0f, 14), options(BvhBuilder::SahExact, 1), "sliver soup");
    expectValidWideTree(makeDeepScene(kDeepSceneMaxTriangles), options(BvhBuilder::SahExact, 1), "deep scene");
    for (uint32_t count : {1u, 2u, 3u, 4u, 9u, 25u})
        expectValidWideTree(firstTriangles(base, count), options(BvhBuilder::SahExact, 1024),
                            std::to_string(count) + " triangles in one leaf");
}

// Large trees are collapsed in parallel parts spliced together (renderer/gpu_wide.cpp): the tree is
// valid and the same, byte for byte, on one thread and on all of them.
TEST(WideTree, ParallelPartsGiveTheSameTreeOnAnyNumberOfThreads) {
    const Scene scene = makeTerrain(100000);
    expectValidWideTree(scene, options(BvhBuilder::SahBinned, 1), "terrain 100k");
    const Bvh bvh = buildBvh(scene, options(BvhBuilder::SahBinned, 1));
    const GpuWideTree all = makeGpuWideTree(scene, bvh);
    GpuWideTree one;
    {
        tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
        one = makeGpuWideTree(scene, bvh);
    }
    ASSERT_EQ(one.nodes.size(), all.nodes.size());
    EXPECT_EQ(std::memcmp(one.nodes.data(), all.nodes.data(), all.nodes.size() * sizeof(gpu::GpuWideNode)), 0);
    EXPECT_EQ(one.order, all.order);
    EXPECT_EQ(one.maxDepth, all.maxDepth);
}

TEST(WideTree, AnEmptySceneHasARootWithoutChildren) {
    const Scene empty;
    const Bvh bvh = buildBvh(empty, BvhBuildOptions{});
    const GpuWideTree tree = makeGpuWideTree(empty, bvh);
    ASSERT_EQ(tree.nodes.size(), 1u);
    for (uint32_t slot = 0; slot < 8; ++slot) EXPECT_EQ(gpu::wideMeta(tree.nodes[0], slot), 0u);
    EXPECT_TRUE(tree.order.empty());
}

RenderSettings settingsFor(const Scene& scene, uint32_t width, uint32_t height) {
    RenderSettings settings;
    settings.width = width;
    settings.height = height;
    settings.kernel = KernelKind::Single;
    settings.camera = frameScene(scene.bounds());
    return settings;
}

// The 8-wide tree's hits and image equal the binary tree's, byte for byte, primary and shadow
// rays, with statistics off and on; and both meet the CPU reference's bars.
void expectWideEqualsBinary(const Scene& scene, const BvhBuildOptions& o, RenderSettings settings,
                            const std::string& what) {
    SCOPED_TRACE(what + ", builder " + toString(o.builder) + ", leaf size " + std::to_string(o.leafSize));
    const Bvh bvh = buildBvh(scene, o);
    GpuTracer tracer(validatedContext());
    const FrameRequest request{true, true, false};
    for (const bool shadows : {true, false}) {
        settings.shadows = shadows;
        settings.bvhWidth = 2;
        tracer.upload(scene, bvh, 2);
        const Frame binary = tracer.render(settings, request);
        settings.bvhWidth = 8;
        tracer.upload(scene, bvh, 8);
        const Frame wide = tracer.render(settings, request);
        EXPECT_TRUE(sameHits(wide, binary)) << (shadows ? "with shadows" : "without shadows");
        EXPECT_EQ(differingPixels(wide, binary), 0u) << (shadows ? "with shadows" : "without shadows");
        settings.collectCounters = true;
        const Frame counted = tracer.render(settings, FrameRequest{true, true, true});
        settings.collectCounters = false;
        EXPECT_TRUE(sameHits(counted, binary)) << "statistics variant";
        if (shadows) {
            // The hits against the CPU reference (the binary kernel's image against the reference's
            // is test_gpu_images' and test_gpu_shapes' business, on images large enough for its bar).
            const HitAgreement h = compareHits(wide, renderCpu(scene, bvh, settings, request));
            EXPECT_GE(double(h.agree), 0.9999 * double(h.rays)) << "hits agree on " << h.agree << " of " << h.rays;
            EXPECT_GE(double(h.shadowAgree), 0.999 * double(h.shadowRays))
                << "shadows agree on " << h.shadowAgree << " of " << h.shadowRays;
        }
    }
    expectNoValidationMessages();
}

TEST(GpuWide, HitsEqualTheBinaryTreesOnTheDefaultScene) {
    const Scene scene = makeDefaultScene();
    for (const auto& o :
         {options(BvhBuilder::SahExact, 1), options(BvhBuilder::SahSplit, 2), options(BvhBuilder::SahBinned, 8)})
        expectWideEqualsBinary(scene, o, settingsFor(scene, 96, 80), "default scene");
}

TEST(GpuWide, HitsEqualTheBinaryTreesOnSibenik) {
    const Scene scene = openScene(sharedScene("sibenik/sibenik_geom_75284.ply"));
    RenderSettings settings = settingsFor(scene, 160, 96);
    settings.camera.eye = glm::vec3(-18.0f, -11.0f, 0.0f);
    settings.camera.at = glm::vec3(0.0f, -8.0f, 0.0f);
    settings.camera.fovYDegrees = 70.0f;
    expectWideEqualsBinary(scene, options(BvhBuilder::SahExact, 1), settings, "Sibenik");
}

TEST(GpuWide, HitsEqualTheBinaryTreesOnIncoherentDeepAndExtremeScenes) {
    const Scene soup = randomSliverSoup(3000, 0.2f, 2.0f, 14);
    expectWideEqualsBinary(soup, options(BvhBuilder::SahExact, 1), settingsFor(soup, 64, 64), "sliver soup");
    const Scene deep = makeDeepScene(kDeepSceneMaxTriangles);
    expectWideEqualsBinary(deep, options(BvhBuilder::SahExact, 1), settingsFor(deep, 48, 48), "deep scene");
    const Scene base = makeDefaultScene();
    for (const int exponent : {100, -100}) {
        const Scene far = scaled(base, exponent);
        expectWideEqualsBinary(far, options(BvhBuilder::SahExact, 1), settingsFor(far, 64, 48),
                               "default scene x 2^" + std::to_string(exponent));
    }
    for (uint32_t count : {1u, 3u, 25u}) {
        const Scene few = firstTriangles(base, count);
        expectWideEqualsBinary(few, options(BvhBuilder::SahExact, 1024), settingsFor(few, 32, 32),
                               std::to_string(count) + " triangles in one leaf");
    }
}

// A camera on an axis looking along another: the centre column and row of rays have direction
// components of exactly 0, which take the decoded-box path (invDir 0 on parallel axes).
TEST(GpuWide, RaysParallelToAnAxisTakeTheDecodedBoxes) {
    const Scene scene = makeDefaultScene();
    RenderSettings settings = settingsFor(scene, 65, 65);
    const Aabb box = scene.bounds();
    const glm::vec3 centre = box.center();
    settings.camera.eye = glm::vec3(centre.x, centre.y, box.hi.z + 2.0f * (box.hi.z - box.lo.z));
    settings.camera.at = centre;
    settings.camera.up = glm::vec3(0.0f, 1.0f, 0.0f);
    expectWideEqualsBinary(scene, options(BvhBuilder::SahExact, 1), settings, "axis-aligned view");
}

TEST(GpuWide, AnEmptySceneMissesEverywhere) {
    const Scene empty;
    const Bvh bvh = buildBvh(empty, BvhBuildOptions{});
    GpuTracer tracer(validatedContext());
    tracer.upload(empty, bvh, 8);
    RenderSettings settings;
    settings.width = settings.height = 16;
    settings.kernel = KernelKind::Single;
    settings.bvhWidth = 8;
    const Frame frame = tracer.render(settings, FrameRequest{true, true, false});
    for (const HitRecord& h : frame.hits) EXPECT_EQ(h.prim, gpu::kNoHit);
    expectNoValidationMessages();
}

TEST(GpuWide, SettingsThatDoNotFitTheTreeAreErrors) {
    const Scene scene = makeDefaultScene();
    const Bvh bvh = buildBvh(scene, BvhBuildOptions{});
    GpuTracer tracer(validatedContext());
    EXPECT_THROW(tracer.upload(scene, bvh, 4), Error);
    tracer.upload(scene, bvh, 8);
    RenderSettings settings = settingsFor(scene, 16, 16);
    EXPECT_THROW(tracer.render(settings, FrameRequest{}), Error);  // width 2 asked of an 8-wide upload
    settings.bvhWidth = 8;
    settings.kernel = KernelKind::Packet;
    EXPECT_THROW(tracer.render(settings, FrameRequest{}), Error);
    settings.kernel = KernelKind::Single;
    settings.shadowOrder = ShadowOrder::Larger;
    EXPECT_THROW(tracer.render(settings, FrameRequest{}), Error);
    EXPECT_THROW(tracer.downloadBvh(), Error);
    settings.shadowOrder = ShadowOrder::Nearest;
    EXPECT_NO_THROW(tracer.render(settings, FrameRequest{}));
    expectNoValidationMessages();
}

}  // namespace
}  // namespace raypack::test
