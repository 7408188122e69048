#include "renderer/start_view.h"

#include "renderer/cpu_tracer.h"
#include "renderer/settings.h"
#include "shaders/camera.h"

#include <algorithm>

namespace raypack {
namespace {

void probeInto(ViewProbe& probe, const Scene& scene, const Bvh& bvh, float diagonal, const Camera& camera) {
    const gpu::GpuCamera gpuCamera = makeGpuCamera(camera, kProbeSide, kProbeSide);
    const glm::vec3 eye = gpu::cameraEye(gpuCamera);
    for (uint32_t y = 0; y < kProbeSide; ++y) {
        for (uint32_t x = 0; x < kProbeSide; ++x) {
            const glm::vec3 dir = gpu::primaryRayDirection(gpuCamera, x, y);
            ++probe.rays;
            const HitRecord hit = traceClosest(scene, bvh, eye, dir);
            if (hit.prim == gpu::kNoHit) continue;
            ++probe.hits;
            if (hit.t < 0.02f * diagonal) ++probe.nearHits;
            const glm::uvec3 tri = scene.triangles[hit.prim];
            glm::vec3 normal;
            if (scene.hasNormals()) {
                normal = scene.normals[tri.x] + scene.normals[tri.y] + scene.normals[tri.z];
            } else {
                const glm::vec3 v0 = scene.positions[tri.x];
                normal = glm::cross(scene.positions[tri.y] - v0, scene.positions[tri.z] - v0);
            }
            if (glm::dot(normal, dir) > 0.0f) ++probe.backHits;
        }
    }
}

}  // namespace

ViewProbe probeView(const Scene& scene, const Bvh& bvh, const Camera& camera) {
    ViewProbe probe;
    const Aabb bounds = scene.bounds();
    if (bounds.empty() || bvh.nodes.empty()) return probe;
    probeInto(probe, scene, bvh, glm::length(bounds.extent()), camera);
    return probe;
}

ViewProbe probeAround(const Scene& scene, const Bvh& bvh, glm::vec3 point) {
    ViewProbe probe;
    const Aabb bounds = scene.bounds();
    if (bounds.empty() || bvh.nodes.empty()) return probe;
    const glm::vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (const glm::vec3& axis : axes) {
        Camera face;
        face.eye = point;
        face.at = point + axis;
        face.up = axis.y != 0.0f ? glm::vec3(0, 0, 1) : glm::vec3(0, 1, 0);
        face.fovYDegrees = 90.0f;
        probeInto(probe, scene, bvh, glm::length(bounds.extent()), face);
    }
    return probe;
}

bool centreIsInARoom(const Scene& scene, const Bvh& bvh) {
    const Aabb bounds = scene.bounds();
    if (bounds.empty() || !(glm::length(bounds.extent()) > 0.0f)) return false;
    const ViewProbe p = probeAround(scene, bvh, bounds.center());
    return p.hits > 0 && 10 * uint64_t(p.hits) >= 9 * uint64_t(p.rays) &&
           5 * uint64_t(p.backHits) <= uint64_t(p.hits) && 2 * uint64_t(p.nearHits) <= uint64_t(p.hits);
}

Camera startCamera(const Scene& scene, const Bvh& bvh) {
    if (scene.fileCamera) return *scene.fileCamera;
    const Aabb bounds = scene.bounds();
    if (!centreIsInARoom(scene, bvh)) return frameScene(bounds);

    const glm::vec3 centre = bounds.center();
    const glm::vec3 extent = bounds.extent();
    const int axis = extent.x >= extent.z ? 0 : 2;
    glm::vec3 along(0.0f);
    along[axis] = 1.0f;
    Camera inside;
    inside.up = glm::vec3(0.0f, 1.0f, 0.0f);
    inside.fovYDegrees = 70.0f;
    inside.eye = centre - along * (extent[axis] / 6.0f);  // a third of the way in from the low end
    const ViewProbe probe = probeView(scene, bvh, Camera{inside.eye, inside.eye + along, inside.up, 70.0f});
    if (probe.hits > 0 && 2 * uint64_t(probe.nearHits) > uint64_t(probe.hits)) inside.eye = centre;
    // Height: the box's centre, lower where the default light (RenderSettings::lightHeight times
    // the box's height above the camera) would be less than a tenth of the room's height under the
    // ceiling found straight above (it would leave the room in shadow), but at least a tenth of the
    // way up from the floor found straight below.
    const HitRecord up = traceClosest(scene, bvh, inside.eye, glm::vec3(0, 1, 0));
    const HitRecord down = traceClosest(scene, bvh, inside.eye, glm::vec3(0, -1, 0));
    if (up.prim != gpu::kNoHit && down.prim != gpu::kNoHit) {
        const float floorY = inside.eye.y - down.t, ceilingY = inside.eye.y + up.t;
        const float roomHeight = ceilingY - floorY;
        const float light = RenderSettings{}.lightHeight * extent.y;
        const float eyeY = std::min(inside.eye.y, ceilingY - 0.1f * roomHeight - light);
        inside.eye.y = std::max(eyeY, floorY + 0.1f * roomHeight);
    }
    inside.at = inside.eye + along;
    return inside;
}

Camera withStartView(const Camera& given, CameraParts parts, const Camera& start) {
    Camera camera = given;
    if (!parts.eye) camera.eye = start.eye;
    if (!parts.at) camera.at = start.at;
    if (!parts.up) camera.up = start.up;
    if (!parts.fov) camera.fovYDegrees = start.fovYDegrees;
    return camera;
}

}  // namespace raypack
