// The packet kernel, SIMD over rays; included by cpu_packet_sse41.cpp and cpu_packet_avx2.cpp only,
// after every system header and inside their `#pragma GCC target`, with RAYPACK_PACKET_AVX2 set
// to 1 or 0. Everything here has internal linkage (an anonymous namespace), so the two widths'
// code never meets at link time. renderer/cpu_packet_tracer.h describes the traversal.
//
// Exactness: every per-ray value below is the one shaders/intersect.h computes, operation for
// operation in IEEE single precision (no FMA: the target pragma does not enable it, and
// raypack builds with -ffp-contract=off):
//  - glm's min(x, y) is (y < x) ? y : x and max(x, y) is (x < y) ? y : x; SSE/AVX minps(a, b) is
//    (a < b) ? a : b and maxps(a, b) is (a > b) ? a : b, so glm::min(x, y) == minps(y, x)
//    (see renderer/cpu_box_pair.h), which S::glmMin / S::glmMax spell out;
//  - a ray's axis permutation (kx, ky, kz of gpu::TraceRay) differs between lanes when their
//    largest direction component does: the permuted vertex components are selected per lane (or
//    broadcast when every lane of the group has the same axes), and v[kx] - org[kx] is exactly
//    the scalar code's a[kx];
//  - rays parallel to an axis (gpu::TraceRay::anyParallel) take gpu::intersectBox lane by lane.
// The closest hit is the least (t, triangle index) over every triangle test that hits, so it does
// not depend on visiting order, and a packet visits every node any of its rays' own box tests
// accept (the interval test and the first-hit range only skip nodes that every skipped ray's own
// test rejects), so each ray finds exactly the reference's hit.

#ifndef RAYPACK_PACKET_AVX2
#error "define RAYPACK_PACKET_AVX2 before including cpu_packet_simd.inl"
#endif

