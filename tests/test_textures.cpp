// Textures and vertex colours: the shared sampling text (shaders/texture.h: wrap modes, bilinear
// taps and weights) on tiny generated textures, the glTF and OBJ/MTL loaders on small files written
// here, the GPU layout of scenes with and without UVs, and GPU images of textured scenes (generated
// and shared) against the CPU reference with the bars of issue 3.
#include "renderer/gpu_layout.h"
#include "renderer/image.h"
#include "renderer/start_view.h"
#include "scenes/textures.h"
#include "shaders/texture.h"
#include "test_gpu_common.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace raypack::test {
namespace {

namespace fs = std::filesystem;

class TempDir {
public:
    TempDir() {
        path_ = fs::temp_directory_path() /
                ("raypack-textures-" + std::to_string(getpid()) + "-" + std::to_string(counter_++));
        fs::create_directories(path_);
    }
    ~TempDir() { fs::remove_all(path_); }
    fs::path operator/(const std::string& name) const { return path_ / name; }

private:
    fs::path path_;
    static inline int counter_ = 0;
};

void writeFile(const fs::path& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

constexpr uint32_t kRed = 0xFF0000FFu, kGreen = 0xFF00FF00u, kBlue = 0xFFFF0000u, kWhite = 0xFFFFFFFFu;

// ---- Sampling (shaders/texture.h) -------------------------------------------------------------

TEST(TextureSampling, WrapIndexRepeatClampMirror) {
    using gpu::wrapIndex;
    // Repeat over 4 texels: -1 is the last, 4 the first.
    EXPECT_EQ(wrapIndex(-1, 4, gpu::kWrapRepeat), 3);
    EXPECT_EQ(wrapIndex(0, 4, gpu::kWrapRepeat), 0);
    EXPECT_EQ(wrapIndex(3, 4, gpu::kWrapRepeat), 3);
    EXPECT_EQ(wrapIndex(4, 4, gpu::kWrapRepeat), 0);
    // Clamp to the edge texels.
    EXPECT_EQ(wrapIndex(-5, 4, gpu::kWrapClamp), 0);
    EXPECT_EQ(wrapIndex(9, 4, gpu::kWrapClamp), 3);
    // Mirror: 0 1 2 3 3 2 1 0 | 0 1 ...; -1 mirrors to 0.
    const int expected[10] = {0, 0, 1, 2, 3, 3, 2, 1, 0, 0};
    for (int i = -1; i <= 8; ++i) EXPECT_EQ(wrapIndex(i, 4, gpu::kWrapMirror), expected[i + 1]) << "i " << i;
}

TEST(TextureSampling, ReduceCoordinate) {
    EXPECT_FLOAT_EQ(gpu::reduceCoordinate(2.25f, gpu::kWrapRepeat), 0.25f);
    EXPECT_FLOAT_EQ(gpu::reduceCoordinate(-0.25f, gpu::kWrapRepeat), 0.75f);
    EXPECT_FLOAT_EQ(gpu::reduceCoordinate(3.25f, gpu::kWrapMirror), 1.25f);
    EXPECT_FLOAT_EQ(gpu::reduceCoordinate(-0.25f, gpu::kWrapMirror), 1.75f);
    EXPECT_FLOAT_EQ(gpu::reduceCoordinate(7.0f, gpu::kWrapClamp), 2.0f);
    EXPECT_FLOAT_EQ(gpu::reduceCoordinate(-7.0f, gpu::kWrapClamp), -1.0f);
}

// A 2x2 texture, red green / blue white, with the descriptor the layout would give it.
Texture tinyTexture(TextureWrap wrap) {
    Texture t;
    t.name = "tiny";
    t.width = 2;
    t.height = 2;
    t.wrapU = t.wrapV = wrap;
    t.texels = {kRed, kGreen, kBlue, kWhite};
    return t;
}

glm::vec4 sample(const Texture& t, glm::vec2 uv) {
    const gpu::BilinearTaps taps = gpu::bilinearTaps(gpuTexture(t, 0), uv);
    return gpu::bilinearBlend(t.texels[taps.texel.x], t.texels[taps.texel.y], t.texels[taps.texel.z],
                              t.texels[taps.texel.w], taps.weight);
}

TEST(TextureSampling, TexelCentresGiveTheTexel) {
    const Texture t = tinyTexture(TextureWrap::Repeat);
    EXPECT_EQ(gpu::packRgba8(sample(t, {0.25f, 0.25f})), kRed);
    EXPECT_EQ(gpu::packRgba8(sample(t, {0.75f, 0.25f})), kGreen);
    EXPECT_EQ(gpu::packRgba8(sample(t, {0.25f, 0.75f})), kBlue);
    EXPECT_EQ(gpu::packRgba8(sample(t, {0.75f, 0.75f})), kWhite);
}

TEST(TextureSampling, BilinearWeights) {
    const Texture t = tinyTexture(TextureWrap::Clamp);
    // The image's centre is the four texels' average.
    const glm::vec4 centre = sample(t, {0.5f, 0.5f});
    EXPECT_FLOAT_EQ(centre.x, 0.5f);  // red + white
    EXPECT_FLOAT_EQ(centre.y, 0.5f);  // green + white
    EXPECT_FLOAT_EQ(centre.z, 0.5f);  // blue + white
    // A quarter of the way from the red texel's centre to the green one's: 3/4 red, 1/4 green.
    const gpu::BilinearTaps taps = gpu::bilinearTaps(gpuTexture(t, 0), {0.375f, 0.25f});
    EXPECT_EQ(taps.texel, glm::uvec4(0, 1, 2, 3));
    EXPECT_FLOAT_EQ(taps.weight.x, 0.25f);
    EXPECT_FLOAT_EQ(taps.weight.y, 0.0f);
    const glm::vec4 c = sample(t, {0.375f, 0.25f});
    EXPECT_FLOAT_EQ(c.x, 0.75f);
    EXPECT_FLOAT_EQ(c.y, 0.25f);
    // The descriptor's offset moves every tap.
    EXPECT_EQ(gpu::bilinearTaps(gpuTexture(t, 100), {0.375f, 0.25f}).texel, glm::uvec4(100, 101, 102, 103));
}

TEST(TextureSampling, WrapModesAtTheBorder) {
    // At u = 0 (the left edge, half a texel left of the first centre) repeat blends with the
    // opposite column, clamp keeps the edge texel, mirror reflects it.
    const glm::vec2 edge(0.0f, 0.25f);
    EXPECT_FLOAT_EQ(sample(tinyTexture(TextureWrap::Repeat), edge).x, 0.5f);  // half red, half green
    EXPECT_FLOAT_EQ(sample(tinyTexture(TextureWrap::Clamp), edge).x, 1.0f);
    EXPECT_FLOAT_EQ(sample(tinyTexture(TextureWrap::Mirror), edge).x, 1.0f);
    // Repeat has period 1, mirror period 2 (u = 1.25 mirrors to 0.75: green).
    EXPECT_EQ(gpu::packRgba8(sample(tinyTexture(TextureWrap::Repeat), {3.25f, 0.25f})), kRed);
    EXPECT_EQ(gpu::packRgba8(sample(tinyTexture(TextureWrap::Mirror), {1.25f, 0.25f})), kGreen);
    EXPECT_EQ(gpu::packRgba8(sample(tinyTexture(TextureWrap::Mirror), {-0.25f, 0.25f})), kRed);
    EXPECT_EQ(gpu::packRgba8(sample(tinyTexture(TextureWrap::Clamp), {5.0f, -3.0f})), kGreen);
    // Mixed: u clamps, v repeats.
    Texture mixed = tinyTexture(TextureWrap::Clamp);
    mixed.wrapV = TextureWrap::Repeat;
    EXPECT_EQ(gpu::packRgba8(sample(mixed, {-2.0f, 1.75f})), kBlue);
}

TEST(TextureSampling, InterpolationAndSurfaceColour) {
    const glm::vec2 uv = gpu::interpolateUv({0, 0}, {1, 0}, {0, 1}, {0.25f, 0.5f});
    EXPECT_FLOAT_EQ(uv.x, 0.25f);
    EXPECT_FLOAT_EQ(uv.y, 0.5f);
    const glm::vec3 c = gpu::interpolateColor(kRed, kGreen, kBlue, {0.25f, 0.5f});
    EXPECT_FLOAT_EQ(c.x, 0.25f);
    EXPECT_FLOAT_EQ(c.y, 0.25f);
    EXPECT_FLOAT_EQ(c.z, 0.5f);
    const glm::vec3 s = gpu::surfaceColor({0.5f, 1.0f, 1.0f}, {1.0f, 0.5f, 1.0f, 0.0f}, {1.0f, 1.0f, 0.25f});
    EXPECT_EQ(s, glm::vec3(0.5f, 0.5f, 0.25f));
}

TEST(TextureSampling, MipLevelsAndLevelOfDetail) {
    // A 4x2 texture: levels 4x2, 2x1, 1x1, each texel the rounded mean of the 2x2 above it.
    Texture t;
    t.width = 4;
    t.height = 2;
    t.texels = {kRed, kRed, kGreen, kGreen, kRed, kRed, kBlue, kBlue};
    buildMipLevels(t);
    EXPECT_EQ(t.levels, 3u);
    ASSERT_EQ(t.texels.size(), Texture::texelCount(4, 2, 3));
    ASSERT_EQ(t.texels.size(), 11u);
    EXPECT_EQ(t.texels[8], kRed);
    EXPECT_EQ(t.texels[9], 0xFF808000u);   // half green, half blue: 127.5 rounds to 128
    EXPECT_EQ(t.texels[10], 0xFF404080u);  // the 2x1 level's mean: red 510 / 4 -> 128, green 256 / 4 -> 64
    const gpu::GpuTexture d = gpuTexture(t, 0);
    EXPECT_EQ(gpu::textureLevels(d), 3u);
    const gpu::GpuTexture level2 = gpu::textureLevel(d, 2);
    EXPECT_EQ(level2.offset, 10u);
    EXPECT_EQ(level2.width, 1u);
    EXPECT_EQ(level2.height, 1u);
    // A unit square with UVs over the whole 4x2 texture, seen head on: 2.83 texels a unit; a
    // footprint of 1/2.83 units is level 0, eight times that level 3 (clamped to 2).
    const glm::vec3 v0(0, 0, 0), v1(1, 0, 0), v2(0, 1, 0);
    const glm::vec2 uv0(0, 0), uv1(1, 0), uv2(0, 1);
    const float perUnit = std::sqrt(8.0f);
    EXPECT_NEAR(gpu::textureLod(d, v0, v1, v2, uv0, uv1, uv2, {0, 0, -1}, 1.0f, 1.0f / perUnit), 0.0f, 1e-5f);
    EXPECT_NEAR(gpu::textureLod(d, v0, v1, v2, uv0, uv1, uv2, {0, 0, -1}, 2.0f, 1.0f / perUnit), 1.0f, 1e-5f);
    EXPECT_NEAR(gpu::textureLod(d, v0, v1, v2, uv0, uv1, uv2, {0, 0, -1}, 8.0f, 1.0f / perUnit), 2.0f, 1e-5f);
    // Slanted 60 degrees: the footprint doubles.
    EXPECT_NEAR(gpu::textureLod(d, v0, v1, v2, uv0, uv1, uv2, {0, std::sqrt(3.0f), -1}, 1.0f, 1.0f / perUnit), 1.0f,
                1e-5f);
}

TEST(TextureImages, DecodesPngAndNamesBadImages) {
    TempDir dir;
    writePng((dir / "t.png").string(), 2, 2, {kRed, kGreen, kBlue, kWhite});
    const Texture t = loadTextureImage(dir / "scene.obj", "t.png");
    EXPECT_EQ(t.width, 2u);
    EXPECT_EQ(t.height, 2u);
    // Level 0 as decoded, then the 1x1 level: the mean of the four.
    EXPECT_EQ(t.levels, 2u);
    EXPECT_TRUE(t.texels == (std::vector<uint32_t>{kRed, kGreen, kBlue, kWhite, 0xFF808080u}));
    writeFile(dir / "bad.png", "not an image");
    try {
        loadTextureImage(dir / "scene.obj", "bad.png");
        FAIL() << "no error for a file that is no image";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("scene.obj: texture bad.png: not an image"), std::string::npos)
            << e.what();
    }
    try {
        loadTextureImage(dir / "scene.obj", "missing.png");
        FAIL() << "no error for a missing file";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("texture missing.png"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("no such file"), std::string::npos) << e.what();
    }
}

// ---- Loaders on generated files ------------------------------------------------------------------

// A unit quad in z = 0 seen from +z, UV (0, 0) at its top-left corner, as glTF: positions,
// UVs and 16-bit indices in one .bin.
void writeQuadBin(const fs::path& path) {
    const float positions[12] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
    const float uvs[8] = {0, 1, 1, 1, 1, 0, 0, 0};
    const uint16_t indices[6] = {0, 1, 2, 0, 2, 3};
    std::string bytes(sizeof positions + sizeof uvs + sizeof indices, '\0');
    std::memcpy(bytes.data(), positions, sizeof positions);
    std::memcpy(bytes.data() + 48, uvs, sizeof uvs);
    std::memcpy(bytes.data() + 80, indices, sizeof indices);
    writeFile(path, bytes);
}

// `material` is the JSON of materials[0]; `extra` more top-level members (with a leading comma).
std::string quadGltf(const std::string& material, const std::string& extra, bool withUvs = true) {
    return std::string(R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1]}],
  "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 5]}],
  "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1}}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0)") +
           (withUvs ? R"(, "TEXCOORD_0": 1)" : "") + R"(}, "indices": 2, "material": 0}]}],
  "materials": [)" +
           material + R"(],
  "buffers": [{"uri": "quad.bin", "byteLength": 92}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                  {"buffer": 0, "byteOffset": 48, "byteLength": 32},
                  {"buffer": 0, "byteOffset": 80, "byteLength": 12}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                 "min": [-1, -1, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}])" +
           extra + "}";
}

