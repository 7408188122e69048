// Ray/triangle, ray/box and shadow-ray code shared by the GPU kernels and the CPU reference
// (renderer/cpu_tracer.cpp): both compile this very text, so a ray that one path hits the other
// hits too (see common.h for the GLSL/C++ rules).
//
// Robustness (issue 3): no ray may slip through a shared edge or vertex of a closed mesh, and rays
// with zero direction components must behave. Hence
//  - the watertight ray/triangle test of Woop, Benthin and Wald 2013 ("Watertight Ray/Triangle
//    Intersection", JCGT 2(1)), edges inclusive, no back-face culling;
//  - the conservative slab test of Ize 2013 ("Robust BVH Ray Traversal", JCGT 2(2)), with axes the
//    ray is parallel to handled explicitly instead of through 0 * inf;
//  - one shadow-ray rule (makeShadowRay) used by every tracer.
#ifndef RAYPACK_SHADERS_INTERSECT_H
#define RAYPACK_SHADERS_INTERSECT_H
#include "common.h"

// RP_PRECISE (common.h) forbids the GLSL compiler from fusing a*b - c*d into an FMA. Watertightness
// rests on the edge function of a shared edge being computed from the same two rounded products by
// both triangles (then one triangle's value is exactly the negation of the other's); a fused
// multiply-add rounds one product differently in each triangle and re-opens the crack.

// The per-ray and per-node functions below take a TraceRay (about 100 bytes) by value, as GLSL
// must; in C++ they are forced inline so that no copy is made per box or triangle test.
#ifdef __cplusplus
#define RP_HOT_FUNC inline __attribute__((always_inline))
#else
#define RP_HOT_FUNC
#endif

RP_BEGIN_NAMESPACE

#ifdef __cplusplus
using glm::step;
#endif

// Largest finite value we use in place of infinity: GLSL does not promise IEEE infinities.
const float kFloatHuge = 3.402823466e38f;
// Ize 2013, Robust BVH Ray Traversal: widen each slab's far distance by 1 + 2*gamma(3), with
// gamma(n) = n*u / (1 - n*u) and u = 2^-24 (unit roundoff of float). This covers the rounding of
// (bound - origin) * invDir in both the near and the far distance.
const float kSlabFarWiden = 1.0000003576278687f;  // 1 + 2 * 3u/(1-3u), rounded up
// A box is culled against the closest hit so far only when its near distance exceeds that hit's t
// by more than rounding: the near distance carries up to gamma(3) of relative error, a triangle's
// t a few ulps more. Without this margin a box holding a triangle that ties the current hit (a ray
// through a vertex shared by triangles in different leaves) is skipped, and which triangle is
// reported would depend on traversal order (tests/test_intersect.cpp, Box.NeverCullsATriangleHit).
// 16 ulps; it costs a negligible number of extra node visits.
const float kBoxTmaxWiden = 1.0000019073486328f;  // 1 + 2^-19
// A direction component smaller than this in magnitude counts as zero (the ray is parallel to that
// slab): 1/x would overflow to infinity, and 0 * infinity is NaN, whose min/max GLSL leaves
// undefined. FLT_MIN also covers denormals, which GPUs may flush to zero anyway.
const float kParallelEpsilon = 1.175494351e-38f;

// Everything a ray needs for box and triangle tests, computed once per ray (makeTraceRay). A local
// value only, never stored in a buffer, so vec3 members are fine here.
struct TraceRay {
    vec3 org;
    vec3 dir;
    // Slab test.
    vec3 invDir;    // 1/dir, 0 on parallel axes
    vec3 parallel;  // 1.0 on axes the ray is parallel to, else 0.0
    vec3 farBias;   // kFloatHuge on parallel axes so they never limit the far distance
    bool anyParallel;
    // Watertight triangle test: kz is the axis of largest |dir|, kx and ky the other two, swapped
    // when dir[kz] < 0 to keep the triangle's winding; the shear maps the ray onto +z.
    int kx;
    int ky;
    int kz;
    float shearX;
    float shearY;
    float shearZ;
};

