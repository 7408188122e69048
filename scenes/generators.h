#pragma once
// Procedural scenes for tests, scaling runs and raypack's own default scene. All deterministic:
// the same arguments give the same scene, bit for bit, on every run (no time-based seeds).
// Triangle counts that do not fit the requested shape exactly are rounded down ("at most N").
#include "renderer/camera.h"
#include "renderer/scene.h"

#include <glm/glm.hpp>

#include <cstdint>

namespace raypack {

// A height-field terrain on a square-ish grid: 2·n·m triangles with n·m ≈ targetTriangles / 2,
// smooth per-vertex normals, no materials. Throws raypack::Error below 2 triangles.
Scene makeTerrain(uint32_t targetTriangles);

// Haines' sphere flake (Standard Procedural Databases, 1987): a sphere with nine children of a
// third its radius, recursively, every sphere a UV-tessellated mesh with smooth normals and one
// material per recursion level. Depth and tessellation are chosen to come close to
// targetTriangles without exceeding it. Throws raypack::Error below 8 triangles.
Scene makeSphereFlake(uint32_t targetTriangles);

// Every triangle split into four through its edge midpoints, `levels` times. Midpoints are shared
// between the triangles of an edge, so a closed mesh stays closed; normals are the normalised
// average of the edge's end normals; children keep their parent's material. Triangle t's children
// are 4t .. 4t+3, so triangle order still follows the source file. Throws raypack::Error when the
// result would need more than 2^32 - 1 triangles or vertices.
Scene subdivide(const Scene& scene, uint32_t levels);

// The largest makeDeepScene input whose nesting still fits float's range.
constexpr uint32_t kDeepSceneMaxTriangles = 60;

// `triangles` nested triangles whose SAH tree degenerates into a spine: each triangle's box holds
// all the smaller ones and is far larger than their union, so that the SAH's best split peels off
// one triangle per level (depth about `triangles`). Used to test that the GPU traversal stack is
// sized from the tree instead of being a fixed guess. Throws raypack::Error outside
// 1..kDeepSceneMaxTriangles.
Scene makeDeepScene(uint32_t triangles);

// Closed and adversarial test scenes of issue 15's trade suite (docs/trade.md): scenes every
// primary ray of their camera must hit, so that a ray that misses is a ray that leaked through a
// shared edge or vertex.

// The icosahedron with every triangle split in four `levels` times (20 * 4^levels triangles), its
// vertices pushed onto the unit sphere. Every vertex is stored once and shared by all triangles
// around it, so the mesh is closed: every edge belongs to exactly two triangles. Outward normals,
// counter-clockwise from outside. Throws raypack::Error above 12 levels (past 2^32 triangles).
Scene makeIcosphere(uint32_t levels);

// A flat lattice in the plane z = 0: cellsX x cellsY unit squares, each split along its diagonal
// from (i, j) to (i + 1, j + 1) into two triangles, vertex (i, j) at exactly
// (i - floor(cellsX / 2), j - floor(cellsY / 2), 0): integers, which float holds exactly far beyond
// any lattice. Vertices shared, normals +z. Throws raypack::Error for no cells or more than 2^31
// triangles.
Scene makeLattice(uint32_t cellsX, uint32_t cellsY);

// The cells latticeCamera(width, height) needs: its view at z = 0, a margin of at least one cell on
// every side.
glm::uvec2 latticeCellsFor(uint32_t width, uint32_t height);

// The camera whose primary rays (shaders/camera.h) at width x height (both even) cross the plane
// z = 0 of makeLattice(latticeCellsFor(width, height)) at the points (k / 2, l / 2): a quarter of
// them through a vertex, half through the middle of an axis-parallel edge, a quarter through the
// middle of a diagonal, to within the rounding of the ray's direction (a few ulps). Eye at
// (-1/4, -1/4, height / 4) looking down -z, up +y, a 90-degree vertical field of view: the
// pixel centres then fall 1/2 apart at z = 0, offset by a quarter pitch from the eye's axis.
Camera latticeCamera(uint32_t width, uint32_t height);

// The icosphere's camera: at its centre (the origin), looking towards the first icosahedron vertex
// (0, 1, golden ratio), up +x, 70 degrees vertically. Every primary ray must hit the sphere.
Camera icosphereCamera();

// `scene` scaled by `scale` about the origin, then moved by `offset` (issue 15's "far from the
// origin" and "tiny" variants: spec place:S:X,Y,Z:SCENE). Each coordinate is rounded once to
// float; a power-of-two scale and offsets that keep the coordinates representable (integers below
// 2^24 for the lattice) leave exact positions exact. Topology (which vertices a triangle names) is
// unchanged, so a closed mesh stays closed. Throws raypack::Error for a scale that is zero or not
// finite, or an offset that is not finite.
Scene placeScene(Scene scene, float scale, glm::vec3 offset);
// The camera of a placed scene: eye and look-at point placed alike, same up and field of view.
Camera placeCamera(const Camera& camera, float scale, glm::vec3 offset);

// raypack's default scene: a checkered ground, a sphere flake and a few coloured primitives, with
// normals and a handful of materials (about 50k triangles), framed well by frameScene(). Every
// material colour is a distinct multiple of 1/255, so that savePly + loadScene reproduce it
// exactly: scenes/data/default.ply is this scene.
Scene makeDefaultScene();

}  // namespace raypack