const char* kTexturedMaterial =
    R"({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 1, 1, 1],
        "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform":
            {"offset": [0.5, 0], "scale": [2, 1]}}}}})";
const char* kTextureMembers =
    R"(, "textures": [{"source": 0, "sampler": 0}], "images": [{"uri": "tiny.png"}],
  "samplers": [{"wrapS": 33071, "wrapT": 33648}],
  "extensionsUsed": ["KHR_texture_transform"])";

TEST(TextureLoaders, GltfBaseColorTextureSamplerTransformAndCamera) {
    TempDir dir;
    writeQuadBin(dir / "quad.bin");
    writePng((dir / "tiny.png").string(), 2, 2, {kRed, kGreen, kBlue, kWhite});
    writeFile(dir / "quad.gltf", quadGltf(kTexturedMaterial, kTextureMembers));
    const Scene scene = loadScene(dir / "quad.gltf");
    ASSERT_EQ(scene.textures.size(), 1u);
    EXPECT_EQ(scene.textures[0].width, 2u);
    EXPECT_TRUE(scene.textures[0].texels == (std::vector<uint32_t>{kRed, kGreen, kBlue, kWhite, 0xFF808080u}));
    EXPECT_EQ(scene.textures[0].wrapU, TextureWrap::Clamp);
    EXPECT_EQ(scene.textures[0].wrapV, TextureWrap::Mirror);
    ASSERT_TRUE(scene.hasMaterials());
    EXPECT_EQ(scene.materials[0].texture, 0u);
    EXPECT_EQ(scene.materials[0].diffuse, glm::vec3(0.5f, 1.0f, 1.0f));
    // KHR_texture_transform folded in: u' = 2u + 0.5, v' = v.
    ASSERT_EQ(scene.uvs.size(), scene.positions.size());
    EXPECT_EQ(scene.uvs[0], glm::vec2(0.5f, 1.0f));
    EXPECT_EQ(scene.uvs[1], glm::vec2(2.5f, 1.0f));
    EXPECT_EQ(scene.uvs[2], glm::vec2(2.5f, 0.0f));
    // The file's camera: at (0, 0, 5) looking down -z, fov 0.5 rad.
    ASSERT_TRUE(scene.fileCamera.has_value());
    EXPECT_EQ(scene.fileCamera->eye, glm::vec3(0, 0, 5));
    EXPECT_EQ(scene.fileCamera->at, glm::vec3(0, 0, 4));
    EXPECT_NEAR(scene.fileCamera->fovYDegrees, 28.6479f, 1e-3f);
    EXPECT_EQ(scene.textureBytes(), 20u);  // 2x2 + 1x1 texels
}

