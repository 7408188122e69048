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
    // gpu::unitDirection's seed: 0x5f3759df - (bits(a) >> 1), as integers.
    static RP_SIMD_INLINE F inverseSqrtSeed(F a) {
        return _mm256_castsi256_ps(
            _mm256_sub_epi32(_mm256_set1_epi32(0x5f3759df), _mm256_srli_epi32(_mm256_castps_si256(a), 1)));
    }
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
    static RP_SIMD_INLINE F select(F mask, F ifTrue, F ifFalse) { return _mm256_blendv_ps(ifFalse, ifTrue, mask); }
    static RP_SIMD_INLINE uint32_t bits(F mask) { return uint32_t(_mm256_movemask_ps(mask)); }
    static RP_SIMD_INLINE F fromBits(uint32_t laneBits) {
        const I bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        const I set = _mm256_and_si256(_mm256_set1_epi32(int(laneBits)), bit);
        return _mm256_castsi256_ps(_mm256_cmpeq_epi32(set, bit));
    }
    static RP_SIMD_INLINE F set1Bits(uint32_t v) { return _mm256_castsi256_ps(_mm256_set1_epi32(int(v))); }
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
        const I biased = _mm256_and_si256(_mm256_srli_epi32(_mm256_castps_si256(largest), 23), _mm256_set1_epi32(255));
        I exponent = _mm256_sub_epi32(_mm256_set1_epi32(126), biased);
        exponent = _mm256_min_epi32(_mm256_max_epi32(exponent, _mm256_set1_epi32(-126)), _mm256_set1_epi32(126));
        return _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_add_epi32(exponent, _mm256_set1_epi32(127)), 23));
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
    static RP_SIMD_INLINE F inverseSqrtSeed(F a) {
        return _mm_castsi128_ps(_mm_sub_epi32(_mm_set1_epi32(0x5f3759df), _mm_srli_epi32(_mm_castps_si128(a), 1)));
    }
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
    static RP_SIMD_INLINE F select(F mask, F ifTrue, F ifFalse) { return _mm_blendv_ps(ifFalse, ifTrue, mask); }
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
        const I biased = _mm_and_si128(_mm_srli_epi32(_mm_castps_si128(largest), 23), _mm_set1_epi32(255));
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
// entry distance is >= 0 and every triangle hit's t > 0, so nothing passes `<= -1`.
constexpr float kLaneDone = -1.0f;

// One SIMD width of rays, structure of arrays. Lanes are 2x2 (SSE) or 4x2 (AVX2) pixels. Every
// ray of a packet starts at the packet's one origin (the eye, or the light), so the vertex and
// box coordinates relative to it are computed once per packet and node, not per lane: the same
// subtraction the scalar code does per ray, so the same bits.
struct alignas(64) RayGroup {
    // Slab test: 1/dir (0 on parallel axes).
    float invX[L], invY[L], invZ[L];
    float dirX[L], dirY[L], dirZ[L];  // the directions themselves, for the kept hit's final t
    // Triangle test: the shear and per-axis lane masks of kx, ky, kz.
    float shearX[L], shearY[L], shearZ[L];
    uint32_t axisIs0[3][L];  // axisIs0[j][lane]: all ones when axis j (kx, ky, kz) of the lane is 0
    uint32_t axisIs1[3][L];
    // Closest hit so far (primary) or the ray's tmax (shadow); kLaneDone for done lanes.
    float tmax[L];
    float baryU[L], baryV[L];
    uint32_t prim[L];      // primary: closest triangle so far; shadow: the triangle to skip
    uint32_t inexactT[L];  // primary: all ones when the closest hit's t is to be recomputed
    uint32_t nodes[L], tests[L];
    uint32_t pixel[L];
    uint32_t activeBits;    // lanes still tracing
    uint32_t occludedBits;  // shadow: lanes that found an occluder
    uint32_t parallelBits;  // lanes parallel to an axis (gpu::TraceRay::anyParallel)
    uint8_t axisCode[L];    // kx | ky << 2 | kz << 4 of each lane
    int32_t axis[3];        // kx, ky, kz when every lane shares them, else -1
    gpu::TraceRay rays[L];  // the lanes of parallelBits only
};

// The interval test of a whole packet (Wald 2007's frustum, in Reshetov 2005's interval form):
// with one origin for every ray, (lo - org) * invDir is monotone in invDir and so is its
// rounding, so the four products of a slab's ends with the bounds of the rays' invDir bound every
// ray's own near and far distance on that axis; a box whose bounds say no ray can hit it is
// culled. Disabled when the rays do not share the origin or one is parallel to an axis.
struct PacketInterval {
    bool enabled = false;
    float invMin[3];
    float invMax[3];
    float tmaxWidened;  // the largest tmax of any ray times gpu::kBoxTmaxWiden
};

