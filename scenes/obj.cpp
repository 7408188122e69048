// Wavefront OBJ (+ MTL) through tinyobjloader. tinyobjloader parses; this file turns its result
// into a Scene in file order and checks what tinyobjloader lets through (indices out of range,
// non-finite numbers, faces with fewer than three corners), naming the offending line.
//
// Polygons are fan-triangulated here as (v0, v(k-1), v(k)) instead of by tinyobjloader's
// triangulate flag, because tinyobjloader 2.0 splits quads along their shorter diagonal, which
// would change the triangle order issue 2 fixes. OBJ normals and UVs belong to face corners, so
// where the file has them every (position, normal, UV) triple becomes its own vertex. UVs are kept
// only when a material used by a face has a map_Kd texture that loads (scenes/textures.h); OBJ's
// v runs up the image, so v is flipped to the top-down convention of Scene::uvs.
#include "scenes/formats.h"
#include "scenes/limits.h"
#include "scenes/textures.h"

#include <tiny_obj_loader.h>

#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <istream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <streambuf>
#include <unordered_map>

namespace raypack {
namespace {

// Hands tinyobjloader the file from memory in slices, reporting progress and stopping at a cancel.
class ProgressBuffer : public std::streambuf {
public:
    ProgressBuffer(const FileBytes& file, LoadProgress* progress, const std::filesystem::path& path)
        : file_(file), progress_(progress), path_(path) {}
    bool cancelled() const { return cancelled_; }

protected:
    int_type underflow() override {
        if (gptr() < egptr()) return traits_type::to_int_type(*gptr());
        if (next_ >= file_.size) return traits_type::eof();
        if (progress_) {
            if (progress_->cancel) {
                cancelled_ = true;
                return traits_type::eof();
            }
            reportParsed(progress_, path_, file_.size, next_);
        }
        constexpr size_t kSlice = size_t(4) << 20;
        char* begin = const_cast<char*>(file_.begin()) + next_;
        const size_t length = std::min(kSlice, file_.size - next_);
        setg(begin, begin, begin + length);
        next_ += length;
        return traits_type::to_int_type(*gptr());
    }

private:
    const FileBytes& file_;
    LoadProgress* progress_;
    const std::filesystem::path& path_;
    size_t next_ = 0;
    bool cancelled_ = false;
};

// Error path only: the 1-based line of the n-th (0-based) statement starting with `keyword`.
size_t lineOfStatement(const FileBytes& file, const char* keyword, size_t n) {
    const size_t keywordLength = std::strlen(keyword);
    size_t line = 1, seen = 0;
    const char* p = file.begin();
    const char* end = file.end();
    while (p < end) {
        const char* eol = static_cast<const char*>(std::memchr(p, '\n', size_t(end - p)));
        if (!eol) eol = end;
        const char* q = p;
        while (q < eol && (*q == ' ' || *q == '\t')) ++q;
        if (size_t(eol - q) > keywordLength && std::memcmp(q, keyword, keywordLength) == 0 &&
            (q[keywordLength] == ' ' || q[keywordLength] == '\t')) {
            if (seen == n) return line;
            ++seen;
        }
        ++line;
        p = eol + 1;
    }
    return 0;
}

// Error path only: the first face statement with fewer than three corners.
size_t lineOfShortFace(const FileBytes& file) {
    size_t line = 1;
    const char* p = file.begin();
    const char* end = file.end();
    while (p < end) {
        const char* eol = static_cast<const char*>(std::memchr(p, '\n', size_t(end - p)));
        if (!eol) eol = end;
        std::istringstream words(std::string(p, size_t(eol - p)));
        std::string word;
        if (words >> word && word == "f") {
            int corners = 0;
            while (words >> word) ++corners;
            if (corners < 3) return line;
        }
        ++line;
        p = eol + 1;
    }
    return 0;
}

// MTL libraries through findReferencedFile: inside the OBJ's folder, a regular file (`mtllib
// /dev/zero` would have tinyobjloader read one endless line), at most maxMtlFileBytes() long.
class CheckedMaterialReader : public tinyobj::MaterialReader {
public:
    explicit CheckedMaterialReader(const std::filesystem::path& objFile) : objFile_(objFile) {}
    bool operator()(const std::string& name, std::vector<tinyobj::material_t>* materials,
                    std::map<std::string, int>* materialMap, std::string* warnings, std::string* errors) override {
        const std::optional<std::filesystem::path> found =
            findReferencedFile(objFile_, name, "mtllib", maxMtlFileBytes());
        if (!found) {
            if (warnings) *warnings += "material library " + name + " not found; default material used\n";
            return false;
        }
        std::istringstream text(readReferencedFile(objFile_, *found, "mtllib", maxMtlFileBytes()));
        tinyobj::LoadMtl(materialMap, materials, &text, warnings, errors);
        return true;
    }

private:
    const std::filesystem::path& objFile_;
};

[[noreturn]] void failAtLine(const std::filesystem::path& path, size_t line, const std::string& what) {
    throwFileError(path, (line ? "line " + std::to_string(line) + ": " : std::string()) + what);
}

// "token" in quotes. Appended, not built with operator+, which GCC 12 warns about wrongly
// (-Wrestrict on the inlined copy).
std::string quotedToken(std::string_view token) {
    std::string quoted(1, '"');
    quoted.append(token);
    quoted.push_back('"');
    return quoted;
}

// tinyobjloader reads what is not a number as 0 ("v inf 0 0", "v a b c"), a missing coordinate as
// 0 ("v 0 0") and an index past 32 bits as a wrapped one ("f 1 2 99999999999999999999" is -1,
// the last vertex). So before it runs, every number of the statements raypack uses is checked
// here: v, vn and vt coordinates parse completely as finite floats (at least 3 for v and vn) and
// face indices as integers that fit 32 bits. One pass over lines in memory.
void checkObjNumbers(const FileBytes& file, const std::filesystem::path& path) {
    size_t line = 0;
    const char* p = file.begin();
    const char* end = file.end();
    auto isSpace = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; };
    while (p < end) {
        const char* eol = static_cast<const char*>(std::memchr(p, '\n', size_t(end - p)));
        if (!eol) eol = end;
        ++line;
        const char* q = p;
        p = eol + 1;
        while (q < eol && isSpace(*q)) ++q;
        const char* keyword = q;
        while (q < eol && !isSpace(*q)) ++q;
        const std::string_view word(keyword, size_t(q - keyword));
        const bool isVertex = word == "v", isNormal = word == "vn", isUv = word == "vt", isFace = word == "f";
        if (!isVertex && !isNormal && !isUv && !isFace) continue;
        size_t tokens = 0;
        while (true) {
            while (q < eol && isSpace(*q)) ++q;
            if (q == eol || *q == '#') break;
            const char* start = q;
            while (q < eol && !isSpace(*q)) ++q;
            const std::string_view token(start, size_t(q - start));
            ++tokens;
            if (isFace) {
                // i, i/j, i//k or i/j/k: every present component an integer of 32 bits.
                size_t from = 0;
                for (int component = 0; from <= token.size(); ++component) {
                    const size_t slash = std::min(token.find('/', from), token.size());
                    const std::string_view number = token.substr(from, slash - from);
                    if (!number.empty() || component == 0) {
                        int64_t value = 0;
                        auto [stop, ec] = std::from_chars(number.data(), number.data() + number.size(), value);
                        if (ec != std::errc() || stop != number.data() + number.size() || value == 0 ||
                            value > std::numeric_limits<int32_t>::max() ||
                            value < -int64_t(std::numeric_limits<int32_t>::max()))
                            failAtLine(path, line,
                                       "face corner \"" + std::string(token) +
                                           "\" is not a valid index (a non-zero integer of at most 32 bits)");
                    }
                    from = slash + 1;
                }
                continue;
            }
            std::string_view number = token;
            if (number.size() > 1 && number[0] == '+') number.remove_prefix(1);  // from_chars takes no '+'
            double value = 0.0;
            auto [stop, ec] = std::from_chars(number.data(), number.data() + number.size(), value);
            if (stop != number.data() + number.size() || (ec != std::errc() && ec != std::errc::result_out_of_range))
                failAtLine(path, line, quotedToken(token) + " is not a number");
            if (ec != std::errc() || !std::isfinite(value) || std::abs(value) > double(FLT_MAX))
                failAtLine(path, line, quotedToken(token) + " is not a finite number of float range");
        }
        if ((isVertex || isNormal) && tokens < 3)
            failAtLine(path, line,
                       std::string(isVertex ? "vertex" : "normal") + " has " + std::to_string(tokens) +
                           " coordinates, expected 3");
    }
}

}  // namespace

