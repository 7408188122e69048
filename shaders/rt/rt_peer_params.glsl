// What the host hands the driver ray tracing peer's shaders (renderer/vk/rt_peer.cpp), defined once
// for GLSL and C++ (see ../common.h for the rules). The peer traces the very rays raypack traces:
// primary rays from shaders/camera.h's primaryRayDirection, shadow rays from shaders/intersect.h's
// makeShadowRay.
#ifndef RAYPACK_SHADERS_RT_RT_PEER_PARAMS_GLSL
#define RAYPACK_SHADERS_RT_RT_PEER_PARAMS_GLSL
#include "../common.h"
#include "../camera.h"

RP_BEGIN_NAMESPACE

// 96 bytes of push constants (within the guaranteed 128).
struct RtPeerParams {
    GpuCamera camera;  // 64 bytes, shaders/camera.h
    vec4 light;        // xyz: the point light (renderer/camera.h lightPosition), w: 0
    uvec4 frame;       // x: width, y: height, z: kRtPeerPass*, w: 0
};
RP_CHECK_SIZE(RtPeerParams, 96);
RP_CHECK_OFFSET(RtPeerParams, light, 64);
RP_CHECK_OFFSET(RtPeerParams, frame, 80);

// Passes: two vkCmdTraceRaysKHR of the same pipeline, so that each has its own timestamps.
const uint kRtPeerPassPrimary = 0u;  // one primary ray per pixel, writes the HitRecord
const uint kRtPeerPassShadow = 1u;   // one shadow ray per primary hit, writes HitRecord::shadow

// Shader groups, in the order of the pipeline's groups and of the shader binding table.
const uint kRtPeerGroupRaygen = 0u;
const uint kRtPeerGroupMissPrimary = 1u;  // miss index 0
const uint kRtPeerGroupMissShadow = 2u;   // miss index 1
const uint kRtPeerGroupHit = 3u;          // triangle hit group: closest hit only
const uint kRtPeerGroupCount = 4u;
const uint kRtPeerMissPrimary = 0u;  // traceRayEXT missIndex of primary rays
const uint kRtPeerMissShadow = 1u;   // traceRayEXT missIndex of shadow rays

RP_END_NAMESPACE

#ifndef __cplusplus
// Payload locations: the raygen shader declares both, the other stages the one they serve.
#define RT_PEER_PRIMARY_PAYLOAD 0
#define RT_PEER_SHADOW_PAYLOAD 1
struct RtPeerPrimaryPayload {
    float t;    // hit distance along the normalized primary direction
    uint prim;  // gl_PrimitiveID: the BLAS keeps the scene's order, so the file-order index
};
#endif

#endif  // RAYPACK_SHADERS_RT_RT_PEER_PARAMS_GLSL
