// PLY reader and writer, by hand: the file is read with one pass of large reads and parsed from
// memory, so that a binary PLY loads at close to disk speed (issue 2: "loading 7 million triangles
// must not be the slow step"). Format: Greg Turk, "The PLY Polygon File Format" (1994).
//
// Supported: ascii, binary_little_endian and binary_big_endian 1.0; elements and properties in any
// order; scalar types char/uchar/short/ushort/int/uint/float/double (and their int8..float64
// aliases); vertex x, y, z (required) and nx, ny, nz (optional, all three or none); a face list
// named vertex_indices or vertex_index with any integer count and index type, polygons fan-
// triangulated as (v0, v(k-1), v(k)); optional red/green/blue on faces, which become one material
// per distinct colour, or on vertices (when the faces have none), kept per vertex and interpolated.
// Every other element and property is skipped.
#include "scenes/formats.h"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace raypack {
namespace {

enum class PlyType : uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

size_t typeSize(PlyType type) {
    switch (type) {
    case PlyType::Int8:
    case PlyType::UInt8: return 1;
    case PlyType::Int16:
    case PlyType::UInt16: return 2;
    case PlyType::Int32:
    case PlyType::UInt32:
    case PlyType::Float32: return 4;
    case PlyType::Float64: return 8;
    }
    return 0;
}

bool isIntegerType(PlyType type) { return type != PlyType::Float32 && type != PlyType::Float64; }

std::optional<PlyType> parseType(std::string_view name) {
    if (name == "char" || name == "int8") return PlyType::Int8;
    if (name == "uchar" || name == "uint8") return PlyType::UInt8;
    if (name == "short" || name == "int16") return PlyType::Int16;
    if (name == "ushort" || name == "uint16") return PlyType::UInt16;
    if (name == "int" || name == "int32") return PlyType::Int32;
    if (name == "uint" || name == "uint32") return PlyType::UInt32;
    if (name == "float" || name == "float32") return PlyType::Float32;
    if (name == "double" || name == "float64") return PlyType::Float64;
    return std::nullopt;
}

struct PlyProperty {
    std::string name;
    PlyType type = PlyType::Float32;  // the value type, or the item type of a list
    bool isList = false;
    PlyType countType = PlyType::UInt8;
};

struct PlyElement {
    std::string name;
    uint64_t count = 0;
    std::vector<PlyProperty> properties;

    // The fewest bytes one instance can take: binary, every list empty; ascii, one character and
    // one separator per value. Used to reject counts the file cannot hold before allocating.
    uint64_t minBytes(bool ascii) const {
        uint64_t bytes = 0;
        for (const PlyProperty& p : properties) bytes += ascii ? 2 : typeSize(p.isList ? p.countType : p.type);
        return bytes;
    }
};

enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct PlyHeader {
    PlyFormat format = PlyFormat::Ascii;
    std::vector<PlyElement> elements;
    std::unordered_map<uint32_t, std::string> materialNames;  // packed rgb -> name (raypack comment)
    size_t bodyOffset = 0;                                    // first byte after "end_header\n"
    size_t bodyLine = 0;                                      // line number of the body's first line
};

uint32_t packRgb(uint8_t r, uint8_t g, uint8_t b) { return (uint32_t(r) << 16) | (uint32_t(g) << 8) | b; }

std::vector<std::string_view> splitWords(std::string_view line) {
    std::vector<std::string_view> words;
    size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
        size_t start = i;
        while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
        if (i > start) words.push_back(line.substr(start, i - start));
    }
    return words;
}

bool parseU64(std::string_view text, uint64_t& value) {
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    return ec == std::errc() && end == text.data() + text.size();
}