TEST(TextureLoaders, GltfWithoutTextureHasNoUvsAndAMissingImageOnlyWarns) {
    TempDir dir;
    writeQuadBin(dir / "quad.bin");
    // TEXCOORD_0 present, but no material samples a texture: no UVs kept.
    writeFile(dir / "plain.gltf", quadGltf(R"({"pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1]}})", ""));
    const Scene plain = loadScene(dir / "plain.gltf");
    EXPECT_FALSE(plain.hasUvs());
    EXPECT_TRUE(plain.textures.empty());
    // The texture's image is missing: the scene loads, untextured.
    writeFile(dir / "missing.gltf", quadGltf(kTexturedMaterial, kTextureMembers));
    const Scene missing = loadScene(dir / "missing.gltf");
    EXPECT_TRUE(missing.textures.empty());
    EXPECT_FALSE(missing.hasUvs());
    EXPECT_EQ(missing.materials[0].texture, kNoTexture);
}

TEST(TextureLoaders, ObjMapKdWithClampAndFlippedV) {
    TempDir dir;
    writePng((dir / "tiny.png").string(), 2, 2, {kRed, kGreen, kBlue, kWhite});
    writeFile(dir / "quad.mtl", "newmtl textured\nKd 1 1 1\nmap_Kd -clamp on tiny.png\nnewmtl plain\nKd 0 1 0\n");
    writeFile(dir / "quad.obj",
              "mtllib quad.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
              "usemtl textured\nf 1/1 2/2 3/3 4/4\nusemtl plain\nf 1 3 4\n");
    const Scene scene = loadScene(dir / "quad.obj");
    ASSERT_EQ(scene.textures.size(), 1u);
    EXPECT_EQ(scene.textures[0].wrapU, TextureWrap::Clamp);
    EXPECT_EQ(scene.materials[0].texture, 0u);
    EXPECT_EQ(scene.materials[1].texture, kNoTexture);
    ASSERT_TRUE(scene.hasUvs());
    ASSERT_EQ(scene.uvs.size(), scene.positions.size());
    // Corner 1/1 has OBJ vt (0, 0): the image's bottom-left, v = 1 top-down.
    EXPECT_EQ(scene.positions[scene.triangles[0].x], glm::vec3(-1, -1, 0));
    EXPECT_EQ(scene.uvs[scene.triangles[0].x], glm::vec2(0.0f, 1.0f));
    EXPECT_EQ(scene.uvs[scene.triangles[0].z], glm::vec2(1.0f, 0.0f));  // vt 3 = (1, 1)
    // The face without UVs gets vertices of its own, at UV (0, 0).
    EXPECT_EQ(scene.triangles.size(), 3u);
    EXPECT_EQ(scene.uvs[scene.triangles[2].x], glm::vec2(0.0f, 0.0f));
}

