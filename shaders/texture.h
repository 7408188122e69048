// Textures as the GPU kernels and the CPU reference both sample them: RGBA8 packing, the wrap
// modes of glTF samplers (and OBJ's -clamp), bilinear filtering and the interpolation of per-vertex
// UVs and colours (see common.h for the GLSL/C++ rules). One text for both, so that textured
// images agree pixel for pixel up to the GPU's arithmetic.
//
// The filter is split in two so that neither side needs the other's memory: bilinearTaps gives the
// four texel indices and the weights, each side reads the four texels from its own storage (a
// storage buffer of uints on the GPU, Texture::texels on the CPU), and bilinearBlend mixes them.
// Textures are mipmapped (scenes/textures.cpp builds the levels) and sampled trilinearly at a level
// of detail from the pixel's footprint (a ray cone: the pixel's angle times the hit distance,
// widened by the slant), so that distant textures neither alias nor turn the GPU's last-ulp
// differences in ray directions into visible steps.
#ifndef RAYPACK_SHADERS_TEXTURE_H
#define RAYPACK_SHADERS_TEXTURE_H
#include "camera.h"  // GpuCamera
#include "common.h"
#include "intersect.h"  // RP_PRECISE

RP_BEGIN_NAMESPACE

#ifdef __cplusplus
using glm::floor;
#endif

// RGBA8 with R in the low byte (the byte order of VK_FORMAT_R8G8B8A8_UNORM in memory, and of the
// texels stb_image decodes). Each channel is clamp(c, 0, 1) * 255 rounded half up; `precise` keeps
// the GPU from fusing the multiply-add so the rounding matches the CPU's.
RP_FUNC uint packChannel(float c) {
    RP_PRECISE const float scaled = clamp(c, 0.0f, 1.0f) * 255.0f + 0.5f;
    return uint(floor(scaled));
}

RP_FUNC uint packRgba8(vec4 c) {
    return packChannel(c.x) | (packChannel(c.y) << 8u) | (packChannel(c.z) << 16u) | (packChannel(c.w) << 24u);
}

// Multiplied by the float nearest 1/255 rather than divided by 255: GLSL lets a division be
// approximate (2.5 ulp), a multiplication is exact to rounding on both sides.
RP_FUNC vec4 unpackRgba8(uint packed) {
    RP_PRECISE const vec4 c =
        vec4(float(packed & 255u), float((packed >> 8u) & 255u), float((packed >> 16u) & 255u), float(packed >> 24u)) *
        (1.0f / 255.0f);
    return c;
}

// Wrap modes (the values of raypack::TextureWrap): glTF's REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT.
const uint kWrapRepeat = 0u;
const uint kWrapClamp = 1u;
const uint kWrapMirror = 2u;
// GpuMaterial's texture index when the material has none (raypack::kNoTexture).
const uint kNoTextureIndex = 0xFFFFFFFFu;

// 16 bytes: one texture's place in the texel buffer.
//   offset: index of its first texel (row 0 is the image's top row, UV v = 0); level k + 1 follows
//           level k, each max(1, size / 2) of the one before
//   wrap:   bits 0-1 the wrap of u, bits 2-3 the wrap of v (kWrap*), bits 8-15 the number of
//           levels (0 counts as 1)
struct GpuTexture {
    uint offset;
    uint width;
    uint height;
    uint wrap;
};
RP_CHECK_SIZE(GpuTexture, 16);

// A texture coordinate brought into the range its wrap mode's index arithmetic expects: [0, 1] for
// repeat (one period), [0, 2] for mirror (a period and its mirror image), [-1, 2] for clamp (far
// enough out to clamp, near enough that the texel index fits an int).
RP_FUNC float reduceCoordinate(float c, uint wrap) {
    if (wrap == kWrapRepeat) return c - floor(c);
    if (wrap == kWrapMirror) return c - 2.0f * floor(c * 0.5f);
    return clamp(c, -1.0f, 2.0f);
}

// Texel index i of a reduced coordinate (reduceCoordinate; i lies in [-1, size] for repeat and in
// [-1, 2 size] for mirror) mapped into [0, size).
RP_FUNC int wrapIndex(int i, int size, uint wrap) {
    if (wrap == kWrapClamp) return clamp(i, 0, size - 1);
    if (wrap == kWrapRepeat) {
        if (i < 0) return i + size;
        if (i >= size) return i - size;
        return i;
    }
    int m = i;  // mirror: period 2 size, its second half reversed
    if (m < 0) m += 2 * size;
    if (m >= 2 * size) m -= 2 * size;
    return m < size ? m : 2 * size - 1 - m;
}

// The four texels of a bilinear lookup at uv (texel centres at half-integer coordinates, as in
// OpenGL and Vulkan) and the weights between them.
//   texel.x: (x0, y0)  texel.y: (x1, y0)  texel.z: (x0, y1)  texel.w: (x1, y1), as indices into
//            the texel buffer (GpuTexture::offset included)
//   weight:  x: towards x1, y: towards y1
struct BilinearTaps {
    uvec4 texel;
    vec2 weight;
};