PlyHeader parseHeader(const FileBytes& file, const std::filesystem::path& path) {
    auto fail = [&](size_t line, const std::string& what) -> void {
        throwFileError(path, "line " + std::to_string(line) + ": " + what);
    };
    PlyHeader header;
    const char* p = file.begin();
    const char* end = file.end();
    size_t line = 0;
    bool sawFormat = false;
    while (true) {
        if (p == end) throwFileError(path, "PLY header has no end_header line (file truncated?)");
        const char* eol = static_cast<const char*>(std::memchr(p, '\n', size_t(end - p)));
        if (!eol) throwFileError(path, "PLY header has no end_header line (file truncated?)");
        std::string_view text(p, size_t(eol - p));
        if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
        ++line;
        p = eol + 1;
        if (line == 1) {
            if (text != "ply") fail(1, "not a PLY file (first line is not \"ply\")");
            continue;
        }
        const std::vector<std::string_view> words = splitWords(text);
        if (words.empty()) continue;
        const std::string_view keyword = words[0];
        if (keyword == "comment" || keyword == "obj_info") {
            // raypack's own comment carrying a material name (written by savePly).
            if (words.size() >= 6 && words[1] == "raypack_material") {
                uint64_t r, g, b;
                if (parseU64(words[2], r) && parseU64(words[3], g) && parseU64(words[4], b) && r < 256 && g < 256 &&
                    b < 256) {
                    const size_t nameStart = size_t(words[5].data() - text.data());
                    header.materialNames[packRgb(uint8_t(r), uint8_t(g), uint8_t(b))] =
                        std::string(text.substr(nameStart));
                }
            }
        } else if (keyword == "format") {
            if (words.size() != 3) fail(line, "malformed format line");
            if (words[1] == "ascii")
                header.format = PlyFormat::Ascii;
            else if (words[1] == "binary_little_endian")
                header.format = PlyFormat::BinaryLittleEndian;
            else if (words[1] == "binary_big_endian")
                header.format = PlyFormat::BinaryBigEndian;
            else
                fail(line, "unknown PLY format \"" + std::string(words[1]) + "\"");
            if (words[2] != "1.0" && words[2] != "1") fail(line, "unsupported PLY version " + std::string(words[2]));
            sawFormat = true;
        } else if (keyword == "element") {
            PlyElement element;
            if (words.size() != 3 || !parseU64(words[2], element.count))
                fail(line, "malformed element line (expected: element NAME COUNT)");
            element.name = std::string(words[1]);
            header.elements.push_back(std::move(element));
        } else if (keyword == "property") {
            if (header.elements.empty()) fail(line, "property before any element");
            PlyProperty property;
            if (words.size() == 5 && words[1] == "list") {
                const auto countType = parseType(words[2]);
                const auto itemType = parseType(words[3]);
                if (!countType || !itemType) fail(line, "unknown property type in list");
                if (!isIntegerType(*countType)) fail(line, "list count type must be an integer type");
                property.isList = true;
                property.countType = *countType;
                property.type = *itemType;
                property.name = std::string(words[4]);
            } else if (words.size() == 3) {
                const auto type = parseType(words[1]);
                if (!type) fail(line, "unknown property type \"" + std::string(words[1]) + "\"");
                property.type = *type;
                property.name = std::string(words[2]);
            } else {
                fail(line, "malformed property line");
            }
            header.elements.back().properties.push_back(std::move(property));
        } else if (keyword == "end_header") {
            break;
        } else {
            fail(line, "unknown header keyword \"" + std::string(keyword) + "\"");
        }
    }
    if (!sawFormat) throwFileError(path, "PLY header has no format line");
    header.bodyOffset = size_t(p - file.begin());
    header.bodyLine = line + 1;
    return header;
}

// ---- Value readers. The element walker below is a template over these, so each format gets its
// own tight loop. Both throw with the position (byte offset or line) of the value they fail on.

template <bool kSwap>
class BinaryReader {
public:
    BinaryReader(const FileBytes& file, size_t offset, const std::filesystem::path& path)
        : begin_(reinterpret_cast<const uint8_t*>(file.begin())),
          p_(begin_ + offset),
          end_(reinterpret_cast<const uint8_t*>(file.end())),
          path_(&path) {}

