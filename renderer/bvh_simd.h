#pragma once
// Four float lanes for the binned BVH builder (renderer/bvh_sah_binned.cpp): boxes and centroids
// as (x, y, z, w) vectors, so a box grows by one min and one max and a centroid maps to its three
// bins by one subtract, multiply, clamp and truncation. SSE2 is part of the x86-64 baseline, so no
// runtime dispatch is needed; elsewhere the same operations run on plain arrays.
//
// Exactness: every lane is computed by the same IEEE single-precision operation the scalar code
// would use (raypack builds with -ffp-contract=off, and intrinsics are never contracted), so the
// builder's bins and boxes do not depend on which path compiled it.
#include <glm/vec3.hpp>

#include <cstdint>

#if defined(__SSE2__)
#include <emmintrin.h>
#define RAYPACK_BVH_SIMD_SSE 1
#else
#define RAYPACK_BVH_SIMD_SSE 0
#endif

namespace raypack::bvh_detail::simd {

// Four int32 lanes (bin indices), read by lane.
struct I4 {
    alignas(16) int32_t lane[4];
    int32_t operator[](int i) const { return lane[i]; }
};

#if RAYPACK_BVH_SIMD_SSE
struct F4 {
    __m128 v;

    static F4 load(const float* aligned16) { return {_mm_load_ps(aligned16)}; }
    static F4 set(float x, float y, float z, float w) { return {_mm_setr_ps(x, y, z, w)}; }
    static F4 splat(float value) { return {_mm_set1_ps(value)}; }
    static F4 zero() { return {_mm_setzero_ps()}; }
    // minps(a, b) is (a < b) ? a : b: without NaN and -0 (the builder has neither) the same as
    // std::min / glm::min in either operand order.
    static F4 min(const F4& a, const F4& b) { return {_mm_min_ps(a.v, b.v)}; }
    static F4 max(const F4& a, const F4& b) { return {_mm_max_ps(a.v, b.v)}; }
    F4 operator+(const F4& o) const { return {_mm_add_ps(v, o.v)}; }
    F4 operator-(const F4& o) const { return {_mm_sub_ps(v, o.v)}; }
    F4 operator*(const F4& o) const { return {_mm_mul_ps(v, o.v)}; }
    // Keeps lanes 0-2 and clears lane 3.
    F4 xyzOnly() const { return {_mm_and_ps(v, _mm_castsi128_ps(_mm_setr_epi32(-1, -1, -1, 0)))}; }
    float operator[](int i) const {
        alignas(16) float lanes[4];
        _mm_store_ps(lanes, v);
        return lanes[i];
    }
    glm::vec3 xyz() const {
        alignas(16) float lanes[4];
        _mm_store_ps(lanes, v);
        return {lanes[0], lanes[1], lanes[2]};
    }
};

// Truncation toward zero of lanes known to lie in [0, 2^31).
inline I4 truncate(const F4& f) {
    I4 result;
    _mm_store_si128(reinterpret_cast<__m128i*>(result.lane), _mm_cvttps_epi32(f.v));
    return result;
}
#else
struct F4 {
    float v[4];

