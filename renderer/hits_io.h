#pragma once
// The hits file (RPKHITS1, docs/hits-format.md): every pixel's primary ray and result, so that any
// other tracer can be checked against the reference ray by ray.
#include "renderer/frame.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace raypack {

struct HitsFile {
    uint32_t width = 0;
    uint32_t height = 0;
    glm::vec3 light{0.0f};
    std::vector<HitRecord> records;  // width * height, row-major, top row first
};

constexpr size_t kHitsHeaderBytes = 32;
constexpr size_t kHitsRecordBytes = 40;
inline constexpr char kHitsMagic[8] = {'R', 'P', 'K', 'H', 'I', 'T', 'S', '1'};

// Throws raypack::Error naming the file when it cannot be written or when records.size() is not
// width * height.
void writeHits(const std::string& path, const HitsFile& hits);
// A frame's hits (Frame::hits must hold one record per pixel).
void writeHits(const std::string& path, const Frame& frame);

// Reads and validates the whole file: magic, header reserved word, file size equal to
// 32 + width * height * 40, and every record's shadow state and reserved word. Throws
// raypack::Error naming the file, and the byte offset where there is one.
HitsFile readHits(const std::string& path);

}  // namespace raypack