// dir need not be normalized (shadow rays use p - light), but must not be zero.
RP_HOT_FUNC TraceRay makeTraceRay(vec3 org, vec3 dir) {
    TraceRay r;
    r.org = org;
    r.dir = dir;
    const vec3 absDir = abs(dir);
    r.parallel = vec3(0.0f);
    r.anyParallel = false;
    for (int axis = 0; axis < 3; ++axis) {
        if (absDir[axis] < kParallelEpsilon) {
            r.parallel[axis] = 1.0f;
            r.invDir[axis] = 0.0f;
            r.anyParallel = true;
        } else {
            r.invDir[axis] = 1.0f / dir[axis];
        }
    }
    r.farBias = r.parallel * kFloatHuge;

    // Ties go to the lower axis, the same on both sides.
    int kz = 0;
    if (absDir.y > absDir[kz]) kz = 1;
    if (absDir.z > absDir[kz]) kz = 2;
    int kx = kz + 1;
    if (kx == 3) kx = 0;
    int ky = kx + 1;
    if (ky == 3) ky = 0;
    if (dir[kz] < 0.0f) {
        const int swapped = kx;
        kx = ky;
        ky = swapped;
    }
    r.kx = kx;
    r.ky = ky;
    r.kz = kz;
    r.shearX = dir[kx] / dir[kz];
    r.shearY = dir[ky] / dir[kz];
    r.shearZ = 1.0f / dir[kz];
    return r;
}

// The slab test's decision from each axis's two plane distances tLo, tHi (however they were
// computed; trace.comp's fusedBoxTest computes them in fused form): the far distance widened by
// farWiden and tmax by tmaxWiden.
RP_HOT_FUNC bool slabsHit(TraceRay r, vec3 lo, vec3 hi, vec3 tLo, vec3 tHi, float tmax, float farWiden, float tmaxWiden,
                          RP_OUT(float) tEntry) {
    const vec3 tNear3 = min(tLo, tHi);
    vec3 tFar3 = max(tLo, tHi);
    if (r.anyParallel) {
        // On a parallel axis tLo = tHi = 0: the axis must not limit the far distance, and the ray
        // misses unless its origin lies in the slab (bounds inclusive).
        tFar3 = tFar3 + r.farBias;
        const vec3 inSlab = step(lo, r.org) * step(r.org, hi);
        if (dot(r.parallel, vec3(1.0f) - inSlab) > 0.0f) {
            tEntry = 0.0f;
            return false;
        }
    }
    const float tNear = max(max(tNear3.x, tNear3.y), max(tNear3.z, 0.0f));
    const float tFar = min(min(tFar3.x, tFar3.y), tFar3.z) * farWiden;
    tEntry = tNear;
    return tNear <= min(tFar, tmax * tmaxWiden);
}

// The slab test against [lo, hi] for t in [0, tmax], its far distance multiplied by farWiden and
// tmax by tmaxWiden: intersectBox (conservative, Ize's factors) and intersectBoxFast (both 1, the
// plain slab test) are this one body, the factors constants that fold away. Multiplying by 1 is
// exact, so the fast test is exactly the unwidened one.
RP_HOT_FUNC bool intersectBoxWidened(TraceRay r, vec3 lo, vec3 hi, float tmax, float farWiden, float tmaxWiden,
                                     RP_OUT(float) tEntry) {
    return slabsHit(r, lo, hi, (lo - r.org) * r.invDir, (hi - r.org) * r.invDir, tmax, farWiden, tmaxWiden, tEntry);
}

// Conservative slab test against [lo, hi] for t in [0, tmax] (tmax widened by kBoxTmaxWiden); closed
// at 0 on purpose: a box is a bound, and a triangle touching the ray origin is decided by
// intersectTriangle's t > 0.
// Returns whether the ray may touch the box; tEntry is the entry distance (clamped to 0). Boxes are
// closed: a ray lying in a face plane, or parallel to an axis and inside that slab, hits.
RP_HOT_FUNC bool intersectBox(TraceRay r, vec3 lo, vec3 hi, float tmax, RP_OUT(float) tEntry) {
    return intersectBoxWidened(r, lo, hi, tmax, kSlabFarWiden, kBoxTmaxWiden, tEntry);
}

