#include "renderer/measure/accuracy.h"

#include "renderer/error.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace raypack {

double exactPlaneDistance(glm::vec3 org, glm::vec3 dir, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2) {
    const glm::dvec3 a(v0), e1 = glm::dvec3(v1) - a, e2 = glm::dvec3(v2) - a;
    const glm::dvec3 n = glm::cross(e1, e2);
    return glm::dot(a - glm::dvec3(org), n) / glm::dot(glm::dvec3(dir), n);
}

LeakCount countLeaks(const std::vector<HitRecord>& hits) {
    LeakCount count;
    count.rays = hits.size();
    for (const HitRecord& h : hits)
        if (h.prim == gpu::kNoHit) ++count.leaked;
    return count;
}

double nearestRankQuantile(std::vector<double> values, double q) {
    if (values.empty()) return 0.0;
    const size_t rank = size_t(std::ceil(std::clamp(q, 0.0, 1.0) * double(values.size())));
    const size_t index = std::clamp<size_t>(rank, 1, values.size()) - 1;
    std::nth_element(values.begin(), values.begin() + ptrdiff_t(index), values.end());
    return values[index];
}

HitDistanceErrors hitDistanceErrors(const Scene& scene, const std::vector<HitRecord>& hits) {
    std::vector<double> errors;
    errors.reserve(hits.size());
    for (const HitRecord& h : hits) {
        if (h.prim == gpu::kNoHit) continue;
        if (h.prim >= scene.triangleCount())
            throw Error("hit distance errors: a hit names triangle " + std::to_string(h.prim) + " of a scene of " +
                        std::to_string(scene.triangleCount()));
        const double exact =
            exactPlaneDistance(glm::vec3(h.orgX, h.orgY, h.orgZ), glm::vec3(h.dirX, h.dirY, h.dirZ),
                               scene.vertex(h.prim, 0), scene.vertex(h.prim, 1), scene.vertex(h.prim, 2));
        if (!(std::isfinite(exact) && exact > 0.0)) continue;
        errors.push_back(std::abs(double(h.t) - exact) / exact);
    }
    HitDistanceErrors result;
    result.hits = errors.size();
    if (errors.empty()) return result;
    result.maxRelative = *std::max_element(errors.begin(), errors.end());
    result.p999Relative = nearestRankQuantile(std::move(errors), 0.999);
    return result;
}

uint64_t differingPixels(const std::vector<uint32_t>& image, const std::vector<uint32_t>& reference) {
    if (image.size() != reference.size())
        throw Error("differing pixels: an image of " + std::to_string(image.size()) + " pixels against one of " +
                    std::to_string(reference.size()));
    uint64_t count = 0;
    for (size_t i = 0; i < image.size(); ++i) count += image[i] != reference[i];
    return count;
}

uint64_t differingHits(const std::vector<HitRecord>& hits, const std::vector<HitRecord>& reference) {
    if (hits.size() != reference.size())
        throw Error("differing hits: " + std::to_string(hits.size()) + " hits against " +
                    std::to_string(reference.size()));
    uint64_t count = 0;
    for (size_t i = 0; i < hits.size(); ++i) count += hits[i].prim != reference[i].prim;
    return count;
}

}  // namespace raypack
