// Scene loaders, generators and the committed default scene: good files (counts from
// ../shared/scenes/MANIFEST.md), every kind of bad input issue 2 names, and exact reproduction.
#include "renderer/bvh.h"
#include "scenes/generators.h"
#include "scenes/load.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace raypack;

namespace {

const fs::path kShared = RAYPACK_SHARED_SCENES;
const fs::path kSource = RAYPACK_SOURCE_DIR;

// A fresh folder per test for the files it writes.
class TempDir {
public:
    TempDir() {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        path_ = fs::temp_directory_path() / (std::string("raypack_test_scenes_") + info->name());
        fs::remove_all(path_);
        fs::create_directories(path_);
    }
    ~TempDir() { fs::remove_all(path_); }
    fs::path operator/(const std::string& name) const { return path_ / name; }

private:
    fs::path path_;
};

void writeFile(const fs::path& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), std::streamsize(bytes.size()));
}

std::string readFile(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

// Everything but `source` equal, bit for bit.
void expectSameScene(const Scene& a, const Scene& b) {
    ASSERT_EQ(a.positions.size(), b.positions.size());
    ASSERT_EQ(a.triangles.size(), b.triangles.size());
    ASSERT_EQ(a.normals.size(), b.normals.size());
    ASSERT_EQ(a.triangleMaterial.size(), b.triangleMaterial.size());
    ASSERT_EQ(a.materials.size(), b.materials.size());
    // memcmp of empty vectors would pass null pointers (undefined behaviour UBSan reports).
    if (!a.positions.empty()) {
        EXPECT_EQ(0, std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * sizeof(glm::vec3)));
    }
    EXPECT_TRUE(a.triangles == b.triangles);
    if (!a.normals.empty()) {
        EXPECT_EQ(0, std::memcmp(a.normals.data(), b.normals.data(), a.normals.size() * sizeof(glm::vec3)));
    }
    EXPECT_TRUE(a.triangleMaterial == b.triangleMaterial);
    for (size_t m = 0; m < a.materials.size(); ++m) {
        EXPECT_EQ(a.materials[m].name, b.materials[m].name);
        EXPECT_EQ(a.materials[m].diffuse, b.materials[m].diffuse) << "material " << m;
    }
}

// Expects loadScene to throw one raypack::Error whose message names the file and contains `part`.
void expectLoadError(const fs::path& path, const std::string& part) {
    try {
        loadScene(path);
        ADD_FAILURE() << path << " loaded; expected an error containing \"" << part << "\"";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find(path.string()), std::string::npos) << "message does not name the file: " << message;
        EXPECT_NE(message.find(part), std::string::npos) << "expected \"" << part << "\" in: " << message;
    }
}

bool allFinite(const Scene& scene) {
    for (const glm::vec3& p : scene.positions)
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return false;
    return true;
}

bool indicesInRange(const Scene& scene) {
    for (const glm::uvec3& t : scene.triangles)
        for (int c = 0; c < 3; ++c)
            if (t[c] >= scene.positions.size()) return false;
    if (scene.hasMaterials())
        for (uint32_t m : scene.triangleMaterial)
            if (m >= scene.materials.size()) return false;
    return scene.normals.empty() || scene.normals.size() == scene.positions.size();
}

// ---- Good files: the shared scenes, counts from the MANIFEST.

struct SharedScene {
    const char* file;
    size_t triangles;
    bool normals;
};

TEST(SceneLoaders, SharedScenesHaveTheManifestCounts) {
    const SharedScene scenes[] = {
        {"sibenik/sibenik_geom_75284.ply", 75284, false},
        {"sibenik/sibenik.obj", 73564, true},
        {"conference/conference_geom.ply", 331179, false},
        {"dabrovic_sponza/sponza.obj", 66454, true},
        {"stanford/bun_zipper.ply", 69451, false},
        {"stanford/stanford-bunny.obj", 69451, false},
        {"stanford/dragon_vrip_res2.ply", 202520, false},
        {"stanford/dragon_vrip_res3.ply", 47794, false},
        {"stanford/armadillo_decimated_99976.obj", 99976, false},
        {"gltf/Box/Box.glb", 12, true},
        {"gltf/Box/glTF/Box.gltf", 12, true},
        {"gltf/BoxTextured/BoxTextured.glb", 12, true},
        {"gltf/Duck/Duck.glb", 4212, true},
        {"gltf/Duck/glTF/Duck.gltf", 4212, true},
        {"gltf/Avocado/glTF/Avocado.gltf", 682, true},
        {"gltf/DamagedHelmet/DamagedHelmet.glb", 15452, true},
        {"gltf/2CylinderEngine/2CylinderEngine.glb", 121496, true},
        {"gltf/ReciprocatingSaw/ReciprocatingSaw.glb", 198470, true},
    };
    for (const SharedScene& s : scenes) {
        SCOPED_TRACE(s.file);
        const Scene scene = loadScene(kShared / s.file);
        EXPECT_EQ(scene.triangleCount(), s.triangles);
        EXPECT_EQ(scene.hasNormals(), s.normals);
        EXPECT_TRUE(allFinite(scene));
        EXPECT_TRUE(indicesInRange(scene));
        EXPECT_FALSE(scene.bounds().empty());
    }
}