// The plain slab test (IntersectMode::Fast): the rounding of the slab distances may cull a box that
// a ray grazes, so a triangle lying in a box's face can be lost to a ray that meets it at the face.
// Parallel axes keep their explicit rule: GLSL does not promise IEEE infinities.
RP_HOT_FUNC bool intersectBoxFast(TraceRay r, vec3 lo, vec3 hi, float tmax, RP_OUT(float) tEntry) {
    return intersectBoxWidened(r, lo, hi, tmax, 1.0f, 1.0f, tEntry);
}

// The 2D edge function of the edge p -> q at the origin (the ray), cross(q, p) = q.x*p.y - q.y*p.x,
// which is u for the edge b -> c in Woop et al. Evaluated as cross(q - p, p) from a canonical end
// of the edge (the lexicographically smaller one) instead of as a difference of two products of
// coordinates: for a triangle far smaller than its distance from the ray origin, those two
// products are huge and nearly equal, and their rounding can flip the sign (a ray thousands of
// units away was reported to hit a 1e-4 triangle); edge vector times coordinate keeps the error
// relative to the edge's own length. Watertightness is kept: both triangles of an edge pick the
// same base point, the edge vectors are exact negations (fl(q - p) = -fl(p - q)), and so are the
// results.
RP_HOT_FUNC float edgeFunction(vec2 p, vec2 q) {
    const bool baseIsP = p.x < q.x || (p.x == q.x && p.y <= q.y);
    const vec2 base = baseIsP ? p : q;
    RP_PRECISE const vec2 edge = (baseIsP ? q : p) - base;
    RP_PRECISE const float f = edge.x * base.y - edge.y * base.x;  // cross(other, base)
    return baseIsP ? f : -f;
}

// The power of two that brings `largest` (>= 0) into [0.5, 1), clamped so that it stays a normal
// float. largest lies in [2^(b-127), 2^(b-126)) for its biased exponent b; the scale is 2^(126-b),
// built from its bits (exact, and no libm call on the CPU). Multiplying by it is exact.
RP_HOT_FUNC float powerOfTwoScale(float largest) {
    const int biasedExponent = int((floatBitsToUint(largest) >> 23u) & 255u);
    const int scaleExponent = clamp(126 - biasedExponent, -126, 126);
    return uintBitsToFloat(uint(scaleExponent + 127) << 23u);
}

// The threshold of intersectTriangle's inexactT: a hit is inexact when depth spread x reach x this
// exceeds |det| x t. At 1/16 the hits left with the triangle test's own t stayed within 2.3e-6 of
// the exact distance (relative) on slivers, grazing rays near and far, and ordinary triangles
// (tests/test_intersect.cpp); 1/64 let 9e-6 through, 1/4 sent three to four times as many hits
// through accurateHitDistance for a gain that issue 15's bar (1e-5) does not ask for.
const float kInexactTSpread = 0.0625f;