namespace raypack::packet_detail {
namespace {

#define RP_SIMD_INLINE inline __attribute__((always_inline))

#if RAYPACK_PACKET_AVX2
struct Simd {
    static constexpr int kLanes = 8;
    // A group of 8 rays is 4 x 2 pixels.
    static constexpr uint32_t kBlockW = 4;
    static constexpr uint32_t kBlockH = 2;
    using F = __m256;
    using I = __m256i;
    static RP_SIMD_INLINE F set1(float v) { return _mm256_set1_ps(v); }
    static RP_SIMD_INLINE F load(const float* p) { return _mm256_loadu_ps(p); }
    static RP_SIMD_INLINE F loadBits(const uint32_t* p) {
        return _mm256_castsi256_ps(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)));
    }
    static RP_SIMD_INLINE void store(float* p, F v) { _mm256_storeu_ps(p, v); }
    static RP_SIMD_INLINE void storeBits(uint32_t* p, F v) {
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), _mm256_castps_si256(v));
    }
    static RP_SIMD_INLINE F add(F a, F b) { return _mm256_add_ps(a, b); }
    static RP_SIMD_INLINE F sub(F a, F b) { return _mm256_sub_ps(a, b); }
    static RP_SIMD_INLINE F mul(F a, F b) { return _mm256_mul_ps(a, b); }
    static RP_SIMD_INLINE F div(F a, F b) { return _mm256_div_ps(a, b); }
    static RP_SIMD_INLINE F glmMin(F x, F y) { return _mm256_min_ps(y, x); }
    static RP_SIMD_INLINE F glmMax(F x, F y) { return _mm256_max_ps(y, x); }
    static RP_SIMD_INLINE F lt(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
    static RP_SIMD_INLINE F le(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
    static RP_SIMD_INLINE F gt(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
    static RP_SIMD_INLINE F eq(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_EQ_OQ); }
    static RP_SIMD_INLINE F andF(F a, F b) { return _mm256_and_ps(a, b); }
    static RP_SIMD_INLINE F orF(F a, F b) { return _mm256_or_ps(a, b); }
    static RP_SIMD_INLINE F andNot(F a, F b) { return _mm256_andnot_ps(a, b); }  // ~a & b
    static RP_SIMD_INLINE F xorF(F a, F b) { return _mm256_xor_ps(a, b); }
    // mask ? ifTrue : ifFalse, lane by lane (mask lanes all ones or all zeros).
    static RP_SIMD_INLINE F select(F mask, F ifTrue, F ifFalse) {
        return _mm256_blendv_ps(ifFalse, ifTrue, mask);
    }
    static RP_SIMD_INLINE uint32_t bits(F mask) { return uint32_t(_mm256_movemask_ps(mask)); }
    static RP_SIMD_INLINE F fromBits(uint32_t laneBits) {
        const I bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        const I set = _mm256_and_si256(_mm256_set1_epi32(int(laneBits)), bit);
        return _mm256_castsi256_ps(_mm256_cmpeq_epi32(set, bit));
    }
    static RP_SIMD_INLINE F set1Bits(uint32_t v) {
        return _mm256_castsi256_ps(_mm256_set1_epi32(int(v)));
    }
    // Unsigned a < b lane by lane, on uint32 values held in float lanes.
    static RP_SIMD_INLINE F ltU32(F a, F b) {
        const I flip = _mm256_set1_epi32(int(0x80000000u));
        const I ia = _mm256_xor_si256(_mm256_castps_si256(a), flip);
        const I ib = _mm256_xor_si256(_mm256_castps_si256(b), flip);
        return _mm256_castsi256_ps(_mm256_cmpgt_epi32(ib, ia));
    }
    static RP_SIMD_INLINE F neU32(F a, F b) {
        const I equal = _mm256_cmpeq_epi32(_mm256_castps_si256(a), _mm256_castps_si256(b));
        return _mm256_castsi256_ps(_mm256_xor_si256(equal, _mm256_set1_epi32(-1)));
    }
    // The power of two of shaders/intersect.h that brings `largest` to [0.5, 1):
    // 2^clamp(126 - biasedExponent, -126, 126), from its bits.
    static RP_SIMD_INLINE F scaleFor(F largest) {
        const I biased = _mm256_and_si256(_mm256_srli_epi32(_mm256_castps_si256(largest), 23),
                                          _mm256_set1_epi32(255));
        I exponent = _mm256_sub_epi32(_mm256_set1_epi32(126), biased);
        exponent = _mm256_min_epi32(_mm256_max_epi32(exponent, _mm256_set1_epi32(-126)),
                                    _mm256_set1_epi32(126));
        return _mm256_castsi256_ps(
            _mm256_slli_epi32(_mm256_add_epi32(exponent, _mm256_set1_epi32(127)), 23));
    }
};
#else
struct Simd {
    static constexpr int kLanes = 4;
    // A group of 4 rays is 2 x 2 pixels.
    static constexpr uint32_t kBlockW = 2;
    static constexpr uint32_t kBlockH = 2;
    using F = __m128;
    using I = __m128i;
    static RP_SIMD_INLINE F set1(float v) { return _mm_set1_ps(v); }
    static RP_SIMD_INLINE F load(const float* p) { return _mm_loadu_ps(p); }
    static RP_SIMD_INLINE F loadBits(const uint32_t* p) {
        return _mm_castsi128_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
    }
    static RP_SIMD_INLINE void store(float* p, F v) { _mm_storeu_ps(p, v); }
    static RP_SIMD_INLINE void storeBits(uint32_t* p, F v) {
        _mm_storeu_si128(reinterpret_cast<__m128i*>(p), _mm_castps_si128(v));
    }
    static RP_SIMD_INLINE F add(F a, F b) { return _mm_add_ps(a, b); }
    static RP_SIMD_INLINE F sub(F a, F b) { return _mm_sub_ps(a, b); }
    static RP_SIMD_INLINE F mul(F a, F b) { return _mm_mul_ps(a, b); }
    static RP_SIMD_INLINE F div(F a, F b) { return _mm_div_ps(a, b); }
    static RP_SIMD_INLINE F glmMin(F x, F y) { return _mm_min_ps(y, x); }
    static RP_SIMD_INLINE F glmMax(F x, F y) { return _mm_max_ps(y, x); }
    static RP_SIMD_INLINE F lt(F a, F b) { return _mm_cmplt_ps(a, b); }
    static RP_SIMD_INLINE F le(F a, F b) { return _mm_cmple_ps(a, b); }
    static RP_SIMD_INLINE F gt(F a, F b) { return _mm_cmpgt_ps(a, b); }
    static RP_SIMD_INLINE F eq(F a, F b) { return _mm_cmpeq_ps(a, b); }
    static RP_SIMD_INLINE F andF(F a, F b) { return _mm_and_ps(a, b); }
    static RP_SIMD_INLINE F orF(F a, F b) { return _mm_or_ps(a, b); }
    static RP_SIMD_INLINE F andNot(F a, F b) { return _mm_andnot_ps(a, b); }  // ~a & b
    static RP_SIMD_INLINE F xorF(F a, F b) { return _mm_xor_ps(a, b); }
    static RP_SIMD_INLINE F select(F mask, F ifTrue, F ifFalse) {
        return _mm_blendv_ps(ifFalse, ifTrue, mask);
    }
    static RP_SIMD_INLINE uint32_t bits(F mask) { return uint32_t(_mm_movemask_ps(mask)); }
    static RP_SIMD_INLINE F fromBits(uint32_t laneBits) {
        const I bit = _mm_setr_epi32(1, 2, 4, 8);
        const I set = _mm_and_si128(_mm_set1_epi32(int(laneBits)), bit);
        return _mm_castsi128_ps(_mm_cmpeq_epi32(set, bit));
    }
    static RP_SIMD_INLINE F set1Bits(uint32_t v) { return _mm_castsi128_ps(_mm_set1_epi32(int(v))); }
    static RP_SIMD_INLINE F ltU32(F a, F b) {
        const I flip = _mm_set1_epi32(int(0x80000000u));
        const I ia = _mm_xor_si128(_mm_castps_si128(a), flip);
        const I ib = _mm_xor_si128(_mm_castps_si128(b), flip);
        return _mm_castsi128_ps(_mm_cmplt_epi32(ia, ib));
    }
    static RP_SIMD_INLINE F neU32(F a, F b) {
        const I equal = _mm_cmpeq_epi32(_mm_castps_si128(a), _mm_castps_si128(b));
        return _mm_castsi128_ps(_mm_xor_si128(equal, _mm_set1_epi32(-1)));
    }
    static RP_SIMD_INLINE F scaleFor(F largest) {
        const I biased =
            _mm_and_si128(_mm_srli_epi32(_mm_castps_si128(largest), 23), _mm_set1_epi32(255));
        I exponent = _mm_sub_epi32(_mm_set1_epi32(126), biased);
        exponent = _mm_min_epi32(_mm_max_epi32(exponent, _mm_set1_epi32(-126)), _mm_set1_epi32(126));
        return _mm_castsi128_ps(_mm_slli_epi32(_mm_add_epi32(exponent, _mm_set1_epi32(127)), 23));
    }
};
#endif

constexpr int L = Simd::kLanes;
using F = Simd::F;
constexpr uint32_t kNoHit = 0xFFFFFFFFu;
constexpr uint32_t kAllLanes = (1u << L) - 1u;
// The tmax of a lane that takes no part any more (padding, occluded shadow ray): every box test's
// entry distance is >= 0 and every triangle hit's t >= 0, so nothing passes `<= -1`.
constexpr float kLaneDone = -1.0f;

// One SIMD width of rays, structure of arrays. Lanes are 2x2 (SSE) or 4x2 (AVX2) pixels.
struct alignas(64) RayGroup {
    // Slab test: origin and 1/dir (0 on parallel axes).
    float orgX[L], orgY[L], orgZ[L];
    float invX[L], invY[L], invZ[L];
    // Triangle test: origin permuted to (kx, ky, kz), the shear, per-axis lane masks of kx, ky, kz.
    float orgK[3][L];
    float shearX[L], shearY[L], shearZ[L];
    uint32_t axisIs0[3][L];  // axisIs0[j][lane]: all ones when axis j (kx, ky, kz) of the lane is 0
    uint32_t axisIs1[3][L];
    // Closest hit so far (primary) or the ray's tmax (shadow); kLaneDone for done lanes.
    float tmax[L];
    float baryU[L], baryV[L];
    uint32_t prim[L];  // primary: closest triangle so far; shadow: the triangle to skip
    uint32_t nodes[L], tests[L];
    uint32_t pixel[L];
    uint32_t activeBits;    // lanes still tracing
    uint32_t occludedBits;  // shadow: lanes that found an occluder
    int32_t axis[3];        // kx, ky, kz when every lane shares them, else -1
    bool anyParallel;
    gpu::TraceRay rays[L];
};

// The interval test of a whole packet (Wald 2007's frustum, in Reshetov 2005's interval form):
// with one origin for every ray, (lo - org) * invDir is monotone in invDir and so is its
// rounding, so the four products of a slab's ends with the bounds of the rays' invDir bound every
// ray's own near and far distance on that axis; a box whose bounds say no ray can hit it is
// culled. Disabled when the rays do not share the origin or one is parallel to an axis.
struct PacketInterval {
    bool enabled = false;
    float org[3];
    float invMin[3];
    float invMax[3];
    float tmaxWidened;  // the largest tmax of any ray times gpu::kBoxTmaxWiden
};

RP_SIMD_INLINE bool intervalMayHit(const PacketInterval& interval, const BvhNode& node) {
    float nearLo[3];
    float farHi[3];
    for (int axis = 0; axis < 3; ++axis) {
        const float a = node.lo[axis] - interval.org[axis];
        const float b = node.hi[axis] - interval.org[axis];
        const float p0 = a * interval.invMin[axis];
        const float p1 = a * interval.invMax[axis];
        const float p2 = b * interval.invMin[axis];
        const float p3 = b * interval.invMax[axis];
        nearLo[axis] = std::min(std::min(p0, p1), std::min(p2, p3));
        farHi[axis] = std::max(std::max(p0, p1), std::max(p2, p3));
    }
    const float nearBound = std::max(std::max(nearLo[0], nearLo[1]), std::max(nearLo[2], 0.0f));
    const float farBound = std::min(std::min(farHi[0], farHi[1]), farHi[2]) * gpu::kSlabFarWiden;
    return nearBound <= std::min(farBound, interval.tmaxWidened);
}

// Lanes of `group` whose ray may touch `node`'s box for t in [0, tmax]: gpu::intersectBox lane by
// lane, bit for bit (see cpu_box_pair.h for the operand order).
RP_SIMD_INLINE uint32_t boxMask(const RayGroup& group, const BvhNode& node) {
    if (group.anyParallel) {
        uint32_t mask = 0;
        for (int lane = 0; lane < L; ++lane) {
            if (!(group.activeBits & (1u << lane))) continue;
            float tEntry;
            if (gpu::intersectBox(group.rays[lane], node.lo, node.hi, group.tmax[lane], tEntry))
                mask |= 1u << lane;
        }
        return mask;
    }
    using S = Simd;
    const F tLoX = S::mul(S::sub(S::set1(node.lo.x), S::load(group.orgX)), S::load(group.invX));
    const F tHiX = S::mul(S::sub(S::set1(node.hi.x), S::load(group.orgX)), S::load(group.invX));
    const F tLoY = S::mul(S::sub(S::set1(node.lo.y), S::load(group.orgY)), S::load(group.invY));
    const F tHiY = S::mul(S::sub(S::set1(node.hi.y), S::load(group.orgY)), S::load(group.invY));
    const F tLoZ = S::mul(S::sub(S::set1(node.lo.z), S::load(group.orgZ)), S::load(group.invZ));
    const F tHiZ = S::mul(S::sub(S::set1(node.hi.z), S::load(group.orgZ)), S::load(group.invZ));
    // tNear3 = min(tLo, tHi), tFar3 = max(tLo, tHi).
    const F nearX = S::glmMin(tLoX, tHiX), farX = S::glmMax(tLoX, tHiX);
    const F nearY = S::glmMin(tLoY, tHiY), farY = S::glmMax(tLoY, tHiY);
    const F nearZ = S::glmMin(tLoZ, tHiZ), farZ = S::glmMax(tLoZ, tHiZ);
    // tNear = max(max(x, y), max(z, 0)); tFar = min(min(x, y), z) * kSlabFarWiden.
    const F tNear = S::glmMax(S::glmMax(nearX, nearY), S::glmMax(nearZ, S::set1(0.0f)));
    const F tFar = S::mul(S::glmMin(S::glmMin(farX, farY), farZ), S::set1(gpu::kSlabFarWiden));
    const F tmaxWidened = S::mul(S::load(group.tmax), S::set1(gpu::kBoxTmaxWiden));
    const F hit = S::le(tNear, S::glmMin(tFar, tmaxWidened));
    return S::bits(hit) & group.activeBits;
}

// A vertex's components in each lane's (kx, ky, kz) order.
struct Permuted {
    F k[3];
};

RP_SIMD_INLINE Permuted permute(const RayGroup& group, const glm::vec3& v) {
    using S = Simd;
    Permuted p;
    if (group.axis[0] >= 0) {
        for (int j = 0; j < 3; ++j) p.k[j] = S::set1(v[group.axis[j]]);
        return p;
    }
    const F x = S::set1(v.x), y = S::set1(v.y), z = S::set1(v.z);
    for (int j = 0; j < 3; ++j)
        p.k[j] = S::select(S::loadBits(group.axisIs0[j]), x,
                           S::select(S::loadBits(group.axisIs1[j]), y, z));
    return p;
}

// gpu::edgeFunction, lane by lane.
RP_SIMD_INLINE F edgeFunction(F px, F py, F qx, F qy) {
    using S = Simd;
    const F baseIsP = S::orF(S::lt(px, qx), S::andF(S::eq(px, qx), S::le(py, qy)));
    const F baseX = S::select(baseIsP, px, qx);
    const F baseY = S::select(baseIsP, py, qy);
    const F edgeX = S::sub(S::select(baseIsP, qx, px), baseX);
    const F edgeY = S::sub(S::select(baseIsP, qy, py), baseY);
    const F f = S::sub(S::mul(edgeX, baseY), S::mul(edgeY, baseX));
    return S::select(baseIsP, f, S::xorF(f, S::set1(-0.0f)));
}

struct TriangleHits {
    F mask;  // lanes that hit with 0 <= t <= tmax
    F t;
    F baryU;
    F baryV;
};

// gpu::intersectTriangle (Woop, Benthin, Wald 2013 with raypack's scaling), lane by lane.
RP_SIMD_INLINE TriangleHits intersectTriangle(const RayGroup& group, const F orgK[3], const F shear[3],
                                             const glm::vec3& v0, const glm::vec3& v1,
                                             const glm::vec3& v2, F tmax) {
    using S = Simd;
    const Permuted p0 = permute(group, v0), p1 = permute(group, v1), p2 = permute(group, v2);
    // a = v0 - org, in (kx, ky, kz) order.
    const F aX = S::sub(p0.k[0], orgK[0]), aY = S::sub(p0.k[1], orgK[1]), aZ = S::sub(p0.k[2], orgK[2]);
    const F bX = S::sub(p1.k[0], orgK[0]), bY = S::sub(p1.k[1], orgK[1]), bZ = S::sub(p1.k[2], orgK[2]);
    const F cX = S::sub(p2.k[0], orgK[0]), cY = S::sub(p2.k[1], orgK[1]), cZ = S::sub(p2.k[2], orgK[2]);
    const F ax = S::sub(aX, S::mul(shear[0], aZ));
    const F ay = S::sub(aY, S::mul(shear[1], aZ));
    const F bx = S::sub(bX, S::mul(shear[0], bZ));
    const F by = S::sub(bY, S::mul(shear[1], bZ));
    const F cx = S::sub(cX, S::mul(shear[0], cZ));
    const F cy = S::sub(cY, S::mul(shear[1], cZ));
    // Only the exponent of `largest` is used, so how abs treats -0 and which of equal values the
    // maxima pick makes no difference.
    const F absMask = S::set1Bits(0x7FFFFFFFu);
    const F largest = S::glmMax(S::glmMax(S::glmMax(S::andF(ax, absMask), S::andF(ay, absMask)),
                                          S::glmMax(S::andF(bx, absMask), S::andF(by, absMask))),
                                S::glmMax(S::andF(cx, absMask), S::andF(cy, absMask)));
    const F scale = Simd::scaleFor(largest);
    const F sax = S::mul(ax, scale), say = S::mul(ay, scale);
    const F sbx = S::mul(bx, scale), sby = S::mul(by, scale);
    const F scx = S::mul(cx, scale), scy = S::mul(cy, scale);
    const F u = edgeFunction(sbx, sby, scx, scy);
    const F v = edgeFunction(scx, scy, sax, say);
    const F w = edgeFunction(sax, say, sbx, sby);
    const F zero = S::set1(0.0f);
    const F anyNegative = S::orF(S::orF(S::lt(u, zero), S::lt(v, zero)), S::lt(w, zero));
    const F anyPositive = S::orF(S::orF(S::gt(u, zero), S::gt(v, zero)), S::gt(w, zero));
    F reject = S::andF(anyNegative, anyPositive);
    const F det = S::add(S::add(u, v), w);
    reject = S::orF(reject, S::eq(det, zero));
    const F az = S::mul(shear[2], aZ);
    const F bz = S::mul(shear[2], bZ);
    const F cz = S::mul(shear[2], cZ);
    const F scaledT = S::add(S::add(S::mul(u, az), S::mul(v, bz)), S::mul(w, cz));
    reject = S::orF(reject, S::select(S::gt(det, zero), S::lt(scaledT, zero), S::gt(scaledT, zero)));
    const F invDet = S::div(S::set1(1.0f), det);
    TriangleHits hits;
    hits.t = S::mul(scaledT, invDet);
    hits.baryU = S::mul(v, invDet);
    hits.baryV = S::mul(w, invDet);
    hits.mask = S::andNot(reject, S::le(hits.t, tmax));  // !(t <= tmax) rejects, NaN included
    return hits;
}

RP_SIMD_INLINE void countLanes(uint32_t* counts, uint32_t laneBits, uint32_t amount) {
    for (; laneBits; laneBits &= laneBits - 1) counts[__builtin_ctz(laneBits)] += amount;
}

// The closest-hit leaf step of one group: every triangle of the leaf against the lanes in
// `laneBits`, keeping per lane the least (t, triangle index) (gpu::isCloserHit).
template <bool kCount>
RP_SIMD_INLINE void closestHitLeaf(RayGroup& group, uint32_t laneBits, const BvhNode& leaf,
                                   const glm::vec3* leafVertices, const uint32_t* primIndices) {
    using S = Simd;
    const F orgK[3] = {S::load(group.orgK[0]), S::load(group.orgK[1]), S::load(group.orgK[2])};
    const F shear[3] = {S::load(group.shearX), S::load(group.shearY), S::load(group.shearZ)};
    const F lanes = S::fromBits(laneBits);
    F tmax = S::load(group.tmax);
    F bestPrim = S::loadBits(group.prim);
    F baryU = S::load(group.baryU);
    F baryV = S::load(group.baryV);
    const uint32_t end = leaf.index + leaf.count;
    for (uint32_t entry = leaf.index; entry < end; ++entry) {
        const glm::vec3* v = leafVertices + 3 * size_t(entry);
        const TriangleHits hits = intersectTriangle(group, orgK, shear, v[0], v[1], v[2], tmax);
        const F prim = S::set1Bits(primIndices[entry]);
        // isCloserHit(t, prim, bestT, bestPrim): t < bestT || (t == bestT && prim < bestPrim).
        const F closer = S::andF(
            S::andF(hits.mask, lanes),
            S::orF(S::lt(hits.t, tmax), S::andF(S::eq(hits.t, tmax), S::ltU32(prim, bestPrim))));
        tmax = S::select(closer, hits.t, tmax);
        bestPrim = S::select(closer, prim, bestPrim);
        baryU = S::select(closer, hits.baryU, baryU);
        baryV = S::select(closer, hits.baryV, baryV);
    }
    if (kCount) countLanes(group.tests, laneBits, leaf.count);
    S::store(group.tmax, tmax);
    S::storeBits(group.prim, bestPrim);
    S::store(group.baryU, baryU);
    S::store(group.baryV, baryV);
}

// The any-hit leaf step of one group: lanes that hit a triangle other than their own are occluded
// and done. Returns the lanes that became done.
template <bool kCount>
RP_SIMD_INLINE uint32_t anyHitLeaf(RayGroup& group, uint32_t laneBits, const BvhNode& leaf,
                                   const glm::vec3* leafVertices, const uint32_t* primIndices) {
    using S = Simd;
    const F orgK[3] = {S::load(group.orgK[0]), S::load(group.orgK[1]), S::load(group.orgK[2])};
    const F shear[3] = {S::load(group.shearX), S::load(group.shearY), S::load(group.shearZ)};
    const F tmax = S::load(group.tmax);
    const F skipPrim = S::loadBits(group.prim);
    uint32_t open = laneBits;  // lanes still looking for an occluder in this leaf
    const uint32_t end = leaf.index + leaf.count;
    for (uint32_t entry = leaf.index; entry < end && open; ++entry) {
        const F prim = S::set1Bits(primIndices[entry]);
        const uint32_t testing = open & S::bits(S::neU32(prim, skipPrim));
        if (!testing) continue;
        if (kCount) countLanes(group.tests, testing, 1);
        const glm::vec3* v = leafVertices + 3 * size_t(entry);
        const TriangleHits hits = intersectTriangle(group, orgK, shear, v[0], v[1], v[2], tmax);
        open &= ~(S::bits(hits.mask) & testing);
    }
    const uint32_t occluded = laneBits & ~open;
    if (occluded) {
        group.occludedBits |= occluded;
        group.activeBits &= ~occluded;
        S::store(group.tmax, S::select(S::fromBits(occluded), S::set1(kLaneDone), tmax));
    }
    return occluded;
}

struct StackItem {
    uint32_t node;
    uint32_t firstGroup;  // the active range of groups when it was pushed: [first, last]
    uint32_t lastGroup;
};

// Per thread, reused by every packet the thread traces (no allocation per packet).
struct PacketScratch {
    std::vector<RayGroup> groups;
    std::vector<StackItem> stack;
};

PacketScratch& threadScratch() {
    thread_local PacketScratch scratch;
    return scratch;
}

// Traverses the packet's groups through the tree (renderer/cpu_packet_tracer.h).
template <bool kShadow, bool kCount>
void traversePacket(const PacketFrame& frame, RayGroup* groups, uint32_t groupCount,
                    const PacketInterval& interval, const float dirSign[3], StackItem* stack) {
    const BvhNode* nodes = frame.nodes;
    uint32_t activeLanes = 0;
    uint32_t first = groupCount;
    uint32_t last = 0;
    for (uint32_t g = 0; g < groupCount; ++g) {
        activeLanes += uint32_t(__builtin_popcount(groups[g].activeBits));
        if (groups[g].activeBits) {
            if (first == groupCount) first = g;
            last = g;
        }
    }
    if (activeLanes == 0) return;
    uint32_t nodeIndex = 0;
    uint32_t top = 0;
    while (true) {
        const BvhNode& node = nodes[nodeIndex];
        uint32_t firstMask = 0;
        uint32_t lastMask = 0;
        if (!interval.enabled || intervalMayHit(interval, node)) {
            // The first and the last group that hit (Overbeck 2008's active range): the groups
            // outside [first, last] miss this node and all below it (a child's box lies inside
            // its parent's, rounding is monotone, and a ray's tmax only shrinks).
            for (; first <= last; ++first) {
                firstMask = boxMask(groups[first], node);
                if (firstMask) break;
            }
            if (firstMask) {
                for (; last > first; --last) {
                    lastMask = boxMask(groups[last], node);
                    if (lastMask) break;
                }
                if (last == first) lastMask = firstMask;
            }
        }
        if (firstMask) {
            if (kCount)
                for (uint32_t g = first; g <= last; ++g) countLanes(groups[g].nodes, groups[g].activeBits, 1);
            if (!node.isLeaf()) {
                // Nearer child first: the packet's direction along the axis that separates the
                // children's centres most.
                const uint32_t left = node.index;
                const BvhNode& l = nodes[left];
                const BvhNode& r = nodes[left + 1];
                const glm::vec3 offset = (r.lo + r.hi) - (l.lo + l.hi);
                const glm::vec3 size = glm::abs(offset);
                const int axis = size.x >= size.y ? (size.x >= size.z ? 0 : 2) : (size.y >= size.z ? 1 : 2);
                const bool rightFirst = offset[axis] * dirSign[axis] < 0.0f;
                RAYPACK_CHECK_MSG(top < frame.stackEntries, "traversal stack deeper than the tree");
                stack[top++] = {rightFirst ? left : left + 1, first, last};
                nodeIndex = rightFirst ? left + 1 : left;
                continue;
            }
            for (uint32_t g = first; g <= last; ++g) {
                RayGroup& group = groups[g];
                const uint32_t mask = g == first ? firstMask : g == last ? lastMask : boxMask(group, node);
                if (!mask) continue;
                if (kShadow) {
                    activeLanes -= uint32_t(__builtin_popcount(
                        anyHitLeaf<kCount>(group, mask, node, frame.leafVertices, frame.primIndices)));
                } else {
                    closestHitLeaf<kCount>(group, mask, node, frame.leafVertices, frame.primIndices);
                }
            }
            if (kShadow && activeLanes == 0) return;  // every shadow ray is occluded
        }
        if (top == 0) return;
        --top;
        nodeIndex = stack[top].node;
        first = stack[top].firstGroup;
        last = stack[top].lastGroup;
    }
}

// Fills group lanes for the packet at (x0, y0); `makeLane(lane data, pixel x, y)` returns false
// for a pixel that casts no ray. Returns the number of groups.
struct PacketLayout {
    uint32_t x0, y0, x1, y1;  // pixels [x0, x1) x [y0, y1) of the packet, cut at the image border
    uint32_t groupsX, groupsY;
};

PacketLayout packetLayout(const PacketFrame& frame, uint32_t x0, uint32_t y0) {
    PacketLayout layout;
    layout.x0 = x0;
    layout.y0 = y0;
    layout.x1 = std::min(frame.width, x0 + frame.packet.width);
    layout.y1 = std::min(frame.height, y0 + frame.packet.height);
    layout.groupsX = (layout.x1 - x0 + Simd::kBlockW - 1) / Simd::kBlockW;
    layout.groupsY = (layout.y1 - y0 + Simd::kBlockH - 1) / Simd::kBlockH;
    return layout;
}

// One lane from its ray: slab data, permuted triangle data.
void setLane(RayGroup& group, int lane, const gpu::TraceRay& ray, float tmax, uint32_t prim) {
    group.rays[lane] = ray;
    group.orgX[lane] = ray.org.x;
    group.orgY[lane] = ray.org.y;
    group.orgZ[lane] = ray.org.z;
    group.invX[lane] = ray.invDir.x;
    group.invY[lane] = ray.invDir.y;
    group.invZ[lane] = ray.invDir.z;
    const int axes[3] = {ray.kx, ray.ky, ray.kz};
    for (int j = 0; j < 3; ++j) {
        group.orgK[j][lane] = ray.org[axes[j]];
        group.axisIs0[j][lane] = axes[j] == 0 ? 0xFFFFFFFFu : 0u;
        group.axisIs1[j][lane] = axes[j] == 1 ? 0xFFFFFFFFu : 0u;
    }
    group.shearX[lane] = ray.shearX;
    group.shearY[lane] = ray.shearY;
    group.shearZ[lane] = ray.shearZ;
    group.tmax[lane] = tmax;
    group.prim[lane] = prim;
    group.activeBits |= 1u << lane;
    if (ray.anyParallel) group.anyParallel = true;
}

void clearGroup(RayGroup& group) {
    for (int lane = 0; lane < L; ++lane) {
        group.baryU[lane] = 0.0f;
        group.baryV[lane] = 0.0f;
        group.nodes[lane] = 0;
        group.tests[lane] = 0;
        group.pixel[lane] = kNoHit;
    }
    group.activeBits = 0;
    group.occludedBits = 0;
    group.anyParallel = false;
}

// A lane that traces nothing keeps finite, harmless values (a unit ray along +z from the origin,
// with both parallel axes' data) and tmax kLaneDone, so that no test it runs in passes.
void setIdleLane(RayGroup& group, int lane) {
    static const gpu::TraceRay idle =
        gpu::makeTraceRay(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, 1.0f));
    const bool parallel = group.anyParallel;
    setLane(group, lane, idle, kLaneDone, kNoHit);
    group.activeBits &= ~(1u << lane);
    group.anyParallel = parallel;
}