TEST(SceneLoaders, BunnyPlyAndObjAgree) {
    const Scene ply = loadScene(kShared / "stanford/bun_zipper.ply");
    const Scene obj = loadScene(kShared / "stanford/stanford-bunny.obj");
    EXPECT_EQ(ply.triangleCount(), obj.triangleCount());
    EXPECT_EQ(ply.positions.size(), 35947u);
}

TEST(SceneLoaders, SibenikObjMaterialsFromMtl) {
    const Scene scene = loadScene(kShared / "sibenik/sibenik.obj");
    ASSERT_TRUE(scene.hasMaterials());
    // 15 materials in sibenik.mtl (staklo unused by the OBJ, see the MANIFEST), every face has one.
    EXPECT_EQ(scene.materials.size(), 15u);
    std::vector<bool> used(scene.materials.size(), false);
    for (uint32_t m : scene.triangleMaterial) used[m] = true;
    size_t usedCount = 0;
    for (size_t m = 0; m < used.size(); ++m) usedCount += used[m];
    EXPECT_EQ(usedCount, 14u);
    for (const Material& m : scene.materials) {
        EXPECT_GE(m.diffuse.x, 0.0f);
        EXPECT_LE(m.diffuse.x, 1.0f);
    }
}

TEST(SceneLoaders, GltfMaterialsAndTransforms) {
    // Box.gltf: one node with a matrix that rotates the unit cube -90 degrees about x, one
    // material with baseColorFactor (0.8, 0, 0).
    const Scene box = loadScene(kShared / "gltf/Box/glTF/Box.gltf");
    ASSERT_TRUE(box.hasMaterials());
    ASSERT_EQ(box.materials.size(), 1u);
    EXPECT_NEAR(box.materials[0].diffuse.x, 0.8f, 1e-6f);
    EXPECT_NEAR(box.materials[0].diffuse.y, 0.0f, 1e-6f);
    const Aabb bounds = box.bounds();
    EXPECT_NEAR(bounds.lo.x, -0.5f, 1e-5f);
    EXPECT_NEAR(bounds.hi.z, 0.5f, 1e-5f);
    for (const glm::vec3& n : box.normals) EXPECT_NEAR(glm::length(n), 1.0f, 1e-5f);
    // The .glb and .gltf versions are the same scene.
    expectSameScene(box, loadScene(kShared / "gltf/Box/Box.glb"));
}

TEST(SceneLoaders, ExtensionIsCaseInsensitive) {
    TempDir dir;
    fs::copy_file(kShared / "gltf/Box/Box.glb", dir / "BOX.GLB");
    EXPECT_EQ(loadScene(dir / "BOX.GLB").triangleCount(), 12u);
    writeFile(dir / "tri.PLY",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
              "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    EXPECT_EQ(loadScene(dir / "tri.PLY").triangleCount(), 1u);
}

// ---- PLY: formats, types, property order, colours, fan order.

// A small mesh with a quad, a pentagon, normals and per-face colours, written by hand in each PLY
// encoding with deliberately unusual layouts (properties reordered, an extra element, odd types).
struct TestMesh {
    std::vector<glm::vec3> positions{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 2, 0.25f}, {-1, 0.5f, 1e-3f}};
    std::vector<glm::vec3> normals{{0, 0, 1}, {0, 0, 1}, {0, 0.6f, 0.8f}, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}};
    std::vector<std::vector<uint32_t>> faces{{0, 1, 2, 3}, {3, 2, 4}, {0, 3, 4, 5, 1}};
    std::vector<std::array<uint8_t, 3>> colours{{255, 0, 0}, {10, 20, 30}, {255, 0, 0}};
};

std::string plyHeader(const char* format, const TestMesh& mesh, const char* countType, const char* indexType) {
    std::ostringstream h;
    h << "ply\r\nformat " << format << " 1.0\ncomment test mesh\n"
      << "element camera 1\nproperty float view_px\nproperty list uchar int junk\n"
      << "element vertex " << mesh.positions.size() << "\n"
      << "property double z\nproperty float nx\nproperty float x\nproperty uchar quality\n"
      << "property float ny\nproperty double y\nproperty float nz\n"
      << "element face " << mesh.faces.size() << "\n"
      << "property uchar green\nproperty list " << countType << " " << indexType << " vertex_indices\n"
      << "property short flags\nproperty uchar red\nproperty uchar blue\n"
      << "end_header\n";
    return h.str();
}

template <typename T>
void put(std::string& out, T value, bool bigEndian) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (bigEndian) std::reverse(bytes, bytes + sizeof(T));
    out.append(bytes, sizeof(T));
}

