#pragma once
// Both children of a canonical BVH inner node (renderer/bvh.h: siblings adjacent) tested against
// one ray at once, with SSE on x86-64 (SSE2 is part of the x86-64 baseline, so no dispatch is
// needed and the binary runs on any x86-64). Used by the CPU reference tracer (cpu_tracer.cpp).
//
// Exactness: for each child this computes bit for bit the result of gpu::intersectBox, or of
// gpu::intersectBoxFast for a ray made with `fast` (shaders/intersect.h), which the GPU kernels and every test of the
// reference use:
//  - the same operations in the same order: (lo - org) * invDir, (hi - org) * invDir, a min and a
//    max per axis, max(max(x, y), max(z, 0)) for the entry, min(min(x, y), z) * kSlabFarWiden for
//    the exit, then entry <= min(exit, tmax * kBoxTmaxWiden). IEEE single precision, rounding to
//    nearest, no fused multiply-add (raypack builds as ISO C++, -ffp-contract=off, and intrinsics
//    are never contracted);
//  - glm's scalar min(x, y) is (y < x) ? y : x and max(x, y) is (x < y) ? y : x, while SSE's
//    minps(a, b) is (a < b) ? a : b and maxps(a, b) is (a > b) ? a : b. So glm::min(x, y) is
//    exactly _mm_min_ps(y, x) and glm::max(x, y) exactly _mm_max_ps(y, x), signed zeros and NaN
//    included; every call below passes its operands in that swapped order.
// Rays parallel to an axis (gpu::TraceRay::anyParallel) take gpu::intersectBox itself: they are
// rare, and its parallel-axis rule is not worth a second copy.
// tests/test_cpu_tracer.cpp (ChildBoxes.*) checks the equality on random and adversarial boxes.
#include "renderer/bvh.h"
#include "shaders/intersect.h"

#include <cstddef>
#include <cstdint>

#if defined(__SSE2__)
#include <emmintrin.h>
#define RAYPACK_CPU_BOX_PAIR_SSE 1
#else
#define RAYPACK_CPU_BOX_PAIR_SSE 0
#endif

namespace raypack {

static_assert(offsetof(BvhNode, lo) == 0 && offsetof(BvhNode, hi) == 16,
              "intersectChildBoxes reads lo and hi as the 16-byte halves of a BvhNode");

// What the pair test needs of a ray, set up once per ray. The children's boxes are read
// transposed: lanes (left.x, right.x, left.y, right.y) for x and y, and (left, right) x (lo, hi)
// for z, so that the packed index/count words of BvhNode never enter the arithmetic (as floats
// they would be denormals, which some x86 cores handle in slow microcode).
struct ChildBoxRay {
    const gpu::TraceRay* ray = nullptr;
    bool parallel = false;  // ray->anyParallel: use gpu::intersectBox per child
#if RAYPACK_CPU_BOX_PAIR_SSE
    __m128 orgXY;  // (org.x, org.x, org.y, org.y)
    __m128 invXY;  // (invDir.x, invDir.x, invDir.y, invDir.y)
    __m128 orgZ;   // org.z in every lane
    __m128 invZ;   // invDir.z in every lane
    // tmax * tmaxWiden in every lane, for the tmax of the last setTmax: the product intersectBox
    // forms per call, formed here once per change of tmax (a closer hit).
    __m128 tmaxWidened;
    __m128 farWidenLanes;  // farWiden in every lane
#endif
    float tmax = 0.0f;
    // gpu::intersectBoxWidened's factors: Ize's (gpu::intersectBox), or 1 and 1 for the plain
    // slab test of IntersectMode::Fast (gpu::intersectBoxFast).
    float farWiden = gpu::kSlabFarWiden;
    float tmaxWiden = gpu::kBoxTmaxWiden;

