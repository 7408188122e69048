#pragma once
// How far one tracer's hits agree with another's on the same rays (the same pixels of the same
// camera): the one comparison the bench, the peers and the tests share.
//
// The bar of issue 5's peers: a ray agrees when both miss, or both hit with
// |t - t_ref| <= 1e-4 * t_ref (a tracer that is not watertight, or that tests triangles in another
// form, may differ in the last bits of t and at shared edges). Shadows are compared where both hit
// and the reference cast a shadow ray (its HitRecord::shadow is lit or occluded).
#include "renderer/frame.h"

#include <cstdint>
#include <vector>

namespace raypack {

constexpr double kHitRelativeTTolerance = 1e-4;

struct HitAgreement {
    uint64_t comparedRays = 0;
    uint64_t agreeingRays = 0;
    uint64_t samePrim = 0;           // both hit the same triangle
    double maxRelativeTError = 0.0;  // over rays that both hit
    uint64_t comparedShadows = 0;
    uint64_t agreeingShadows = 0;
    double rayShare() const { return comparedRays ? double(agreeingRays) / double(comparedRays) : 0.0; }
    double shadowShare() const { return comparedShadows ? double(agreeingShadows) / double(comparedShadows) : 0.0; }
};

// Throws raypack::Error when the two differ in pixel count.
HitAgreement compareHits(const std::vector<HitRecord>& hits, const std::vector<HitRecord>& reference);

// Share of pixels whose hits are identical to the reference's: the same triangle, t to the bit and
// the same shadow state (what a tracer with the reference's arithmetic, the CPU packet tracer, must
// give). 0 when the counts differ or there are none.
double identicalHitShare(const std::vector<HitRecord>& hits, const std::vector<HitRecord>& reference);

}  // namespace raypack