// After the lanes are set: the group's common axes, if any.
void finishGroup(RayGroup& group) {
    for (int j = 0; j < 3; ++j) group.axis[j] = -1;
    if (!group.activeBits) return;
    const int firstLane = __builtin_ctz(group.activeBits);
    const gpu::TraceRay& ref = group.rays[firstLane];
    for (int lane = 0; lane < L; ++lane) {
        if (!(group.activeBits & (1u << lane))) continue;
        const gpu::TraceRay& r = group.rays[lane];
        if (r.kx != ref.kx || r.ky != ref.ky || r.kz != ref.kz) return;
    }
    group.axis[0] = ref.kx;
    group.axis[1] = ref.ky;
    group.axis[2] = ref.kz;
}

// The interval of the packet's active rays, and a representative direction's signs.
void packetBounds(const RayGroup* groups, uint32_t groupCount, PacketInterval& interval,
                  float dirSign[3]) {
    interval.enabled = false;
    bool any = false;
    bool sameOrigin = true;
    bool parallel = false;
    float tmaxMax = 0.0f;
    glm::vec3 dirSum(0.0f);
    for (int a = 0; a < 3; ++a) {
        interval.invMin[a] = std::numeric_limits<float>::infinity();
        interval.invMax[a] = -std::numeric_limits<float>::infinity();
    }
    for (uint32_t g = 0; g < groupCount; ++g) {
        const RayGroup& group = groups[g];
        if (group.anyParallel) parallel = true;
        for (uint32_t bits = group.activeBits; bits; bits &= bits - 1) {
            const int lane = __builtin_ctz(bits);
            const glm::vec3 org(group.orgX[lane], group.orgY[lane], group.orgZ[lane]);
            const glm::vec3 inv(group.invX[lane], group.invY[lane], group.invZ[lane]);
            // Primary directions are unit; shadow directions differ in length, which a sign
            // does not mind.
            dirSum += group.rays[lane].dir;
            if (!any) {
                any = true;
                interval.org[0] = org.x;
                interval.org[1] = org.y;
                interval.org[2] = org.z;
            }
            sameOrigin = sameOrigin && org.x == interval.org[0] && org.y == interval.org[1] &&
                         org.z == interval.org[2];
            for (int a = 0; a < 3; ++a) {
                interval.invMin[a] = std::min(interval.invMin[a], inv[a]);
                interval.invMax[a] = std::max(interval.invMax[a], inv[a]);
            }
            tmaxMax = std::max(tmaxMax, group.tmax[lane]);
        }
    }
    for (int a = 0; a < 3; ++a) dirSign[a] = dirSum[a] < 0.0f ? -1.0f : 1.0f;
    interval.tmaxWidened = tmaxMax * gpu::kBoxTmaxWiden;
    interval.enabled = any && sameOrigin && !parallel;
}