// Watertight ray/triangle test (Woop, Benthin, Wald 2013), edges and vertices inclusive, both faces.
// On a hit with 0 < t <= tmax returns true with t and the barycentric weights of v1 and v2 (the
// weight of v0 is 1 - bary.x - bary.y).
//
// t = 0 (or -0) is not a hit (issue 11, class 12): a ray starting on a triangle, an eye placed
// exactly on a face, would otherwise hit that face at t = 0 for every direction and see nothing
// beyond it. Embree counts a hit only for tnear < t (with tnear = 0), and a ray leaving a surface
// (a shadow ray from a hit point) needs the same; every tracer of raypack decides t's sign here or
// in a vectorised copy of this test (renderer/cpu_packet_simd.inl), the driver peer through its
// tmin (shaders/rt/rt_peer.rgen).
//
// The paper recomputes the edge functions in double precision when one of them is exactly 0. We do
// not, on either side: GLSL doubles are optional (and slow where present), and the CPU reference
// must decide exactly as the GPU does. Watertightness does not need the fallback: a shared edge's
// edge function is computed from the same rounded numbers in both triangles (edgeFunction), so it
// is exactly negated between them; with inclusive edges a ray on the edge hits at least one.
// What the fallback would add is only the exact sign of a product difference that rounds to 0, i.e.
// which of two triangles sharing an edge a ray grazing that edge reports (both lie at the same t).
// Beyond the paper: the 2D coordinates are scaled by a power of two per triangle (see below), so
// neither huge (1e20) nor tiny (1e-20) coordinates overflow or underflow the edge functions; and
// the edge functions are evaluated from edge vectors (edgeFunction), so small triangles far from
// the ray origin keep the right signs. Both keep the test watertight.
// This t can carry a relative error well above an ulp where the hit is close to the ray origin
// compared to the triangle's size, on slivers and at grazing angles (t is a weighted mean of the
// vertices' depths whose weights cancel), so two triangles meeting the ray at the same point may
// order differently than their exact distances; it decides which hit traversal keeps, and the
// kept hit's reported t is accurateHitDistance (below), within an ulp or two of the exact one.
RP_HOT_FUNC bool intersectTriangle(TraceRay r, vec3 v0, vec3 v1, vec3 v2, float tmax, RP_OUT(float) t,
                                   RP_OUT(vec2) bary, RP_OUT(bool) inexactT) {
    t = 0.0f;
    bary = vec2(0.0f);
    inexactT = false;
    // Vertices relative to the ray origin.
    RP_PRECISE const vec3 a = v0 - r.org;
    RP_PRECISE const vec3 b = v1 - r.org;
    RP_PRECISE const vec3 c = v2 - r.org;
    // Shear and scale so the ray is the +z axis through the origin.
    RP_PRECISE const float ax = a[r.kx] - r.shearX * a[r.kz];
    RP_PRECISE const float ay = a[r.ky] - r.shearY * a[r.kz];
    RP_PRECISE const float bx = b[r.kx] - r.shearX * b[r.kz];
    RP_PRECISE const float by = b[r.ky] - r.shearY * b[r.kz];
    RP_PRECISE const float cx = c[r.kx] - r.shearX * c[r.kz];
    RP_PRECISE const float cy = c[r.ky] - r.shearY * c[r.kz];
    // Scale the 2D coordinates by a power of two that brings the largest to [0.5, 1), so that the
    // products below neither overflow (coordinates beyond ~1e19 would give inf - inf = NaN) nor
    // underflow (below ~1e-19 they would vanish). A power of two commutes with rounding, so each
    // edge function is exactly s^2 times its unscaled value: the two triangles of a shared edge,
    // scaled by different s, still get exactly opposite signs, and watertightness is kept. The
    // exponent is clamped so the scale stays a normal float.
    const float largest = max(max(max(abs(ax), abs(ay)), max(abs(bx), abs(by))), max(abs(cx), abs(cy)));
    const float scale = powerOfTwoScale(largest);
    RP_PRECISE const float sax = ax * scale;
    RP_PRECISE const float say = ay * scale;
    RP_PRECISE const float sbx = bx * scale;
    RP_PRECISE const float sby = by * scale;
    RP_PRECISE const float scx = cx * scale;
    RP_PRECISE const float scy = cy * scale;
    // Scaled barycentric coordinates (2D edge functions).
    RP_PRECISE const float u = edgeFunction(vec2(sbx, sby), vec2(scx, scy));
    RP_PRECISE const float v = edgeFunction(vec2(scx, scy), vec2(sax, say));
    RP_PRECISE const float w = edgeFunction(vec2(sax, say), vec2(sbx, sby));
    // Inclusive edges: reject only when the signs disagree strictly.
    if ((u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f)) return false;
    RP_PRECISE const float det = u + v + w;
    if (det == 0.0f) return false;  // degenerate triangle, or the ray lies in its plane
    // The z coordinates are not scaled: shearZ * a[kz] is in units of t already, and u, v, w and
    // det all carry the same s^2, which cancels in t = scaledT / det.
    RP_PRECISE const float az = r.shearZ * a[r.kz];
    RP_PRECISE const float bz = r.shearZ * b[r.kz];
    RP_PRECISE const float cz = r.shearZ * c[r.kz];
    RP_PRECISE const float scaledT = u * az + v * bz + w * cz;
    // Same sign as det, strictly, means t > 0: scaledT = +-0 (the ray origin in the triangle's
    // plane) is rejected, whatever the sign of det, so neither t = 0 nor t = -0 is a hit. The
    // division is done once the sign test passed.
    if (det > 0.0f ? scaledT <= 0.0f : scaledT >= 0.0f) return false;
    RP_PRECISE const float invDet = 1.0f / det;
    const float hitT = scaledT * invDet;
    // The quotient of two nonzero numbers of one sign can still round (underflow) to +0, or be
    // flushed to it where the GPU drops denormals: t > 0 is tested on the result too.
    if (!(hitT > 0.0f && hitT <= tmax)) return false;
    t = hitT;
    bary = vec2(v * invDet, w * invDet);
    // t is the mean of the depths az, bz, cz weighted by u, v, w. Each weight carries the rounding
    // of the sheared coordinates, a few ulps of the vertices' distance from the origin in units of
    // the scaled coordinates (`reach`, at least about 1), so t's error is about that times the
    // depths' spread over det. Where it is not small against t (slivers, grazing rays, far and
    // near), the kept hit's t is recomputed (accurateHitDistance).
    const float depthSpread = max(max(az, bz), cz) - min(min(az, bz), cz);
    const vec3 farthest = max(max(abs(a), abs(b)), abs(c));
    const float reach = max(max(farthest.x, farthest.y), farthest.z) * scale;
    inexactT = depthSpread * reach * kInexactTSpread > abs(det) * hitT;
    return true;
}