TEST(TextureLoaders, ObjWithoutMaterialsKeepsNoUvs) {
    // Dabrovic Sponza has UVs and normals but no MTL: nothing samples a texture.
    const Scene sponza = openScene(sharedScene("dabrovic_sponza/sponza.obj"));
    EXPECT_FALSE(sponza.hasUvs());
    EXPECT_TRUE(sponza.textures.empty());
    const GpuLayout layout = makeGpuLayout(sponza, buildBvh(sponza, BvhBuildOptions{}));
    EXPECT_TRUE(layout.uvs.empty());
    EXPECT_TRUE(layout.texels.empty());
    EXPECT_EQ(layout.textureBytes(), 0u);
}

TEST(TextureLoaders, SharedTexturedScenes) {
    const Scene sibenik = openScene(sharedScene("sibenik/sibenik.obj"));
    EXPECT_EQ(sibenik.textures.size(), 3u);  // kamen.png, KAMEN-stup.png, mramor6x6.png
    EXPECT_EQ(sibenik.uvs.size(), sibenik.positions.size());
    const Scene duck = openScene(sharedScene("gltf/Duck/Duck.glb"));
    ASSERT_EQ(duck.textures.size(), 1u);
    EXPECT_GT(duck.textures[0].width, 0u);
    EXPECT_TRUE(duck.fileCamera.has_value());
    const Scene helmet = openScene(sharedScene("gltf/DamagedHelmet/DamagedHelmet.glb"));
    EXPECT_EQ(helmet.textures.size(), 1u);  // only the base colour of its five images
}

