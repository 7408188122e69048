#pragma once
// The per-format loaders behind loadScene, and what they share: reading a whole file into memory
// with progress and cancellation, and error messages that name the file.
#include "renderer/huge_pages.h"  // adviseHugePages, for the loaders
#include "scenes/load.h"

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>

namespace raypack {

Scene loadPly(const std::filesystem::path& path, LoadProgress* progress = nullptr);
Scene loadObj(const std::filesystem::path& path, LoadProgress* progress = nullptr);
Scene loadGltf(const std::filesystem::path& path, LoadProgress* progress = nullptr);

// A whole file in memory, read with one pass of large reads (no per-line streams). The buffer is
// not zero-initialised first: for a binary PLY the read is most of the load's time.
struct FreeDeleter {
    void operator()(char* p) const;
};
struct FileBytes {
    std::unique_ptr<char[], FreeDeleter> data;
    size_t size = 0;
    const char* begin() const { return data.get(); }
    const char* end() const { return data.get() + size; }
};

// Reads `path`, reporting the first half of LoadProgress (total = 2 * size). Throws
// raypack::Error for a missing, unreadable or empty file, LoadCancelled when cancelled.
FileBytes readWholeFile(const std::filesystem::path& path, LoadProgress* progress);

// Reports that the parser has consumed `parsedBytes` of a file of `fileSize` bytes (the second half
// of LoadProgress) and throws LoadCancelled when cancel is set.
void reportParsed(LoadProgress* progress, const std::filesystem::path& path, uint64_t fileSize, uint64_t parsedBytes);

// "PATH: what" — every loader error starts with the file it is about.
[[noreturn]] void throwFileError(const std::filesystem::path& path, const std::string& what);

}  // namespace raypack
