// The primary ray of a pixel: the one definition the CPU reference, the GPU kernels and the viewer
// all use, so that their images and hits compare pixel for pixel.
//   right = normalize(cross(forward, up)), up' = cross(right, forward)
//   u = (2(x+0.5)/W - 1) * tan(fov/2) * W/H,  v = (1 - 2(y+0.5)/H) * tan(fov/2)
//   dir = normalize(forward + u*right + v*up'), row 0 at the top.
#ifndef RAYPACK_SHADERS_CAMERA_H
#define RAYPACK_SHADERS_CAMERA_H
#include "common.h"

RP_BEGIN_NAMESPACE

// 64 bytes. Built on the CPU by makeGpuCamera (renderer/camera.h).
struct GpuCamera {
    vec4 eye;      // xyz: eye position, w: tan(fov/2) * W/H  (horizontal scale of u)
    vec4 forward;  // xyz: view direction (+ the pixel jitter, renderer/camera.h), w: tan(fov/2)
    vec4 right;    // xyz: normalized right vector, w: image width as float
    vec4 up;       // xyz: up' = cross(right, forward), w: image height as float
};
RP_CHECK_SIZE(GpuCamera, 64);

RP_FUNC vec3 primaryRayDirection(GpuCamera cam, uint x, uint y) {
    const float u = (2.0f * (float(x) + 0.5f) / cam.right.w - 1.0f) * cam.eye.w;
    const float v = (1.0f - 2.0f * (float(y) + 0.5f) / cam.up.w) * cam.forward.w;
    const vec3 forward = vec3(cam.forward.x, cam.forward.y, cam.forward.z);
    const vec3 right = vec3(cam.right.x, cam.right.y, cam.right.z);
    const vec3 up = vec3(cam.up.x, cam.up.y, cam.up.z);
    return normalize(forward + u * right + v * up);
}

RP_FUNC vec3 cameraEye(GpuCamera cam) { return vec3(cam.eye.x, cam.eye.y, cam.eye.z); }

RP_END_NAMESPACE

#endif  // RAYPACK_SHADERS_CAMERA_H
