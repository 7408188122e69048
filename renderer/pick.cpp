#include "renderer/pick.h"

#include "renderer/cpu_tracer.h"

namespace raypack {

std::optional<PickHit> pickPixel(const Scene& scene, const Bvh& bvh, const Camera& camera, uint32_t width,
                                 uint32_t height, uint32_t x, uint32_t y) {
    if (x >= width || y >= height) return std::nullopt;
    const GpuCamera gpuCamera = makeGpuCamera(camera, width, height);
    const glm::vec3 origin = gpu::cameraEye(gpuCamera);
    const glm::vec3 direction = gpu::primaryRayDirection(gpuCamera, x, y);
    const HitRecord record = traceClosest(scene, bvh, origin, direction);
    if (record.prim == gpu::kNoHit) return std::nullopt;
    return PickHit{origin + record.t * direction, record.t, record.prim};
}

}  // namespace raypack
