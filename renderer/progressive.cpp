#include "renderer/progressive.h"

#include "renderer/error.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace raypack {
namespace {

// The radical inverse of `index` in `base`: the Halton sequence's coordinate.
float radicalInverse(uint32_t index, uint32_t base) {
    double inverse = 0.0, digitWeight = 1.0 / base;
    for (uint32_t i = index; i > 0; i /= base) {
        inverse += (i % base) * digitWeight;
        digitWeight /= base;
    }
    return float(inverse);
}

uint32_t channel(uint32_t texel, int c) { return (texel >> (8 * c)) & 0xFFu; }

}  // namespace

glm::vec2 samplePatternOffset(uint32_t index, uint32_t samples) {
    if (samples == 0 || samples > kMaxSamplesPerPixel)
        throw Error("samples per pixel: " + std::to_string(samples) + " is outside 1.." +
                    std::to_string(kMaxSamplesPerPixel));
    if (index >= samples)
        throw Error("sample " + std::to_string(index) + " of " + std::to_string(samples));
    if (samples == 1) return glm::vec2(0.0f);
    return glm::vec2(radicalInverse(index + 1, 2), radicalInverse(index + 1, 3)) - 0.5f;
}

void SampleAccumulator::reset(uint32_t width, uint32_t height) {
    width_ = width;
    height_ = height;
    samples_ = 0;
    sums_.assign(size_t(width) * height * 4, 0u);
}

void SampleAccumulator::add(const std::vector<uint32_t>& rgba) {
    if (rgba.size() != size_t(width_) * height_)
        throw Error("sample image of " + std::to_string(rgba.size()) + " texels added to an accumulation of " +
                    std::to_string(width_) + "x" + std::to_string(height_));
    for (size_t i = 0; i < rgba.size(); ++i)
        for (int c = 0; c < 4; ++c) sums_[4 * i + c] += channel(rgba[i], c);
    ++samples_;
}

std::vector<uint32_t> SampleAccumulator::resolve() const {
    std::vector<uint32_t> out;
    if (samples_ == 0) return out;
    out.resize(size_t(width_) * height_);
    const uint32_t n = samples_;
    for (size_t i = 0; i < out.size(); ++i) {
        uint32_t texel = 0;
        for (int c = 0; c < 4; ++c) texel |= ((2 * sums_[4 * i + c] + n) / (2 * n)) << (8 * c);
        out[i] = texel;
    }
    return out;
}

uint32_t scaledExtent(uint32_t size, uint32_t scale) {
    RAYPACK_CHECK(scale >= 1);
    return std::max(1u, (size + scale - 1) / scale);
}

Image scaleImage(const Image& source, uint32_t width, uint32_t height, ScaleFilter filter) {
    RAYPACK_CHECK(source.width > 0 && source.height > 0 &&
                  source.rgba.size() == size_t(source.width) * source.height);
    if (source.width == width && source.height == height) return source;
    Image out{width, height, std::vector<uint32_t>(size_t(width) * height)};
    const float sx = float(source.width) / float(width);
    const float sy = float(source.height) / float(height);
    const auto at = [&](int x, int y) {
        x = std::clamp(x, 0, int(source.width) - 1);
        y = std::clamp(y, 0, int(source.height) - 1);
        return source.rgba[size_t(y) * source.width + x];
    };
    for (uint32_t y = 0; y < height; ++y) {
        const float cy = (float(y) + 0.5f) * sy;  // the target texel's centre in source texels
        for (uint32_t x = 0; x < width; ++x) {
            const float cx = (float(x) + 0.5f) * sx;
            uint32_t& texel = out.rgba[size_t(y) * width + x];
            if (filter == ScaleFilter::Nearest) {
                texel = at(int(cx), int(cy));
                continue;
            }
            const float fx = cx - 0.5f, fy = cy - 0.5f;
            const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
            const float wx = fx - float(x0), wy = fy - float(y0);
            const uint32_t t00 = at(x0, y0), t10 = at(x0 + 1, y0), t01 = at(x0, y0 + 1), t11 = at(x0 + 1, y0 + 1);
            texel = 0;
            for (int c = 0; c < 4; ++c) {
                const float top = float(channel(t00, c)) * (1.0f - wx) + float(channel(t10, c)) * wx;
                const float bottom = float(channel(t01, c)) * (1.0f - wx) + float(channel(t11, c)) * wx;
                const float value = top * (1.0f - wy) + bottom * wy;
                texel |= uint32_t(std::clamp(std::floor(value + 0.5f), 0.0f, 255.0f)) << (8 * c);
            }
        }
    }
    return out;
}

}  // namespace raypack
