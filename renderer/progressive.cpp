#include "renderer/progressive.h"

#include "renderer/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

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
    if (index >= samples) throw Error("sample " + std::to_string(index) + " of " + std::to_string(samples));
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
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rgba.size(), 1 << 14), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i)
            for (int c = 0; c < 4; ++c) sums_[4 * i + c] += channel(rgba[i], c);
    });
    ++samples_;
}

std::vector<uint32_t> SampleAccumulator::resolve() const {
    std::vector<uint32_t> out;
    if (samples_ == 0) return out;
    out.resize(size_t(width_) * height_);
    const uint32_t n = samples_;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, out.size(), 1 << 14), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
            uint32_t texel = 0;
            for (int c = 0; c < 4; ++c) texel |= ((2 * sums_[4 * i + c] + n) / (2 * n)) << (8 * c);
            out[i] = texel;
        }
    });
    return out;
}

uint32_t scaledExtent(uint32_t size, uint32_t scale) {
    RAYPACK_CHECK(scale >= 1);
    return std::max(1u, (size + scale - 1) / scale);
}

namespace {

// One axis of a bilinear scale: for each target texel the two source texels around its centre and
// the weight of the second, in 1/256 (texel centres at (i + 0.5) * source / target, clamped).
struct Taps {
    std::vector<uint32_t> first, second, weight;
};

Taps bilinearTaps(uint32_t source, uint32_t target) {
    Taps taps;
    taps.first.resize(target);
    taps.second.resize(target);
    taps.weight.resize(target);
    const float step = float(source) / float(target);
    for (uint32_t i = 0; i < target; ++i) {
        const float position = (float(i) + 0.5f) * step - 0.5f;
        const float floor = std::floor(position);
        const int lower = int(floor);
        taps.first[i] = uint32_t(std::clamp(lower, 0, int(source) - 1));
        taps.second[i] = uint32_t(std::clamp(lower + 1, 0, int(source) - 1));
        taps.weight[i] = uint32_t(std::clamp(int(std::lround((position - floor) * 256.0f)), 0, 256));
    }
    return taps;
}

// (a * (256 - w) + b * w) / 256, rounded, for the four 8-bit channels at once: R and B in the
// 16-bit lanes of one word, G and A in the other (SWAR; the sums stay below 65,536).
uint32_t lerpTexel(uint32_t a, uint32_t b, uint32_t w) {
    constexpr uint32_t kLanes = 0x00FF00FFu, kHalf = 0x00800080u;
    const uint32_t rb = (((a & kLanes) * (256 - w) + (b & kLanes) * w + kHalf) >> 8) & kLanes;
    const uint32_t ga = ((((a >> 8) & kLanes) * (256 - w) + ((b >> 8) & kLanes) * w + kHalf) >> 8) & kLanes;
    return rb | (ga << 8);
}

}  // namespace

Image scaleImage(const Image& source, uint32_t width, uint32_t height, ScaleFilter filter) {
    RAYPACK_CHECK(source.width > 0 && source.height > 0 && source.rgba.size() == size_t(source.width) * source.height);
    if (source.width == width && source.height == height) return source;
    Image out{width, height, std::vector<uint32_t>(size_t(width) * height)};
    if (filter == ScaleFilter::Nearest) {
        // The source texel containing the target texel's centre.
        std::vector<uint32_t> columns(width);
        for (uint32_t x = 0; x < width; ++x)
            columns[x] = std::min(source.width - 1, uint32_t((float(x) + 0.5f) * float(source.width) / float(width)));
        tbb::parallel_for(tbb::blocked_range<uint32_t>(0, height, 16), [&](const tbb::blocked_range<uint32_t>& rows) {
            for (uint32_t y = rows.begin(); y != rows.end(); ++y) {
                const uint32_t sy =
                    std::min(source.height - 1, uint32_t((float(y) + 0.5f) * float(source.height) / float(height)));
                const uint32_t* in = &source.rgba[size_t(sy) * source.width];
                uint32_t* row = &out.rgba[size_t(y) * width];
                for (uint32_t x = 0; x < width; ++x) row[x] = in[columns[x]];
            }
        });
        return out;
    }
    // Bilinear, separable: each source row pair blended horizontally, then the two vertically.
    const Taps tx = bilinearTaps(source.width, width), ty = bilinearTaps(source.height, height);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, height, 16), [&](const tbb::blocked_range<uint32_t>& rows) {
        for (uint32_t y = rows.begin(); y != rows.end(); ++y) {
            const uint32_t* top = &source.rgba[size_t(ty.first[y]) * source.width];
            const uint32_t* bottom = &source.rgba[size_t(ty.second[y]) * source.width];
            const uint32_t wy = ty.weight[y];
            uint32_t* row = &out.rgba[size_t(y) * width];
            for (uint32_t x = 0; x < width; ++x) {
                const uint32_t a = lerpTexel(top[tx.first[x]], top[tx.second[x]], tx.weight[x]);
                const uint32_t b = lerpTexel(bottom[tx.first[x]], bottom[tx.second[x]], tx.weight[x]);
                row[x] = lerpTexel(a, b, wy);
            }
        }
    });
    return out;
}

}  // namespace raypack