std::string binaryPly(const TestMesh& mesh, bool bigEndian) {
    std::string out = plyHeader(bigEndian ? "binary_big_endian" : "binary_little_endian", mesh, "ushort", "uint");
    put<float>(out, 1.5f, bigEndian);
    put<uint8_t>(out, 2, bigEndian);
    put<int32_t>(out, 7, bigEndian);
    put<int32_t>(out, 8, bigEndian);
    for (size_t v = 0; v < mesh.positions.size(); ++v) {
        put<double>(out, mesh.positions[v].z, bigEndian);
        put<float>(out, mesh.normals[v].x, bigEndian);
        put<float>(out, mesh.positions[v].x, bigEndian);
        put<uint8_t>(out, 200, bigEndian);
        put<float>(out, mesh.normals[v].y, bigEndian);
        put<double>(out, mesh.positions[v].y, bigEndian);
        put<float>(out, mesh.normals[v].z, bigEndian);
    }
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
        put<uint8_t>(out, mesh.colours[f][1], bigEndian);
        put<uint16_t>(out, uint16_t(mesh.faces[f].size()), bigEndian);
        for (uint32_t i : mesh.faces[f]) put<uint32_t>(out, i, bigEndian);
        put<int16_t>(out, -3, bigEndian);
        put<uint8_t>(out, mesh.colours[f][0], bigEndian);
        put<uint8_t>(out, mesh.colours[f][2], bigEndian);
    }
    return out;
}

std::string asciiPly(const TestMesh& mesh) {
    std::ostringstream out;
    out << plyHeader("ascii", mesh, "uchar", "int");
    out.precision(9);
    out << "1.5 2 7 8\n";
    for (size_t v = 0; v < mesh.positions.size(); ++v)
        out << double(mesh.positions[v].z) << ' ' << mesh.normals[v].x << ' ' << mesh.positions[v].x << " 200 "
            << mesh.normals[v].y << ' ' << double(mesh.positions[v].y) << "\t" << mesh.normals[v].z << "\r\n";
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
        out << int(mesh.colours[f][1]) << ' ' << mesh.faces[f].size();
        for (uint32_t i : mesh.faces[f]) out << ' ' << i;
        out << " -3 " << int(mesh.colours[f][0]) << ' ' << int(mesh.colours[f][2]) << '\n';
    }
    return out.str();
}

TEST(PlyLoader, AsciiBigAndLittleEndianGiveTheSameScene) {
    TempDir dir;
    const TestMesh mesh;
    writeFile(dir / "le.ply", binaryPly(mesh, false));
    writeFile(dir / "be.ply", binaryPly(mesh, true));
    writeFile(dir / "ascii.ply", asciiPly(mesh));
    const Scene le = loadScene(dir / "le.ply");
    expectSameScene(le, loadScene(dir / "be.ply"));
    expectSameScene(le, loadScene(dir / "ascii.ply"));

    // Fan triangulation (v0, v(k-1), v(k)) in file order.
    const std::vector<glm::uvec3> expected{{0, 1, 2}, {0, 2, 3}, {3, 2, 4}, {0, 3, 4}, {0, 4, 5}, {0, 5, 1}};
    EXPECT_TRUE(le.triangles == expected);
    ASSERT_TRUE(le.hasNormals());
    EXPECT_EQ(le.normals[2], glm::vec3(0, 0.6f, 0.8f));
    EXPECT_EQ(le.positions[5], mesh.positions[5]);
    // One material per distinct colour, in order of first use.
    ASSERT_EQ(le.materials.size(), 2u);
    EXPECT_EQ(le.materials[0].diffuse, glm::vec3(1, 0, 0));
    EXPECT_EQ(le.materials[1].diffuse, glm::vec3(colourFromByte(10), colourFromByte(20), colourFromByte(30)));
    EXPECT_TRUE(le.triangleMaterial == (std::vector<uint32_t>{0, 0, 1, 0, 0, 0}));
}

TEST(PlyLoader, SavePlyRoundTrip) {
    TempDir dir;
    writeFile(dir / "in.ply", asciiPly(TestMesh{}));
    const Scene scene = loadScene(dir / "in.ply");
    savePly(scene, dir / "out.ply");
    expectSameScene(scene, loadScene(dir / "out.ply"));
    // Without normals or materials too.
    Scene bare = scene;
    bare.normals.clear();
    bare.materials.clear();
    bare.triangleMaterial.clear();
    savePly(bare, dir / "bare.ply");
    expectSameScene(bare, loadScene(dir / "bare.ply"));
}

TEST(PlyLoader, VertexColoursStayPerVertex) {
    TempDir dir;
    writeFile(dir / "vc.ply",
              "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
              "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
              "element face 2\nproperty list uchar uint vertex_index\nend_header\n"
              "0 0 0 0 255 0\n1 0 0 9 9 9\n1 1 0 9 9 9\n0 1 0 1 2 3\n3 0 1 2\n3 3 2 1\n");
    const Scene scene = loadScene(dir / "vc.ply");
    EXPECT_FALSE(scene.hasMaterials());
    // RGBA8, R in the low byte, opaque.
    EXPECT_TRUE(scene.vertexColors == (std::vector<uint32_t>{0xFF00FF00u, 0xFF090909u, 0xFF090909u, 0xFF030201u}));
    EXPECT_FALSE(scene.hasNormals());
    EXPECT_FALSE(scene.hasUvs());
}

TEST(PlyLoader, DegenerateTrianglesAreKept) {
    TempDir dir;
    writeFile(dir / "degenerate.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
              "end_header\n0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n3 1 1 1\n");
    const Scene scene = loadScene(dir / "degenerate.ply");
    EXPECT_EQ(scene.triangleCount(), 2u);
    EXPECT_EQ(scene.degenerateCount(), 2u);
}

// ---- Bad input: one raypack::Error naming the file and the problem, never a crash or hang.

