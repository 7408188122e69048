#version 460
// Miss of shadow rays: nothing lies between the light and the point, which is lit.
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require

#include "rt_peer_params.glsl"

layout(location = RT_PEER_SHADOW_PAYLOAD) rayPayloadInEXT uint shadowOccluded;

void main() { shadowOccluded = 0u; }