template <bool kCount>
void tracePrimaryPacket(const PacketFrame& frame, uint32_t x0, uint32_t y0) {
    const PacketLayout layout = packetLayout(frame, x0, y0);
    const uint32_t groupCount = layout.groupsX * layout.groupsY;
    PacketScratch& scratch = threadScratch();
    if (scratch.groups.size() < groupCount) scratch.groups.resize(groupCount);
    if (scratch.stack.size() < frame.stackEntries) scratch.stack.resize(frame.stackEntries);
    RayGroup* groups = scratch.groups.data();
    for (uint32_t gy = 0; gy < layout.groupsY; ++gy) {
        for (uint32_t gx = 0; gx < layout.groupsX; ++gx) {
            RayGroup& group = groups[gy * layout.groupsX + gx];
            clearGroup(group);
            for (int lane = 0; lane < L; ++lane) {
                const uint32_t x = x0 + gx * Simd::kBlockW + uint32_t(lane) % Simd::kBlockW;
                const uint32_t y = y0 + gy * Simd::kBlockH + uint32_t(lane) / Simd::kBlockW;
                if (x >= layout.x1 || y >= layout.y1) {
                    setIdleLane(group, lane);
                    continue;
                }
                const glm::vec3 dir = gpu::primaryRayDirection(frame.camera, x, y);
                setLane(group, lane, gpu::makeTraceRay(frame.eye, dir), kRayTmaxInfinite, kNoHit);
                group.pixel[lane] = y * frame.width + x;
            }
            finishGroup(group);
        }
    }
    PacketInterval interval;
    float dirSign[3];
    packetBounds(groups, groupCount, interval, dirSign);
    traversePacket<false, kCount>(frame, groups, groupCount, interval, dirSign, scratch.stack.data());
    for (uint32_t g = 0; g < groupCount; ++g) {
        const RayGroup& group = groups[g];
        for (int lane = 0; lane < L; ++lane) {
            const uint32_t pixel = group.pixel[lane];
            if (pixel == kNoHit) continue;
            ClosestHit& hit = frame.hits[pixel];
            hit = ClosestHit{};
            if (group.prim[lane] != kNoHit) {
                hit.t = group.tmax[lane];
                hit.prim = group.prim[lane];
                hit.bary = glm::vec2(group.baryU[lane], group.baryV[lane]);
            }
            if (kCount) {
                frame.counters[pixel].primaryNodes = group.nodes[lane];
                frame.counters[pixel].primaryTests = group.tests[lane];
            }
        }
    }
}

