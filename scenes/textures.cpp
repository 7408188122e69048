#include "scenes/textures.h"

#include "scenes/limits.h"

#include "scenes/formats.h"

#include <stb/stb_image.h>

#include <algorithm>
#include <bit>
#include <cstdio>
#include <cstring>
#include <limits>

namespace raypack {
namespace {

[[noreturn]] void failTexture(const std::filesystem::path& sceneFile, const std::string& name,
                              const std::string& what) {
    throwFileError(sceneFile, "texture " + name + ": " + what);
}

void warnWithout(const Error& error) { std::fprintf(stderr, "raypack: warning: %s; drawn without it\n", error.what()); }

}  // namespace

void buildMipLevels(Texture& texture) {
    RAYPACK_CHECK(texture.levels == 1 && texture.texels.size() == size_t(texture.width) * texture.height);
    uint32_t width = texture.width, height = texture.height;
    size_t level = 0;  // offset of the level above
    while (width > 1 || height > 1) {
        const uint32_t w = std::max(width / 2, 1u), h = std::max(height / 2, 1u);
        const size_t next = texture.texels.size();
        texture.texels.resize(next + size_t(w) * h);
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x) {
                const uint32_t x0 = std::min(2 * x, width - 1), x1 = std::min(2 * x + 1, width - 1);
                const uint32_t y0 = std::min(2 * y, height - 1), y1 = std::min(2 * y + 1, height - 1);
                const uint32_t taps[4] = {
                    texture.texels[level + size_t(y0) * width + x0], texture.texels[level + size_t(y0) * width + x1],
                    texture.texels[level + size_t(y1) * width + x0], texture.texels[level + size_t(y1) * width + x1]};
                uint32_t mean = 0;
                for (int c = 0; c < 4; ++c) {
                    uint32_t sum = 2;  // rounds the mean of four to nearest
                    for (uint32_t t : taps) sum += (t >> (8 * c)) & 0xFFu;
                    mean |= (sum / 4) << (8 * c);
                }
                texture.texels[next + size_t(y) * w + x] = mean;
            }
        level = next;
        width = w;
        height = h;
        ++texture.levels;
    }
}

Texture decodeTextureImage(const unsigned char* bytes, size_t size, const std::string& name,
                           const std::filesystem::path& sceneFile) {
    if (size == 0) failTexture(sceneFile, name, "the image is empty");
    if (size > size_t(std::numeric_limits<int>::max()))
        failTexture(sceneFile, name, "the image file is larger than 2 GiB");
    int width = 0, height = 0, channels = 0;
    if (!stbi_info_from_memory(bytes, int(size), &width, &height, &channels)) {
        const char* reason = stbi_failure_reason();
        failTexture(sceneFile, name,
                    std::string("not an image stb_image can read (") + (reason ? reason : "unknown") + ")");
    }
    if (width <= 0 || height <= 0 || uint32_t(width) > kMaxTextureSide || uint32_t(height) > kMaxTextureSide)
        failTexture(sceneFile, name,
                    std::to_string(width) + "x" + std::to_string(height) + " texels; at most " +
                        std::to_string(kMaxTextureSide) + " a side are supported");
    unsigned char* decoded = stbi_load_from_memory(bytes, int(size), &width, &height, &channels, 4);
    if (!decoded) {
        const char* reason = stbi_failure_reason();
        failTexture(sceneFile, name, std::string("could not be decoded (") + (reason ? reason : "unknown") + ")");
    }
    Texture texture;
    texture.name = name;
    texture.width = uint32_t(width);
    texture.height = uint32_t(height);
    texture.texels.resize(size_t(width) * size_t(height));
    // stb_image's RGBA bytes in memory order are the texels' R-low-byte order on a little-endian
    // host, which every machine raypack runs on is.
    static_assert(std::endian::native == std::endian::little);
    std::memcpy(texture.texels.data(), decoded, texture.texels.size() * 4);
    stbi_image_free(decoded);
    buildMipLevels(texture);
    return texture;
}

Texture loadTextureImage(const std::filesystem::path& sceneFile, const std::string& uri) {
    std::string relative = uri;
    std::replace(relative.begin(), relative.end(), '\\', '/');
    if (relative.empty()) failTexture(sceneFile, "\"\"", "empty file name");
    // Inside the scene's folder, a regular file of bounded size (scenes/limits.h), as every file a
    // scene names.
    std::string bytes;
    try {
        const std::filesystem::path file =
            resolveReferencedFile(sceneFile, relative, "texture image", maxReferencedFileBytes());
        bytes = readReferencedFile(sceneFile, file, "texture image", maxReferencedFileBytes());
    } catch (const Error& error) {
        failTexture(sceneFile, uri, error.what());
    }
    Texture texture =
        decodeTextureImage(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), uri, sceneFile);
    texture.fileBytes = bytes.size();
    return texture;
}

std::optional<Texture> tryLoadTextureImage(const std::filesystem::path& sceneFile, const std::string& uri) {
    try {
        return loadTextureImage(sceneFile, uri);
    } catch (const LoadCancelled&) {
        throw;
    } catch (const Error& error) {
        warnWithout(error);
        return std::nullopt;
    }
}

std::optional<Texture> tryDecodeTextureImage(const unsigned char* bytes, size_t size, const std::string& name,
                                             const std::filesystem::path& sceneFile) {
    try {
        return decodeTextureImage(bytes, size, name, sceneFile);
    } catch (const Error& error) {
        warnWithout(error);
        return std::nullopt;
    }
}

}  // namespace raypack
