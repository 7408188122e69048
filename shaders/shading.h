// Shading shared by the GPU kernels, the CPU reference and the viewer: the normal at a hit, Phong
// and the heat-map ramp of the N_TR / N_IT views; RGBA8 packing and texture sampling are in
// texture.h (see common.h for the GLSL/C++ rules). One text for all, so images compare pixel for
// pixel up to the GPU's arithmetic.
#ifndef RAYPACK_SHADERS_SHADING_H
#define RAYPACK_SHADERS_SHADING_H
#include "common.h"
#include "frame_types.h"  // RayCounters
#include "intersect.h"    // RP_PRECISE, hitPosition
#include "texture.h"      // RGBA8 packing, texture sampling

RP_BEGIN_NAMESPACE

#ifdef __cplusplus
using glm::floor;
#endif

// The geometric normal of a triangle, unit length and facing the viewer (against rayDir). A
// triangle the watertight test hits has non-zero area in the ray's projection, so the cross product
// is non-zero; a zero one (which only a caller bypassing that test could produce) gives -rayDir.
RP_FUNC vec3 geometricNormal(vec3 v0, vec3 v1, vec3 v2, vec3 rayDir) {
    vec3 n = cross(v1 - v0, v2 - v0);
    if (dot(n, n) == 0.0f) return -normalize(rayDir);
    n = normalize(n);
    return dot(n, rayDir) > 0.0f ? -n : n;
}

// The shading normal: the vertex normals interpolated with the hit's barycentric weights (bary.x
// for n1, bary.y for n2), flipped to face the viewer; the geometric normal when their blend is zero.
RP_FUNC vec3 interpolatedNormal(vec3 n0, vec3 n1, vec3 n2, vec2 bary, vec3 geometric, vec3 rayDir) {
    const vec3 n = (1.0f - bary.x - bary.y) * n0 + bary.x * n1 + bary.y * n2;
    if (dot(n, n) == 0.0f) return geometric;
    const vec3 unit = normalize(n);
    return dot(unit, rayDir) > 0.0f ? -unit : unit;
}

// Phong (ambient + diffuse + specular) for a white point light without falloff.
//  phong:      x ambient, y diffuse, z specular, w shininess (RenderSettings::phong)
//  normal:     unit, facing the viewer
//  toViewer:   unit, from the hit point towards the ray origin
//  toLight:    unit, from the hit point towards the light
//  lit:        false when the shadow ray found an occluder: ambient only
// The specular highlight is white; the result is clamped to [0, 1].
RP_FUNC vec3 shadePhong(vec4 phong, vec3 diffuseColor, vec3 normal, vec3 toViewer, vec3 toLight, bool lit) {
    vec3 color = phong.x * diffuseColor;
    const float cosLight = dot(normal, toLight);
    if (lit && cosLight > 0.0f) {
        color = color + phong.y * cosLight * diffuseColor;
        const vec3 reflected = reflect(-toLight, normal);
        const float cosView = max(dot(reflected, toViewer), 0.0f);
        if (cosView > 0.0f) color = color + vec3(phong.z * pow(cosView, phong.w));
    }
    return clamp(color, vec3(0.0f), vec3(1.0f));
}

// Heat-map views: the per-pixel work (primary + shadow ray) divided by a fixed full-scale value, so
// that every tracer and every frame maps the same count to the same colour (no per-frame maximum
// the GPU would need a second pass for). Full scale: nodes visited (N_TR) and triangle tests (N_IT).
const float kHeatFullScaleNodes = 256.0f;
const float kHeatFullScaleTests = 128.0f;

// Ramp from dark blue (0) through blue, cyan-green and yellow to red (1); values outside [0, 1] are
// clamped. Piecewise linear through five stops.
RP_FUNC vec3 heatColor(float value) {
    const float x = clamp(value, 0.0f, 1.0f) * 4.0f;
    const vec3 c0 = vec3(0.0f, 0.0f, 0.25f);
    const vec3 c1 = vec3(0.0f, 0.35f, 1.0f);
    const vec3 c2 = vec3(0.0f, 0.85f, 0.45f);
    const vec3 c3 = vec3(1.0f, 0.9f, 0.0f);
    const vec3 c4 = vec3(1.0f, 0.0f, 0.0f);
    if (x < 1.0f) return mix(c0, c1, x);
    if (x < 2.0f) return mix(c1, c2, x - 1.0f);
    if (x < 3.0f) return mix(c2, c3, x - 2.0f);
    return mix(c3, c4, x - 3.0f);
}

// The full-scale value of a heat map: the one asked for (RenderSettings::heatFullScale, > 0), or
// the view's default above.
RP_FUNC float heatFullScaleOf(float requested, bool nodes) {
    return requested > 0.0f ? requested : (nodes ? kHeatFullScaleNodes : kHeatFullScaleTests);
}

RP_FUNC vec3 heatColorForCount(uint count, float fullScale) { return heatColor(float(count) / fullScale); }

// The colour of a heat-map view: the pixel's nodes visited (N_TR, `nodes`) or triangle tests
// (N_IT), primary and shadow ray together, at full scale `requested` (0: the view's default).
RP_FUNC vec3 heatViewColor(bool nodes, RayCounters c, float requested) {
    const uint count = nodes ? c.primaryNodes + c.shadowNodes : c.primaryTests + c.shadowTests;
    return heatColorForCount(count, heatFullScaleOf(requested, nodes));
}

// The shaded colour of a hit at distance t along the ray from eye in direction dir: Phong with the
// point light at `light`, lit unless the shadow ray found an occluder. A point at the light itself
// is not lit (it has no direction to the light). The kernels and the CPU reference both end here.
RP_FUNC vec3 shadeHit(vec4 phong, vec3 eye, vec3 dir, float t, vec3 normal, vec3 diffuseColor, vec3 light,
                      bool occluded) {
    const vec3 p = hitPosition(eye, dir, t);
    const vec3 toLight = light - p;
    const bool lit = !occluded && toLight != vec3(0.0f);
    return shadePhong(phong, diffuseColor, normal, -dir, lit ? normalize(toLight) : normal, lit);
}

RP_END_NAMESPACE

#endif  // RAYPACK_SHADERS_SHADING_H