    double readFloat(PlyType type) {
        switch (type) {
        case PlyType::Float32: return double(load<float, uint32_t>());
        case PlyType::Float64: return load<double, uint64_t>();
        default: return double(readInt(type));
        }
    }
    int64_t readInt(PlyType type) {
        switch (type) {
        case PlyType::Int8: return load<int8_t, uint8_t>();
        case PlyType::UInt8: return load<uint8_t, uint8_t>();
        case PlyType::Int16: return load<int16_t, uint16_t>();
        case PlyType::UInt16: return load<uint16_t, uint16_t>();
        case PlyType::Int32: return load<int32_t, uint32_t>();
        case PlyType::UInt32: return load<uint32_t, uint32_t>();
        case PlyType::Float32: return checkedInteger(double(load<float, uint32_t>()));
        case PlyType::Float64: return checkedInteger(load<double, uint64_t>());
        }
        return 0;
    }
    void skip(PlyType type, uint64_t count = 1) {
        const uint64_t bytes = count * typeSize(type);
        if (count > uint64_t(end_ - p_) || bytes > uint64_t(end_ - p_)) truncated();
        p_ += bytes;
    }
    // True when `count` values of `type` still fit in the file: checked before allocating for a list.
    bool canHold(uint64_t count, PlyType type) const { return count <= uint64_t(end_ - p_) / typeSize(type); }
    std::string where() const { return "byte offset " + std::to_string(p_ - begin_); }
    size_t offset() const { return size_t(p_ - begin_); }
    // Unchecked typed load for the fast paths, which check the whole element's size first.
    template <typename T>
    T loadUnchecked(size_t at) const {
        using Bits = std::conditional_t<
            sizeof(T) == 1, uint8_t,
            std::conditional_t<sizeof(T) == 2, uint16_t, std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>>;
        Bits bits;
        std::memcpy(&bits, p_ + at, sizeof(Bits));
        if constexpr (kSwap && sizeof(Bits) > 1) bits = byteSwap(bits);
        T value;
        std::memcpy(&value, &bits, sizeof(T));
        return value;
    }
    void advance(size_t bytes) { p_ += bytes; }
    void retreat(size_t bytes) { p_ -= bytes; }  // back over bytes just read (the fast path's undo)
    // What is left after the last element: binary bodies should end exactly there.
    size_t trailingBytes() const { return size_t(end_ - p_); }
    [[noreturn]] void fail(const std::string& what) const { throwFileError(*path_, where() + ": " + what); }

private:
    template <typename T, typename Bits>
    T load() {
        if (size_t(end_ - p_) < sizeof(T)) truncated();
        Bits bits;
        std::memcpy(&bits, p_, sizeof(Bits));
        p_ += sizeof(Bits);
        if constexpr (kSwap && sizeof(Bits) > 1) bits = byteSwap(bits);
        T value;
        std::memcpy(&value, &bits, sizeof(T));
        return value;
    }
    template <typename Bits>
    static Bits byteSwap(Bits bits) {
        if constexpr (sizeof(Bits) == 2)
            return Bits(__builtin_bswap16(bits));
        else if constexpr (sizeof(Bits) == 4)
            return Bits(__builtin_bswap32(bits));
        else
            return Bits(__builtin_bswap64(bits));
    }
    int64_t checkedInteger(double value) const {
        if (!(std::abs(value) < 9.0e18) || value != std::floor(value)) fail("expected an integer value");
        return int64_t(value);
    }
    [[noreturn]] void truncated() const {
        fail("file ends in the middle of the data (truncated, or the header's counts are too large)");
    }

    const uint8_t* begin_;
    const uint8_t* p_;
    const uint8_t* end_;
    const std::filesystem::path* path_;
};

class AsciiReader {
public:
    AsciiReader(const FileBytes& file, size_t offset, size_t line, const std::filesystem::path& path)
        : begin_(file.begin()), p_(file.begin() + offset), end_(file.end()), line_(line), path_(path) {}

    double readFloat(PlyType type) {
        const std::string_view token = next();
        double value = 0.0;
        auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
        // from_chars accepts "nan" and "inf"; those are rejected where vertices are checked.
        if (ec != std::errc() || end != token.data() + token.size()) {
            if (ec == std::errc::result_out_of_range) return token[0] == '-' ? -HUGE_VAL : HUGE_VAL;
            fail("\"" + std::string(token) + "\" is not a number");
        }
        (void)type;
        return value;
    }
    int64_t readInt(PlyType type) {
        if (!isIntegerType(type)) {
            const double value = readFloat(type);
            if (!(std::abs(value) < 9.0e18) || value != std::floor(value)) fail("expected an integer value");
            return int64_t(value);
        }
        const std::string_view token = next();
        int64_t value = 0;
        auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
        if (ec != std::errc() || end != token.data() + token.size())
            fail("\"" + std::string(token) + "\" is not an integer");
        return value;
    }
    void skip(PlyType, uint64_t count = 1) {
        for (uint64_t i = 0; i < count; ++i) next();
    }
    bool canHold(uint64_t count, PlyType) const { return count <= uint64_t(end_ - p_) / 2 + 1; }
    std::string where() const { return "line " + std::to_string(line_); }
    size_t offset() const { return size_t(p_ - begin_); }
    size_t trailingBytes() {
        skipSpace();
        return size_t(end_ - p_);
    }
    [[noreturn]] void fail(const std::string& what) const { throwFileError(path_, where() + ": " + what); }

private:
    void skipSpace() {
        while (p_ != end_ && (*p_ == ' ' || *p_ == '\t' || *p_ == '\r' || *p_ == '\n')) {
            if (*p_ == '\n') ++line_;
            ++p_;
        }
    }
    std::string_view next() {
        skipSpace();
        if (p_ == end_) fail("file ends in the middle of the data (truncated, or the header's counts are too large)");
        const char* start = p_;
        while (p_ != end_ && *p_ != ' ' && *p_ != '\t' && *p_ != '\r' && *p_ != '\n') ++p_;
        return std::string_view(start, size_t(p_ - start));
    }

    const char* begin_;
    const char* p_;
    const char* end_;
    size_t line_;
    const std::filesystem::path& path_;
};

