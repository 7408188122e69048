// What raypack reads from a file's name.
#ifndef RAYPACK_RENDERER_FILE_NAMES_H
#define RAYPACK_RENDERER_FILE_NAMES_H

#include <cctype>
#include <filesystem>
#include <string>

namespace raypack {

// The name's extension with its dot, in lower case (".PLY" -> ".ply"; "" when there is none): the
// loaders and writers pick formats by it, case-insensitively.
inline std::string lowercaseExtension(const std::filesystem::path& path) {
    std::string extension = path.extension().string();
    for (char& c : extension) c = char(std::tolower(static_cast<unsigned char>(c)));
    return extension;
}

}  // namespace raypack

#endif  // RAYPACK_RENDERER_FILE_NAMES_H