// ---- GPU layout and images -----------------------------------------------------------------------

TEST(TextureLayout, GathersUvsColoursAndTexels) {
    Scene scene;
    scene.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    scene.triangles = {{0, 1, 2}};
    scene.uvs = {{0, 0}, {1, 0}, {0, 1}};
    scene.vertexColors = {kRed, kGreen, kBlue};
    scene.textures = {tinyTexture(TextureWrap::Mirror), tinyTexture(TextureWrap::Clamp)};
    scene.materials = {Material{"m", glm::vec3(1.0f), 1u}};
    scene.triangleMaterial = {0};
    const GpuLayout layout = makeGpuLayout(scene, buildBvh(scene, BvhBuildOptions{}));
    ASSERT_EQ(layout.uvs.size(), 1u);
    EXPECT_EQ(layout.uvs[0].uv01, glm::vec4(0, 0, 1, 0));
    EXPECT_EQ(layout.uvs[0].uv2, glm::vec4(0, 1, 0, 0));
    ASSERT_EQ(layout.colors.size(), 1u);
    EXPECT_EQ(layout.colors[0].rgba, glm::uvec4(kRed, kGreen, kBlue, 0u));
    ASSERT_EQ(layout.textures.size(), 2u);
    EXPECT_EQ(layout.textures[1].offset, 4u);
    EXPECT_EQ(layout.textures[0].wrap, gpu::kWrapMirror | (gpu::kWrapMirror << 2u) | (1u << 8u));  // one level
    EXPECT_EQ(layout.texels.size(), 8u);
    uint32_t textureBits;
    std::memcpy(&textureBits, &layout.materials[0].diffuse.w, 4);
    EXPECT_EQ(textureBits, 1u);
    EXPECT_EQ(layout.textureBytes(), 2 * sizeof(gpu::GpuTexture) + 8 * sizeof(uint32_t));
}