// Where the interesting properties of the vertex and face elements sit.
struct VertexLayout {
    int x = -1, y = -1, z = -1, nx = -1, ny = -1, nz = -1, red = -1, green = -1, blue = -1;
    bool hasNormals() const { return nx >= 0 && ny >= 0 && nz >= 0; }
    bool hasColours() const { return red >= 0 && green >= 0 && blue >= 0; }
};
struct FaceLayout {
    int indices = -1, red = -1, green = -1, blue = -1;
    bool hasColours() const { return red >= 0 && green >= 0 && blue >= 0; }
};

// An 8-bit colour channel from a uchar (as is) or a float/double (0..1, as many exporters write).
template <typename Reader>
uint8_t readColour(Reader& reader, PlyType type) {
    if (isIntegerType(type)) {
        const int64_t value = reader.readInt(type);
        return uint8_t(std::clamp<int64_t>(value, 0, 255));
    }
    const double value = reader.readFloat(type);
    if (!std::isfinite(value)) reader.fail("colour is not a finite number");
    return uint8_t(std::lround(std::clamp(value, 0.0, 1.0) * 255.0));
}

class PlyParser {
public:
    PlyParser(const std::filesystem::path& path, const FileBytes& file, LoadProgress* progress)
        : path_(path), file_(file), progress_(progress) {}

    Scene parse() {
        header_ = parseHeader(file_, path_);
        locateElements();
        checkCountsFitFile();
        switch (header_.format) {
        case PlyFormat::Ascii: {
            AsciiReader reader(file_, header_.bodyOffset, header_.bodyLine, path_);
            readBody(reader);
            break;
        }
        case PlyFormat::BinaryLittleEndian: {
            BinaryReader<std::endian::native != std::endian::little> reader(file_, header_.bodyOffset, path_);
            readBody(reader);
            break;
        }
        case PlyFormat::BinaryBigEndian: {
            BinaryReader<std::endian::native != std::endian::big> reader(file_, header_.bodyOffset, path_);
            readBody(reader);
            break;
        }
        }
        if (scene_.triangles.empty()) throwFileError(path_, "PLY file has no triangles");
        scene_.source = path_.string();
        return std::move(scene_);
    }

private:
    void locateElements() {
        for (size_t e = 0; e < header_.elements.size(); ++e) {
            const PlyElement& element = header_.elements[e];
            if (element.name == "vertex") {
                if (vertexElement_ >= 0) throwFileError(path_, "PLY header declares two vertex elements");
                vertexElement_ = int(e);
                for (size_t i = 0; i < element.properties.size(); ++i) {
                    const PlyProperty& p = element.properties[i];
                    if (p.isList) continue;
                    int* slot = p.name == "x"                                      ? &vertex_.x
                                : p.name == "y"                                    ? &vertex_.y
                                : p.name == "z"                                    ? &vertex_.z
                                : p.name == "nx"                                   ? &vertex_.nx
                                : p.name == "ny"                                   ? &vertex_.ny
                                : p.name == "nz"                                   ? &vertex_.nz
                                : (p.name == "red" || p.name == "diffuse_red")     ? &vertex_.red
                                : (p.name == "green" || p.name == "diffuse_green") ? &vertex_.green
                                : (p.name == "blue" || p.name == "diffuse_blue")   ? &vertex_.blue
                                                                                   : nullptr;
                    if (slot) *slot = int(i);
                }
                if (vertex_.x < 0 || vertex_.y < 0 || vertex_.z < 0)
                    throwFileError(path_, "PLY vertex element lacks an x, y or z property");
            } else if (element.name == "face") {
                if (faceElement_ >= 0) throwFileError(path_, "PLY header declares two face elements");
                faceElement_ = int(e);
                for (size_t i = 0; i < element.properties.size(); ++i) {
                    const PlyProperty& p = element.properties[i];
                    if (p.isList && (p.name == "vertex_indices" || p.name == "vertex_index")) {
                        if (!isIntegerType(p.type)) throwFileError(path_, "PLY face indices are not integers");
                        face_.indices = int(i);
                    } else if (!p.isList) {
                        if (p.name == "red") face_.red = int(i);
                        if (p.name == "green") face_.green = int(i);
                        if (p.name == "blue") face_.blue = int(i);
                    }
                }
                if (face_.indices < 0) throwFileError(path_, "PLY face element has no vertex_indices list");
            }
        }
        if (vertexElement_ < 0) throwFileError(path_, "PLY file has no vertex element");
        if (faceElement_ < 0) throwFileError(path_, "PLY file has no face element (a point cloud, not a mesh)");
        const uint64_t vertexCount = header_.elements[size_t(vertexElement_)].count;
        if (vertexCount > std::numeric_limits<uint32_t>::max())
            throwFileError(path_, "PLY file declares " + std::to_string(vertexCount) +
                                      " vertices, more than 32-bit indices can address");
    }