const char* kTriangleHeader =
    "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

std::string triangleBody(float x0 = 0.0f, int32_t index2 = 2) {
    std::string body;
    const float xyz[9] = {x0, 0, 0, 1, 0, 0, 0, 1, 0};
    body.append(reinterpret_cast<const char*>(xyz), sizeof xyz);
    body.push_back(3);
    const int32_t indices[3] = {0, 1, index2};
    body.append(reinterpret_cast<const char*>(indices), sizeof indices);
    return body;
}

TEST(BadInput, PlyFiles) {
    TempDir dir;
    writeFile(dir / "good.ply", kTriangleHeader + triangleBody());
    EXPECT_EQ(loadScene(dir / "good.ply").triangleCount(), 1u);

    writeFile(dir / "empty.ply", "");
    expectLoadError(dir / "empty.ply", "empty");

    const std::string full = kTriangleHeader + triangleBody();
    writeFile(dir / "truncated.ply", full.substr(0, full.size() - 5));
    expectLoadError(dir / "truncated.ply", "byte offset");
    writeFile(dir / "header_only.ply", std::string(kTriangleHeader).substr(0, 60));
    expectLoadError(dir / "header_only.ply", "end_header");

    // Counts far beyond what the file holds are rejected before allocating.
    std::string huge = kTriangleHeader;
    huge.replace(huge.find("vertex 3"), 8, "vertex 4000000000");
    writeFile(dir / "huge_count.ply", huge + triangleBody());
    expectLoadError(dir / "huge_count.ply", "bytes follow the header");
    std::string hugeFaces = kTriangleHeader;
    hugeFaces.replace(hugeFaces.find("face 1"), 6, "face 99999999999");
    writeFile(dir / "huge_faces.ply", hugeFaces + triangleBody());
    expectLoadError(dir / "huge_faces.ply", "bytes follow the header");
    // A list count larger than the rest of the file.
    std::string longList = kTriangleHeader + triangleBody();
    longList[longList.size() - 13] = char(250);
    writeFile(dir / "long_list.ply", longList);
    expectLoadError(dir / "long_list.ply", "byte offset");

    writeFile(dir / "index.ply", kTriangleHeader + triangleBody(0.0f, 3));
    expectLoadError(dir / "index.ply", "vertex index 3");
    writeFile(dir / "negative.ply", kTriangleHeader + triangleBody(0.0f, -1));
    expectLoadError(dir / "negative.ply", "vertex index -1");

    writeFile(dir / "nan.ply", kTriangleHeader + triangleBody(std::nanf("")));
    expectLoadError(dir / "nan.ply", "byte offset");
    writeFile(dir / "inf.ply", kTriangleHeader + triangleBody(INFINITY));
    expectLoadError(dir / "inf.ply", "non-finite");

    const std::string asciiHeader =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    writeFile(dir / "ascii_nan.ply", asciiHeader + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n");
    expectLoadError(dir / "ascii_nan.ply", "line 11");
    writeFile(dir / "ascii_word.ply", asciiHeader + "0 0 0\n1 0 0\n0 one 0\n3 0 1 2\n");
    expectLoadError(dir / "ascii_word.ply", "line 12");
    writeFile(dir / "ascii_truncated.ply", asciiHeader + "0 0 0\n1 0 0\n0 1 0\n3 0 1");
    expectLoadError(dir / "ascii_truncated.ply", "line 13");
    writeFile(dir / "ascii_index.ply", asciiHeader + "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
    expectLoadError(dir / "ascii_index.ply", "line 13: face 0 has vertex index 7");
    writeFile(dir / "two_corners.ply", asciiHeader + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n");
    expectLoadError(dir / "two_corners.ply", "2 vertices");

    writeFile(dir / "not_ply.ply", "solid cube\nfacet normal 0 0 1\n");
    expectLoadError(dir / "not_ply.ply", "not a PLY file");
    writeFile(dir / "bad_format.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n");
    expectLoadError(dir / "bad_format.ply", "line 2");
    writeFile(dir / "bad_type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n");
    expectLoadError(dir / "bad_type.ply", "line 4");
    writeFile(dir / "points.ply",
              "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
              "property float z\nend_header\n0 0 0\n");
    expectLoadError(dir / "points.ply", "no face element");
}

TEST(BadInput, ObjFiles) {
    TempDir dir;
    writeFile(dir / "good.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 2 0\nf 1 2 3 4 5\n");
    const Scene good = loadScene(dir / "good.obj");
    const std::vector<glm::uvec3> fan{{0, 1, 2}, {0, 2, 3}, {0, 3, 4}};
    EXPECT_TRUE(good.triangles == fan);

    writeFile(dir / "empty.obj", "");
    expectLoadError(dir / "empty.obj", "empty");
    writeFile(dir / "no_faces.obj", "# nothing\nv 0 0 0\n");
    expectLoadError(dir / "no_faces.obj", "no faces");
    writeFile(dir / "index.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n\nf 1 2 9\n");
    expectLoadError(dir / "index.obj", "line 6");
    writeFile(dir / "negative.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nf -1 -2 -7\n");
    expectLoadError(dir / "negative.obj", "line 5");
    writeFile(dir / "normal_index.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n");
    expectLoadError(dir / "normal_index.obj", "line 5");
    writeFile(dir / "zero.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 0 1 2\n");
    expectLoadError(dir / "zero.obj", "line 4");
    writeFile(dir / "short_face.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nf 1 2\n");
    expectLoadError(dir / "short_face.obj", "line 5");
    writeFile(dir / "inf.obj", "v 0 0 0\nv 1e999 0 0\nv 1 1 0\nf 1 2 3\n");
    expectLoadError(dir / "inf.obj", "line 2");
}

TEST(ObjLoader, NormalsUnweldVerticesAndMissingMtlIsAWarning) {
    TempDir dir;
    // Two triangles share vertices 1 and 3 but with different normals at vertex 3.
    writeFile(dir / "n.obj",
              "mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nvn 0 1 0\n"
              "usemtl red\nf 1//1 2//1 3//1\nf 2//1 4//2 3//2\n");
    const Scene scene = loadScene(dir / "n.obj");
    ASSERT_EQ(scene.triangleCount(), 2u);
    ASSERT_TRUE(scene.hasNormals());
    // Pairs: (1,1) (2,1) (3,1) (4,2) (3,2) -> 5 vertices.
    EXPECT_EQ(scene.positions.size(), 5u);
    EXPECT_EQ(scene.positions[scene.triangles[1][2]], glm::vec3(0, 1, 0));
    EXPECT_EQ(scene.normals[scene.triangles[1][2]], glm::vec3(0, 1, 0));
    EXPECT_EQ(scene.normals[scene.triangles[0][2]], glm::vec3(0, 0, 1));
    EXPECT_FALSE(scene.hasMaterials());  // the MTL is missing: no colours, but no error either
}

TEST(ObjLoader, MtlDiffuseColour) {
    TempDir dir;
    writeFile(dir / "m.mtl", "newmtl red\nKd 0.9 0.1 0.2\nnewmtl blue\nKd 0 0 1\n");
    writeFile(dir / "m.obj",
              "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl blue\nf 1 3 2\n"
              "usemtl red\nf 2 3 1\n");
    const Scene scene = loadScene(dir / "m.obj");
    ASSERT_EQ(scene.materials.size(), 3u);  // red, blue, and a default for the first face
    EXPECT_EQ(scene.materials[0].name, "red");
    EXPECT_NEAR(scene.materials[0].diffuse.x, 0.9f, 1e-6f);
    EXPECT_EQ(scene.materials[1].diffuse, glm::vec3(0, 0, 1));
    EXPECT_TRUE(scene.triangleMaterial == (std::vector<uint32_t>{2, 1, 0}));
}

TEST(BadInput, GltfFiles) {
    TempDir dir;
    const std::string glb = readFile(kShared / "gltf/Box/Box.glb");
    writeFile(dir / "truncated.glb", glb.substr(0, glb.size() / 2));
    expectLoadError(dir / "truncated.glb", "");
    writeFile(dir / "empty.glb", "");
    expectLoadError(dir / "empty.glb", "empty");
    writeFile(dir / "garbage.gltf", "{ \"asset\": { \"version\": \"2.0\" }, \"nodes\": [ { \"mesh\": 4 ");
    expectLoadError(dir / "garbage.gltf", "");

    // A hand-made glTF with one non-indexed triangle in an embedded buffer, then broken variants.
    auto gltf = [](const std::string& positions, size_t count, const std::string& indices) {
        std::string accessors =
            "{\"bufferView\":0,\"componentType\":5126,\"count\":" + std::to_string(count) + ",\"type\":\"VEC3\"}";
        std::string primitive = "{\"attributes\":{\"POSITION\":0}";
        std::string views = "{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36}";
        std::string buffers = "{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64," + positions + "\"}";
        if (!indices.empty()) {
            accessors += ",{\"bufferView\":1,\"componentType\":5121,\"count\":3,\"type\":\"SCALAR\"}";
            primitive += ",\"indices\":1";
            views += ",{\"buffer\":1,\"byteOffset\":0,\"byteLength\":3}";
            buffers += ",{\"byteLength\":3,\"uri\":\"data:application/octet-stream;base64," + indices + "\"}";
        }
        primitive += "}";
        return "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0,"
               "\"translation\":[10,0,0]}],\"meshes\":[{\"primitives\":[" +
               primitive + "]}],\"accessors\":[" + accessors + "],\"bufferViews\":[" + views + "],\"buffers\":[" +
               buffers + "]}";
    };
    // Base64 of floats (0,0,0, 1,0,0, 0,1,0).
    const std::string triangle = "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA";
    writeFile(dir / "ok.gltf", gltf(triangle, 3, ""));
    const Scene ok = loadScene(dir / "ok.gltf");
    ASSERT_EQ(ok.triangleCount(), 1u);
    EXPECT_EQ(ok.positions[1], glm::vec3(11, 0, 0));             // translation applied
    writeFile(dir / "indexed.gltf", gltf(triangle, 3, "AAEC"));  // 8-bit indices 0 1 2
    EXPECT_EQ(loadScene(dir / "indexed.gltf").triangleCount(), 1u);
    writeFile(dir / "bad_index.gltf", gltf(triangle, 3, "AAEH"));  // 0 1 7
    expectLoadError(dir / "bad_index.gltf", "outside");
    writeFile(dir / "overrun.gltf", gltf(triangle, 6, ""));  // 6 vertices in a 36-byte view
    expectLoadError(dir / "overrun.gltf", "more than its buffer view holds");
    // (0,0,0, inf,0,0, 0,1,0)
    writeFile(dir / "inf.gltf", gltf("AAAAAAAAAAAAAAAAAACAfwAAAAAAAAAAAAAAAAAAgD8AAAAA", 3, ""));
    expectLoadError(dir / "inf.gltf", "not finite");
}

TEST(BadInput, UnknownFormatMissingFileAndDirectory) {
    TempDir dir;
    writeFile(dir / "scene.stl", "solid x\n");
    expectLoadError(dir / "scene.stl", "unknown scene format");
    writeFile(dir / "noextension", "ply\n");
    expectLoadError(dir / "noextension", "no file extension");
    expectLoadError(dir / "missing.ply", "no such file");
    fs::create_directories(dir / "folder.obj");
    expectLoadError(dir / "folder.obj", "directory");
}

// ---- Progress and cancellation.

TEST(LoadProgressTest, ReachesTotalAndCancels) {
    const fs::path path = kShared / "stanford/bun_zipper.ply";
    LoadProgress progress;
    loadScene(path, &progress);
    EXPECT_EQ(progress.total.load(), 2 * fs::file_size(path));
    EXPECT_EQ(progress.done.load(), progress.total.load());

    for (const char* file : {"stanford/bun_zipper.ply", "stanford/stanford-bunny.obj", "gltf/Duck/Duck.glb"}) {
        LoadProgress cancelled;
        cancelled.cancel = true;
        EXPECT_THROW(loadScene(kShared / file, &cancelled), LoadCancelled) << file;
    }
}

// ---- Specs and generators.

TEST(SceneSpecs, GeneratorsAndSubdivision) {
    EXPECT_EQ(openScene("gen:terrain:1k").source, "gen:terrain:1000");
    EXPECT_EQ(openScene("subdiv:2:gen:deep:3").triangleCount(), 48u);
    EXPECT_EQ(openScene((kShared / "gltf/Box/Box.glb").string()).triangleCount(), 12u);
    EXPECT_EQ(openScene("subdiv:1:" + (kShared / "gltf/Box/Box.glb").string()).triangleCount(), 48u);
    for (const char* bad : {"gen:", "gen:terrain", "gen:terrain:x", "gen:cube:5", "gen:default:3", "subdiv:1",
                            "subdiv:x:gen:default", "gen:deep:100000", "gen:terrain:1", "gen:terrain:99999999999"})
        EXPECT_THROW(openScene(bad), Error) << bad;
    EXPECT_NE(std::string(sceneSpecHelp()).find("subdiv:L:"), std::string::npos);
}

TEST(Generators, CountsAndDeterminism) {
    for (uint32_t target : {2u, 100u, 10000u, 123457u}) {
        const Scene terrain = makeTerrain(target);
        EXPECT_LE(terrain.triangleCount(), target);
        EXPECT_GE(terrain.triangleCount(), target * 0.9 - 2);
        EXPECT_TRUE(indicesInRange(terrain));
        EXPECT_TRUE(allFinite(terrain));
    }
    for (uint32_t target : {8u, 1000u, 50000u, 1000000u}) {
        const Scene flake = makeSphereFlake(target);
        EXPECT_LE(flake.triangleCount(), target);
        EXPECT_GE(flake.triangleCount(), target / 2);
        EXPECT_TRUE(indicesInRange(flake));
    }
    expectSameScene(makeTerrain(5000), makeTerrain(5000));
    expectSameScene(makeSphereFlake(5000), makeSphereFlake(5000));
    expectSameScene(makeDefaultScene(), makeDefaultScene());
}

// Every edge of a closed mesh is shared by exactly two triangles; subdivision must keep that.
std::map<std::pair<uint32_t, uint32_t>, int> edgeUse(const Scene& scene) {
    std::map<std::pair<uint32_t, uint32_t>, int> use;
    for (const glm::uvec3& t : scene.triangles)
        for (int e = 0; e < 3; ++e) ++use[{std::min(t[e], t[(e + 1) % 3]), std::max(t[e], t[(e + 1) % 3])}];
    return use;
}

TEST(Generators, SubdivisionKeepsClosedMeshesClosedAndCarriesAttributes) {
    const Scene sphere = makeSphereFlake(200);  // one closed UV sphere
    for (const auto& [edge, count] : edgeUse(sphere)) ASSERT_EQ(count, 2);
    const Scene fine = subdivide(sphere, 2);
    EXPECT_EQ(fine.triangleCount(), 16 * sphere.triangleCount());
    for (const auto& [edge, count] : edgeUse(fine)) ASSERT_EQ(count, 2);
    ASSERT_EQ(fine.normals.size(), fine.positions.size());
    ASSERT_EQ(fine.triangleMaterial.size(), fine.triangleCount());
    // Children 4t..4t+3 lie in their parent: same material, corners on the parent's plane.
    for (uint32_t t = 0; t < sphere.triangleCount(); t += 7)
        for (uint32_t c = 0; c < 16; ++c) EXPECT_EQ(fine.triangleMaterial[16 * t + c], sphere.triangleMaterial[t]);
    // Area is preserved: four children of a triangle cover it exactly.
    auto area = [](const Scene& s) {
        double a = 0;
        for (uint32_t t = 0; t < s.triangleCount(); ++t)
            a += 0.5 * glm::length(glm::cross(s.vertex(t, 1) - s.vertex(t, 0), s.vertex(t, 2) - s.vertex(t, 0)));
        return a;
    };
    EXPECT_NEAR(area(fine), area(sphere), 1e-4 * area(sphere));
}

// Issue 15's closed test scenes: the icosphere is closed with every vertex stored once, the
// lattice's vertices are exact integers, and its camera's pixel rays cross it at vertices and edges.
TEST(Generators, IcosphereIsClosedWithSharedVertices) {
    for (uint32_t levels : {0u, 1u, 3u}) {
        const Scene sphere = makeIcosphere(levels);
        const size_t faces = size_t(20) << (2 * levels);
        ASSERT_EQ(sphere.triangleCount(), faces);
        // Euler: V - E + F = 2 with E = 3F/2 gives V = F/2 + 2, so no vertex is stored twice.
        EXPECT_EQ(sphere.positions.size(), faces / 2 + 2);
        std::map<std::array<float, 3>, int> distinct;
        for (const glm::vec3& p : sphere.positions) ++distinct[{p.x, p.y, p.z}];
        EXPECT_EQ(distinct.size(), sphere.positions.size()) << "two vertices at one position";
        const auto use = edgeUse(sphere);
        EXPECT_EQ(use.size(), faces * 3 / 2);
        for (const auto& [edge, count] : use) ASSERT_EQ(count, 2) << edge.first << "-" << edge.second;
        for (const glm::vec3& p : sphere.positions) EXPECT_NEAR(glm::length(p), 1.0f, 1e-6f);
        for (uint32_t t = 0; t < sphere.triangleCount(); ++t) {
            const glm::vec3 a = sphere.vertex(t, 0), b = sphere.vertex(t, 1), c = sphere.vertex(t, 2);
            EXPECT_GT(glm::dot(glm::cross(b - a, c - a), a + b + c), 0.0f) << "triangle " << t << " faces inwards";
        }
    }
    EXPECT_EQ(openScene("gen:icosphere:2").triangleCount(), 320u);
    EXPECT_THROW(makeIcosphere(13), Error);
}

TEST(Generators, LatticeVerticesAreExactAndShared) {
    const Scene lattice = openScene("gen:lattice:6x4");
    ASSERT_EQ(lattice.triangleCount(), 48u);
    ASSERT_EQ(lattice.positions.size(), 7u * 5u);
    for (uint32_t j = 0; j <= 4; ++j)
        for (uint32_t i = 0; i <= 6; ++i) {
            const glm::vec3 p = lattice.positions[j * 7 + i];
            EXPECT_EQ(p, glm::vec3(float(int(i) - 3), float(int(j) - 2), 0.0f)) << i << "," << j;
        }
    // Inner edges belong to two triangles, border edges to one: 2NM + N + M inner... counted.
    int inner = 0, border = 0;
    for (const auto& [edge, count] : edgeUse(lattice)) {
        ASSERT_TRUE(count == 1 || count == 2);
        (count == 2 ? inner : border) += 1;
    }
    EXPECT_EQ(border, 2 * (6 + 4));
    EXPECT_EQ(inner, 3 * 6 * 4 - 6 - 4);  // 3 edges per cell, the top and right border counted apart
    for (uint32_t t = 0; t < lattice.triangleCount(); ++t) {
        const glm::vec3 n =
            glm::cross(lattice.vertex(t, 1) - lattice.vertex(t, 0), lattice.vertex(t, 2) - lattice.vertex(t, 0));
        EXPECT_EQ(n, glm::vec3(0, 0, 1)) << "unit cells, half each, facing +z";
    }
    EXPECT_EQ(openScene("gen:lattice:5").triangleCount(), 50u);
    for (const char* bad : {"gen:lattice:0", "gen:lattice:4x", "gen:lattice:x4", "gen:lattice:4y4"})
        EXPECT_THROW(openScene(bad), Error) << bad;
}

// The pixel rays of latticeCamera cross z = 0 at multiples of 1/2 to within a few ulps, all inside
// the lattice latticeCellsFor sizes: a quarter at vertices, half at edge midpoints, a quarter at the
// middle of a diagonal.
TEST(Generators, LatticeCameraRaysCrossVerticesAndEdges) {
    for (auto [width, height] : {std::pair<uint32_t, uint32_t>{96, 96}, {64, 48}, {1024, 768}}) {
        const glm::uvec2 cells = latticeCellsFor(width, height);
        const Scene lattice = makeLattice(cells.x, cells.y);
        Aabb bounds;
        for (const glm::vec3& p : lattice.positions) bounds.grow(p);
        const GpuCamera camera = makeGpuCamera(latticeCamera(width, height), width, height);
        const glm::vec3 eye = gpu::cameraEye(camera);
        // Distance from the intended point, in ulps of the ray's length to it (the precision a ray
        // from the eye can have there: its direction is a float vector).
        double worst = 0.0;
        std::map<int, int> kinds;  // 0 vertex, 1 axis-parallel edge, 2 diagonal
        for (uint32_t y = 0; y < height; ++y)
            for (uint32_t x = 0; x < width; ++x) {
                const glm::dvec3 dir(gpu::primaryRayDirection(camera, x, y));
                const double t = -double(eye.z) / dir.z;
                const glm::dvec3 p = glm::dvec3(eye) + t * dir;
                const glm::dvec2 target(std::round(2.0 * p.x) / 2.0, std::round(2.0 * p.y) / 2.0);
                const double ulp = std::ldexp(1.0, std::ilogb(t * glm::length(dir)) - 23);
                worst = std::max(worst, glm::length(glm::dvec2(p) - target) / ulp);
                ASSERT_GT(target.x, bounds.lo.x + 0.5);
                ASSERT_LT(target.x, bounds.hi.x - 0.5);
                ASSERT_GT(target.y, bounds.lo.y + 0.5);
                ASSERT_LT(target.y, bounds.hi.y - 0.5);
                ++kinds[int(target.x != std::floor(target.x)) + int(target.y != std::floor(target.y))];
            }
        EXPECT_LT(worst, 4.0) << width << "x" << height;
        const int rays = int(width * height);
        EXPECT_EQ(kinds[0], rays / 4);
        EXPECT_EQ(kinds[1], rays / 2);
        EXPECT_EQ(kinds[2], rays / 4);
        std::printf("lattice camera %ux%u: rays within %.2f ulps (of their length) of a vertex or edge point\n", width,
                    height, worst);
    }
}

TEST(SceneSpecs, PlaceScalesAndMovesExactly) {
    const Scene lattice = makeLattice(8, 8);
    const Scene far = openScene("place:1:100000,100000,100000:gen:lattice:8");
    const Scene tiny = openScene("place:6.103515625e-5:0,0,0:gen:lattice:8");
    ASSERT_EQ(far.positions.size(), lattice.positions.size());
    EXPECT_EQ(far.triangles, lattice.triangles);
    for (size_t i = 0; i < lattice.positions.size(); ++i) {
        EXPECT_EQ(glm::dvec3(far.positions[i]), glm::dvec3(lattice.positions[i]) + 1e5) << "exact far away";
        EXPECT_EQ(glm::dvec3(tiny.positions[i]), glm::dvec3(lattice.positions[i]) * std::ldexp(1.0, -14));
    }
    const Scene sphere = openScene("place:-2:1,2,3:gen:icosphere:1");
    for (const auto& [edge, count] : edgeUse(sphere)) ASSERT_EQ(count, 2);
    EXPECT_NEAR(glm::length(sphere.positions[0] - glm::vec3(1, 2, 3)), 2.0f, 1e-5f);
    const Camera placed = placeCamera(latticeCamera(8, 8), 2.0f, glm::vec3(1, 0, 0));
    EXPECT_EQ(placed.eye, glm::vec3(0.5f, -0.5f, 4.0f));
    for (const char* bad :
         {"place:1:0,0:gen:lattice:2", "place:0:0,0,0:gen:lattice:2", "place:x:0,0,0:gen:lattice:2", "place:1:0,0,0",
          "place:1:0,0,0:", "place:inf:0,0,0:gen:lattice:2", "place:1:0,0,0,0:gen:lattice:2"})
        EXPECT_THROW(openScene(bad), Error) << bad;
    EXPECT_NE(std::string(sceneSpecHelp()).find("place:S:X,Y,Z:SCENE"), std::string::npos);
}

TEST(Generators, DeepSceneIsASpine) {
    for (uint32_t n : {8u, 30u, kDeepSceneMaxTriangles}) {
        const Scene deep = makeDeepScene(n);
        ASSERT_EQ(deep.triangleCount(), n);
        EXPECT_TRUE(allFinite(deep));
        for (uint32_t t = 0; t < n; ++t) EXPECT_GT(deep.vertex(t, 0).x, 0.0f) << "triangle " << t << " underflowed";
        const Bvh bvh = buildBvh(deep, BvhBuildOptions{});
        // A spine: every level peels one triangle off (the last two may share a leaf).
        EXPECT_GE(bvh.stats.maxLeafDepth, n - 2) << "n = " << n;
        EXPECT_LE(bvh.stats.maxLeafDepth, n - 1) << "n = " << n;
    }
}

// ---- The committed default scene.

TEST(DefaultScene, CommittedFileEqualsTheGenerator) {
    const Scene generated = makeDefaultScene();
    EXPECT_GE(generated.triangleCount(), 30000u);
    EXPECT_LE(generated.triangleCount(), 100000u);
    EXPECT_TRUE(generated.hasNormals());
    EXPECT_GE(generated.materials.size(), 5u);
    // Regenerate with `raypack-cli generate gen:default scenes/data/default.ply`, or by running this
    // test with RAYPACK_REGENERATE_DEFAULT_SCENE=1 (docs/scenes.md).
    const fs::path committed = kSource / "scenes/data/default.ply";
    if (std::getenv("RAYPACK_REGENERATE_DEFAULT_SCENE")) savePly(generated, committed);
    EXPECT_LT(fs::file_size(committed), 3u << 20);
    expectSameScene(generated, loadScene(committed));
    expectSameScene(generated, openScene("gen:default"));
}

}  // namespace
