#pragma once
// What the speed/accuracy trade (issue 15, docs/trade.md) measures beside speed, from a frame's
// hits alone (each HitRecord carries its ray): how many primary rays leaked through a scene every
// ray must hit, how far the reported hit distances are from the exact ones, and how many pixels
// differ from a reference image.
#include "renderer/frame.h"
#include "renderer/scene.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace raypack {

// The exact distance along org + t dir to the plane of the float triangle (v0, v1, v2), evaluated
// in double: the differences of float coordinates are exact there and the rest rounds at 2^-53,
// far below float's 2^-24, so it serves as the oracle of the hit distance t. +-inf or NaN where the
// ray is parallel to the plane or the triangle is degenerate.
double exactPlaneDistance(glm::vec3 org, glm::vec3 dir, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2);

// Primary rays that missed, among `hits`, on a closed scene whose camera sees it everywhere (so
// every miss is a leak through a shared edge or vertex).
struct LeakCount {
    uint64_t rays = 0;
    uint64_t leaked = 0;
    double perMillion() const { return rays ? double(leaked) / double(rays) * 1e6 : 0.0; }
};
LeakCount countLeaks(const std::vector<HitRecord>& hits);

// Relative error |t - t_exact| / t_exact of every hit's t against exactPlaneDistance to the
// triangle the hit names (its prim, in file order). Hits whose exact distance is not finite and
// positive (a ray in the triangle's plane) are not counted.
struct HitDistanceErrors {
    uint64_t hits = 0;          // hits compared
    double maxRelative = 0.0;   // largest relative error
    double p999Relative = 0.0;  // the 99.9th percentile (nearest rank) of the relative errors
};
// Throws raypack::Error when a hit names a triangle `scene` does not have.
HitDistanceErrors hitDistanceErrors(const Scene& scene, const std::vector<HitRecord>& hits);

// The value at nearest rank ceil(q * n) (1-based) of the sorted values, 0 when empty; q in (0, 1].
double nearestRankQuantile(std::vector<double> values, double q);

// Pixels whose RGBA8 value differs in any channel. Throws raypack::Error when the sizes differ.
uint64_t differingPixels(const std::vector<uint32_t>& image, const std::vector<uint32_t>& reference);
// Pixels whose hits differ: one hits and the other misses, or they name different triangles.
// Throws raypack::Error when the counts differ.
uint64_t differingHits(const std::vector<HitRecord>& hits, const std::vector<HitRecord>& reference);

}  // namespace raypack
