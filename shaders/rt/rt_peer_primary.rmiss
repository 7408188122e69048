#version 460
// Miss of primary rays: no triangle (the raygen shader writes t = +inf).
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require

#include "frame_types.h"
#include "rt_peer_params.glsl"

layout(location = RT_PEER_PRIMARY_PAYLOAD) rayPayloadInEXT RtPeerPrimaryPayload primaryPayload;

void main() { primaryPayload.prim = kNoHit; }