    void setTmax(float newTmax) {
        tmax = newTmax;
#if RAYPACK_CPU_BOX_PAIR_SSE
        tmaxWidened = _mm_set1_ps(newTmax * tmaxWiden);
#endif
    }
};

// `fast`: the plain slab test (IntersectMode::Fast) instead of the conservative one.
inline ChildBoxRay makeChildBoxRay(const gpu::TraceRay& ray, float tmax, bool fast = false) {
    ChildBoxRay pair;
    pair.ray = &ray;
    pair.parallel = ray.anyParallel;
    pair.farWiden = fast ? 1.0f : gpu::kSlabFarWiden;
    pair.tmaxWiden = fast ? 1.0f : gpu::kBoxTmaxWiden;
#if RAYPACK_CPU_BOX_PAIR_SSE
    pair.farWidenLanes = _mm_set1_ps(pair.farWiden);
#endif
#if RAYPACK_CPU_BOX_PAIR_SSE
    pair.orgXY = _mm_setr_ps(ray.org.x, ray.org.x, ray.org.y, ray.org.y);
    pair.invXY = _mm_setr_ps(ray.invDir.x, ray.invDir.x, ray.invDir.y, ray.invDir.y);
    pair.orgZ = _mm_set1_ps(ray.org.z);
    pair.invZ = _mm_set1_ps(ray.invDir.z);
#endif
    pair.setTmax(tmax);
    return pair;
}

// What intersectChildBoxes finds: which children the ray may touch and their entry distances.
struct ChildBoxHits {
    uint32_t mask;  // bit 0: the left child may be hit, bit 1: the right one
    float tLeft;    // entry distances as gpu::intersectBox gives them (also for a miss)
    float tRight;
};

// Tests children[0] (left) and children[1] (right) for t in [0, pair.tmax].
__attribute__((always_inline)) inline ChildBoxHits intersectChildBoxes(const ChildBoxRay& pair,
                                                                       const BvhNode* children) {
#if RAYPACK_CPU_BOX_PAIR_SSE
    if (!pair.parallel) {
        // BvhNode is {vec3 lo; uint32 index; vec3 hi; uint32 count}: 16-byte halves.
        const float* left = &children[0].lo.x;
        const float* right = &children[1].lo.x;
        const __m128 leftLo = _mm_loadu_ps(left);
        const __m128 leftHi = _mm_loadu_ps(left + 4);
        const __m128 rightLo = _mm_loadu_ps(right);
        const __m128 rightHi = _mm_loadu_ps(right + 4);
        // x and y: lanes (left.x, right.x, left.y, right.y).
        const __m128 loXY = _mm_unpacklo_ps(leftLo, rightLo);
        const __m128 hiXY = _mm_unpacklo_ps(leftHi, rightHi);
        // z: lanes (left.lo.z, right.lo.z, left.hi.z, right.hi.z).
        const __m128 loHiZ = _mm_movelh_ps(_mm_unpackhi_ps(leftLo, rightLo), _mm_unpackhi_ps(leftHi, rightHi));
        // tLo = (lo - org) * invDir, tHi = (hi - org) * invDir.
        const __m128 tLoXY = _mm_mul_ps(_mm_sub_ps(loXY, pair.orgXY), pair.invXY);
        const __m128 tHiXY = _mm_mul_ps(_mm_sub_ps(hiXY, pair.orgXY), pair.invXY);
        const __m128 tLoHiZ = _mm_mul_ps(_mm_sub_ps(loHiZ, pair.orgZ), pair.invZ);
        const __m128 tHiZ = _mm_movehl_ps(tLoHiZ, tLoHiZ);  // lanes 0, 1: hi.z of left, right
        // tNear3 = min(tLo, tHi), tFar3 = max(tLo, tHi) (glm order: operands swapped).
        const __m128 nearXY = _mm_min_ps(tHiXY, tLoXY);
        const __m128 farXY = _mm_max_ps(tHiXY, tLoXY);
        const __m128 nearZ = _mm_min_ps(tHiZ, tLoHiZ);
        const __m128 farZ = _mm_max_ps(tHiZ, tLoHiZ);
        const __m128 nearY = _mm_movehl_ps(nearXY, nearXY);
        const __m128 farY = _mm_movehl_ps(farXY, farXY);
        // tNear = max(max(near.x, near.y), max(near.z, 0)).
        const __m128 nearMaxXY = _mm_max_ps(nearY, nearXY);
        const __m128 nearMaxZ0 = _mm_max_ps(_mm_setzero_ps(), nearZ);
        const __m128 tNear = _mm_max_ps(nearMaxZ0, nearMaxXY);
        // tFar = min(min(far.x, far.y), far.z) * farWiden.
        const __m128 farMinXY = _mm_min_ps(farY, farXY);
        const __m128 tFar = _mm_mul_ps(_mm_min_ps(farZ, farMinXY), pair.farWidenLanes);
        // tNear <= min(tFar, tmax * tmaxWiden).
        const __m128 limit = _mm_min_ps(pair.tmaxWidened, tFar);
        ChildBoxHits hits;
        hits.mask = uint32_t(_mm_movemask_ps(_mm_cmple_ps(tNear, limit))) & 3u;
        hits.tLeft = _mm_cvtss_f32(tNear);
        hits.tRight = _mm_cvtss_f32(_mm_shuffle_ps(tNear, tNear, 1));
        return hits;
    }
#endif
    const gpu::TraceRay& ray = *pair.ray;
    ChildBoxHits hits;
    const bool hitLeft = gpu::intersectBoxWidened(ray, children[0].lo, children[0].hi, pair.tmax, pair.farWiden,
                                                  pair.tmaxWiden, hits.tLeft);
    const bool hitRight = gpu::intersectBoxWidened(ray, children[1].lo, children[1].hi, pair.tmax, pair.farWiden,
                                                   pair.tmaxWiden, hits.tRight);
    hits.mask = (hitLeft ? 1u : 0u) | (hitRight ? 2u : 0u);
    return hits;
}

}  // namespace raypack
