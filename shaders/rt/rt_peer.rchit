#version 460
// Closest hit of primary rays: the distance and the triangle. gl_PrimitiveID indexes the
// triangles of the BLAS's one geometry, which keeps the scene's (file) order.
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require

#include "rt_peer_params.glsl"

layout(location = RT_PEER_PRIMARY_PAYLOAD) rayPayloadInEXT RtPeerPrimaryPayload primaryPayload;

void main() {
    primaryPayload.t = gl_HitTEXT;
    primaryPayload.prim = uint(gl_PrimitiveID);
}