    static F4 load(const float* p) { return {{p[0], p[1], p[2], p[3]}}; }
    static F4 set(float x, float y, float z, float w) { return {{x, y, z, w}}; }
    static F4 splat(float value) { return {{value, value, value, value}}; }
    static F4 zero() { return splat(0.0f); }
    static F4 min(const F4& a, const F4& b) {
        F4 r;
        for (int i = 0; i < 4; ++i) r.v[i] = a.v[i] < b.v[i] ? a.v[i] : b.v[i];
        return r;
    }
    static F4 max(const F4& a, const F4& b) {
        F4 r;
        for (int i = 0; i < 4; ++i) r.v[i] = a.v[i] > b.v[i] ? a.v[i] : b.v[i];
        return r;
    }
    F4 operator+(const F4& o) const { return {{v[0] + o.v[0], v[1] + o.v[1], v[2] + o.v[2], v[3] + o.v[3]}}; }
    F4 operator-(const F4& o) const { return {{v[0] - o.v[0], v[1] - o.v[1], v[2] - o.v[2], v[3] - o.v[3]}}; }
    F4 operator*(const F4& o) const { return {{v[0] * o.v[0], v[1] * o.v[1], v[2] * o.v[2], v[3] * o.v[3]}}; }
    F4 xyzOnly() const { return {{v[0], v[1], v[2], 0.0f}}; }
    float operator[](int i) const { return v[i]; }
    glm::vec3 xyz() const { return {v[0], v[1], v[2]}; }
};

inline I4 truncate(const F4& f) { return {{int32_t(f.v[0]), int32_t(f.v[1]), int32_t(f.v[2]), int32_t(f.v[3])}}; }
#endif

#if RAYPACK_BVH_SIMD_SSE
// Half the surface area of the box (lo, hi), lanes 0-2, in double: the same operations in the same
// order as SahMeasure::halfArea (renderer/bvh_build.h), so the same value, without its empty-box
// check (callers price only boxes that hold something).
inline double halfArea(const F4& lo, const F4& hi) {
    const __m128d extentXY = _mm_sub_pd(_mm_cvtps_pd(hi.v), _mm_cvtps_pd(lo.v));
    const __m128d extentZ =
        _mm_sub_sd(_mm_cvtps_pd(_mm_movehl_ps(hi.v, hi.v)), _mm_cvtps_pd(_mm_movehl_ps(lo.v, lo.v)));
    const double ex = _mm_cvtsd_f64(extentXY), ey = _mm_cvtsd_f64(_mm_unpackhi_pd(extentXY, extentXY));
    const double ez = _mm_cvtsd_f64(extentZ);
    return ex * ey + ey * ez + ez * ex;
}
#else
inline double halfArea(const F4& lo, const F4& hi) {
    const double ex = double(hi.v[0]) - double(lo.v[0]);
    const double ey = double(hi.v[1]) - double(lo.v[1]);
    const double ez = double(hi.v[2]) - double(lo.v[2]);
    return ex * ey + ey * ez + ez * ex;
}
#endif

// Half the surface areas of boxes (lo[i], hi[i]), i < count, with the extents multiplied by
// `scale`, four boxes at a time, into out[i]. Reads and writes up to 3 entries past `count`
// (callers pad their arrays).
inline void scaledHalfAreas(const F4* lo, const F4* hi, uint32_t count, float scale, float* out) {
    const F4 factor = F4::splat(scale);
    for (uint32_t i = 0; i < count; i += 4) {
#if RAYPACK_BVH_SIMD_SSE
        __m128 e0 = ((hi[i] - lo[i]) * factor).v, e1 = ((hi[i + 1] - lo[i + 1]) * factor).v;
        __m128 e2 = ((hi[i + 2] - lo[i + 2]) * factor).v, e3 = ((hi[i + 3] - lo[i + 3]) * factor).v;
        _MM_TRANSPOSE4_PS(e0, e1, e2, e3);  // e0: four x extents, e1: y, e2: z
        const __m128 area = _mm_add_ps(_mm_add_ps(_mm_mul_ps(e0, e1), _mm_mul_ps(e1, e2)), _mm_mul_ps(e2, e0));
        _mm_storeu_ps(out + i, area);
#else
        for (uint32_t k = i; k < i + 4; ++k) {
            const F4 e = (hi[k] - lo[k]) * factor;
            out[k] = e.v[0] * e.v[1] + e.v[1] * e.v[2] + e.v[2] * e.v[0];
        }
#endif
    }
}

// SAH prices of `count` candidates, four at a time: leftArea·(total - rightCount) +
// rightArea·rightCount, into out[i]. Reads and writes up to 3 entries past `count`.
inline void sahPrices(const float* leftArea, const float* rightArea, const float* rightCount, float total,
                      uint32_t count, float* out) {
    for (uint32_t i = 0; i < count; i += 4) {
#if RAYPACK_BVH_SIMD_SSE
        const __m128 right = _mm_loadu_ps(rightCount + i);
        const __m128 left = _mm_sub_ps(_mm_set1_ps(total), right);
        _mm_storeu_ps(out + i, _mm_add_ps(_mm_mul_ps(_mm_loadu_ps(leftArea + i), left),
                                          _mm_mul_ps(_mm_loadu_ps(rightArea + i), right)));
#else
        for (uint32_t k = i; k < i + 4; ++k)
            out[k] = leftArea[k] * (total - rightCount[k]) + rightArea[k] * rightCount[k];
#endif
    }
}

// The centroid as centroidOf (renderer/bvh_build.h) computes it, 0.5·lo + 0.5·hi, on lanes 0-2;
// lane 3 is 0 (the box's lane 3 may hold other data, which must not enter the arithmetic: as a
// float it can be a denormal, which some x86 cores handle in slow microcode).
inline F4 centroidXYZ(const F4& lo, const F4& hi) {
    const F4 half = F4::splat(0.5f);
    return (half * lo.xyzOnly()) + (half * hi.xyzOnly());
}

}  // namespace raypack::bvh_detail::simd
