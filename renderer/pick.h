#pragma once
// The scene point under one pixel: the pixel's primary ray (shaders/camera.h, through
// makeGpuCamera, so the same ray the tracers shoot for that pixel) traced through the CPU
// reference (traceClosest). One ray, no frame rendered: the viewer calls it on a double-click
// (the orbit pivot) and on a wheel step (zoom toward the cursor).
#include "renderer/bvh.h"
#include "renderer/camera.h"
#include "renderer/scene.h"

#include <cstdint>
#include <optional>

namespace raypack {

struct PickHit {
    glm::vec3 point{0.0f};  // origin + t * direction
    float t = 0.0f;         // along the unit ray direction
    uint32_t prim = 0;      // triangle index in the scene's order
};

// Pixel (x, y) of a width x height image of `camera`, row 0 at the top; nullopt when the ray
// misses the scene or the pixel lies outside the image. Throws raypack::Error for a degenerate
// camera (makeGpuCamera).
std::optional<PickHit> pickPixel(const Scene& scene, const Bvh& bvh, const Camera& camera, uint32_t width,
                                 uint32_t height, uint32_t x, uint32_t y);

}  // namespace raypack