// A node's box relative to the packet's origin: lo - org and hi - org, per axis, as the scalar
// slab test computes them (vectors for the box test, floats for the interval test).
struct NodeSlabs {
    F lo[3];
    F hi[3];
    float loS[3];
    float hiS[3];
};

RP_SIMD_INLINE NodeSlabs nodeSlabs(const BvhNode& node, const glm::vec3& org) {
    NodeSlabs slabs;
    for (int axis = 0; axis < 3; ++axis) {
        slabs.loS[axis] = node.lo[axis] - org[axis];
        slabs.hiS[axis] = node.hi[axis] - org[axis];
        slabs.lo[axis] = Simd::set1(slabs.loS[axis]);
        slabs.hi[axis] = Simd::set1(slabs.hiS[axis]);
    }
    return slabs;
}

RP_SIMD_INLINE bool intervalMayHit(const PacketInterval& interval, const NodeSlabs& slabs) {
    float nearLo[3];
    float farHi[3];
    for (int axis = 0; axis < 3; ++axis) {
        const float a = slabs.loS[axis];
        const float b = slabs.hiS[axis];
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
// lane, bit for bit (see cpu_box_pair.h for the operand order), or gpu::intersectBoxFast (kFast).
template <bool kFast>
RP_SIMD_INLINE uint32_t boxMask(const RayGroup& group, const NodeSlabs& slabs, const BvhNode& node) {
    const float kFarWiden = kFast ? 1.0f : gpu::kSlabFarWiden;
    const float kTmaxWiden = kFast ? 1.0f : gpu::kBoxTmaxWiden;
    using S = Simd;
    const F invX = S::load(group.invX), invY = S::load(group.invY), invZ = S::load(group.invZ);
    const F tLoX = S::mul(slabs.lo[0], invX), tHiX = S::mul(slabs.hi[0], invX);
    const F tLoY = S::mul(slabs.lo[1], invY), tHiY = S::mul(slabs.hi[1], invY);
    const F tLoZ = S::mul(slabs.lo[2], invZ), tHiZ = S::mul(slabs.hi[2], invZ);
    // tNear3 = min(tLo, tHi), tFar3 = max(tLo, tHi).
    const F nearX = S::glmMin(tLoX, tHiX), farX = S::glmMax(tLoX, tHiX);
    const F nearY = S::glmMin(tLoY, tHiY), farY = S::glmMax(tLoY, tHiY);
    const F nearZ = S::glmMin(tLoZ, tHiZ), farZ = S::glmMax(tLoZ, tHiZ);
    // tNear = max(max(x, y), max(z, 0)); tFar = min(min(x, y), z) * farWiden.
    const F tNear = S::glmMax(S::glmMax(nearX, nearY), S::glmMax(nearZ, S::set1(0.0f)));
    const F tFar = S::mul(S::glmMin(S::glmMin(farX, farY), farZ), S::set1(kFarWiden));
    const F tmaxWidened = S::mul(S::load(group.tmax), S::set1(kTmaxWiden));
    const F hit = S::le(tNear, S::glmMin(tFar, tmaxWidened));
    uint32_t mask = S::bits(hit) & group.activeBits;
    if (group.parallelBits) {  // rare: those lanes take gpu::intersectBox itself
        mask &= ~group.parallelBits;
        for (uint32_t bits = group.parallelBits & group.activeBits; bits; bits &= bits - 1) {
            const int lane = __builtin_ctz(bits);
            float tEntry;
            if (gpu::intersectBoxWidened(group.rays[lane], node.lo, node.hi, group.tmax[lane], kFarWiden, kTmaxWiden,
                                         tEntry))
                mask |= 1u << lane;
        }
    }
    return mask;
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
        p.k[j] = S::select(S::loadBits(group.axisIs0[j]), x, S::select(S::loadBits(group.axisIs1[j]), y, z));
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
    F mask;      // lanes that hit with 0 < t <= tmax
    F inexactT;  // lanes whose t is to be recomputed if kept (gpu::intersectTriangle's inexactT)
    F t;
    F baryU;
    F baryV;
};

// gpu::intersectTriangle (Woop, Benthin, Wald 2013 with raypack's scaling), lane by lane.
// `a`, `b`, `c`: the vertices minus the packet's origin (computed once for all lanes).
RP_SIMD_INLINE TriangleHits intersectTriangle(const RayGroup& group, const F shear[3], const glm::vec3& a,
                                              const glm::vec3& b, const glm::vec3& c, F tmax) {
    using S = Simd;
    // a, b, c in each lane's (kx, ky, kz) order.
    const Permuted pa = permute(group, a), pb = permute(group, b), pc = permute(group, c);
    const F aX = pa.k[0], aY = pa.k[1], aZ = pa.k[2];
    const F bX = pb.k[0], bY = pb.k[1], bZ = pb.k[2];
    const F cX = pc.k[0], cY = pc.k[1], cZ = pc.k[2];
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
    // t > 0 strictly, as gpu::intersectTriangle: scaledT = +-0 is rejected for either sign of det.
    reject = S::orF(reject, S::select(S::gt(det, zero), S::le(scaledT, zero), S::le(zero, scaledT)));
    const F invDet = S::div(S::set1(1.0f), det);
    TriangleHits hits;
    hits.t = S::mul(scaledT, invDet);
    hits.baryU = S::mul(v, invDet);
    hits.baryV = S::mul(w, invDet);
    // !(0 < t <= tmax) rejects: a quotient that underflowed to 0, and NaN.
    hits.mask = S::andNot(reject, S::andF(S::gt(hits.t, zero), S::le(hits.t, tmax)));
    // depthSpread * reach * kInexactTSpread > |det| * t, with reach = max |a, b, c| * scale.
    const F depthSpread = S::sub(S::glmMax(S::glmMax(az, bz), cz), S::glmMin(S::glmMin(az, bz), cz));
    const glm::vec3 farthest = glm::max(glm::max(glm::abs(a), glm::abs(b)), glm::abs(c));
    const F reach = S::mul(S::set1(std::max(std::max(farthest.x, farthest.y), farthest.z)), scale);
    hits.inexactT =
        S::gt(S::mul(S::mul(depthSpread, reach), S::set1(gpu::kInexactTSpread)), S::mul(S::andF(det, absMask), hits.t));
    return hits;
}

// dot(a, b) for one vector a and one per lane: (a.x b.x + a.y b.y) + a.z b.z, as glm::dot.
RP_SIMD_INLINE F dotLanes(const glm::vec3& a, F bx, F by, F bz) {
    using S = Simd;
    return S::add(S::add(S::mul(S::set1(a.x), bx), S::mul(S::set1(a.y), by)), S::mul(S::set1(a.z), bz));
}

// gpu::intersectTriangleFast (Moller-Trumbore) lane by lane, operation for operation as glm's
// cross and dot order them (cross(x, y) = (x.y y.z - y.y x.z, x.z y.x - y.z x.x, x.x y.y - y.x x.y),
// dot(a, b) = (a.x b.x + a.y b.y) + a.z b.z). Every ray of the packet starts at `org`, so
// s = org - v0, q = cross(s, e1) and dot(e2, q) are the same in every lane and computed once.
RP_SIMD_INLINE TriangleHits intersectTriangleFastLanes(const RayGroup& group, const glm::vec3& v0, const glm::vec3& v1,
                                                       const glm::vec3& v2, const glm::vec3& org, F tmax) {
    using S = Simd;
    const glm::vec3 e1 = v1 - v0;
    const glm::vec3 e2 = v2 - v0;
    const glm::vec3 s = org - v0;
    const glm::vec3 q = glm::cross(s, e1);
    const float tNumerator = glm::dot(e2, q);
    const F dx = S::load(group.dirX), dy = S::load(group.dirY), dz = S::load(group.dirZ);
    const F e2x = S::set1(e2.x), e2y = S::set1(e2.y), e2z = S::set1(e2.z);
    // p = cross(dir, e2).
    const F px = S::sub(S::mul(dy, e2z), S::mul(e2y, dz));
    const F py = S::sub(S::mul(dz, e2x), S::mul(e2z, dx));
    const F pz = S::sub(S::mul(dx, e2y), S::mul(e2x, dy));
    const F det = dotLanes(e1, px, py, pz);
    const F zero = S::set1(0.0f), one = S::set1(1.0f);
    const F invDet = S::div(one, det);
    const F u = S::mul(dotLanes(s, px, py, pz), invDet);
    // dot(dir, q) = (dir.x q.x + dir.y q.y) + dir.z q.z.
    const F v =
        S::mul(S::add(S::add(S::mul(dx, S::set1(q.x)), S::mul(dy, S::set1(q.y))), S::mul(dz, S::set1(q.z))), invDet);
    F reject = S::orF(S::eq(det, zero), S::orF(S::lt(u, zero), S::gt(u, one)));
    reject = S::orF(reject, S::orF(S::lt(v, zero), S::gt(S::add(u, v), one)));
    TriangleHits hits;
    hits.t = S::mul(S::set1(tNumerator), invDet);
    hits.baryU = u;
    hits.baryV = v;
    hits.mask = S::andNot(reject, S::andF(S::gt(hits.t, zero), S::le(hits.t, tmax)));
    hits.inexactT = zero;
    return hits;
}

RP_SIMD_INLINE void countLanes(uint32_t* counts, uint32_t laneBits, uint32_t amount) {
    for (; laneBits; laneBits &= laneBits - 1) counts[__builtin_ctz(laneBits)] += amount;
}

// The closest-hit leaf step of one group: every triangle of the leaf against the lanes in
// `laneBits`, keeping per lane the least (t, triangle index) (gpu::isCloserHit).
template <bool kCount, bool kFast>
RP_SIMD_INLINE void closestHitLeaf(RayGroup& group, uint32_t laneBits, const BvhNode& leaf,
                                   const glm::vec3* leafVertices, const uint32_t* primIndices, const glm::vec3& org) {
    using S = Simd;
    const F shear[3] = {S::load(group.shearX), S::load(group.shearY), S::load(group.shearZ)};
    const F lanes = S::fromBits(laneBits);
    F tmax = S::load(group.tmax);
    F bestPrim = S::loadBits(group.prim);
    F baryU = S::load(group.baryU);
    F baryV = S::load(group.baryV);
    F inexactT = S::loadBits(group.inexactT);
    const uint32_t end = leaf.index + leaf.count;
    for (uint32_t entry = leaf.index; entry < end; ++entry) {
        const glm::vec3* v = leafVertices + 3 * size_t(entry);
        const TriangleHits hits = kFast ? intersectTriangleFastLanes(group, v[0], v[1], v[2], org, tmax)
                                        : intersectTriangle(group, shear, v[0] - org, v[1] - org, v[2] - org, tmax);
        const F prim = S::set1Bits(primIndices[entry]);
        // isCloserHit(t, prim, bestT, bestPrim): t < bestT || (t == bestT && prim < bestPrim).
        const F closer = S::andF(S::andF(hits.mask, lanes),
                                 S::orF(S::lt(hits.t, tmax), S::andF(S::eq(hits.t, tmax), S::ltU32(prim, bestPrim))));
        tmax = S::select(closer, hits.t, tmax);
        bestPrim = S::select(closer, prim, bestPrim);
        baryU = S::select(closer, hits.baryU, baryU);
        baryV = S::select(closer, hits.baryV, baryV);
        inexactT = S::select(closer, hits.inexactT, inexactT);
    }
    if (kCount) countLanes(group.tests, laneBits, leaf.count);
    S::store(group.tmax, tmax);
    S::storeBits(group.prim, bestPrim);
    S::store(group.baryU, baryU);
    S::store(group.baryV, baryV);
    S::storeBits(group.inexactT, inexactT);
}

// The any-hit leaf step of one group: lanes that hit a triangle other than their own are occluded
// and done. Returns the lanes that became done.
template <bool kCount, bool kFast>
RP_SIMD_INLINE uint32_t anyHitLeaf(RayGroup& group, uint32_t laneBits, const BvhNode& leaf,
                                   const glm::vec3* leafVertices, const uint32_t* primIndices, const glm::vec3& org) {
    using S = Simd;
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
        const TriangleHits hits = kFast ? intersectTriangleFastLanes(group, v[0], v[1], v[2], org, tmax)
                                        : intersectTriangle(group, shear, v[0] - org, v[1] - org, v[2] - org, tmax);
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
template <bool kShadow, bool kCount, bool kFast>
void traversePacket(const PacketFrame& frame, RayGroup* groups, uint32_t groupCount, const glm::vec3& org,
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
        const NodeSlabs slabs = nodeSlabs(node, org);
        // The first group of the range is tested first (it hits most nodes of a coherent
        // packet); only when it misses does the interval test try to cull the node for the
        // whole packet before the other groups are tested.
        firstMask = boxMask<kFast>(groups[first], slabs, node);
        if (firstMask || !interval.enabled || intervalMayHit(interval, slabs)) {
            // The first and the last group that hit (Overbeck 2008's active range): the groups
            // outside [first, last] miss this node and all below it (a child's box lies inside
            // its parent's, rounding is monotone, and a ray's tmax only shrinks).
            for (; !firstMask && first < last;) {
                ++first;
                firstMask = boxMask<kFast>(groups[first], slabs, node);
            }
            if (firstMask) {
                for (; last > first; --last) {
                    lastMask = boxMask<kFast>(groups[last], slabs, node);
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
                const uint32_t mask = g == first  ? firstMask
                                      : g == last ? lastMask
                                                  : boxMask<kFast>(group, slabs, node);
                if (!mask) continue;
                if (kShadow) {
                    activeLanes -= uint32_t(__builtin_popcount(
                        anyHitLeaf<kCount, kFast>(group, mask, node, frame.leafVertices, frame.primIndices, org)));
                } else {
                    closestHitLeaf<kCount, kFast>(group, mask, node, frame.leafVertices, frame.primIndices, org);
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

// The pixels of a packet, cut at the image border, and its groups.
struct PacketLayout {
    uint32_t x0, y0, x1, y1;  // pixels [x0, x1) x [y0, y1)
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

// What the whole packet's tests need, gathered group by group after the lanes are set: the
// bounds of 1/dir and the largest tmax (PacketInterval), whether a ray is parallel to an axis,
// and the signs of the packet's direction (the child order).
struct PacketBuilder {
    F invMin[3];
    F invMax[3];
    F tmaxMax;
    bool any = false;
    bool parallel = false;

    // A constructor of its own (not member initializers): GCC compiles an implicit one without
    // the file's target pragma, and the SIMD calls would not inline into it.
    PacketBuilder() {
        for (int a = 0; a < 3; ++a) {
            invMin[a] = Simd::set1(std::numeric_limits<float>::infinity());
            invMax[a] = Simd::set1(-std::numeric_limits<float>::infinity());
        }
        tmaxMax = Simd::set1(0.0f);
    }

    void add(const RayGroup& group) {
        using S = Simd;
        if (!group.activeBits) return;
        any = true;
        if (group.parallelBits) parallel = true;
        const F active = S::fromBits(group.activeBits);
        const float* inv[3] = {group.invX, group.invY, group.invZ};
        for (int a = 0; a < 3; ++a) {
            const F v = S::load(inv[a]);
            invMin[a] = S::select(active, S::glmMin(invMin[a], v), invMin[a]);
            invMax[a] = S::select(active, S::glmMax(invMax[a], v), invMax[a]);
        }
        tmaxMax = S::select(active, S::glmMax(tmaxMax, S::load(group.tmax)), tmaxMax);
    }

    void finish(PacketInterval& interval, float dirSign[3]) const {
        alignas(32) float lanes[L];
        for (int a = 0; a < 3; ++a) {
            Simd::store(lanes, invMin[a]);
            interval.invMin[a] = *std::min_element(lanes, lanes + L);
            Simd::store(lanes, invMax[a]);
            interval.invMax[a] = *std::max_element(lanes, lanes + L);
            // Where every ray has the same sign on an axis, so do both bounds of 1/dir.
            dirSign[a] = interval.invMin[a] + interval.invMax[a] < 0.0f ? -1.0f : 1.0f;
        }
        Simd::store(lanes, tmaxMax);
        interval.tmaxWidened = *std::max_element(lanes, lanes + L) * gpu::kBoxTmaxWiden;
        interval.enabled = any && !parallel;
    }
};

void clearGroup(RayGroup& group) {
    for (int lane = 0; lane < L; ++lane) {
        // Lanes that trace nothing keep finite, harmless values and tmax kLaneDone, so that no
        // test they run passes.
        group.invX[lane] = group.invY[lane] = group.invZ[lane] = 1.0f;
        group.shearX[lane] = group.shearY[lane] = 0.0f;
        group.shearZ[lane] = 1.0f;
        group.axisCode[lane] = 0 | 1 << 2 | 2 << 4;
        group.tmax[lane] = kLaneDone;
        group.prim[lane] = kNoHit;
        group.inexactT[lane] = 0;
        group.baryU[lane] = 0.0f;
        group.baryV[lane] = 0.0f;
        group.nodes[lane] = 0;
        group.tests[lane] = 0;
        group.pixel[lane] = kNoHit;
    }
    group.activeBits = 0;
    group.occludedBits = 0;
    group.parallelBits = 0;
}

// gpu::primaryRayDirection for the lanes' pixels (x, y), operation for operation:
// u = x eye.w + right.w, v = up.w - y forward.w, d = (forward + u right) + v up, and
// gpu::unitDirection's three Newton steps from its integer seed.
RP_SIMD_INLINE void primaryDirections(const gpu::GpuCamera& cam, F x, F y, F dir[3]) {
    using S = Simd;
    const F u = S::add(S::mul(x, S::set1(cam.eye.w)), S::set1(cam.right.w));
    const F v = S::sub(S::set1(cam.up.w), S::mul(y, S::set1(cam.forward.w)));
    F d[3];
    for (int a = 0; a < 3; ++a)
        d[a] = S::add(S::add(S::set1(cam.forward[a]), S::mul(u, S::set1(cam.right[a]))), S::mul(v, S::set1(cam.up[a])));
    const F length2 = S::add(S::add(S::mul(d[0], d[0]), S::mul(d[1], d[1])), S::mul(d[2], d[2]));
    const F half = S::set1(0.5f), threeHalves = S::set1(1.5f);
    F inverseLength = S::inverseSqrtSeed(length2);
    for (int step = 0; step < 3; ++step) {
        const F halfSquare = S::mul(S::mul(S::mul(half, length2), inverseLength), inverseLength);
        inverseLength = S::mul(inverseLength, S::sub(threeHalves, halfSquare));
    }
    for (int a = 0; a < 3; ++a) dir[a] = S::mul(d[a], inverseLength);
}

// gpu::makeTraceRay(org, dir) for the lanes of `lanes`, into the group (tmax and prim are the
// caller's): 1/dir (0 on axes with |dir| < kParallelEpsilon), the axis kz of the largest |dir|
// (ties to the lower axis), kx and ky after it (swapped when dir[kz] < 0) and the shear. Lanes
// parallel to an axis also get their whole TraceRay, for gpu::intersectBox.
RP_SIMD_INLINE void setRays(RayGroup& group, uint32_t lanes, const glm::vec3& org, const F dir[3]) {
    using S = Simd;
    const F absMask = S::set1Bits(0x7FFFFFFFu);
    const F one = S::set1(1.0f), zero = S::set1(0.0f);
    F absDir[3];
    F parallel = zero;
    float* inv[3] = {group.invX, group.invY, group.invZ};
    float* dirs[3] = {group.dirX, group.dirY, group.dirZ};
    for (int a = 0; a < 3; ++a) {
        S::store(dirs[a], dir[a]);
        absDir[a] = S::andF(dir[a], absMask);
        const F isParallel = S::lt(absDir[a], S::set1(gpu::kParallelEpsilon));
        parallel = S::orF(parallel, isParallel);
        S::store(inv[a], S::select(isParallel, zero, S::div(one, dir[a])));
    }
    // kz: 0, then 1 where |y| > |x|, then 2 where |z| > |dir[kz]|.
    const F kzIs1 = S::gt(absDir[1], absDir[0]);
    const F absKz = S::select(kzIs1, absDir[1], absDir[0]);
    const F kzIs2 = S::gt(absDir[2], absKz);
    const F kz1 = S::andNot(kzIs2, kzIs1);  // kz == 1
    const F dirKz = S::select(kzIs2, dir[2], S::select(kz1, dir[1], dir[0]));
    // kx = kz + 1, ky = kz + 2 (mod 3), swapped where dir[kz] < 0.
    const F dirNext = S::select(kzIs2, dir[0], S::select(kz1, dir[2], dir[1]));
    const F dirNextNext = S::select(kzIs2, dir[1], S::select(kz1, dir[0], dir[2]));
    const F swap = S::lt(dirKz, zero);
    const F dirKx = S::select(swap, dirNextNext, dirNext);
    const F dirKy = S::select(swap, dirNext, dirNextNext);
    S::store(group.shearX, S::div(dirKx, dirKz));
    S::store(group.shearY, S::div(dirKy, dirKz));
    S::store(group.shearZ, S::div(one, dirKz));
    const uint32_t kzBits1 = S::bits(kz1), kzBits2 = S::bits(kzIs2), swapBits = S::bits(swap);
    group.activeBits |= lanes;
    group.parallelBits |= S::bits(parallel) & lanes;
    for (uint32_t bits = lanes; bits; bits &= bits - 1) {
        const int lane = __builtin_ctz(bits);
        const uint32_t bit = 1u << lane;
        const int kz = (kzBits2 & bit) ? 2 : (kzBits1 & bit) ? 1 : 0;
        int kx = kz == 2 ? 0 : kz + 1;
        int ky = kx == 2 ? 0 : kx + 1;
        if (swapBits & bit) std::swap(kx, ky);
        group.axisCode[lane] = uint8_t(kx | ky << 2 | kz << 4);
    }
    if (group.parallelBits) {
        alignas(32) float d[3][L];
        for (int a = 0; a < 3; ++a) S::store(d[a], dir[a]);
        for (uint32_t bits = group.parallelBits; bits; bits &= bits - 1) {
            const int lane = __builtin_ctz(bits);
            group.rays[lane] = gpu::makeTraceRay(org, glm::vec3(d[0][lane], d[1][lane], d[2][lane]));
        }
    }
}

// The lanes' pixel coordinates as floats (exact below 2^24), for the group at (gx, gy).
RP_SIMD_INLINE void lanePixels(uint32_t x0, uint32_t y0, uint32_t gx, uint32_t gy, float xs[L], float ys[L]) {
    for (int lane = 0; lane < L; ++lane) {
        xs[lane] = float(x0 + gx * Simd::kBlockW + uint32_t(lane) % Simd::kBlockW);
        ys[lane] = float(y0 + gy * Simd::kBlockH + uint32_t(lane) / Simd::kBlockW);
    }
}

// After the lanes are set: the group's common axes if every active lane has the same, else the
// per-lane axis masks that permute() selects with.
void finishGroup(RayGroup& group, PacketBuilder& builder) {
    builder.add(group);
    for (int j = 0; j < 3; ++j) group.axis[j] = -1;
    if (!group.activeBits) return;
    const uint8_t code = group.axisCode[__builtin_ctz(group.activeBits)];
    bool uniform = true;
    for (uint32_t bits = group.activeBits; bits; bits &= bits - 1)
        uniform = uniform && group.axisCode[__builtin_ctz(bits)] == code;
    if (uniform) {
        for (int j = 0; j < 3; ++j) group.axis[j] = (code >> (2 * j)) & 3;
        return;
    }
    for (int lane = 0; lane < L; ++lane) {
        for (int j = 0; j < 3; ++j) {
            const int axis = (group.axisCode[lane] >> (2 * j)) & 3;
            group.axisIs0[j][lane] = axis == 0 ? 0xFFFFFFFFu : 0u;
            group.axisIs1[j][lane] = axis == 1 ? 0xFFFFFFFFu : 0u;
        }
    }
}

// The kept hits' t of the lanes whose triangle test called it inexact, recomputed from their
// triangles' planes as the reference does (gpu::accurateHitDistanceF64), lane by lane: in doubles
// it is some 45 scalar operations, and only the flagged lanes (a few percent of primary rays,
// docs/trade.md) pay them, where a lane-wise float-pair form made every lane of a group with one
// flagged lane pay about 400.
RP_SIMD_INLINE void refineInexactHits(const PacketFrame& frame, RayGroup& group) {
    for (int lane = 0; lane < L; ++lane) {
        if (group.pixel[lane] == kNoHit || group.prim[lane] == kNoHit || !group.inexactT[lane]) continue;
        const glm::uvec3 tri = frame.scene->triangles[group.prim[lane]];
        const glm::vec3 dir(group.dirX[lane], group.dirY[lane], group.dirZ[lane]);
        group.tmax[lane] =
            gpu::accurateHitDistanceF64(frame.eye, dir, frame.scene->positions[tri[0]], frame.scene->positions[tri[1]],
                                        frame.scene->positions[tri[2]], group.tmax[lane]);
    }
}

template <bool kCount, bool kFast>
void tracePrimaryPacket(const PacketFrame& frame, uint32_t x0, uint32_t y0) {
    const PacketLayout layout = packetLayout(frame, x0, y0);
    const uint32_t groupCount = layout.groupsX * layout.groupsY;
    PacketScratch& scratch = threadScratch();
    if (scratch.groups.size() < groupCount) scratch.groups.resize(groupCount);
    if (scratch.stack.size() < frame.stackEntries) scratch.stack.resize(frame.stackEntries);
    RayGroup* groups = scratch.groups.data();
    PacketBuilder builder;
    for (uint32_t gy = 0; gy < layout.groupsY; ++gy) {
        for (uint32_t gx = 0; gx < layout.groupsX; ++gx) {
            RayGroup& group = groups[gy * layout.groupsX + gx];
            clearGroup(group);
            alignas(32) float xs[L], ys[L];
            lanePixels(x0, y0, gx, gy, xs, ys);
            uint32_t lanes = 0;
            for (int lane = 0; lane < L; ++lane) {
                const uint32_t x = uint32_t(xs[lane]), y = uint32_t(ys[lane]);
                if (x >= layout.x1 || y >= layout.y1) continue;
                lanes |= 1u << lane;
                group.tmax[lane] = kRayTmaxInfinite;
                group.pixel[lane] = y * frame.width + x;
            }
            F dir[3];
            primaryDirections(frame.camera, Simd::load(xs), Simd::load(ys), dir);
            setRays(group, lanes, frame.eye, dir);
            finishGroup(group, builder);
        }
    }
    PacketInterval interval;
    float dirSign[3];
    builder.finish(interval, dirSign);
    traversePacket<false, kCount, kFast>(frame, groups, groupCount, frame.eye, interval, dirSign, scratch.stack.data());
    for (uint32_t g = 0; g < groupCount; ++g) {
        RayGroup& group = groups[g];
        if (!kFast) refineInexactHits(frame, group);
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

template <bool kCount, bool kFast>
void traceShadowPacket(const PacketFrame& frame, uint32_t x0, uint32_t y0) {
    const PacketLayout layout = packetLayout(frame, x0, y0);
    const uint32_t groupCount = layout.groupsX * layout.groupsY;
    PacketScratch& scratch = threadScratch();
    if (scratch.groups.size() < groupCount) scratch.groups.resize(groupCount);
    if (scratch.stack.size() < frame.stackEntries) scratch.stack.resize(frame.stackEntries);
    RayGroup* groups = scratch.groups.data();
    PacketBuilder builder;
    for (uint32_t gy = 0; gy < layout.groupsY; ++gy) {
        for (uint32_t gx = 0; gx < layout.groupsX; ++gx) {
            RayGroup& group = groups[gy * layout.groupsX + gx];
            clearGroup(group);
            alignas(32) float xs[L], ys[L], hitT[L];
            lanePixels(x0, y0, gx, gy, xs, ys);
            uint32_t lanes = 0;
            for (int lane = 0; lane < L; ++lane) {
                hitT[lane] = 0.0f;
                const uint32_t x = uint32_t(xs[lane]), y = uint32_t(ys[lane]);
                if (x >= layout.x1 || y >= layout.y1) continue;
                const uint32_t pixel = y * frame.width + x;
                const ClosestHit& hit = frame.hits[pixel];
                if (!hit.hit()) continue;  // no shadow ray: stays gpu::kShadowNone
                group.pixel[lane] = pixel;
                group.prim[lane] = hit.prim;  // gpu::makeShadowRay's skipPrim
                hitT[lane] = hit.t;
                lanes |= 1u << lane;
            }
            if (lanes) {
                // As renderCpu: from the light to hitPosition(eye, dir, t) = eye + t dir
                // (gpu::makeShadowRay, tmax 1 - kShadowRayGap); a point at the light is lit
                // without tracing (gpu::isDegenerateShadowRay).
                F primaryDir[3], dir[3];
                primaryDirections(frame.camera, Simd::load(xs), Simd::load(ys), primaryDir);
                const F t = Simd::load(hitT);
                F zero = Simd::set1(0.0f), degenerate = Simd::set1Bits(0xFFFFFFFFu);
                for (int a = 0; a < 3; ++a) {
                    const F point = Simd::add(Simd::set1(frame.eye[a]), Simd::mul(t, primaryDir[a]));
                    dir[a] = Simd::sub(point, Simd::set1(frame.light[a]));
                    degenerate = Simd::andF(degenerate, Simd::eq(dir[a], zero));
                }
                lanes &= ~Simd::bits(degenerate);
                const float tmax = 1.0f - gpu::kShadowRayGap;
                for (uint32_t bits = lanes; bits; bits &= bits - 1) group.tmax[__builtin_ctz(bits)] = tmax;
                setRays(group, lanes, frame.light, dir);
            }
            finishGroup(group, builder);
        }
    }
    PacketInterval interval;
    float dirSign[3];
    builder.finish(interval, dirSign);
    traversePacket<true, kCount, kFast>(frame, groups, groupCount, frame.light, interval, dirSign,
                                        scratch.stack.data());
    for (uint32_t g = 0; g < groupCount; ++g) {
        const RayGroup& group = groups[g];
        for (int lane = 0; lane < L; ++lane) {
            const uint32_t pixel = group.pixel[lane];
            if (pixel == kNoHit) continue;
            frame.shadowState[pixel] = (group.occludedBits & (1u << lane)) ? gpu::kShadowOccluded : gpu::kShadowLit;
            if (kCount) {
                frame.counters[pixel].shadowNodes = group.nodes[lane];
                frame.counters[pixel].shadowTests = group.tests[lane];
            }
        }
    }
}

// One instantiation per (counting, intersection mode): neither costs the other a branch.
void tracePrimary(const PacketFrame& frame, uint32_t x0, uint32_t y0) {
    const bool fast = frame.intersect == IntersectMode::Fast;
    if (frame.counters)
        fast ? tracePrimaryPacket<true, true>(frame, x0, y0) : tracePrimaryPacket<true, false>(frame, x0, y0);
    else
        fast ? tracePrimaryPacket<false, true>(frame, x0, y0) : tracePrimaryPacket<false, false>(frame, x0, y0);
}

void traceShadow(const PacketFrame& frame, uint32_t x0, uint32_t y0) {
    const bool fast = frame.intersect == IntersectMode::Fast;
    if (frame.counters)
        fast ? traceShadowPacket<true, true>(frame, x0, y0) : traceShadowPacket<true, false>(frame, x0, y0);
    else
        fast ? traceShadowPacket<false, true>(frame, x0, y0) : traceShadowPacket<false, false>(frame, x0, y0);
}

#undef RP_SIMD_INLINE

}  // namespace
}  // namespace raypack::packet_detail