void expectGpuMatchesCpu(const Scene& scene, const Camera& camera, const std::string& what) {
    const Bvh bvh = buildBvh(scene, BvhBuildOptions{});
    GpuTracer tracer(validatedContext());
    tracer.upload(scene, bvh);
    RenderSettings settings;
    settings.width = 400;
    settings.height = 300;
    settings.camera = camera;
    const FrameRequest request{true, true, false};
    const Frame gpu = tracer.render(settings, request);
    const Frame cpu = renderCpu(scene, bvh, settings, request);
    expectMatchesReference(gpu, cpu, what);
    expectNoValidationMessages();
}

TEST(TextureImages, GeneratedTexturedQuadGpuMatchesCpu) {
    TempDir dir;
    writeQuadBin(dir / "quad.bin");
    writePng((dir / "tiny.png").string(), 2, 2, {kRed, kGreen, kBlue, kWhite});
    writeFile(dir / "quad.gltf", quadGltf(kTexturedMaterial, kTextureMembers));
    const Scene scene = loadScene(dir / "quad.gltf");
    ASSERT_EQ(scene.textures.size(), 1u);
    // Close enough that each texel covers many pixels: the bilinear ramps and both wrap modes show.
    Camera camera;
    camera.eye = {0.0f, 0.0f, 2.0f};
    camera.at = {0.0f, 0.0f, 0.0f};
    const Frame cpu = renderCpu(scene, buildBvh(scene, BvhBuildOptions{}), [&] {
        RenderSettings s;
        s.width = 64;
        s.height = 64;
        s.camera = camera;
        return s;
    }());
    // Textured: the image is not one flat grey (an untextured quad would be); with u' = 2u + 0.5
    // clamped, most of the quad shows the texture's right column, green above and white below.
    size_t greenish = 0, whitish = 0;
    for (uint32_t p : cpu.rgba) {
        const glm::vec4 c = gpu::unpackRgba8(p);
        if (c.y > c.x + 0.2f && c.y > c.z + 0.2f) ++greenish;
        if (c.y > c.x + 0.2f && std::abs(c.y - c.z) < 0.05f) ++whitish;  // (0.5, 1, 1) x white
    }
    EXPECT_GT(greenish, 200u);
    EXPECT_GT(whitish, 200u);
    expectGpuMatchesCpu(scene, camera, "generated textured quad");
}

TEST(TextureImages, VertexColouredPlyGpuMatchesCpu) {
    TempDir dir;
    writeFile(dir / "vc.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
              "element face 1\nproperty list uchar uint vertex_index\nend_header\n"
              "-1 -1 0 255 0 0\n1 -1 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n");
    const Scene scene = loadScene(dir / "vc.ply");
    ASSERT_TRUE(scene.hasVertexColors());
    Camera camera;
    camera.eye = {0.0f, 0.0f, 3.0f};
    expectGpuMatchesCpu(scene, camera, "vertex-coloured triangle");
}

TEST(TextureImages, SharedTexturedScenesGpuMatchCpu) {
    for (const char* file : {"gltf/Duck/Duck.glb", "gltf/BoxTextured/BoxTextured.glb", "gltf/Avocado/glTF/Avocado.gltf",
                             "gltf/DamagedHelmet/DamagedHelmet.glb"}) {
        const Scene scene = openScene(sharedScene(file));
        ASSERT_FALSE(scene.textures.empty()) << file;
        expectGpuMatchesCpu(scene, frameScene(scene.bounds()), file);
    }
    // Sibenik from its start view, inside the nave.
    const Scene sibenik = openScene(sharedScene("sibenik/sibenik.obj"));
    expectGpuMatchesCpu(sibenik, startCamera(sibenik, buildBvh(sibenik, BvhBuildOptions{})), "sibenik.obj");
}

}  // namespace
}  // namespace raypack::test