    // Rejects, before anything is allocated, element counts that the rest of the file cannot hold.
    void checkCountsFitFile() const {
        const bool ascii = header_.format == PlyFormat::Ascii;
        const uint64_t bodyBytes = file_.size - header_.bodyOffset;
        uint64_t needed = 0;
        for (const PlyElement& element : header_.elements) {
            const uint64_t perInstance = element.minBytes(ascii);
            if (perInstance != 0 && element.count > (bodyBytes + 1) / perInstance)
                throwFileError(path_, "PLY header declares " + std::to_string(element.count) + " " + element.name +
                                          " elements, but only " + std::to_string(bodyBytes) +
                                          " bytes follow the header (truncated file?)");
            needed += element.count * perInstance;
            if (needed > bodyBytes + 1)
                throwFileError(path_, "PLY header's element counts need more than the " + std::to_string(bodyBytes) +
                                          " bytes that follow the header (truncated file?)");
        }
    }

    template <typename Reader>
    void readBody(Reader& reader) {
        for (size_t e = 0; e < header_.elements.size(); ++e) {
            if (int(e) == vertexElement_)
                readVertices(reader, header_.elements[e]);
            else if (int(e) == faceElement_)
                readFaces(reader, header_.elements[e]);
            else
                skipElement(reader, header_.elements[e]);
        }
        if (const size_t trailing = reader.trailingBytes(); trailing != 0)
            std::fprintf(stderr, "raypack: warning: %s: %zu bytes after the last PLY element are ignored\n",
                         path_.string().c_str(), trailing);
        finishMaterials();
    }

    template <typename Reader>
    void tick(Reader& reader, uint64_t i) {
        if ((i & 0xFFFF) == 0) reportParsed(progress_, path_, file_.size, reader.offset());
    }

    template <typename Reader>
    void skipElement(Reader& reader, const PlyElement& element) {
        // An element without properties takes no bytes, whatever its count (which may be 2^64-1:
        // walking it instance by instance would take millennia).
        if (element.properties.empty()) return;
        for (uint64_t i = 0; i < element.count; ++i) {
            tick(reader, i);
            for (const PlyProperty& p : element.properties) {
                if (!p.isList) {
                    reader.skip(p.type);
                    continue;
                }
                const int64_t count = reader.readInt(p.countType);
                if (count < 0) reader.fail("negative list length");
                if (!reader.canHold(uint64_t(count), p.type)) reader.fail("list longer than the rest of the file");
                reader.skip(p.type, uint64_t(count));
            }
        }
    }

    template <typename Reader>
    void readVertices(Reader& reader, const PlyElement& element) {
        const uint64_t count = element.count;
        scene_.positions.reserve(count);
        adviseHugePages(scene_.positions.data(), count * sizeof(glm::vec3));
        scene_.positions.resize(count);
        if (vertex_.hasNormals()) {
            scene_.normals.reserve(count);
            adviseHugePages(scene_.normals.data(), count * sizeof(glm::vec3));
            scene_.normals.resize(count);
        }
        if (vertex_.hasColours()) vertexColour_.resize(count);
        double values[9] = {};
        int slotOf[64];
        const size_t propertyCount = element.properties.size();
        if (propertyCount > 64) reader.fail("vertex element has more than 64 properties");
        for (size_t i = 0; i < propertyCount; ++i) slotOf[i] = -1;
        const int slots[9] = {vertex_.x,  vertex_.y,   vertex_.z,     vertex_.nx,  vertex_.ny,
                              vertex_.nz, vertex_.red, vertex_.green, vertex_.blue};
        for (int s = 0; s < 9; ++s)
            if (slots[s] >= 0) slotOf[slots[s]] = s;
        if constexpr (!std::is_same_v<Reader, AsciiReader>) {
            if (readFloatVerticesFast(reader, element)) return;
        }
        for (uint64_t v = 0; v < count; ++v) {
            tick(reader, v);
            const size_t vertexOffset = reader.offset();
            uint8_t colour[3] = {0, 0, 0};
            for (size_t i = 0; i < propertyCount; ++i) {
                const PlyProperty& p = element.properties[i];
                const int slot = slotOf[i];
                if (p.isList) {
                    const int64_t n = reader.readInt(p.countType);
                    if (n < 0 || !reader.canHold(uint64_t(n), p.type)) reader.fail("bad list length in vertex");
                    reader.skip(p.type, uint64_t(n));
                } else if (slot < 0) {
                    reader.skip(p.type);
                } else if (slot >= 6) {
                    colour[slot - 6] = readColour(reader, p.type);
                } else {
                    values[slot] = reader.readFloat(p.type);
                }
            }
            const glm::vec3 position(static_cast<float>(values[0]), static_cast<float>(values[1]),
                                     static_cast<float>(values[2]));
            if (!std::isfinite(position.x) || !std::isfinite(position.y) || !std::isfinite(position.z))
                failAtVertex(reader, v, vertexOffset, "has a non-finite coordinate (NaN, Inf or out of float range)");
            scene_.positions[v] = position;
            if (vertex_.hasNormals()) {
                const glm::vec3 normal(static_cast<float>(values[3]), static_cast<float>(values[4]),
                                       static_cast<float>(values[5]));
                if (!std::isfinite(normal.x) || !std::isfinite(normal.y) || !std::isfinite(normal.z))
                    failAtVertex(reader, v, vertexOffset, "has a non-finite normal");
                scene_.normals[v] = normal;
            }
            if (vertex_.hasColours()) vertexColour_[v] = packRgb(colour[0], colour[1], colour[2]);
        }
    }