RP_HOT_FUNC bool intersectTriangle(TraceRay r, vec3 v0, vec3 v1, vec3 v2, float tmax, RP_OUT(float) t,
                                   RP_OUT(vec2) bary) {
    bool inexactT;
    return intersectTriangle(r, v0, v1, v2, tmax, t, bary, inexactT);
}

// ---- The fast triangle test (issue 15, IntersectMode::Fast).
// Moller and Trumbore 1997 ("Fast, Minimum Storage Ray/Triangle Intersection", JGT 2(1)): two cross
// products and four dot products, no shear, no scaling, no accurate distance. What it gives up is
// the watertight test's care: u and v are rounded quotients computed differently in the two
// triangles of an edge, so a ray through a shared edge or vertex can pass both tests' bounds and
// miss both triangles (tests/test_intersect.cpp, FastIntersect.*, shows it on a lattice of shared
// vertices where the watertight test loses none), and its t is only as good as dot(e2, q) / det.
// The classic absolute epsilon on det is left out (det == 0 only): an absolute bound would discard
// every triangle of a scene drawn at 1e-4 units, which is not a speed trade but a broken image.
// GLSL may fuse its products (no `precise`): the fast path promises no bit-equality between tracers.
RP_HOT_FUNC bool intersectTriangleFast(TraceRay r, vec3 v0, vec3 v1, vec3 v2, float tmax, RP_OUT(float) t,
                                       RP_OUT(vec2) bary) {
    t = 0.0f;
    bary = vec2(0.0f);
    const vec3 e1 = v1 - v0;
    const vec3 e2 = v2 - v0;
    const vec3 p = cross(r.dir, e2);
    const float det = dot(e1, p);
    if (det == 0.0f) return false;
    const float invDet = 1.0f / det;
    const vec3 s = r.org - v0;
    const float u = dot(s, p) * invDet;
    if (u < 0.0f || u > 1.0f) return false;
    const vec3 q = cross(s, e1);
    const float v = dot(r.dir, q) * invDet;
    if (v < 0.0f || u + v > 1.0f) return false;
    const float hitT = dot(e2, q) * invDet;
    if (!(hitT > 0.0f && hitT <= tmax)) return false;
    t = hitT;
    bary = vec2(u, v);
    return true;
}

