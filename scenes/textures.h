#pragma once
// Texture images for the loaders: every image file a scene names is opened here, by
// loadTextureImage, and every image is decoded here (stb_image: PNG, JPEG, BMP, TGA, ...), into
// raypack::Texture's RGBA8 texels (renderer/scene.h).
#include "renderer/scene.h"

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>

namespace raypack {

// The largest width or height accepted: 16384, as GPUs' maxImageDimension2D; larger images
// would also overflow the kernels' 32-bit texel indices sooner.
constexpr uint32_t kMaxTextureSide = 16384;

// Appends the mip levels below level 0 (which `texture` holds alone) down to 1 x 1: each texel the
// rounded mean of the 2 x 2 texels above it (odd sizes drop the last row or column).
void buildMipLevels(Texture& texture);

// Decodes an encoded image (`name` says where it came from, for messages), with its mip levels. Throws raypack::Error
// naming `sceneFile` and `name` when the bytes are not an image stb_image reads or it is too large.
Texture decodeTextureImage(const unsigned char* bytes, size_t size, const std::string& name,
                           const std::filesystem::path& sceneFile);

// Opens and decodes the image `uri` names, relative to the folder of `sceneFile` (as glTF URIs and
// MTL map_Kd names are); backslashes count as separators. Throws raypack::Error naming the scene
// file and the image when it is missing, unreadable or not an image.
Texture loadTextureImage(const std::filesystem::path& sceneFile, const std::string& uri);

// A scene still loads when one of its textures does not: these print one warning line
// ("raypack: warning: SCENE: texture NAME: why; drawn without it") and return nothing instead.
std::optional<Texture> tryLoadTextureImage(const std::filesystem::path& sceneFile, const std::string& uri);
std::optional<Texture> tryDecodeTextureImage(const unsigned char* bytes, size_t size, const std::string& name,
                                             const std::filesystem::path& sceneFile);

}  // namespace raypack
