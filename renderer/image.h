#pragma once
// RGBA8 images: PNG and JPEG files (stb) and the pixel-by-pixel comparison the tests and `raypack-cli diff`
// use to hold a tracer against the reference.
#include <cstdint>
#include <string>
#include <vector>

namespace raypack {

// R in the low byte of each uint32_t (RGBA8 in memory), row-major, top row first: the layout of
// Frame::rgba.
struct Image {
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<uint32_t> rgba;
};

// Throws raypack::Error naming the file when it cannot be written or the image is inconsistent
// (rgba.size() != width * height, or empty).
void writePng(const std::string& path, const Image& image);
void writePng(const std::string& path, uint32_t width, uint32_t height, const std::vector<uint32_t>& rgba);

// The formats an image can be written in, by the path's extension (case-insensitive): .png, and
// .jpg / .jpeg (JPEG, quality 95, alpha dropped).
enum class ImageFormat { Png, Jpeg };
// Throws raypack::Error naming the path when its extension is none of those.
ImageFormat imageFormatFor(const std::string& path);
// Writes PNG or JPEG by imageFormatFor(path); throws as writePng does.
void writeImage(const std::string& path, uint32_t width, uint32_t height, const std::vector<uint32_t>& rgba);

// Checks, before any work is done, that a file can be created at `path`: its folder exists, is a
// folder and is writable, and `path` is not a folder. Throws raypack::Error ("FLAG PATH: why").
void checkOutputPath(const std::string& flag, const std::string& path);
// checkOutputPath, and that writeImage takes the name (imageFormatFor); the error names the flag.
void checkImageOutputPath(const std::string& flag, const std::string& path);

// Reads any PNG (grey, grey+alpha, RGB, RGBA; 8 bit) as RGBA8. Throws raypack::Error naming the
// file when it is missing, not a PNG (other formats are refused, whatever the name), not a
// readable PNG, or larger than RAYPACK_MAX_IMAGE_PIXELS pixels (default 67,108,864 = 8192x8192;
// checked from the header before decoding).
Image readPng(const std::string& path);

struct ImageDiff {
    uint64_t differingPixels = 0;  // pixels where some channel differs by more than the threshold
    uint64_t pixels = 0;
    double differingShare = 0.0;        // differingPixels / pixels (0..1)
    uint32_t maxChannelDifference = 0;  // over R, G, B, A
    double psnr = 0.0;                  // dB over R, G, B with peak 255; +infinity for identical images
    Image difference;                   // differing pixels red, the rest a dimmed grey of `a`
};

// Compares two images of the same size. A pixel differs when any of its four channels differs by
// more than `threshold`. Throws raypack::Error when the sizes differ; `nameA` / `nameB` name the
// images (e.g. their files) in that message.
ImageDiff diffImages(const Image& a, const Image& b, uint8_t threshold = 0, const std::string& nameA = "first image",
                     const std::string& nameB = "second image");

}  // namespace raypack