// ---- The accurate distance of an accepted hit (issue 15).
// intersectTriangle's t is a weighted mean of the sheared vertex depths, weighted by the edge
// functions. Where those cancel (a sliver: two long, nearly parallel edges) or the ray grazes the
// triangle, t carried relative errors up to 1e-3 (a soup of 1e-4-wide slivers), and shadow rays
// start from org + t dir. The hit decision stays Woop et al.'s; the hit that traversal finally
// keeps gets its t from the triangle's plane, t = ((v0 - org) . n) / (dir . n) with
// n = (v1 - v0) x (v2 - v0), evaluated in double-float arithmetic (a float pair hi + lo): the
// differences of the float inputs are exact (TwoSum), products carry their rounding error
// (Dekker's TwoProduct with Veltkamp's split, so no fused multiply-add is needed, which Vulkan
// does not promise), and the result is the exact plane distance to about 2^-44 relative before
// its final rounding to float, even for slivers and grazing rays. Only `precise` arithmetic, so
// every device computes the same bits where division is correctly rounded. About 400 float
// operations, once per primary ray (not per triangle test): the GPU kernels' form on devices
// without fast 64-bit floats; elsewhere they and the CPU tracers take accurateHitDistanceF64
// (below), which agrees with this one to an ulp of the result.

// s + e = a + b exactly (Knuth's TwoSum), for any order of magnitude.
RP_HOT_FUNC vec2 twoSum(float a, float b) {
    RP_PRECISE const float s = a + b;
    RP_PRECISE const float bb = s - a;
    RP_PRECISE const float e = (a - (s - bb)) + (b - bb);
    return vec2(s, e);
}

// s + e = a + b exactly when |a| >= |b| or a == 0 (Dekker's FastTwoSum).
RP_HOT_FUNC vec2 fastTwoSum(float a, float b) {
    RP_PRECISE const float s = a + b;
    RP_PRECISE const float e = b - (s - a);
    return vec2(s, e);
}

// hi + lo = a with hi and lo of at most 12 significant bits each (Veltkamp's split, 2^12 + 1).
RP_HOT_FUNC vec2 veltkampSplit(float a) {
    RP_PRECISE const float c = 4097.0f * a;
    RP_PRECISE const float hi = c - (c - a);
    RP_PRECISE const float lo = a - hi;
    return vec2(hi, lo);
}

// p + e = a * b exactly (Dekker's TwoProduct), barring underflow and overflow.
RP_HOT_FUNC vec2 twoProduct(float a, float b) {
    RP_PRECISE const float p = a * b;
    const vec2 sa = veltkampSplit(a);
    const vec2 sb = veltkampSplit(b);
    RP_PRECISE const float e = ((sa.x * sb.x - p) + sa.x * sb.y + sa.y * sb.x) + sa.y * sb.y;
    return vec2(p, e);
}

// Double-float sum and product (Dekker 1971; the "sloppy" forms, relative error about 2^-44).
RP_HOT_FUNC vec2 ddAdd(vec2 a, vec2 b) {
    const vec2 s = twoSum(a.x, b.x);
    RP_PRECISE const float e = s.y + (a.y + b.y);
    return fastTwoSum(s.x, e);
}

RP_HOT_FUNC vec2 ddMul(vec2 a, vec2 b) {
    const vec2 p = twoProduct(a.x, b.x);
    RP_PRECISE const float e = p.y + (a.x * b.y + a.y * b.x);
    return fastTwoSum(p.x, e);
}

RP_HOT_FUNC vec2 ddMulFloat(vec2 a, float b) {
    const vec2 p = twoProduct(a.x, b);
    RP_PRECISE const float e = p.y + a.y * b;
    return fastTwoSum(p.x, e);
}

