#include "renderer/hits_io.h"

#include "renderer/error.h"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <limits>

namespace raypack {
namespace {

// The file is little-endian; on a big-endian host each 32-bit word is swapped.
uint32_t toLittleEndian(uint32_t word) {
    if constexpr (std::endian::native == std::endian::little) return word;
    return ((word & 0xFFu) << 24) | ((word & 0xFF00u) << 8) | ((word >> 8) & 0xFF00u) | (word >> 24);
}

void putWord(unsigned char* out, uint32_t word) {
    word = toLittleEndian(word);
    std::memcpy(out, &word, 4);
}
void putFloat(unsigned char* out, float value) { putWord(out, std::bit_cast<uint32_t>(value)); }
uint32_t getWord(const unsigned char* in) {
    uint32_t word;
    std::memcpy(&word, in, 4);
    return toLittleEndian(word);
}
float getFloat(const unsigned char* in) { return std::bit_cast<float>(getWord(in)); }

void encodeRecord(unsigned char* out, const HitRecord& r) {
    const float floats[7] = {r.orgX, r.orgY, r.orgZ, r.dirX, r.dirY, r.dirZ, r.t};
    for (int i = 0; i < 7; ++i) putFloat(out + 4 * i, floats[i]);
    putWord(out + 28, r.prim);
    putWord(out + 32, r.shadow);
    putWord(out + 36, r.reserved);
}

HitRecord decodeRecord(const unsigned char* in) {
    HitRecord r;
    r.orgX = getFloat(in + 0);
    r.orgY = getFloat(in + 4);
    r.orgZ = getFloat(in + 8);
    r.dirX = getFloat(in + 12);
    r.dirY = getFloat(in + 16);
    r.dirZ = getFloat(in + 20);
    r.t = getFloat(in + 24);
    r.prim = getWord(in + 28);
    r.shadow = getWord(in + 32);
    r.reserved = getWord(in + 36);
    return r;
}

}  // namespace

void writeHits(const std::string& path, const HitsFile& hits) {
    const uint64_t pixels = uint64_t(hits.width) * hits.height;
    if (hits.records.size() != pixels)
        throw Error("cannot write hits file " + path + ": " + std::to_string(hits.records.size()) + " records for a " +
                    std::to_string(hits.width) + "x" + std::to_string(hits.height) + " image");
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out) throw Error("cannot write hits file " + path + ": " + std::strerror(errno));

    unsigned char header[kHitsHeaderBytes];
    std::memcpy(header, kHitsMagic, 8);
    putWord(header + 8, hits.width);
    putWord(header + 12, hits.height);
    putFloat(header + 16, hits.light.x);
    putFloat(header + 20, hits.light.y);
    putFloat(header + 24, hits.light.z);
    putWord(header + 28, 0u);
    out.write(reinterpret_cast<const char*>(header), sizeof header);

    // Encoded in blocks so a large frame is neither written record by record nor copied whole.
    constexpr size_t kBlockRecords = 4096;
    std::vector<unsigned char> block(kBlockRecords * kHitsRecordBytes);
    for (size_t first = 0; first < hits.records.size(); first += kBlockRecords) {
        const size_t count = std::min(kBlockRecords, hits.records.size() - first);
        for (size_t i = 0; i < count; ++i) encodeRecord(block.data() + i * kHitsRecordBytes, hits.records[first + i]);
        out.write(reinterpret_cast<const char*>(block.data()), std::streamsize(count * kHitsRecordBytes));
    }
    out.flush();
    if (!out) throw Error("cannot write hits file " + path + ": write failed");
}

void writeHits(const std::string& path, const Frame& frame) {
    HitsFile hits;
    hits.width = frame.width;
    hits.height = frame.height;
    hits.light = frame.light;
    hits.records = frame.hits;
    writeHits(path, hits);
}

HitsFile readHits(const std::string& path) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) throw Error("cannot open hits file " + path + ": " + std::strerror(errno));
    const std::streamoff fileBytes = in.tellg();
    in.seekg(0);
    if (fileBytes < std::streamoff(kHitsHeaderBytes))
        throw Error("hits file " + path + " is truncated: " + std::to_string(fileBytes) +
                    " bytes, the header alone is 32");

    unsigned char header[kHitsHeaderBytes];
    in.read(reinterpret_cast<char*>(header), sizeof header);
    if (!in) throw Error("cannot read the header of hits file " + path);
    if (std::memcmp(header, kHitsMagic, 8) != 0)
        throw Error("hits file " + path + " does not start with the magic RPKHITS1");
    HitsFile hits;
    hits.width = getWord(header + 8);
    hits.height = getWord(header + 12);
    hits.light = glm::vec3(getFloat(header + 16), getFloat(header + 20), getFloat(header + 24));
    if (getWord(header + 28) != 0) throw Error("hits file " + path + ": the header's reserved word (byte 28) is not 0");

    const uint64_t pixels = uint64_t(hits.width) * hits.height;
    // width * height fits in 64 bits, but times 40 it wraps for absurd headers: check that first,
    // so nothing is allocated for a size the file does not back.
    const uint64_t expected = kHitsHeaderBytes + pixels * kHitsRecordBytes;
    if (pixels > (std::numeric_limits<uint64_t>::max() - kHitsHeaderBytes) / kHitsRecordBytes ||
        uint64_t(fileBytes) != expected)
        throw Error("hits file " + path + " has " + std::to_string(fileBytes) + " bytes, but a " +
                    std::to_string(hits.width) + "x" + std::to_string(hits.height) + " image needs 32 + " +
                    std::to_string(pixels) + " * 40 = " + std::to_string(expected));

    hits.records.resize(pixels);
    constexpr size_t kBlockRecords = 4096;
    std::vector<unsigned char> block(kBlockRecords * kHitsRecordBytes);
    for (size_t first = 0; first < pixels; first += kBlockRecords) {
        const size_t count = std::min<size_t>(kBlockRecords, pixels - first);
        in.read(reinterpret_cast<char*>(block.data()), std::streamsize(count * kHitsRecordBytes));
        if (!in)
            throw Error("hits file " + path + ": read failed at byte " +
                        std::to_string(kHitsHeaderBytes + first * kHitsRecordBytes));
        for (size_t i = 0; i < count; ++i) {
            const HitRecord r = decodeRecord(block.data() + i * kHitsRecordBytes);
            const uint64_t offset = kHitsHeaderBytes + (first + i) * kHitsRecordBytes;
            if (r.shadow > gpu::kShadowNone)
                throw Error("hits file " + path + ": record " + std::to_string(first + i) + " (byte " +
                            std::to_string(offset + 32) + ") has shadow state " + std::to_string(r.shadow) +
                            ", expected 0, 1 or 2");
            if (r.reserved != 0)
                throw Error("hits file " + path + ": record " + std::to_string(first + i) + " (byte " +
                            std::to_string(offset + 36) + ") has a non-zero reserved word");
            hits.records[first + i] = r;
        }
    }
    return hits;
}

}  // namespace raypack
