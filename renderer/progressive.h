#pragma once
// Progressive display: what the viewer shows between "the camera moved" and "the image is final",
// and what `raypack-cli render --spp N` reproduces.
//
//  - Reduced resolution while moving: the image traced at ceil(W/s) x ceil(H/s) for a scale s of
//    1, 2, 4 or 8, scaled up to W x H (nearest for heat maps, bilinear for shaded images).
//  - Refinement when still: N samples per pixel from one fixed pattern (samplePatternOffset),
//    averaged exactly (integer sums of the 8-bit channels, rounded half up), so the viewer's
//    converged image and the CLI's are the same bytes.
#include "renderer/image.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace raypack {

// The pattern's name as screenshot sidecars and `render --json` record it.
constexpr const char* kSamplePatternName = "halton-2-3";
// The largest samples-per-pixel count accepted (the sums stay exact in 32 bits far beyond it).
constexpr uint32_t kMaxSamplesPerPixel = 4096;

// Offset from the pixel centre, in pixels (each component in [-0.5, 0.5)), of sample `index`
// (0-based) of an image of `samples` samples per pixel. One sample is the pixel centre (offset 0:
// the image of a plain render); N > 1 samples are the points 1..N of the Halton sequence in bases
// 2 and 3, shifted by -0.5: stratified in both axes for every prefix, so a partly refined image
// is already evenly spread. Throws raypack::Error when samples is 0 or above the maximum or
// index >= samples.
glm::vec2 samplePatternOffset(uint32_t index, uint32_t samples);

// Sums of RGBA8 images of one size; resolve() is the rounded mean.
class SampleAccumulator {
public:
    void reset(uint32_t width, uint32_t height);
    // Adds one sample image (width x height RGBA8). Throws raypack::Error on a size mismatch.
    void add(const std::vector<uint32_t>& rgba);
    uint32_t samples() const { return samples_; }
    uint32_t width() const { return width_; }
    uint32_t height() const { return height_; }
    // Each channel: floor(sum / n + 0.5) computed in integers. Empty before the first sample.
    std::vector<uint32_t> resolve() const;

private:
    uint32_t width_ = 0, height_ = 0, samples_ = 0;
    std::vector<uint32_t> sums_;  // 4 per pixel: R, G, B, A
};

// The traced size for a resolution scale: ceil(size / scale), at least 1.
uint32_t scaledExtent(uint32_t size, uint32_t scale);

enum class ScaleFilter { Nearest, Bilinear };

// Scales `source` to width x height. Texel centres at (i + 0.5) * source / target; nearest picks
// the source texel containing the target texel's centre; bilinear blends the four around it with
// weights in 1/256, horizontally then vertically, each step rounded, clamped at the borders.
// Identical sizes return the source unchanged. Multithreaded over rows (TBB).
Image scaleImage(const Image& source, uint32_t width, uint32_t height, ScaleFilter filter);

}  // namespace raypack