// a * b - c * d in double-float.
RP_HOT_FUNC vec2 ddCrossTerm(vec2 a, vec2 b, vec2 c, vec2 d) { return ddAdd(ddMul(a, b), -ddMul(c, d)); }

// The distance along org + t dir to the plane of (v0, v1, v2), for a hit intersectTriangle
// accepted with distance `acceptedT`. Falls back to `acceptedT` where the plane distance is not a
// positive finite float (the ray lies in the plane as far as the arithmetic can tell, or an
// input beyond float range), so a hit never moves behind the origin or to infinity.
RP_HOT_FUNC float accurateHitDistance(vec3 org, vec3 dir, vec3 v0, vec3 v1, vec3 v2, float acceptedT) {
    // Exact differences: a = v0 - org, e1 = v1 - v0, e2 = v2 - v0, as hi + lo per component.
    vec2 a[3];
    vec2 e1[3];
    vec2 e2[3];
    for (int i = 0; i < 3; ++i) {
        a[i] = twoSum(v0[i], -org[i]);
        e1[i] = twoSum(v1[i], -v0[i]);
        e2[i] = twoSum(v2[i], -v0[i]);
    }
    // t is unchanged when the edges are scaled (n scales in both dot products) and when a and dir
    // are scaled together: powers of two bring both groups near 1, so that no product overflows
    // (the split multiplies by 4097) or underflows, from 1e-30 to 1e30 scenes alike.
    const float edgeScale = powerOfTwoScale(
        max(max(max(abs(e1[0].x), abs(e1[1].x)), max(abs(e1[2].x), abs(e2[0].x))), max(abs(e2[1].x), abs(e2[2].x))));
    const float rayScale = powerOfTwoScale(
        max(max(max(abs(a[0].x), abs(a[1].x)), max(abs(a[2].x), abs(dir.x))), max(abs(dir.y), abs(dir.z))));
    vec3 d;
    for (int i = 0; i < 3; ++i) {
        e1[i] = e1[i] * edgeScale;
        e2[i] = e2[i] * edgeScale;
        a[i] = a[i] * rayScale;
        d[i] = dir[i] * rayScale;
    }
    const vec2 nx = ddCrossTerm(e1[1], e2[2], e1[2], e2[1]);
    const vec2 ny = ddCrossTerm(e1[2], e2[0], e1[0], e2[2]);
    const vec2 nz = ddCrossTerm(e1[0], e2[1], e1[1], e2[0]);
    const vec2 numerator = ddAdd(ddAdd(ddMul(a[0], nx), ddMul(a[1], ny)), ddMul(a[2], nz));
    const vec2 denominator = ddAdd(ddAdd(ddMulFloat(nx, d[0]), ddMulFloat(ny, d[1])), ddMulFloat(nz, d[2]));
    // One Newton step on the quotient: t0 = hi / hi, then t = t0 + (num - den * t0) / den.
    RP_PRECISE const float t0 = numerator.x / denominator.x;
    const vec2 residual = ddAdd(numerator, -ddMulFloat(denominator, t0));
    RP_PRECISE const float t = t0 + residual.x / denominator.x;
    return t > 0.0f && t <= kFloatHuge ? t : acceptedT;
}

