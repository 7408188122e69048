// The primary ray of a pixel: the one definition the CPU reference, the GPU kernels and the viewer
// all use, so that their images and hits compare pixel for pixel.
//   right = normalize(cross(forward, up)), up' = cross(right, forward)
//   u = (2(x+0.5)/W - 1) * tan(fov/2) * W/H,  v = (1 - 2(y+0.5)/H) * tan(fov/2)
//   dir = normalize(forward + u*right + v*up'), row 0 at the top.
// Every device computes the same bits of dir: u and v are one product and one sum of constants the
// host made (makeGpuCamera), the sum and the normalization use only products and sums, `precise`
// (RP_PRECISE), which Vulkan rounds correctly, where a GPU's division and normalize() (an
// approximate inverse square root) round as the device likes. Before 2026-12-08 they did: on
// lavapipe 351,680 of 720,000 directions differed from the CPU's in their last bits (Sibenik,
// 900x800), and 107 pixels hit another triangle at a shared edge.
#ifndef RAYPACK_SHADERS_CAMERA_H
#define RAYPACK_SHADERS_CAMERA_H
#include "common.h"

RP_BEGIN_NAMESPACE

// 64 bytes. Built on the CPU by makeGpuCamera (renderer/camera.h), from doubles rounded once.
struct GpuCamera {
    vec4 eye;      // xyz: eye position, w: the step of u from one pixel to the next, 2 tan(fov/2) / H
    vec4 forward;  // xyz: view direction (+ the pixel jitter, renderer/camera.h), w: the step of v, 2 tan(fov/2) / H
    vec4 right;    // xyz: normalized right vector, w: u of pixel column 0, (1/W - 1) tan(fov/2) W/H
    vec4 up;       // xyz: up' = cross(right, forward), w: v of pixel row 0, (1 - 1/H) tan(fov/2)
};
RP_CHECK_SIZE(GpuCamera, 64);

// d / |d| for a d of normal squared length, from products and sums only: the inverse square root
// of the classic bit trick (integer arithmetic, exact everywhere) and three Newton steps, within
// 1.3 ulps of 1 / sqrt(|d|^2) (2 million lengths from 1e-3 to 1e12, 2026-12-08).
RP_FUNC vec3 unitDirection(vec3 d) {
    RP_PRECISE const float lengthSquared = (d.x * d.x + d.y * d.y) + d.z * d.z;
    float inverseLength = uintBitsToFloat(0x5f3759dfu - (floatBitsToUint(lengthSquared) >> 1u));
    for (int step = 0; step < 3; ++step) {
        RP_PRECISE const float halfSquare = ((0.5f * lengthSquared) * inverseLength) * inverseLength;
        RP_PRECISE const float next = inverseLength * (1.5f - halfSquare);
        inverseLength = next;
    }
    RP_PRECISE const vec3 unit = d * inverseLength;
    return unit;
}

RP_FUNC vec3 primaryRayDirection(GpuCamera cam, uint x, uint y) {
    RP_PRECISE const float u = float(x) * cam.eye.w + cam.right.w;
    RP_PRECISE const float v = cam.up.w - float(y) * cam.forward.w;
    const vec3 forward = vec3(cam.forward.x, cam.forward.y, cam.forward.z);
    const vec3 right = vec3(cam.right.x, cam.right.y, cam.right.z);
    const vec3 up = vec3(cam.up.x, cam.up.y, cam.up.z);
    RP_PRECISE const vec3 d = (forward + u * right) + v * up;
    return unitDirection(d);
}

RP_FUNC vec3 cameraEye(GpuCamera cam) { return vec3(cam.eye.x, cam.eye.y, cam.eye.z); }

RP_END_NAMESPACE

#endif  // RAYPACK_SHADERS_CAMERA_H
