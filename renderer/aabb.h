#pragma once
#include <glm/glm.hpp>

#include <cfloat>

namespace raypack {

// Axis-aligned box. An empty box has lo = +FLT_MAX and hi = -FLT_MAX so that growing it by any
// point or box gives that point or box.
struct Aabb {
    glm::vec3 lo{FLT_MAX};
    glm::vec3 hi{-FLT_MAX};

    void grow(const glm::vec3& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    void grow(const Aabb& b) {
        lo = glm::min(lo, b.lo);
        hi = glm::max(hi, b.hi);
    }
    bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
    glm::vec3 extent() const { return empty() ? glm::vec3(0.0f) : hi - lo; }
    glm::vec3 center() const { return (lo + hi) * 0.5f; }
    // Surface area; 0 for an empty box.
    float area() const {
        const glm::vec3 e = extent();
        return 2.0f * (e.x * e.y + e.y * e.z + e.z * e.x);
    }
    bool contains(const Aabb& b) const {
        return glm::all(glm::lessThanEqual(lo, b.lo)) && glm::all(glm::greaterThanEqual(hi, b.hi));
    }
};

}  // namespace raypack
