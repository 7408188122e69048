#pragma once
// Procedural scenes for tests, scaling runs and raypack's own default scene. All deterministic:
// the same arguments give the same scene, bit for bit, on every run (no time-based seeds).
// Triangle counts that do not fit the requested shape exactly are rounded down ("at most N").
#include "renderer/scene.h"

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

// raypack's default scene: a checkered ground, a sphere flake and a few coloured primitives, with
// normals and a handful of materials (about 50k triangles), framed well by frameScene(). Every
// material colour is a distinct multiple of 1/255, so that savePly + loadScene reproduce it
// exactly: scenes/data/default.ply is this scene.
Scene makeDefaultScene();

}  // namespace raypack