template <bool kCount>
void traceShadowPacket(const PacketFrame& frame, uint32_t x0, uint32_t y0) {
    const PacketLayout layout = packetLayout(frame, x0, y0);
    const uint32_t groupCount = layout.groupsX * layout.groupsY;
    PacketScratch& scratch = threadScratch();
    if (scratch.groups.size() < groupCount) scratch.groups.resize(groupCount);
    if (scratch.stack.size() < frame.stackEntries) scratch.stack.resize(frame.stackEntries);
    RayGroup* groups = scratch.groups.data();
    for (uint32_t gy = 0; gy < layout.groupsY; ++gy) {
        for (uint32_t gx = 0; gx < layout.groupsX; ++gx) {
            RayGroup& group = groups[gy * layout.groupsX + gx];
            clearGroup(group);
            for (int lane = 0; lane < L; ++lane) {
                const uint32_t x = x0 + gx * Simd::kBlockW + uint32_t(lane) % Simd::kBlockW;
                const uint32_t y = y0 + gy * Simd::kBlockH + uint32_t(lane) / Simd::kBlockW;
                if (x >= layout.x1 || y >= layout.y1) {
                    setIdleLane(group, lane);
                    continue;
                }
                const uint32_t pixel = y * frame.width + x;
                const ClosestHit& hit = frame.hits[pixel];
                if (!hit.hit()) {  // no shadow ray: stays gpu::kShadowNone
                    setIdleLane(group, lane);
                    continue;
                }
                // As renderCpu: the shadow ray of the hit point, lit without tracing when the
                // point is the light.
                const glm::vec3 dir = gpu::primaryRayDirection(frame.camera, x, y);
                const glm::vec3 point = gpu::hitPosition(frame.eye, dir, hit.t);
                const gpu::ShadowRay shadow = gpu::makeShadowRay(frame.light, point, hit.prim);
                group.pixel[lane] = pixel;
                if (gpu::isDegenerateShadowRay(shadow)) {
                    setIdleLane(group, lane);
                    continue;
                }
                setLane(group, lane, gpu::makeTraceRay(shadow.org, shadow.dir), shadow.tmax,
                        shadow.skipPrim);
            }
            finishGroup(group);
        }
    }
    PacketInterval interval;
    float dirSign[3];
    packetBounds(groups, groupCount, interval, dirSign);
    traversePacket<true, kCount>(frame, groups, groupCount, interval, dirSign, scratch.stack.data());
    for (uint32_t g = 0; g < groupCount; ++g) {
        const RayGroup& group = groups[g];
        for (int lane = 0; lane < L; ++lane) {
            const uint32_t pixel = group.pixel[lane];
            if (pixel == kNoHit) continue;
            frame.shadowState[pixel] =
                (group.occludedBits & (1u << lane)) ? gpu::kShadowOccluded : gpu::kShadowLit;
            if (kCount) {
                frame.counters[pixel].shadowNodes = group.nodes[lane];
                frame.counters[pixel].shadowTests = group.tests[lane];
            }
        }
    }
}

void tracePrimary(const PacketFrame& frame, uint32_t x0, uint32_t y0) {
    if (frame.counters)
        tracePrimaryPacket<true>(frame, x0, y0);
    else
        tracePrimaryPacket<false>(frame, x0, y0);
}

void traceShadow(const PacketFrame& frame, uint32_t x0, uint32_t y0) {
    if (frame.counters)
        traceShadowPacket<true>(frame, x0, y0);
    else
        traceShadowPacket<false>(frame, x0, y0);
}

#undef RP_SIMD_INLINE

}  // namespace
}  // namespace raypack::packet_detail