    // Binary vertices whose properties are all float scalars (the usual x y z [nx ny nz]): direct
    // loads at fixed offsets. Returns false, having read nothing, for any other layout.
    template <typename Reader>
    bool readFloatVerticesFast(Reader& reader, const PlyElement& element) {
        for (const PlyProperty& p : element.properties)
            if (p.isList || p.type != PlyType::Float32) return false;
        if (vertex_.hasColours()) return false;
        const size_t stride = 4 * element.properties.size();
        if (element.count > reader.trailingBytes() / stride) return false;
        const size_t x = 4 * size_t(vertex_.x), y = 4 * size_t(vertex_.y), z = 4 * size_t(vertex_.z);
        const bool normals = vertex_.hasNormals();
        const size_t nx = 4 * size_t(std::max(vertex_.nx, 0)), ny = 4 * size_t(std::max(vertex_.ny, 0)),
                     nz = 4 * size_t(std::max(vertex_.nz, 0));
        for (uint64_t v = 0; v < element.count; ++v) {
            if ((v & 0xFFFF) == 0) tick(reader, v);
            const glm::vec3 p(reader.template loadUnchecked<float>(x), reader.template loadUnchecked<float>(y),
                              reader.template loadUnchecked<float>(z));
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
                failAtVertex(reader, v, reader.offset(),
                             "has a non-finite coordinate (NaN, Inf or out of float range)");
            scene_.positions[v] = p;
            if (normals) {
                const glm::vec3 n(reader.template loadUnchecked<float>(nx), reader.template loadUnchecked<float>(ny),
                                  reader.template loadUnchecked<float>(nz));
                if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z))
                    failAtVertex(reader, v, reader.offset(), "has a non-finite normal");
                scene_.normals[v] = n;
            }
            reader.advance(stride);
        }
        return true;
    }

    template <typename Reader>
    [[noreturn]] void failAtVertex(Reader& reader, uint64_t v, size_t offset, const std::string& what) {
        // The reader now stands after the vertex; for binary files name where the vertex starts.
        if constexpr (std::is_same_v<Reader, AsciiReader>) {
            reader.fail("vertex " + std::to_string(v) + " " + what);
        } else {
            throwFileError(path_,
                           "byte offset " + std::to_string(offset) + ": vertex " + std::to_string(v) + " " + what);
        }
    }

    // The common binary layout, a face element holding only its index list with every face a
    // triangle, in one tight loop. Returns false, having consumed nothing, at the first face that
    // is not a triangle, so that the general loop below handles the file from its start.
    template <typename Reader>
    bool readTriangleFacesFast(Reader& reader, const PlyElement& element) {
        const PlyProperty& list = element.properties[0];
        const size_t countSize = typeSize(list.countType), indexSize = typeSize(list.type);
        const size_t faceBytes = countSize + 3 * indexSize;
        if (element.count > reader.trailingBytes() / faceBytes)
            return false;  // truncated: let the general loop say where
        const uint64_t vertexCount = header_.elements[size_t(vertexElement_)].count;
        // The usual uchar count with int or uint indices: direct loads, whole element size-checked above.
        if (list.countType == PlyType::UInt8 && (list.type == PlyType::Int32 || list.type == PlyType::UInt32)) {
            const size_t before = scene_.triangles.size();
            for (uint64_t f = 0; f < element.count; ++f) {
                if ((f & 0xFFFF) == 0) tick(reader, f);
                const uint32_t a = reader.template loadUnchecked<uint32_t>(1);
                const uint32_t b = reader.template loadUnchecked<uint32_t>(5);
                const uint32_t c = reader.template loadUnchecked<uint32_t>(9);
                // A negative int index reads as a huge uint32 and fails the same range check.
                if (reader.template loadUnchecked<uint8_t>(0) != 3 || a >= vertexCount || b >= vertexCount ||
                    c >= vertexCount) {
                    // Rewind to the element's start and let the general loop find and report it.
                    const size_t consumed = size_t(f) * faceBytes;
                    reader.retreat(consumed);
                    scene_.triangles.resize(before);
                    return false;
                }
                scene_.triangles.emplace_back(a, b, c);
                reader.advance(faceBytes);
            }
            return true;
        }
        const Reader start = reader;
        for (uint64_t f = 0; f < element.count; ++f) {
            tick(reader, f);
            const int64_t n = reader.readInt(list.countType);
            if (n != 3) {
                reader = start;
                scene_.triangles.clear();
                return false;
            }
            const int64_t a = reader.readInt(list.type), b = reader.readInt(list.type), c = reader.readInt(list.type);
            if (uint64_t(a) >= vertexCount || uint64_t(b) >= vertexCount || uint64_t(c) >= vertexCount) {
                reader = start;
                scene_.triangles.clear();
                return false;  // the general loop reports the index and where it is
            }
            scene_.triangles.emplace_back(uint32_t(a), uint32_t(b), uint32_t(c));
        }
        return true;
    }

    template <typename Reader>
    void readFaces(Reader& reader, const PlyElement& element) {
        const uint64_t vertexCount = header_.elements[size_t(vertexElement_)].count;
        scene_.triangles.reserve(element.count);  // bounded by checkCountsFitFile
        adviseHugePages(scene_.triangles.data(), element.count * sizeof(glm::uvec3));
        if constexpr (!std::is_same_v<Reader, AsciiReader>)
            if (element.properties.size() == 1 && readTriangleFacesFast(reader, element)) return;
        const bool faceColours = face_.hasColours();
        uint32_t corners[256];
        std::vector<uint32_t> bigPolygon;
        for (uint64_t f = 0; f < element.count; ++f) {
            tick(reader, f);
            uint8_t colour[3] = {0, 0, 0};
            uint32_t* polygon = corners;
            uint64_t polygonSize = 0;
            for (size_t i = 0; i < element.properties.size(); ++i) {
                const PlyProperty& p = element.properties[i];
                if (int(i) == face_.indices) {
                    const int64_t n = reader.readInt(p.countType);
                    if (n < 3)
                        reader.fail("face " + std::to_string(f) + " has " + std::to_string(n) +
                                    " vertices (need at least 3)");
                    if (!reader.canHold(uint64_t(n), p.type))
                        reader.fail("face " + std::to_string(f) + " is longer than the rest of the file");
                    if (n > 256) {
                        bigPolygon.resize(size_t(n));
                        polygon = bigPolygon.data();
                    }
                    polygonSize = uint64_t(n);
                    for (uint64_t k = 0; k < polygonSize; ++k) {
                        const int64_t index = reader.readInt(p.type);
                        if (index < 0 || uint64_t(index) >= vertexCount)
                            reader.fail("face " + std::to_string(f) + " has vertex index " + std::to_string(index) +
                                        " outside 0.." + std::to_string(int64_t(vertexCount) - 1));
                        polygon[k] = uint32_t(index);
                    }
                } else if (p.isList) {
                    const int64_t n = reader.readInt(p.countType);
                    if (n < 0 || !reader.canHold(uint64_t(n), p.type)) reader.fail("bad list length in face");
                    reader.skip(p.type, uint64_t(n));
                } else if (faceColours && int(i) == face_.red) {
                    colour[0] = readColour(reader, p.type);
                } else if (faceColours && int(i) == face_.green) {
                    colour[1] = readColour(reader, p.type);
                } else if (faceColours && int(i) == face_.blue) {
                    colour[2] = readColour(reader, p.type);
                } else {
                    reader.skip(p.type);
                }
            }
            if (scene_.triangles.size() + (polygonSize - 2) > std::numeric_limits<uint32_t>::max())
                reader.fail("more triangles than 32-bit triangle indices can address");
            // Fan triangulation (v0, v(k-1), v(k)), the order issue 2 fixes for every loader.
            for (uint64_t k = 2; k < polygonSize; ++k)
                scene_.triangles.emplace_back(polygon[0], polygon[k - 1], polygon[k]);
            if (faceColours) {
                faceColour_.insert(faceColour_.end(), polygonSize - 2, packRgb(colour[0], colour[1], colour[2]));
            }
        }
    }

    // Face colours: one material per distinct colour, in order of first use. Vertex colours (when
    // the faces have none) stay per vertex (Scene::vertexColors), interpolated across each face.
    void finishMaterials() {
        std::vector<uint32_t> colours;
        if (face_.hasColours()) {
            colours = std::move(faceColour_);
        } else if (vertex_.hasColours()) {
            scene_.vertexColors.resize(vertexColour_.size());
            for (size_t v = 0; v < vertexColour_.size(); ++v) {
                const uint32_t rgb = vertexColour_[v];  // packRgb's 0xRRGGBB
                scene_.vertexColors[v] = ((rgb >> 16) & 0xFFu) | (rgb & 0xFF00u) | ((rgb & 0xFFu) << 16) | 0xFF000000u;
            }
            return;
        } else {
            return;
        }
        std::unordered_map<uint32_t, uint32_t> materialOf;
        scene_.triangleMaterial.resize(colours.size());
        for (size_t t = 0; t < colours.size(); ++t) {
            auto [it, inserted] = materialOf.try_emplace(colours[t], uint32_t(scene_.materials.size()));
            if (inserted) {
                const uint8_t r = uint8_t(colours[t] >> 16), g = uint8_t(colours[t] >> 8), b = uint8_t(colours[t]);
                Material material;
                const auto named = header_.materialNames.find(colours[t]);
                material.name = named != header_.materialNames.end()
                                    ? named->second
                                    : "rgb_" + std::to_string(r) + "_" + std::to_string(g) + "_" + std::to_string(b);
                material.diffuse = glm::vec3(colourFromByte(r), colourFromByte(g), colourFromByte(b));
                scene_.materials.push_back(std::move(material));
            }
            scene_.triangleMaterial[t] = it->second;
        }
    }

    const std::filesystem::path& path_;
    const FileBytes& file_;
    LoadProgress* progress_;
    PlyHeader header_;
    int vertexElement_ = -1;
    int faceElement_ = -1;
    VertexLayout vertex_;
    FaceLayout face_;
    std::vector<uint32_t> vertexColour_;
    std::vector<uint32_t> faceColour_;
    Scene scene_;
};

