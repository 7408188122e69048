#include "renderer/image.h"

#include "renderer/error.h"
#include "renderer/file_names.h"

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

namespace raypack {
namespace {

uint32_t channel(uint32_t pixel, int c) { return (pixel >> (8 * c)) & 0xFFu; }

}  // namespace

void writePng(const std::string& path, uint32_t width, uint32_t height, const std::vector<uint32_t>& rgba) {
    if (width == 0 || height == 0) throw Error("cannot write " + path + ": the image is empty");
    if (rgba.size() != size_t(width) * height)
        throw Error("cannot write " + path + ": " + std::to_string(rgba.size()) + " pixels for a " +
                    std::to_string(width) + "x" + std::to_string(height) + " image");
    if (width > uint32_t(std::numeric_limits<int>::max() / 4) || height > uint32_t(std::numeric_limits<int>::max()))
        throw Error("cannot write " + path + ": the image is too large for PNG writing");
    // Bytes in memory are R, G, B, A on a little-endian host; make that explicit for any host.
    std::vector<unsigned char> bytes(rgba.size() * 4);
    for (size_t i = 0; i < rgba.size(); ++i)
        for (int c = 0; c < 4; ++c) bytes[4 * i + c] = static_cast<unsigned char>(channel(rgba[i], c));
    if (!stbi_write_png(path.c_str(), int(width), int(height), 4, bytes.data(), int(width) * 4))
        throw Error("cannot write " + path + ": " + std::strerror(errno));
}

ImageFormat imageFormatFor(const std::string& path) {
    const std::string extension = lowercaseExtension(path);
    if (extension == ".png") return ImageFormat::Png;
    if (extension == ".jpg" || extension == ".jpeg") return ImageFormat::Jpeg;
    throw Error(path + ": unknown image format \"" + extension + "\" (the file name must end in .png, .jpg or .jpeg)");
}

void writeImage(const std::string& path, uint32_t width, uint32_t height, const std::vector<uint32_t>& rgba) {
    if (imageFormatFor(path) == ImageFormat::Png) return writePng(path, width, height, rgba);
    if (width == 0 || height == 0 || rgba.size() != size_t(width) * height)
        throw Error("cannot write " + path + ": the image is empty or inconsistent");
    if (width > 65535 || height > 65535)
        throw Error("cannot write " + path + ": JPEG images are at most 65535 pixels a side");
    std::vector<unsigned char> bytes(rgba.size() * 3);
    for (size_t i = 0; i < rgba.size(); ++i)
        for (int c = 0; c < 3; ++c) bytes[3 * i + c] = static_cast<unsigned char>(channel(rgba[i], c));
    errno = 0;
    if (!stbi_write_jpg(path.c_str(), int(width), int(height), 3, bytes.data(), 95))
        throw Error("cannot write " + path + ": " + (errno ? std::strerror(errno) : "stb_image_write failed"));
}

void checkOutputPath(const std::string& flag, const std::string& path) {
    namespace fs = std::filesystem;
    const std::string what = flag + " " + path + ": ";
    if (path.empty()) throw Error(flag + ": empty file name");
    std::error_code error;
    if (fs::is_directory(path, error)) throw Error(what + "is a folder, not a file");
    const fs::path folder = fs::path(path).has_parent_path() ? fs::path(path).parent_path() : fs::path(".");
    if (!fs::exists(folder, error)) throw Error(what + "the folder " + folder.string() + " does not exist");
    if (!fs::is_directory(folder, error)) throw Error(what + folder.string() + " is not a folder");
    if (::access(folder.c_str(), W_OK) != 0) throw Error(what + "the folder " + folder.string() + " is not writable");
}

void checkImageOutputPath(const std::string& flag, const std::string& path) {
    checkOutputPath(flag, path);
    try {
        imageFormatFor(path);
    } catch (const Error& e) {
        throw Error(flag + " " + e.what());
    }
}

void writePng(const std::string& path, const Image& image) { writePng(path, image.width, image.height, image.rgba); }

namespace {

// The most pixels readPng decodes (RAYPACK_MAX_IMAGE_PIXELS, default 2^26).
uint64_t maxPngPixels() {
    uint64_t limit = uint64_t(1) << 26;  // 67,108,864: 8192x8192, 256 MB as RGBA8
    if (const char* text = std::getenv("RAYPACK_MAX_IMAGE_PIXELS")) {
        uint64_t value = 0;
        const char* end = text + std::strlen(text);
        auto [stop, ec] = std::from_chars(text, end, value);
        if (ec == std::errc() && stop == end && value > 0) limit = value;
    }
    return limit;
}

}  // namespace

Image readPng(const std::string& path) {
    // The whole file, bounded: a PNG of maxPngPixels() pixels compresses to far less than 1 GiB.
    std::ifstream in(path, std::ios::binary);
    if (!in) throw Error("cannot read image " + path + ": " + std::strerror(errno));
    std::error_code error;
    const uintmax_t size = std::filesystem::file_size(path, error);
    if (error || !std::filesystem::is_regular_file(path, error))
        throw Error("cannot read image " + path + ": not a regular file");
    constexpr uintmax_t kMaxFileBytes = uintmax_t(1) << 30;
    if (size > kMaxFileBytes)
        throw Error("cannot read image " + path + ": " + std::to_string(size) +
                    " bytes, more than a PNG raypack reads (1 GiB)");
    std::vector<unsigned char> bytes(static_cast<size_t>(size));
    in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
    if (size_t(in.gcount()) != bytes.size()) throw Error("cannot read image " + path + ": read failed");

    // PNG only (stb would decode BMP, PSD, GIF... named .png as well), and its IHDR, which the
    // PNG specification puts first, holds the dimensions: they are checked against the limit
    // before anything is decoded, so a small file cannot ask for gigabytes (a decompression bomb).
    static constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    if (bytes.size() < 8 || std::memcmp(bytes.data(), kSignature, 8) != 0)
        throw Error("cannot read image " + path + ": not a PNG file (no PNG signature)");
    if (bytes.size() < 8 + 8 + 13 || std::memcmp(bytes.data() + 12, "IHDR", 4) != 0)
        throw Error("cannot read image " + path + ": the PNG has no IHDR chunk first (truncated or corrupt)");
    auto bigEndian = [&](size_t at) {
        return uint32_t(bytes[at]) << 24 | uint32_t(bytes[at + 1]) << 16 | uint32_t(bytes[at + 2]) << 8 | bytes[at + 3];
    };
    const uint32_t headerWidth = bigEndian(16), headerHeight = bigEndian(20);
    const uint64_t limit = maxPngPixels();
    if (headerWidth == 0 || headerHeight == 0)
        throw Error("cannot read image " + path + ": the PNG header says " + std::to_string(headerWidth) + "x" +
                    std::to_string(headerHeight));
    if (uint64_t(headerWidth) * headerHeight > limit || headerWidth > (1u << 24) || headerHeight > (1u << 24))
        throw Error("cannot read image " + path + ": " + std::to_string(headerWidth) + "x" +
                    std::to_string(headerHeight) + " pixels, more than the limit of " + std::to_string(limit) +
                    " (set RAYPACK_MAX_IMAGE_PIXELS to raise it)");

    // Every chunk must lie inside the file: stb grows its IDAT buffer to a chunk's declared length
    // before reading it, so a 100-byte file claiming a 1 GB chunk took 1 GB (found by fuzz_png).
    for (size_t at = 8; at + 8 <= bytes.size();) {
        const uint64_t length = bigEndian(at);
        if (length > uint64_t(INT32_MAX) || at + 12 + length > bytes.size())
            throw Error("cannot read image " + path + ": a PNG chunk at byte " + std::to_string(at) + " claims " +
                        std::to_string(length) + " bytes, more than the file holds (truncated or corrupt)");
        if (std::memcmp(bytes.data() + at + 4, "IEND", 4) == 0) break;
        at += 12 + size_t(length);
    }

    int width = 0, height = 0, channels = 0;
    unsigned char* data = stbi_load_from_memory(bytes.data(), int(std::min<size_t>(bytes.size(), INT32_MAX)), &width,
                                                &height, &channels, 4);
    if (!data) {
        // stb's reason is a short word ("bad IHDR len", "outofdata"), but not always printable.
        std::string reason = stbi_failure_reason() ? stbi_failure_reason() : "";
        for (char& c : reason)
            if (!std::isprint(static_cast<unsigned char>(c))) c = ' ';
        while (!reason.empty() && reason.back() == ' ') reason.pop_back();
        throw Error("cannot read image " + path + ": corrupt PNG data" + (reason.empty() ? "" : " (" + reason + ")"));
    }
    Image image;
    image.width = uint32_t(width);
    image.height = uint32_t(height);
    image.rgba.resize(size_t(width) * size_t(height));
    for (size_t i = 0; i < image.rgba.size(); ++i) {
        const unsigned char* p = data + 4 * i;
        image.rgba[i] = uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
    }
    stbi_image_free(data);
    return image;
}

ImageDiff diffImages(const Image& a, const Image& b, uint8_t threshold, const std::string& nameA,
                     const std::string& nameB) {
    if (a.width != b.width || a.height != b.height)
        throw Error("cannot compare " + nameA + " (" + std::to_string(a.width) + "x" + std::to_string(a.height) +
                    ") with " + nameB + " (" + std::to_string(b.width) + "x" + std::to_string(b.height) +
                    "): sizes differ");
    RAYPACK_CHECK(a.rgba.size() == size_t(a.width) * a.height);
    RAYPACK_CHECK(b.rgba.size() == size_t(b.width) * b.height);

    ImageDiff diff;
    diff.pixels = a.rgba.size();
    diff.difference.width = a.width;
    diff.difference.height = a.height;
    diff.difference.rgba.resize(a.rgba.size());
    double squaredError = 0.0;
    for (size_t i = 0; i < a.rgba.size(); ++i) {
        uint32_t pixelMax = 0;
        for (int c = 0; c < 4; ++c) {
            const int d = std::abs(int(channel(a.rgba[i], c)) - int(channel(b.rgba[i], c)));
            pixelMax = std::max(pixelMax, uint32_t(d));
            if (c < 3) squaredError += double(d) * double(d);
        }
        diff.maxChannelDifference = std::max(diff.maxChannelDifference, pixelMax);
        if (pixelMax > threshold) {
            ++diff.differingPixels;
            diff.difference.rgba[i] = 0xFF0000FFu;  // opaque red
        } else {
            // Context: a's luminance at a third of its brightness.
            const uint32_t grey =
                (channel(a.rgba[i], 0) * 77 + channel(a.rgba[i], 1) * 150 + channel(a.rgba[i], 2) * 29) >> 8;
            const uint32_t dim = grey / 3;
            diff.difference.rgba[i] = dim | dim << 8 | dim << 16 | 0xFF000000u;
        }
    }
    diff.differingShare = diff.pixels ? double(diff.differingPixels) / double(diff.pixels) : 0.0;
    const double meanSquaredError = diff.pixels ? squaredError / (3.0 * double(diff.pixels)) : 0.0;
    diff.psnr = meanSquaredError > 0.0 ? 10.0 * std::log10(255.0 * 255.0 / meanSquaredError)
                                       : std::numeric_limits<double>::infinity();
    return diff;
}

}  // namespace raypack