RP_FUNC BilinearTaps bilinearTaps(GpuTexture tex, vec2 uv) {
    const uint wrapU = tex.wrap & 3u;
    const uint wrapV = (tex.wrap >> 2u) & 3u;
    RP_PRECISE const float x = reduceCoordinate(uv.x, wrapU) * float(tex.width) - 0.5f;
    RP_PRECISE const float y = reduceCoordinate(uv.y, wrapV) * float(tex.height) - 0.5f;
    const float fx = floor(x);
    const float fy = floor(y);
    const int w = int(tex.width);
    const int h = int(tex.height);
    const int xa = wrapIndex(int(fx), w, wrapU);
    const int xb = wrapIndex(int(fx) + 1, w, wrapU);
    const int ya = wrapIndex(int(fy), h, wrapV);
    const int yb = wrapIndex(int(fy) + 1, h, wrapV);
    BilinearTaps taps;
    taps.texel = uvec4(tex.offset) + uvec4(uint(ya * w + xa), uint(ya * w + xb), uint(yb * w + xa), uint(yb * w + xb));
    taps.weight = vec2(x - fx, y - fy);
    return taps;
}

// a (1 - w) + b w, with the GPU kept from fusing it differently from the CPU (GLSL's mix leaves
// the formula to the implementation).
RP_FUNC vec4 lerpPrecise(vec4 a, vec4 b, float w) {
    RP_PRECISE const vec4 r = a * (1.0f - w) + b * w;
    return r;
}

RP_FUNC uint textureLevels(GpuTexture tex) { return max((tex.wrap >> 8u) & 255u, 1u); }

// The descriptor of one mip level (its offset and size, the same wrap modes).
RP_FUNC GpuTexture textureLevel(GpuTexture tex, uint level) {
    GpuTexture l = tex;
    for (uint k = 0u; k < level; ++k) {
        l.offset += l.width * l.height;
        l.width = max(l.width / 2u, 1u);
        l.height = max(l.height / 2u, 1u);
    }
    return l;
}

// The angle one pixel spans vertically: 2 tan(fov / 2) / height (shaders/camera.h's GpuCamera).
RP_FUNC float pixelSpread(GpuCamera camera) { return camera.forward.w; }

// The level of detail at a hit: log2 of the texels the pixel's footprint covers. The footprint is
// hitT * pixelSpread (the pixel's angle, 2 tan(fov / 2) / height) over the cosine between the ray
// and the triangle (at least 0.1); the texels per unit of length are the square root of the
// triangle's area in texels over its area in the scene. Clamped to the texture's levels.
RP_FUNC float textureLod(GpuTexture tex, vec3 v0, vec3 v1, vec3 v2, vec2 uv0, vec2 uv1, vec2 uv2, vec3 rayDir,
                         float hitT, float pixelSpread) {
    const vec3 n = cross(v1 - v0, v2 - v0);
    const float worldArea = length(n);
    const vec2 a = uv1 - uv0;
    const vec2 b = uv2 - uv0;
    const float texelArea = abs(a.x * b.y - a.y * b.x) * float(tex.width) * float(tex.height);
    if (!(worldArea > 0.0f) || !(texelArea > 0.0f)) return 0.0f;
    const float cosine = max(abs(dot(n, rayDir)) / (worldArea * length(rayDir)), 0.1f);
    const float footprint = hitT * pixelSpread / cosine;
    const float texels = footprint * sqrt(texelArea / worldArea);
    const float lod = texels > 1.0f ? log2(texels) : 0.0f;
    return min(lod, float(textureLevels(tex) - 1u));
}

// The filtered colour from the four texels bilinearTaps named, in its order.
RP_FUNC vec4 bilinearBlend(uint t00, uint t10, uint t01, uint t11, vec2 weight) {
    const vec4 top = lerpPrecise(unpackRgba8(t00), unpackRgba8(t10), weight.x);
    const vec4 bottom = lerpPrecise(unpackRgba8(t01), unpackRgba8(t11), weight.x);
    return lerpPrecise(top, bottom, weight.y);
}

// Per-vertex attributes at a hit, with its barycentric weights (bary.x for vertex 1, bary.y for
// vertex 2); `precise` keeps the GPU from contracting the sums differently from the CPU.
RP_FUNC vec2 interpolateUv(vec2 uv0, vec2 uv1, vec2 uv2, vec2 bary) {
    RP_PRECISE const vec2 uv = (1.0f - bary.x - bary.y) * uv0 + bary.x * uv1 + bary.y * uv2;
    return uv;
}

RP_FUNC vec3 interpolateColor(uint c0, uint c1, uint c2, vec2 bary) {
    RP_PRECISE const vec4 c =
        (1.0f - bary.x - bary.y) * unpackRgba8(c0) + bary.x * unpackRgba8(c1) + bary.y * unpackRgba8(c2);
    return vec3(c.x, c.y, c.z);
}

// The default material's diffuse grey (Material::diffuse; the OBJ loader's and the generators'
// default material): the colour of a surface that names no material.
const float kDefaultDiffuse = 0.8f;

// The material colour of a triangle before its material (if any) is applied: the default grey, or
// white where vertex colours give the colour (they are multiplied in by surfaceColor).
RP_FUNC vec3 defaultMaterialColor(bool hasVertexColors) { return hasVertexColors ? vec3(1.0f) : vec3(kDefaultDiffuse); }

// RGBA8 <-> BGRA8 (one packed texel, R in the low byte): swaps bytes 0 and 2, keeps G and A. For
// a B8G8R8A8 swapchain and its read-back.
RP_FUNC uint swapRedBlue(uint texel) {
    return (texel & 0xFF00FF00u) | ((texel & 0xFFu) << 16u) | ((texel >> 16u) & 0xFFu);
}

// The diffuse colour of a surface point: the material's colour times the texel (rgb; alpha is
// not used) times the vertex colour, each vec3(1) where the scene has none.
RP_FUNC vec3 surfaceColor(vec3 materialColor, vec4 texel, vec3 vertexColor) {
    return materialColor * vec3(texel.x, texel.y, texel.z) * vertexColor;
}

RP_END_NAMESPACE

#endif  // RAYPACK_SHADERS_TEXTURE_H