// The same plane distance in 64-bit floats (C++ double; GLSL double, where the device has
// shaderFloat64 and the kernel is built with RP_FLOAT64). What float pairs need care for, doubles
// do plainly: the differences of float inputs are exact in double (or within 2^-53 where their
// exponents lie more than 29 apart), the products of two such differences round once at 2^-53, and
// nothing overflows or underflows (a float's range cubed is within a double's), so no scaling
// either. Its result is the exact plane distance to about 2^-50 relative before the final rounding
// to float, as good as the float-pair form's 2^-44 or better, in some 45 double operations against
// about 400 float ones: the CPU tracers' form, and the GPU kernels' where doubles are fast
// (GpuTracer chooses, docs/trade.md "Accurate hit distances").
#if defined(__cplusplus) || defined(RP_FLOAT64)
RP_HOT_FUNC float accurateHitDistanceF64(vec3 org, vec3 dir, vec3 v0, vec3 v1, vec3 v2, float acceptedT) {
    RP_PRECISE const double ax = double(v0.x) - double(org.x);
    RP_PRECISE const double ay = double(v0.y) - double(org.y);
    RP_PRECISE const double az = double(v0.z) - double(org.z);
    RP_PRECISE const double e1x = double(v1.x) - double(v0.x);
    RP_PRECISE const double e1y = double(v1.y) - double(v0.y);
    RP_PRECISE const double e1z = double(v1.z) - double(v0.z);
    RP_PRECISE const double e2x = double(v2.x) - double(v0.x);
    RP_PRECISE const double e2y = double(v2.y) - double(v0.y);
    RP_PRECISE const double e2z = double(v2.z) - double(v0.z);
    RP_PRECISE const double nx = e1y * e2z - e1z * e2y;
    RP_PRECISE const double ny = e1z * e2x - e1x * e2z;
    RP_PRECISE const double nz = e1x * e2y - e1y * e2x;
    RP_PRECISE const double numerator = (ax * nx + ay * ny) + az * nz;
    RP_PRECISE const double denominator = (double(dir.x) * nx + double(dir.y) * ny) + double(dir.z) * nz;
    RP_PRECISE const double t = numerator / denominator;
    // A zero denominator gives an infinity or a NaN, which the range test turns away.
    if (!(t > double(0.0f) && t <= double(kFloatHuge))) return acceptedT;
    const float rounded = float(t);
    return rounded > 0.0f ? rounded : acceptedT;
}
#endif

// The order of closest hits: nearer t first, and among equal t (coplanar or shared-edge triangles)
// the lower triangle index. With it the closest hit is independent of traversal order, so the
// CPU reference, a brute-force loop and the GPU kernels agree on `prim` even at ties.
RP_HOT_FUNC bool isCloserHit(float t, uint prim, float bestT, uint bestPrim) {
    return t < bestT || (t == bestT && prim < bestPrim);
}

// The hit point org + t * dir, computed the same way everywhere (shadow rays start from it).
RP_FUNC vec3 hitPosition(vec3 org, vec3 dir, float t) {
    RP_PRECISE const vec3 p = org + t * dir;
    return p;
}

// Shadow rays (report 3.5): traced from the light towards the hit point p, ignoring what lies at or
// beyond p. The ray is light + s * (p - light); p itself is at s = 1. Two rules together:
//  - the triangle that p lies on is skipped: a planar triangle cannot occlude its own points from a
//    point light, and skipping it is exact, unlike any epsilon;
//  - intersections at s > 1 - kShadowRayGap are ignored, so that the neighbours of the hit
//    triangle (which meet it at p's edge, at s = 1 up to rounding) do not cast acne at concave
//    edges. The gap is relative to the light distance: 1e-4 of it (a millimetre at 10 m) is far
//    below a pixel at the distances the report's scenes are viewed from, yet far above the
//    rounding of p (a few ulps of the scene's size), even at grazing angles down to ~1 degree.
// A tracer must treat p == light (zero direction) as lit without tracing.
const float kShadowRayGap = 1.0e-4f;

struct ShadowRay {
    vec3 org;       // the light
    vec3 dir;       // p - light, not normalized
    float tmax;     // 1 - kShadowRayGap
    uint skipPrim;  // the triangle p lies on
};

RP_FUNC ShadowRay makeShadowRay(vec3 light, vec3 hitPoint, uint hitPrim) {
    ShadowRay s;
    s.org = light;
    s.dir = hitPoint - light;
    s.tmax = 1.0f - kShadowRayGap;
    s.skipPrim = hitPrim;
    return s;
}

RP_FUNC bool isDegenerateShadowRay(ShadowRay s) { return s.dir == vec3(0.0f); }

RP_END_NAMESPACE

#endif  // RAYPACK_SHADERS_INTERSECT_H
