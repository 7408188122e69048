// What a traced frame hands back, shared by the GPU kernels (which write it) and C++ (which reads
// it, writes the hits file and compares it with the CPU reference).
#ifndef RAYPACK_SHADERS_FRAME_TYPES_H
#define RAYPACK_SHADERS_FRAME_TYPES_H
#include "common.h"

RP_BEGIN_NAMESPACE

// Shadow state of a pixel (HitRecord::shadow).
const uint kShadowLit = 0u;
const uint kShadowOccluded = 1u;
const uint kShadowNone = 2u;  // no shadow ray: the primary ray missed, or shadows are off
const uint kNoHit = 0xFFFFFFFFu;

// 40 bytes: exactly one record of the hits file (docs/hits-format.md), little-endian.
// t is +inf on a miss; the hit point is org + t * dir; prim is the triangle index in file order.
struct HitRecord {
    float orgX, orgY, orgZ;
    float dirX, dirY, dirZ;
    float t;
    uint prim;
    uint shadow;
    uint reserved;  // 0
};
RP_CHECK_SIZE(HitRecord, 40);

// The record of a ray from org along dir: t (+inf on a miss), prim (file order, kNoHit on a miss)
// and its shadow state (kShadow*). Every tracer fills its records through this.
RP_FUNC HitRecord makeHitRecord(vec3 org, vec3 dir, float t, uint prim, uint shadow) {
    HitRecord h;
    h.orgX = org.x;
    h.orgY = org.y;
    h.orgZ = org.z;
    h.dirX = dir.x;
    h.dirY = dir.y;
    h.dirZ = dir.z;
    h.t = t;
    h.prim = prim;
    h.shadow = shadow;
    h.reserved = 0u;
    return h;
}

// Per-ray traversal counters (the report's N_TR and N_IT), primary and shadow apart.
struct RayCounters {
    uint primaryNodes;  // N_TR of the primary ray: nodes visited
    uint primaryTests;  // N_IT of the primary ray: ray/triangle tests
    uint shadowNodes;   // N_TR of the shadow ray (0 when there is none)
    uint shadowTests;   // N_IT of the shadow ray
};
RP_CHECK_SIZE(RayCounters, 16);

RP_END_NAMESPACE

#endif  // RAYPACK_SHADERS_FRAME_TYPES_H
