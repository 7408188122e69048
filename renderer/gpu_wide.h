#pragma once
// The compressed 8-wide tree (Ylitie, Karras and Laine 2017) that the single-ray Vulkan kernel
// traces with RenderSettings::bvhWidth 8 (the tracer gpu-cwbvh): made from the canonical binary
// tree at upload, like the binary layout (renderer/gpu_layout.h). Node format: GpuWideNode in
// shaders/gpu_types.h; decoding: shaders/wide_node.h.
#include "renderer/bvh.h"
#include "renderer/scene.h"
#include "shaders/gpu_types.h"

#include <cstdint>
#include <vector>

namespace raypack {

struct GpuWideTree {
    std::vector<gpu::GpuWideNode> nodes;  // node 0 is the root
    // Leaf order of the wide tree: slot k of the triangle arrays holds file-order triangle order[k]
    // (a permutation of Bvh::primIndices, so that each node's leaf triangles are consecutive). The
    // triangles and their attributes are gathered in this order (writeGpuTriangles).
    std::vector<uint32_t> order;
    uint32_t maxDepth = 0;    // deepest wide node below the root (root = 0): sizes the ray stack
    uint64_t innerSlots = 0;  // child slots holding an inner node, over all nodes
    uint64_t leafSlots = 0;   // child slots holding a leaf (one to three triangles)
};

// Collapses `bvh` into the 8-wide tree. Each wide node takes its binary node's two children and
// then repeatedly replaces the child of the largest surface area that can be opened by its two
// halves, until it has eight or none can be opened: a binary inner node opens into its children; a
// leaf of more than three triangles (the most a wide leaf holds) into two halves of its range,
// boxed from the triangles (clipped to the leaf's box, which a spatial split may have cut). What
// is then left of more than three references becomes an inner child; the rest are leaf slots (a
// binary subtree of at most three references one slot, its leaves merged). The children go into
// slots by direction (GpuWideNode; greedily, the cheapest child-slot pair first), and each box is
// quantized outwards to the node's grid, checked against both readings the kernel makes of it
// (shaders/wide_node.h), the grid made coarser until it contains the box. Large trees are
// collapsed in parallel parts spliced in a fixed order: the same tree on any number of threads.
// Throws raypack::Error when a box cannot be quantized (a node wider than the float range).
GpuWideTree makeGpuWideTree(const Scene& scene, const Bvh& bvh);

}  // namespace raypack