uint8_t colourToByte(float value) {
    return uint8_t(std::lround(std::clamp(std::isfinite(value) ? value : 0.0f, 0.0f, 1.0f) * 255.0f));
}

}  // namespace

Scene loadPly(const std::filesystem::path& path, LoadProgress* progress) {
    const FileBytes file = readWholeFile(path, progress);
    Scene scene = PlyParser(path, file, progress).parse();
    reportParsed(progress, path, file.size, file.size);
    return scene;
}

void savePly(const Scene& scene, const std::filesystem::path& path) {
    const bool normals = scene.hasNormals();
    const bool colours = scene.hasMaterials();
    RAYPACK_CHECK(!normals || scene.normals.size() == scene.positions.size());
    RAYPACK_CHECK(!colours || scene.triangleMaterial.size() == scene.triangles.size());

    std::ostringstream header;
    header << "ply\nformat binary_little_endian 1.0\ncomment written by raypack (" << scene.source << ")\n";
    std::vector<std::array<uint8_t, 3>> materialColour(scene.materials.size());
    for (size_t m = 0; m < scene.materials.size(); ++m) {
        const glm::vec3 d = scene.materials[m].diffuse;
        materialColour[m] = {colourToByte(d.x), colourToByte(d.y), colourToByte(d.z)};
        std::string name = scene.materials[m].name;
        for (char& c : name)
            if (c == '\n' || c == '\r') c = ' ';
        if (colours && !name.empty())
            header << "comment raypack_material " << int(materialColour[m][0]) << ' ' << int(materialColour[m][1])
                   << ' ' << int(materialColour[m][2]) << ' ' << name << '\n';
    }
    header << "element vertex " << scene.positions.size() << "\nproperty float x\nproperty float y\nproperty float z\n";
    if (normals) header << "property float nx\nproperty float ny\nproperty float nz\n";
    header << "element face " << scene.triangles.size() << "\nproperty list uchar uint vertex_indices\n";
    if (colours) header << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    header << "end_header\n";

    static_assert(std::endian::native == std::endian::little, "savePly writes the host's byte order");
    std::vector<char> body;
    const size_t vertexBytes = normals ? 24 : 12;
    const size_t faceBytes = colours ? 16 : 13;
    body.resize(scene.positions.size() * vertexBytes + scene.triangles.size() * faceBytes);
    char* out = body.data();
    for (size_t v = 0; v < scene.positions.size(); ++v) {
        std::memcpy(out, &scene.positions[v], 12);
        if (normals) std::memcpy(out + 12, &scene.normals[v], 12);
        out += vertexBytes;
    }
    for (size_t t = 0; t < scene.triangles.size(); ++t) {
        *out = 3;
        std::memcpy(out + 1, &scene.triangles[t], 12);
        if (colours) {
            const uint32_t m = scene.triangleMaterial[t];
            RAYPACK_CHECK(m < scene.materials.size());
            std::memcpy(out + 13, materialColour[m].data(), 3);
        }
        out += faceBytes;
    }

    std::ofstream stream(path, std::ios::binary | std::ios::trunc);
    if (!stream) throwFileError(path, "cannot open for writing");
    const std::string headerText = header.str();
    stream.write(headerText.data(), std::streamsize(headerText.size()));
    stream.write(body.data(), std::streamsize(body.size()));
    stream.close();
    if (!stream) throwFileError(path, "write failed (disk full?)");
}

}  // namespace raypack
