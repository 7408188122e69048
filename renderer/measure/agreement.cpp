#include "renderer/measure/agreement.h"

#include "renderer/error.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

namespace raypack {

HitAgreement compareHits(const std::vector<HitRecord>& hits, const std::vector<HitRecord>& reference) {
    if (hits.size() != reference.size())
        throw Error("hit comparison: cannot compare " + std::to_string(hits.size()) + " hits with " +
                    std::to_string(reference.size()) + " reference hits");
    HitAgreement a;
    for (size_t i = 0; i < hits.size(); ++i) {
        const HitRecord& p = hits[i];
        const HitRecord& r = reference[i];
        ++a.comparedRays;
        const bool hit = p.prim != gpu::kNoHit, refHit = r.prim != gpu::kNoHit;
        if (!hit && !refHit) {
            ++a.agreeingRays;
            continue;
        }
        if (hit != refHit) continue;
        const double error = std::abs(double(p.t) - double(r.t)) / std::max(std::abs(double(r.t)), 1e-30);
        a.maxRelativeTError = std::max(a.maxRelativeTError, error);
        if (error <= kHitRelativeTTolerance) ++a.agreeingRays;
        if (p.prim == r.prim) ++a.samePrim;
        if (r.shadow == gpu::kShadowLit || r.shadow == gpu::kShadowOccluded) {
            ++a.comparedShadows;
            if (p.shadow == r.shadow) ++a.agreeingShadows;
        }
    }
    return a;
}

double identicalHitShare(const std::vector<HitRecord>& hits, const std::vector<HitRecord>& reference) {
    if (reference.empty() || hits.size() != reference.size()) return 0.0;
    uint64_t same = 0;
    for (size_t i = 0; i < reference.size(); ++i) {
        const HitRecord& a = reference[i];
        const HitRecord& b = hits[i];
        same += a.prim == b.prim && std::memcmp(&a.t, &b.t, sizeof a.t) == 0 && a.shadow == b.shadow;
    }
    return double(same) / double(reference.size());
}

}  // namespace raypack
