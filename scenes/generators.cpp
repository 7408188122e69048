// Procedural scenes. Everything here is a pure function of its arguments (integer hashes, no
// clocks, no std::random_device), so tests and committed files can rely on exact reproduction.
#include "scenes/generators.h"

#include "renderer/error.h"
#include "scenes/load.h"
#include "shaders/texture.h"

#include <tbb/parallel_sort.h>
#include <glm/gtc/constants.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace raypack {
namespace {

// Appends vertices, triangles and materials to a Scene; a material is created the first time it is
// used, so material indices follow the order of first use, as the PLY loader rebuilds them.
class SceneBuilder {
public:
    explicit SceneBuilder(std::string source) { scene_.source = std::move(source); }

    uint32_t vertex(const glm::vec3& position, const glm::vec3& normal) {
        scene_.positions.push_back(position);
        scene_.normals.push_back(normal);
        return uint32_t(scene_.positions.size() - 1);
    }
    // Selects the material of the triangles that follow, creating it when new. Colours are bytes so
    // that they survive a PLY round trip exactly.
    void material(const char* name, uint8_t r, uint8_t g, uint8_t b) {
        for (uint32_t m = 0; m < scene_.materials.size(); ++m)
            if (scene_.materials[m].name == name) {
                current_ = m;
                return;
            }
        pendingName_ = name;
        pendingColour_ = glm::vec3(colourFromByte(r), colourFromByte(g), colourFromByte(b));
        current_ = kPending;
    }
    void triangle(uint32_t a, uint32_t b, uint32_t c) {
        if (current_ == kPending) {
            scene_.materials.push_back(Material{pendingName_, pendingColour_});
            current_ = uint32_t(scene_.materials.size() - 1);
        }
        scene_.triangles.emplace_back(a, b, c);
        scene_.triangleMaterial.push_back(current_);
    }
    Scene& scene() { return scene_; }

private:
    static constexpr uint32_t kPending = std::numeric_limits<uint32_t>::max();
    Scene scene_;
    uint32_t current_ = kPending;
    std::string pendingName_ = "default";
    glm::vec3 pendingColour_{gpu::kDefaultDiffuse};
};

// ---- Terrain: fractal value noise (Perlin 1985's sum of octaves, with value instead of gradient
// noise), from an integer hash so that it is exact and portable.

float hashToUnit(int32_t x, int32_t y) {
    uint32_t h = uint32_t(x) * 374761393u + uint32_t(y) * 668265263u;
    h = (h ^ (h >> 13)) * 1274126177u;
    h ^= h >> 16;
    return float(h & 0xFFFFFFu) / float(0xFFFFFF);
}

float valueNoise(float x, float y) {
    const float fx = std::floor(x), fy = std::floor(y);
    const int32_t ix = int32_t(fx), iy = int32_t(fy);
    const float tx = x - fx, ty = y - fy;
    const float sx = tx * tx * (3.0f - 2.0f * tx), sy = ty * ty * (3.0f - 2.0f * ty);
    const float a = hashToUnit(ix, iy), b = hashToUnit(ix + 1, iy);
    const float c = hashToUnit(ix, iy + 1), d = hashToUnit(ix + 1, iy + 1);
    return glm::mix(glm::mix(a, b, sx), glm::mix(c, d, sx), sy);
}

float terrainHeight(float x, float z) {
    float height = 0.0f, amplitude = 0.5f, frequency = 1.5f;
    for (int octave = 0; octave < 6; ++octave) {
        height += amplitude * (valueNoise(x * frequency + 17.0f, z * frequency + 5.0f) - 0.5f);
        amplitude *= 0.5f;
        frequency *= 2.0f;
    }
    return 0.6f * height;
}

// ---- Spheres and other primitives, appended to a builder with smooth normals.

// UV sphere: `stacks` bands from pole to pole, `slices` around; 2·slices·(stacks-1) triangles.
void addUvSphere(SceneBuilder& builder, const glm::vec3& center, float radius, uint32_t stacks, uint32_t slices) {
    const float pi = glm::pi<float>();
    const uint32_t north = builder.vertex(center + glm::vec3(0, radius, 0), glm::vec3(0, 1, 0));
    std::vector<uint32_t> rings;
    for (uint32_t j = 1; j < stacks; ++j) {
        const float theta = pi * float(j) / float(stacks);
        for (uint32_t k = 0; k < slices; ++k) {
            const float phi = 2.0f * pi * float(k) / float(slices);
            const glm::vec3 n(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
            rings.push_back(builder.vertex(center + radius * n, n));
        }
    }
    const uint32_t south = builder.vertex(center - glm::vec3(0, radius, 0), glm::vec3(0, -1, 0));
    auto ring = [&](uint32_t j, uint32_t k) { return rings[(j - 1) * slices + (k % slices)]; };
    for (uint32_t k = 0; k < slices; ++k) builder.triangle(north, ring(1, k + 1), ring(1, k));
    for (uint32_t j = 1; j + 1 < stacks; ++j)
        for (uint32_t k = 0; k < slices; ++k) {
            builder.triangle(ring(j, k), ring(j, k + 1), ring(j + 1, k + 1));
            builder.triangle(ring(j, k), ring(j + 1, k + 1), ring(j + 1, k));
        }
    for (uint32_t k = 0; k < slices; ++k) builder.triangle(south, ring(stacks - 1, k), ring(stacks - 1, k + 1));
}

uint32_t uvSphereTriangles(uint32_t stacks) { return 4 * stacks * (stacks - 1); }  // slices = 2·stacks

// An orthonormal pair perpendicular to `w`.
void basisAround(const glm::vec3& w, glm::vec3& u, glm::vec3& v) {
    const glm::vec3 helper = std::abs(w.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
    u = glm::normalize(glm::cross(helper, w));
    v = glm::cross(w, u);
}

struct FlakeLevelStyle {
    const char* name;
    uint8_t r, g, b;
};
constexpr FlakeLevelStyle kFlakeStyles[] = {
    {"flake_level0", 210, 210, 220}, {"flake_level1", 230, 150, 60}, {"flake_level2", 80, 160, 230},
    {"flake_level3", 120, 200, 110}, {"flake_level4", 220, 90, 150}, {"flake_level5", 240, 220, 90},
    {"flake_level6", 160, 120, 220},
};

// Haines' sphere flake: nine children of a third the radius, touching their parent: six around the
// parent's equator (relative to the direction it grew in) and three above it.
void addFlake(SceneBuilder& builder, const glm::vec3& center, float radius, const glm::vec3& up, uint32_t level,
              uint32_t maxLevel, const std::vector<uint32_t>& stacksPerLevel) {
    const FlakeLevelStyle& style = kFlakeStyles[level % std::size(kFlakeStyles)];
    builder.material(style.name, style.r, style.g, style.b);
    addUvSphere(builder, center, radius, stacksPerLevel[level], 2 * stacksPerLevel[level]);
    if (level == maxLevel) return;
    glm::vec3 u, v;
    basisAround(up, u, v);
    const float childRadius = radius / 3.0f;
    const float distance = radius + childRadius;
    const float pi = glm::pi<float>();
    for (int k = 0; k < 9; ++k) {
        const bool upper = k >= 6;
        const float azimuth = upper ? pi / 6.0f + float(k - 6) * 2.0f * pi / 3.0f : float(k) * pi / 3.0f;
        const float elevation = upper ? 50.0f * pi / 180.0f : 0.0f;
        const glm::vec3 direction = glm::normalize(
            std::cos(elevation) * (std::cos(azimuth) * u + std::sin(azimuth) * v) + std::sin(elevation) * up);
        addFlake(builder, center + distance * direction, childRadius, direction, level + 1, maxLevel, stacksPerLevel);
    }
}

uint64_t flakeSphereCount(uint32_t depth) {
    uint64_t count = 0, atLevel = 1;
    for (uint32_t d = 0; d <= depth; ++d, atLevel *= 9) count += atLevel;
    return count;
}

void addTorus(SceneBuilder& builder, const glm::vec3& center, float major, float minor, uint32_t around,
              uint32_t tube) {
    const float pi = glm::pi<float>();
    const uint32_t first = uint32_t(builder.scene().positions.size());
    for (uint32_t i = 0; i < around; ++i) {
        const float a = 2.0f * pi * float(i) / float(around);
        const glm::vec3 radial(std::cos(a), 0.0f, std::sin(a));
        for (uint32_t j = 0; j < tube; ++j) {
            const float b = 2.0f * pi * float(j) / float(tube);
            const glm::vec3 n = std::cos(b) * radial + std::sin(b) * glm::vec3(0, 1, 0);
            builder.vertex(center + major * radial + minor * n, n);
        }
    }
    auto at = [&](uint32_t i, uint32_t j) { return first + (i % around) * tube + (j % tube); };
    for (uint32_t i = 0; i < around; ++i)
        for (uint32_t j = 0; j < tube; ++j) {
            builder.triangle(at(i, j), at(i + 1, j), at(i + 1, j + 1));
            builder.triangle(at(i, j), at(i + 1, j + 1), at(i, j + 1));
        }
}

// An upright box rotated by `yaw` about +y, flat-shaded (four vertices per face).
void addBox(SceneBuilder& builder, const glm::vec3& center, const glm::vec3& halfSize, float yaw) {
    const glm::vec3 ax(std::cos(yaw), 0, -std::sin(yaw)), ay(0, 1, 0), az(std::sin(yaw), 0, std::cos(yaw));
    const glm::vec3 axes[3] = {ax, ay, az};
    for (int axis = 0; axis < 3; ++axis)
        for (int sign = -1; sign <= 1; sign += 2) {
            const glm::vec3 n = float(sign) * axes[axis];
            const glm::vec3 s = axes[(axis + 1) % 3] * halfSize[(axis + 1) % 3];
            const glm::vec3 t = axes[(axis + 2) % 3] * halfSize[(axis + 2) % 3];
            const glm::vec3 c = center + n * halfSize[axis];
            const uint32_t a = builder.vertex(c - s - t, n), b = builder.vertex(c + s - t, n);
            const uint32_t d = builder.vertex(c + s + t, n), e = builder.vertex(c - s + t, n);
            builder.triangle(a, b, d);
            builder.triangle(a, d, e);
        }
}

// Cylinder (topRadius == bottomRadius) or cone (topRadius == 0) standing on `base`, with smooth
// sides and flat caps.
void addLathe(SceneBuilder& builder, const glm::vec3& base, float bottomRadius, float topRadius, float height,
              uint32_t slices) {
    const float pi = glm::pi<float>();
    const float slope = (bottomRadius - topRadius) / height;  // outward tilt of the side normal
    std::vector<uint32_t> bottom, top;
    for (uint32_t k = 0; k < slices; ++k) {
        const float a = 2.0f * pi * float(k) / float(slices);
        const glm::vec3 radial(std::cos(a), 0, std::sin(a));
        const glm::vec3 n = glm::normalize(radial + glm::vec3(0, slope, 0));
        bottom.push_back(builder.vertex(base + bottomRadius * radial, n));
        top.push_back(builder.vertex(base + glm::vec3(0, height, 0) + topRadius * radial, n));
    }
    for (uint32_t k = 0; k < slices; ++k) {
        const uint32_t k1 = (k + 1) % slices;
        if (topRadius > 0.0f) {
            builder.triangle(bottom[k], top[k], top[k1]);
            builder.triangle(bottom[k], top[k1], bottom[k1]);
        } else {
            builder.triangle(bottom[k], top[k], bottom[k1]);  // a cone: top[k] is the apex
        }
    }
    const uint32_t bottomCenter = builder.vertex(base, glm::vec3(0, -1, 0));
    std::vector<uint32_t> bottomCap;
    for (uint32_t k = 0; k < slices; ++k)
        bottomCap.push_back(builder.vertex(builder.scene().positions[bottom[k]], glm::vec3(0, -1, 0)));
    for (uint32_t k = 0; k < slices; ++k) builder.triangle(bottomCenter, bottomCap[k], bottomCap[(k + 1) % slices]);
    if (topRadius > 0.0f) {
        const uint32_t topCenter = builder.vertex(base + glm::vec3(0, height, 0), glm::vec3(0, 1, 0));
        std::vector<uint32_t> topCap;
        for (uint32_t k = 0; k < slices; ++k)
            topCap.push_back(builder.vertex(builder.scene().positions[top[k]], glm::vec3(0, 1, 0)));
        for (uint32_t k = 0; k < slices; ++k) builder.triangle(topCenter, topCap[(k + 1) % slices], topCap[k]);
    }
}

}  // namespace

Scene makeTerrain(uint32_t targetTriangles) {
    if (targetTriangles < 2)
        throw Error("gen:terrain needs at least 2 triangles, got " + std::to_string(targetTriangles));
    const uint64_t cells = targetTriangles / 2;
    const uint64_t n = std::max<uint64_t>(1, uint64_t(std::sqrt(double(cells))));
    const uint64_t m = cells / n;
    if ((n + 1) * (m + 1) > std::numeric_limits<uint32_t>::max())
        throw Error("gen:terrain: too many vertices for 32-bit indices");
    Scene scene;
    scene.source = "gen:terrain:" + std::to_string(targetTriangles);
    const float cell = 2.0f / float(std::max(n, m));
    const float x0 = -0.5f * cell * float(n), z0 = -0.5f * cell * float(m);
    scene.positions.resize((n + 1) * (m + 1));
    scene.normals.resize(scene.positions.size());
    for (uint64_t j = 0; j <= m; ++j)
        for (uint64_t i = 0; i <= n; ++i) {
            const float x = x0 + cell * float(i), z = z0 + cell * float(j);
            const float h = terrainHeight(x, z);
            // Central differences of the height field give the smooth normal (-dh/dx, 1, -dh/dz).
            const float dx = terrainHeight(x + cell, z) - terrainHeight(x - cell, z);
            const float dz = terrainHeight(x, z + cell) - terrainHeight(x, z - cell);
            scene.positions[j * (n + 1) + i] = glm::vec3(x, h, z);
            scene.normals[j * (n + 1) + i] = glm::normalize(glm::vec3(-dx, 2.0f * cell, -dz));
        }
    scene.triangles.reserve(2 * n * m);
    for (uint64_t j = 0; j < m; ++j)
        for (uint64_t i = 0; i < n; ++i) {
            const uint32_t a = uint32_t(j * (n + 1) + i), b = a + 1;
            const uint32_t c = uint32_t(a + n + 1), d = c + 1;
            scene.triangles.emplace_back(a, c, d);
            scene.triangles.emplace_back(a, d, b);
        }
    return scene;
}

Scene makeSphereFlake(uint32_t targetTriangles) {
    if (targetTriangles < uvSphereTriangles(2))
        throw Error("gen:sphereflake needs at least 8 triangles, got " + std::to_string(targetTriangles));
    // The deepest flake whose spheres still get a recognisable tessellation (6 stacks, 120
    // triangles), then the finest tessellation that keeps the total within the target.
    uint32_t depth = 0;
    while (depth < 6 && targetTriangles / flakeSphereCount(depth + 1) >= uvSphereTriangles(6)) ++depth;
    const uint64_t perSphere = targetTriangles / flakeSphereCount(depth);
    uint32_t stacks = 2;
    while (uvSphereTriangles(stacks + 1) <= perSphere) ++stacks;
    SceneBuilder builder("gen:sphereflake:" + std::to_string(targetTriangles));
    addFlake(builder, glm::vec3(0.0f), 1.0f, glm::vec3(0, 1, 0), 0, depth, std::vector<uint32_t>(depth + 1, stacks));
    return std::move(builder.scene());
}

namespace {

Scene subdivideOnce(const Scene& in) {
    const size_t triangleCount = in.triangles.size();
    // Each triangle edge, keyed by its sorted end points, so that the two triangles of an edge get
    // the same midpoint vertex. Sorting (not hashing) keeps 10M-edge levels fast and compact.
    struct Edge {
        uint64_t key;
        uint32_t slot;  // 3 * triangle + edge (0: v0-v1, 1: v1-v2, 2: v2-v0)
    };
    std::vector<Edge> edges(3 * triangleCount);
    for (size_t t = 0; t < triangleCount; ++t)
        for (int e = 0; e < 3; ++e) {
            const uint32_t a = in.triangles[t][e], b = in.triangles[t][(e + 1) % 3];
            edges[3 * t + size_t(e)] = {(uint64_t(std::min(a, b)) << 32) | std::max(a, b), uint32_t(3 * t + size_t(e))};
        }
    tbb::parallel_sort(edges.begin(), edges.end(), [](const Edge& x, const Edge& y) {
        return x.key < y.key || (x.key == y.key && x.slot < y.slot);
    });
    size_t uniqueEdges = 0;
    for (size_t i = 0; i < edges.size(); ++i)
        if (i == 0 || edges[i].key != edges[i - 1].key) ++uniqueEdges;
    if (in.positions.size() + uniqueEdges > std::numeric_limits<uint32_t>::max())
        throw Error("subdivision of " + in.source + " would need more than 2^32 - 1 vertices");

    Scene out;
    out.materials = in.materials;
    out.textures = in.textures;
    out.fileCamera = in.fileCamera;
    out.uvs = in.uvs;
    out.vertexColors = in.vertexColors;
    out.positions = in.positions;
    out.positions.reserve(in.positions.size() + uniqueEdges);
    if (in.hasNormals()) {
        out.normals = in.normals;
        out.normals.reserve(out.positions.capacity());
    }
    std::vector<uint32_t> midpoint(3 * triangleCount);
    for (size_t i = 0; i < edges.size(); ++i) {
        if (i == 0 || edges[i].key != edges[i - 1].key) {
            const uint32_t a = uint32_t(edges[i].key >> 32), b = uint32_t(edges[i].key);
            out.positions.push_back(0.5f * (in.positions[a] + in.positions[b]));
            if (in.hasNormals()) {
                const glm::vec3 sum = in.normals[a] + in.normals[b];
                const float length = glm::length(sum);
                out.normals.push_back(length > 0.0f ? sum / length : in.normals[a]);
            }
            // The midpoint's UV and colour are the ends' average, what the unsplit triangle gave it.
            if (in.hasUvs()) out.uvs.push_back(0.5f * (in.uvs[a] + in.uvs[b]));
            if (in.hasVertexColors())
                out.vertexColors.push_back(gpu::packRgba8(
                    0.5f * (gpu::unpackRgba8(in.vertexColors[a]) + gpu::unpackRgba8(in.vertexColors[b]))));
        }
        midpoint[edges[i].slot] = uint32_t(out.positions.size() - 1);
    }
    out.triangles.resize(4 * triangleCount);
    for (size_t t = 0; t < triangleCount; ++t) {
        const glm::uvec3 v = in.triangles[t];
        const uint32_t ab = midpoint[3 * t], bc = midpoint[3 * t + 1], ca = midpoint[3 * t + 2];
        out.triangles[4 * t + 0] = {v[0], ab, ca};
        out.triangles[4 * t + 1] = {ab, v[1], bc};
        out.triangles[4 * t + 2] = {ca, bc, v[2]};
        out.triangles[4 * t + 3] = {ab, bc, ca};
    }
    if (in.hasMaterials()) {
        out.triangleMaterial.resize(4 * triangleCount);
        for (size_t t = 0; t < triangleCount; ++t)
            std::fill_n(out.triangleMaterial.begin() + ptrdiff_t(4 * t), 4, in.triangleMaterial[t]);
    }
    return out;
}

}  // namespace

Scene subdivide(const Scene& scene, uint32_t levels) {
    uint64_t triangles = scene.triangles.size();
    for (uint32_t l = 0; l < levels; ++l) {
        triangles *= 4;
        if (triangles > std::numeric_limits<uint32_t>::max())
            throw Error("subdiv:" + std::to_string(levels) + ": " + scene.source +
                        " would have more than 2^32 - 1 triangles");
    }
    Scene result = scene;
    for (uint32_t l = 0; l < levels; ++l) result = subdivideOnce(result);
    result.source = "subdiv:" + std::to_string(levels) + ":" + scene.source;
    return result;
}

Scene makeDeepScene(uint32_t triangles) {
    if (triangles < 1 || triangles > kDeepSceneMaxTriangles)
        throw Error("gen:deep:" + std::to_string(triangles) + ": the count must be between 1 and " +
                    std::to_string(kDeepSceneMaxTriangles));
    // Triangle i spans the corner of the cube [0, s_i]^3, so every box holds all smaller ones. With
    // n triangles left, splitting off the largest costs C_trav + 1 + (n-1)·q·C_isect (q: the area
    // ratio of the next box to this one); splitting off the k largest costs about C_trav + k +
    // (n-k)·q^k. The first wins for every k when q <= 1/n, which is what the shrink below keeps.
    // Extents go from 1e4 down to about 1e-35 at the maximum count, within float's normal range;
    // the builder measures areas in double.
    Scene scene;
    scene.source = "gen:deep:" + std::to_string(triangles);
    double extent = 1.0e4;
    for (uint32_t i = 0; i < triangles; ++i) {
        const float s = float(extent);
        const uint32_t first = uint32_t(scene.positions.size());
        scene.positions.emplace_back(s, 0.0f, 0.0f);
        scene.positions.emplace_back(0.0f, s, 0.0f);
        scene.positions.emplace_back(0.0f, 0.0f, s);
        scene.triangles.emplace_back(first, first + 1, first + 2);
        const uint32_t remaining = triangles - i;
        extent *= std::sqrt(1.0 / double(std::max<uint32_t>(remaining, 4)));
    }
    return scene;
}

Scene makeDefaultScene() {
    SceneBuilder builder("gen:default");
    // Checkered ground, 7 x 7 units at y = 0, 28 x 28 squares.
    const int squares = 28;
    const float size = 7.0f, step = size / float(squares);
    std::vector<uint32_t> grid;
    for (int j = 0; j <= squares; ++j)
        for (int i = 0; i <= squares; ++i)
            grid.push_back(builder.vertex(
                glm::vec3(-0.5f * size + step * float(i), 0.0f, -0.5f * size + step * float(j)), glm::vec3(0, 1, 0)));
    for (int j = 0; j < squares; ++j)
        for (int i = 0; i < squares; ++i) {
            if ((i + j) % 2 == 0)
                builder.material("ground_light", 225, 222, 214);
            else
                builder.material("ground_dark", 96, 100, 110);
            const uint32_t a = grid[size_t(j * (squares + 1) + i)], b = a + 1;
            const uint32_t c = a + uint32_t(squares + 1), d = c + 1;
            builder.triangle(a, c, d);
            builder.triangle(a, d, b);
        }
    // The sphere flake in the middle, resting on the ground, finer tessellation on bigger spheres.
    addFlake(builder, glm::vec3(0.0f, 1.0f, 0.0f), 1.0f, glm::vec3(0, 1, 0), 0, 3, {24, 14, 8, 4});
    builder.material("red_torus", 200, 40, 40);
    addTorus(builder, glm::vec3(-2.3f, 0.22f, 1.7f), 0.55f, 0.22f, 64, 24);
    builder.material("green_box", 60, 170, 80);
    addBox(builder, glm::vec3(2.3f, 0.45f, 1.5f), glm::vec3(0.45f), 0.5f);
    builder.material("gold_cylinder", 230, 180, 50);
    addLathe(builder, glm::vec3(2.2f, 0.0f, -1.9f), 0.4f, 0.4f, 1.3f, 48);
    builder.material("blue_sphere", 50, 90, 200);
    addUvSphere(builder, glm::vec3(-2.2f, 0.55f, -1.8f), 0.55f, 32, 64);
    builder.material("purple_cone", 150, 70, 170);
    addLathe(builder, glm::vec3(0.2f, 0.0f, 2.6f), 0.45f, 0.0f, 1.0f, 48);
    return std::move(builder.scene());
}

}  // namespace raypack

namespace raypack {

Scene makeIcosphere(uint32_t levels) {
    if (levels > 12)
        throw Error("gen:icosphere:" + std::to_string(levels) + ": at most 12 levels (20 * 4^12 triangles)");
    // The icosahedron's 12 vertices are the cyclic permutations of (0, +-1, +-phi); its 20 faces,
    // counter-clockwise seen from outside.
    const float phi = 0.5f * (1.0f + std::sqrt(5.0f));
    Scene base;
    base.positions = {{-1, phi, 0},  {1, phi, 0},  {-1, -phi, 0}, {1, -phi, 0}, {0, -1, phi},  {0, 1, phi},
                      {0, -1, -phi}, {0, 1, -phi}, {phi, 0, -1},  {phi, 0, 1},  {-phi, 0, -1}, {-phi, 0, 1}};
    base.triangles = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                      {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    base.source = "icosahedron";
    // subdivide() shares each edge's midpoint between its two triangles, so the result is closed.
    Scene scene = subdivide(base, levels);
    for (glm::vec3& p : scene.positions) p = glm::normalize(p);
    scene.normals = scene.positions;
    scene.source = "gen:icosphere:" + std::to_string(levels);
    return scene;
}

Camera icosphereCamera() {
    Camera camera;
    camera.eye = glm::vec3(0.0f);
    camera.at = glm::vec3(0.0f, 1.0f, 0.5f * (1.0f + std::sqrt(5.0f)));
    camera.up = glm::vec3(1.0f, 0.0f, 0.0f);
    camera.fovYDegrees = 70.0f;
    return camera;
}

Scene makeLattice(uint32_t cellsX, uint32_t cellsY) {
    const std::string name = "gen:lattice:" + std::to_string(cellsX) + "x" + std::to_string(cellsY);
    if (cellsX == 0 || cellsY == 0) throw Error(name + ": the lattice needs at least one cell each way");
    if (uint64_t(cellsX) * uint64_t(cellsY) > (uint64_t(1) << 30)) throw Error(name + ": more than 2^31 triangles");
    Scene scene;
    scene.source = name;
    const int32_t x0 = int32_t(cellsX / 2), y0 = int32_t(cellsY / 2);
    scene.positions.reserve(size_t(cellsX + 1) * (cellsY + 1));
    for (uint32_t j = 0; j <= cellsY; ++j)
        for (uint32_t i = 0; i <= cellsX; ++i)
            scene.positions.emplace_back(float(int32_t(i) - x0), float(int32_t(j) - y0), 0.0f);
    scene.normals.assign(scene.positions.size(), glm::vec3(0.0f, 0.0f, 1.0f));
    scene.triangles.reserve(size_t(2) * cellsX * cellsY);
    const auto index = [&](uint32_t i, uint32_t j) { return j * (cellsX + 1) + i; };
    for (uint32_t j = 0; j < cellsY; ++j)
        for (uint32_t i = 0; i < cellsX; ++i) {
            const uint32_t a = index(i, j), b = index(i + 1, j), c = index(i + 1, j + 1), d = index(i, j + 1);
            scene.triangles.emplace_back(a, b, c);  // counter-clockwise seen from +z
            scene.triangles.emplace_back(a, c, d);
        }
    return scene;
}

glm::uvec2 latticeCellsFor(uint32_t width, uint32_t height) {
    // latticeCamera sees x in [-1/4 - width/4, -1/4 + width/4] at z = 0 (and y alike): a lattice
    // of half-extent ceil(width / 4) + 1 holds that with a cell to spare.
    return {2 * ((width + 3) / 4 + 1), 2 * ((height + 3) / 4 + 1)};
}

Camera latticeCamera(uint32_t width, uint32_t height) {
    if (width == 0 || height == 0) throw Error("lattice camera: the image is empty");
    // With tan(45 degrees) = 1 the pixel (x, y) of shaders/camera.h has u = (2x + 1 - W) / H and
    // v = (H - 2y - 1) / H; at distance H / 4 its ray meets z = 0 at the eye's (x, y) plus
    // ((2x + 1 - W) / 4, (H - 2y - 1) / 4): for even W and H, odd multiples of 1/4, which the eye's
    // offset of -1/4 turns into multiples of 1/2.
    Camera camera;
    camera.eye = glm::vec3(-0.25f, -0.25f, float(height) / 4.0f);
    camera.at = glm::vec3(-0.25f, -0.25f, 0.0f);
    camera.up = glm::vec3(0.0f, 1.0f, 0.0f);
    camera.fovYDegrees = 90.0f;
    return camera;
}

Scene placeScene(Scene scene, float scale, glm::vec3 offset) {
    if (!(std::isfinite(scale) && scale != 0.0f))
        throw Error("place: the scale " + std::to_string(scale) + " must be finite and not zero");
    if (!(std::isfinite(offset.x) && std::isfinite(offset.y) && std::isfinite(offset.z)))
        throw Error("place: the offset must be finite");
    for (glm::vec3& p : scene.positions) p = scale * p + offset;
    if (scale < 0.0f)
        for (glm::vec3& n : scene.normals) n = -n;
    return scene;
}

Camera placeCamera(const Camera& camera, float scale, glm::vec3 offset) {
    Camera placed = camera;
    placed.eye = scale * camera.eye + offset;
    placed.at = scale * camera.at + offset;
    return placed;
}

}  // namespace raypack