Scene loadObj(const std::filesystem::path& path, LoadProgress* progress) {
    const FileBytes file = readWholeFile(path, progress);
    checkObjNumbers(file, path);
    ProgressBuffer buffer(file, progress, path);
    std::istream stream(&buffer);

    tinyobj::attrib_t attrib;
    std::vector<tinyobj::shape_t> shapes;
    std::vector<tinyobj::material_t> objMaterials;
    std::string warnings, errors;
    // MTL files are looked up next to the OBJ, as their names in `mtllib` are relative to it.
    CheckedMaterialReader materialReader(path);
    const bool ok = tinyobj::LoadObj(&attrib, &shapes, &objMaterials, &warnings, &errors, &stream, &materialReader,
                                     /*triangulate=*/false, /*default_vcols_fallback=*/false);
    if (buffer.cancelled()) throw LoadCancelled(path.string() + ": loading cancelled");
    if (!ok) {
        // One line: tinyobjloader ends each of its messages with a newline.
        errors = errors.substr(0, errors.find('\n'));
        while (!errors.empty() && errors.back() == '.') errors.pop_back();
        throwFileError(path, errors.empty() ? "tinyobjloader could not parse the file" : errors);
    }
    if (warnings.find("Degenerated face") != std::string::npos)
        failAtLine(path, lineOfShortFace(file), "face with fewer than 3 vertices");
    if (!warnings.empty()) {
        // tinyobjloader repeats a warning once per occurrence (e.g. per usemtl of a missing
        // material); print each distinct one once.
        std::set<std::string> printed;
        std::istringstream lines(warnings);
        std::string line;
        while (std::getline(lines, line)) {
            // MTL dissolve details do not matter to raypack, which reads only Kd. Indices out of
            // bounds are raypack's own error below, at the first face that has one (tinyobjloader
            // warns at the last, a different line).
            const bool ignored = line.find("`d` and `Tr`") != std::string::npos ||
                                 line.find("indices out of bounds") != std::string::npos;
            if (!line.empty() && !ignored && printed.insert(line).second)
                std::fprintf(stderr, "raypack: warning: %s: %s\n", path.string().c_str(), line.c_str());
        }
    }

    const size_t positionCount = attrib.vertices.size() / 3;
    const size_t normalCount = attrib.normals.size() / 3;
    const size_t uvCount = attrib.texcoords.size() / 2;
    if (positionCount > std::numeric_limits<uint32_t>::max())
        throwFileError(path, "more vertices than 32-bit indices can address");
    for (size_t i = 0; i < attrib.vertices.size(); ++i)
        if (!std::isfinite(attrib.vertices[i]))
            failAtLine(path, lineOfStatement(file, "v", i / 3),
                       "vertex " + std::to_string(i / 3 + 1) + " is not finite");

    // Faces in file order; normals are kept only when every corner of every face has one.
    size_t faceCount = 0, cornerCount = 0;
    bool everyCornerHasNormal = normalCount > 0;
    for (const tinyobj::shape_t& shape : shapes) {
        faceCount += shape.mesh.num_face_vertices.size();
        cornerCount += shape.mesh.indices.size();
        for (const tinyobj::index_t& index : shape.mesh.indices)
            if (index.normal_index < 0) everyCornerHasNormal = false;
    }
    if (faceCount == 0) throwFileError(path, "OBJ file has no faces");
    if (cornerCount - 2 * faceCount > std::numeric_limits<uint32_t>::max())
        throwFileError(path, "more triangles than 32-bit triangle indices can address");
    if (normalCount > 0 && !everyCornerHasNormal)
        std::fprintf(stderr, "raypack: warning: %s: some face corners have no normal; normals ignored\n",
                     path.string().c_str());
    if (everyCornerHasNormal)
        for (size_t i = 0; i < attrib.normals.size(); ++i)
            if (!std::isfinite(attrib.normals[i]))
                failAtLine(path, lineOfStatement(file, "vn", i / 3),
                           "normal " + std::to_string(i / 3 + 1) + " is not finite");

    Scene scene;
    scene.source = path.string();
    scene.triangles.reserve(cornerCount - 2 * faceCount);
    // Materials: those of the MTL, in its order, plus a default one for faces without a material.
    bool anyMaterial = false;
    std::vector<bool> materialUsed(objMaterials.size(), false);
    for (const tinyobj::shape_t& shape : shapes)
        for (int id : shape.mesh.material_ids)
            if (id >= 0) {
                anyMaterial = true;
                if (size_t(id) < materialUsed.size()) materialUsed[size_t(id)] = true;
            }
    uint32_t defaultMaterial = 0;
    if (anyMaterial) {
        for (const tinyobj::material_t& m : objMaterials)
            scene.materials.push_back(Material{m.name, glm::vec3(m.diffuse[0], m.diffuse[1], m.diffuse[2])});
        defaultMaterial = uint32_t(scene.materials.size());
        scene.triangleMaterial.reserve(scene.triangles.capacity());
    }
    bool usedDefaultMaterial = false;

    // map_Kd textures of the used materials, each file decoded once per wrap mode (-clamp on).
    if (uvCount > 0) {
        std::map<std::pair<std::string, bool>, uint32_t> textureOfFile;
        for (size_t m = 0; m < objMaterials.size(); ++m) {
            const tinyobj::material_t& objMaterial = objMaterials[m];
            if (!materialUsed[m] || objMaterial.diffuse_texname.empty()) continue;
            const bool clamp = objMaterial.diffuse_texopt.clamp;
            const auto key = std::make_pair(objMaterial.diffuse_texname, clamp);
            auto known = textureOfFile.find(key);
            if (known == textureOfFile.end()) {
                uint32_t index = kNoTexture;
                if (std::optional<Texture> texture = tryLoadTextureImage(path, objMaterial.diffuse_texname)) {
                    texture->wrapU = texture->wrapV = clamp ? TextureWrap::Clamp : TextureWrap::Repeat;
                    index = uint32_t(scene.textures.size());
                    scene.textures.push_back(std::move(*texture));
                }
                known = textureOfFile.emplace(key, index).first;
            }
            scene.materials[m].texture = known->second;
        }
    }
    const bool keepUvs = !scene.textures.empty();
    for (size_t i = 0; keepUvs && i < attrib.texcoords.size(); ++i)
        if (!std::isfinite(attrib.texcoords[i]))
            failAtLine(path, lineOfStatement(file, "vt", i / 2),
                       "texture coordinate " + std::to_string(i / 2 + 1) + " is not finite");
    const bool unweld = everyCornerHasNormal || keepUvs;

    if (!unweld) {
        scene.positions.resize(positionCount);
        for (size_t v = 0; v < positionCount; ++v)
            scene.positions[v] =
                glm::vec3(attrib.vertices[3 * v], attrib.vertices[3 * v + 1], attrib.vertices[3 * v + 2]);
    }
    // (position, normal, UV) -> vertex, when un-welding by normals or UVs (an absent one is -1).
    struct Corner {
        int32_t v, n, t;
        bool operator==(const Corner&) const = default;
    };
    struct CornerHash {
        size_t operator()(const Corner& c) const {
            return size_t((uint64_t(uint32_t(c.v)) * 0x9E3779B97F4A7C15ull) ^ (uint64_t(uint32_t(c.n)) << 32) ^
                          (uint64_t(uint32_t(c.t)) * 0xC2B2AE3D27D4EB4Full));
        }
    };
    std::unordered_map<Corner, uint32_t, CornerHash> vertexOfCorner;
    auto vertexOf = [&](const tinyobj::index_t& index) -> uint32_t {
        if (!unweld) return uint32_t(index.vertex_index);
        const Corner key{index.vertex_index, everyCornerHasNormal ? index.normal_index : -1,
                         keepUvs ? index.texcoord_index : -1};
        auto [it, inserted] = vertexOfCorner.try_emplace(key, uint32_t(scene.positions.size()));
        if (inserted) {
            const size_t v = size_t(index.vertex_index);
            scene.positions.emplace_back(attrib.vertices[3 * v], attrib.vertices[3 * v + 1],
                                         attrib.vertices[3 * v + 2]);
            if (everyCornerHasNormal) {
                const size_t n = size_t(index.normal_index);
                scene.normals.emplace_back(attrib.normals[3 * n], attrib.normals[3 * n + 1], attrib.normals[3 * n + 2]);
            }
            if (keepUvs) {
                // A corner without a UV samples the texture's corner (0, 0) of the top-down image.
                const size_t t = size_t(key.t);
                scene.uvs.push_back(key.t < 0 ? glm::vec2(0.0f, 0.0f)
                                              : glm::vec2(attrib.texcoords[2 * t], 1.0f - attrib.texcoords[2 * t + 1]));
            }
        }
        return it->second;
    };

    size_t faceIndex = 0;
    std::vector<uint32_t> polygon;
    for (const tinyobj::shape_t& shape : shapes) {
        size_t corner = 0;
        for (size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f, ++faceIndex) {
            const size_t n = shape.mesh.num_face_vertices[f];
            polygon.clear();
            for (size_t k = 0; k < n; ++k) {
                const tinyobj::index_t& index = shape.mesh.indices[corner + k];
                if (index.vertex_index < 0 || size_t(index.vertex_index) >= positionCount)
                    failAtLine(path, lineOfStatement(file, "f", faceIndex),
                               "face refers to vertex " + std::to_string(int64_t(index.vertex_index) + 1) +
                                   ", but the file has " + std::to_string(positionCount) + " vertices");
                if (everyCornerHasNormal && size_t(index.normal_index) >= normalCount)
                    failAtLine(path, lineOfStatement(file, "f", faceIndex),
                               "face refers to normal " + std::to_string(int64_t(index.normal_index) + 1) +
                                   ", but the file has " + std::to_string(normalCount) + " normals");
                if (keepUvs && index.texcoord_index >= 0 && size_t(index.texcoord_index) >= uvCount)
                    failAtLine(path, lineOfStatement(file, "f", faceIndex),
                               "face refers to texture coordinate " +
                                   std::to_string(int64_t(index.texcoord_index) + 1) + ", but the file has " +
                                   std::to_string(uvCount));
                polygon.push_back(vertexOf(index));
            }
            corner += n;
            uint32_t material = defaultMaterial;
            if (anyMaterial) {
                const int id = f < shape.mesh.material_ids.size() ? shape.mesh.material_ids[f] : -1;
                if (id >= 0 && size_t(id) < objMaterials.size())
                    material = uint32_t(id);
                else
                    usedDefaultMaterial = true;
            }
            for (size_t k = 2; k < n; ++k) {
                scene.triangles.emplace_back(polygon[0], polygon[k - 1], polygon[k]);
                if (anyMaterial) scene.triangleMaterial.push_back(material);
            }
        }
    }
    if (usedDefaultMaterial) scene.materials.push_back(Material{"default", glm::vec3(gpu::kDefaultDiffuse)});
    scene.sourceBytes = file.size;  // the MTL, which tinyobjloader reads, is not counted
    for (const Texture& texture : scene.textures) scene.sourceBytes += texture.fileBytes;
    reportParsed(progress, path, file.size, file.size);
    return scene;
}

}  // namespace raypack
