#version 460
// raypack's tracing kernels: the packet traversal with a shared stack of Gunther, Popov and Seidel
// 2007 as the report describes it (../shared/reference/gpu-packet-traversal-report.txt 2.2, 2.3,
// 3.3-3.5), and the single-ray while-while traversal of Aila and Laine 2009 ("Understanding the
// Efficiency of Ray Traversal on GPUs") on the same nodes, and the hybrid of the two (traceHybrid,
// Benthin et al. 2012). Which kernel, which pass, the packet
// shape (the workgroup size), the statistics variant, the view and the stack sizes are
// specialization constants: the host builds one pipeline per combination from this one module.
//
// Passes (two dispatches, so that each has its own timestamps, T_K primary and T_K shadow):
//   kPassPrimary       primary rays; the hits go to primaryHits for the shadow pass
//   kPassPrimaryShade  primary rays, then shading without shadows
//   kPassShadowShade   shadow rays from the light to each kept hit (report 2.3), then shading
// Intersection, the shadow-ray rule and shading are shaders/intersect.h and shaders/shading.h, the
// text the CPU reference compiles too. Built twice: as is, and with RP_FLOAT64, where the kept
// hit's accurate distance is computed in doubles (accurateHitDistanceF64; HitDistanceMath).
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_EXT_control_flow_attributes : require

#include "bindings.h"
#include "gpu_types.h"
#include "frame_types.h"
#include "intersect.h"
#include "shading.h"
#include "wide_node.h"

// Packet shape PW x PH: one workgroup is one packet covering a PW x PH tile, one invocation a ray.
layout(local_size_x_id = kSpecPacketWidth, local_size_y_id = kSpecPacketHeight, local_size_z = 1) in;
layout(constant_id = kSpecKernel) const uint kKernel = kKernelPacket;
layout(constant_id = kSpecPass) const uint kPass = kPassPrimaryShade;
layout(constant_id = kSpecStatistics) const bool kStatistics = false;  // per-ray N_TR / N_IT counters
layout(constant_id = kSpecView) const uint kView = kViewShaded;
// The packet's shared stack; 1 for the single-ray kernel. Sized by the host from the tree's
// maximal depth (the report's fixed 50 entries overflow on deep trees).
layout(constant_id = kSpecPacketStackEntries) const uint kPacketStackEntries = 64;
// Each ray's own stack in the single-ray kernel; 1 for the packet kernel.
layout(constant_id = kSpecRayStackEntries) const uint kRayStackEntries = 1;
// Whether one packet is exactly one subgroup (decided by the host, GpuTracer): then the vote needs
// neither shared memory nor a barrier. Checked once per packet (kStatusSubgroupMismatch).
layout(constant_id = kSpecPacketIsOneSubgroup) const bool kPacketIsOneSubgroup = false;
// IntersectMode::Fast: Moller-Trumbore and the plain slab test instead of the watertight test, the
// conservative slab test and the accurate hit distance (shaders/intersect.h). A constant, so that
// each pipeline holds one path only and neither pays for the other.
layout(constant_id = kSpecFastIntersect) const bool kFastIntersect = false;
// Which child a shadow ray of the single-ray kernel enters first (ShadowOrder, renderer/settings.h).
layout(constant_id = kSpecShadowOrder) const uint kShadowOrder = kShadowOrderNearest;
// The hybrid kernel's two split rules (traceHybrid, docs/gpu.md): the packet splits into single
// rays when fewer than kHybridMinRays of its active rays want the node it visits (0: never by this
// rule), or, when kHybridVisitRatio is not 0, when its inner-node visits summed over its active
// rays pass kHybridVisitRatio / 100 times the visits those rays wanted.
layout(constant_id = kSpecHybridMinRays) const uint kHybridMinRays = 8;
layout(constant_id = kSpecHybridVisitRatio) const uint kHybridVisitRatio = 0;
// Packets per workgroup, stacked in y, each exactly one subgroup (the hybrid kernel only; 1
// otherwise). An SM holds a limited number of workgroups (32 on the H200), so packets of 32 rays,
// one a workgroup, cap it at 32 warps; several a workgroup lift that. Each has its own part of the
// shared stack (packetStackBase).
layout(constant_id = kSpecPacketsPerGroup) const uint kPacketsPerGroup = 1;
// The single-ray kernel traces the compressed 8-wide tree (GpuWideNode, traceWide) that the host
// uploaded instead of the binary one (RenderSettings::bvhWidth 8).
layout(constant_id = kSpecWideBvh) const bool kWideBvh = false;
// The binary kernels read nodes through the uniform texel buffer nodeTexels instead of the storage
// buffer: on lavapipe 1.14-1.59x the storage loads (medians, every binary kernel), on an H100
// 0.97-1.03x (docs/gpu.md, "Nodes through a texel buffer"), so the host takes it on CPU devices.
layout(constant_id = kSpecTexelNodes) const bool kTexelNodes = false;

layout(push_constant) uniform Params { GpuFrameParams params; };

layout(std430, set = 0, binding = kBindNodes) readonly buffer Nodes { GpuNode nodes[]; };
// The same binding seen as the compressed 8-wide tree's nodes (kWideBvh): a pipeline reads one or the other.
layout(std430, set = 0, binding = kBindNodes) readonly buffer WideNodes { GpuWideNode wideNodes[]; };
// The same nodes as RGBA32F texels, two a node (kTexelNodes). Always bound: the host gives a view of
// the node buffer, cut to the device's maxTexelBufferElements where the texel path is not taken.
layout(set = 0, binding = kBindNodeTexels) uniform samplerBuffer nodeTexels;
layout(std430, set = 0, binding = kBindTriangles) readonly buffer Triangles { GpuTriangle triangles[]; };
layout(std430, set = 0, binding = kBindNormals) readonly buffer Normals { GpuTriangleNormals normals[]; };
layout(std430, set = 0, binding = kBindMaterials) readonly buffer Materials { GpuMaterial materials[]; };
layout(std430, set = 0, binding = kBindPrimaryHits) buffer PrimaryHits { GpuPrimaryHit primaryHits[]; };
layout(std430, set = 0, binding = kBindOutput) writeonly buffer Output { uint outputRgba[]; };
layout(std430, set = 0, binding = kBindHits) writeonly buffer Hits { HitRecord hitRecords[]; };
layout(std430, set = 0, binding = kBindCounters) buffer Counters { RayCounters counters[]; };
layout(std430, set = 0, binding = kBindStatus) buffer Status { uint status; };
// Present only when the scene has UVs and textures (kFrameHasUvs), vertex colours (kFrameHasColors).
layout(std430, set = 0, binding = kBindUvs) readonly buffer Uvs { GpuTriangleUvs uvs[]; };
layout(std430, set = 0, binding = kBindColors) readonly buffer Colors { GpuTriangleColors colors[]; };
layout(std430, set = 0, binding = kBindTextures) readonly buffer Textures { GpuTexture textures[]; };
layout(std430, set = 0, binding = kBindTexels) readonly buffer Texels { uint texels[]; };

// One bilinear lookup in mip level `level` (shaders/texture.h; the CPU's sampleLevel).
vec4 sampleLevel(GpuTexture tex, uint level, vec2 uv) {
    const BilinearTaps taps = bilinearTaps(textureLevel(tex, level), uv);
    return bilinearBlend(texels[taps.texel.x], texels[taps.texel.y], texels[taps.texel.z],
                         texels[taps.texel.w], taps.weight);
}

// (node index, count) of the nodes the packet still has to visit; written by one invocation only.
shared uvec2 sStack[kPacketStackEntries * kPacketsPerGroup];
// Where this invocation's packet's part of sStack starts (kPacketsPerGroup packets a workgroup).
uint packetStackBase = 0u;
// The packet's vote counts across subgroups, four rotating slots (see packetVote).
shared uvec4 sVote[4];

// +inf: the t of a miss (HitRecord). GLSL has no infinity literal; 1.0 / 0.0 folds to +inf.
const float kInfinity = 1.0f / 0.0f;

// fusedBoxTest's absolute slack: 8u of |org/dir| per axis (u = 2^-24).
const float kSlabFusedSlack = 4.76837158203125e-07f;  // 8u = 2^-21

// One ray's state during a traversal.
struct RayQuery {
    TraceRay ray;
    float tmax;      // nearest hit so far (closest hit), or the shadow ray's limit
    uint leafTri;    // nearest triangle in leaf order, kNoHit while none
    uint fileTri;    // the same in file order (ties go to the lower file index: isCloserHit)
    vec2 bary;
    bool inexactT;   // the nearest hit's t is to be recomputed (intersectTriangle, accurateHitDistance)
    bool anyHit;     // shadow ray: stop at the first occluder
    uint skipFile;   // shadow ray: the triangle the shaded point lies on
    bool isActive;   // takes part in the traversal (and in the vote)
    uint nodes;      // N_TR
    uint tests;      // N_IT
    vec3 slabLo;     // fusedBoxTest's offsets for the box's lo and hi planes (makeQuery)
    vec3 slabHi;
};

RayQuery makeQuery(vec3 org, vec3 dir, float tmax, bool anyHit, uint skipFile, bool tracing) {
    RayQuery q;
    q.ray = makeTraceRay(org, dir);
    q.tmax = tmax;
    q.leafTri = kNoHit;
    q.fileTri = kNoHit;
    q.bary = vec2(0.0f);
    q.inexactT = false;
    q.anyHit = anyHit;
    q.skipFile = skipFile;
    q.isActive = tracing;
    q.nodes = 0u;
    q.tests = 0u;
    // -org/dir per axis, moved by the slack towards the near side on the near plane and the far
    // side on the far plane (lo is the near plane where 1/dir > 0).
    const vec3 offset = -org * q.ray.invDir;
    const vec3 slack = kSlabFusedSlack * abs(offset);
    const vec3 loSlack = slack * (2.0f * step(vec3(0.0f), q.ray.invDir) - 1.0f);  // + where lo is near
    q.slabLo = offset - loSlack;
    q.slabHi = offset + loSlack;
    return q;
}

// The binary kernels' slab test: the distances in fused form, t = bound * (1/dir) + (-org/dir), one
// multiply-add a plane where intersectBox (the CPU reference's) subtracts and multiplies; Aila and
// Laine's kernels store the ray the same way. It stays conservative:
//   - the relative part of its rounding is intersectBox's: the reciprocal, a product and a sum (the
//     multiply-add's one rounding, or two if a compiler does not fuse), which kSlabFarWiden covers;
//   - the absolute part, from -org/dir: its product and the offset's sum round by u |org/dir| each,
//     an unfused product once more. 8u |org/dir| (kSlabFusedSlack) per axis is folded into the
//     axis's two offsets in makeQuery, the near plane's distance lowered and the far plane's
//     raised, so that part never narrows the slab;
//   - parallel axes have 1/dir = 0 and offset 0, so t = 0 there as in intersectBox, which then
//     decides them the same way.
// The slack is per axis: one slack for all three axes, from the largest |org/dir|, loosened the
// boxes for the other two and cost 3% on Sibenik (docs/gpu.md, "The slab test in fused form").
// Hits are the reference's; boxes within the slack may be visited where intersectBox would not.
bool fusedBoxTest(RayQuery q, vec3 lo, vec3 hi, out float tEntry) {
    return slabsHit(q.ray, lo, hi, fma(lo, q.ray.invDir, q.slabLo), fma(hi, q.ray.invDir, q.slabHi), q.tmax,
                    kSlabFarWiden, kBoxTmaxWiden, tEntry);
}

// The box and triangle tests of the pipeline's IntersectMode.
bool boxTest(RayQuery q, vec3 lo, vec3 hi, out float tEntry) {
    if (kFastIntersect) return intersectBoxFast(q.ray, lo, hi, q.tmax, tEntry);
    return fusedBoxTest(q, lo, hi, tEntry);
}

bool triangleTest(TraceRay r, vec3 v0, vec3 v1, vec3 v2, float tmax, out float t, out vec2 bary, out bool inexactT) {
    if (kFastIntersect) {
        inexactT = false;  // the fast path keeps the triangle test's t
        return intersectTriangleFast(r, v0, v1, v2, tmax, t, bary);
    }
    return intersectTriangle(r, v0, v1, v2, tmax, t, bary, inexactT);
}

uvec2 nodeEntry(GpuNode n) { return uvec2(floatBitsToUint(n.lo.w), floatBitsToUint(n.hi.w)); }

// Binary node `index`, through the path kTexelNodes picks.
GpuNode loadNode(uint index) {
    if (kTexelNodes) {
        const int texel = int(2u * index);
        return GpuNode(texelFetch(nodeTexels, texel), texelFetch(nodeTexels, texel + 1));
    }
    return nodes[index];
}

// The root entry of an empty scene: a leaf of no triangles. Its box (lo > hi) is no guard, since the
// slab test orders each axis's two distances and so "hits" an inverted box; a kernel that took the
// entry (0, 0) for an inner node would read past the one-node tree (before 2026-12-02 the
// single-ray kernel did, and looped until kMaxTraversalSteps).
bool isEmptyRoot(uvec2 entry) { return entry == uvec2(0u); }

// Tests the `count` triangles from `first` (leaf order). Shadow rays stop at the first occluder
// and then leave the traversal: a ray that has found one stops voting (report 2.3).
void intersectLeaf(inout RayQuery q, uint first, uint count) {
    for (uint i = first; i < first + count; ++i) {
        const GpuTriangle tri = triangles[i];
        const uint file = floatBitsToUint(tri.v0.w);
        if (kStatistics) q.tests += 1u;
        if (q.anyHit && file == q.skipFile) continue;
        float t;
        vec2 bary;
        bool inexactT;
        if (!triangleTest(q.ray, tri.v0.xyz, tri.v1.xyz, tri.v2.xyz, q.tmax, t, bary, inexactT)) continue;
        if (q.anyHit) {
            q.leafTri = i;
            q.fileTri = file;
            q.isActive = false;
            return;
        }
        if (isCloserHit(t, file, q.tmax, q.fileTri)) {
            q.tmax = t;
            q.leafTri = i;
            q.fileTri = file;
            q.bary = bary;
            q.inexactT = inexactT;
        }
    }
}

// The packet's vote over one inner node (report 2.2), as counts of rays: those that want the right
// child first, those that hit either child (the others of them want the left child first), those
// that hit the left and the right child, and (shadow packets) those still active.
struct PacketVote {
    uint rightFirst;
    uint hitting;
    uint hitLeft;
    uint hitRight;
    uint stillActive;
};

// The counts over the packet. Within a subgroup by subgroup operations; across subgroups the per
// subgroup counts (16 bits a field, packets of at most 65535 rays) go through one shared atomic add
// per field and subgroup, so the result is right for any subgroup size, packet size and assignment
// of invocations to subgroups. The shared sums rotate through four slots: the slot of vote k is
// cleared at vote k - 2, after every invocation has read it at vote k - 4 and before any adds to it
// at vote k, so one barrier per vote suffices. `countActive` is a constant at every call.
PacketVote packetVote(bool leftHit, bool rightHit, bool rightFirst, bool isActive, bool countActive,
                      inout uint parity) {
    PacketVote v;
    // A ballot and a bit count per field: on NVIDIA a vote and a population count, measured faster
    // than subgroupAdd (docs/gpu.md).
    const uvec4 left = subgroupBallot(leftHit);
    const uvec4 right = subgroupBallot(rightHit);
    v.rightFirst = subgroupBallotBitCount(subgroupBallot(rightFirst));
    v.hitting = subgroupBallotBitCount(left | right);
    v.hitLeft = subgroupBallotBitCount(left);
    v.hitRight = subgroupBallotBitCount(right);
    v.stillActive = countActive ? subgroupBallotBitCount(subgroupBallot(isActive)) : 0u;
    uvec2 packed = uvec2(v.rightFirst | (v.hitting << 16u), v.hitLeft | (v.hitRight << 16u));
    if (kPacketIsOneSubgroup) {
        // Orders the stack writes of one invocation before the other lanes' later reads.
        subgroupBarrier();
    } else {
        const uint slot = parity & 3u;
        if (subgroupElect()) {
            atomicAdd(sVote[slot].x, packed.x);
            atomicAdd(sVote[slot].y, packed.y);
            if (countActive) atomicAdd(sVote[slot].z, v.stillActive);
        }
        barrier();
        const uvec4 total = sVote[slot];
        if (gl_LocalInvocationIndex == 0u) sVote[(slot + 2u) & 3u] = uvec4(0u);
        parity += 1u;
        packed = total.xy;
        v.stillActive = total.z;
    }
    v.rightFirst = packed.x & 0xFFFFu;
    v.hitting = packed.x >> 16u;
    v.hitLeft = packed.y & 0xFFFFu;
    v.hitRight = packed.y >> 16u;
    return v;
}

// The shared stack's accesses: one invocation writes, every invocation reads after the next vote's
// barrier (a subgroup barrier within one subgroup). Handing popped entries from one reader to the
// others by a broadcast instead was measured slower on the H100 (docs/gpu.md).
// The packet's first stack entry: 0 (a constant) with one packet a workgroup, so that those
// pipelines index the stack as they did before several packets could share a workgroup.
uint stackBase() { return kPacketsPerGroup == 1u ? 0u : packetStackBase; }

void pushEntry(uint slot, uvec2 entry) {
    if (kPacketIsOneSubgroup ? subgroupElect() : gl_LocalInvocationIndex == 0u) sStack[stackBase() + slot] = entry;
}

uvec2 popEntry(uint slot) {
    return sStack[stackBase() + slot];
}

// Packet traversal with a stack in shared memory, shared by the packet (report 2.2, 3.3, 3.4).
// Every invocation of the workgroup runs this loop in lockstep, padding and finished rays included
// (report 3.5): all control flow depends only on packet-uniform values (votes and the stack).
void tracePacket(inout RayQuery q) {
    const GpuNode root = loadNode(0u);
    float entry;
    uvec2 current = nodeEntry(root);
    bool wantCurrent = q.isActive && !isEmptyRoot(current) && boxTest(q, root.lo.xyz, root.hi.xyz, entry);
    q.isActive = wantCurrent;
    uint parity = 0u;
    uint stackSize = 0u;
    // Primary rays stay active to the end; only shadow rays drop out (at their first occluder), so
    // only shadow packets count active rays to stop early.
    // A packet of one subgroup checks that after each leaf (the only place a ray drops out) with
    // one subgroupAny; across subgroups the inner-node vote counts active rays (no extra barrier).
    const bool shadowPacket = kPass == kPassShadowShade;
    const bool countActive = shadowPacket && !kPacketIsOneSubgroup;
    // Slots 0 and 1 start cleared (2 and 3 are cleared by votes 0 and 1), and the barrier orders
    // that before the first adds. A shadow pass restarts here with its own clear.
    if (kPacketIsOneSubgroup) {
        // The host's promise, checked: a packet split across subgroups would vote wrong.
        if (subgroupAdd(1u) != gl_WorkGroupSize.x * gl_WorkGroupSize.y) {
            if (subgroupElect()) atomicOr(status, kStatusSubgroupMismatch);
            return;
        }
    } else {
        if (gl_LocalInvocationIndex == 0u) sVote[0] = sVote[1] = uvec4(0u);
        barrier();
    }
    uint wantedBits = 0u;  // bit s: this ray wanted stack entry s (s < 32; deeper entries: assumed)
    // Whether any ray hits the root: a vote with all fields but "active" empty.
    if (packetVote(false, false, false, q.isActive, true, parity).stillActive == 0u) return;

    // Steps (iterations plus triangles of the leaves visited) are the same for every ray of the
    // packet, so stopping at the budget is uniform, as the votes' barriers need.
    uint steps = 0u;
    while (true) {
        if (++steps > kMaxTraversalSteps) {
            if (gl_LocalInvocationIndex == 0u) atomicOr(status, kStatusTraversalTruncated);
            break;
        }
        bool haveNext = false;  // a sibling to visit right after a leaf, instead of a push + pop
        uvec2 next = uvec2(0u);
        bool wantNext = false;
        if (current.y == 0u) {
            // Inner node: both children in one 64-byte read (siblings are adjacent).
            const GpuNode left = loadNode(current.x);
            const GpuNode right = loadNode(current.x + 1u);
            // A child whose entry distance lies beyond the nearest hit counts as missed. Inactive
            // rays test too and are masked afterwards (the test first: && would branch): a branch
            // around the tests, which the packet takes together anyway, was measured 2% slower on
            // the H100 (docs/gpu.md).
            if (kStatistics && q.isActive) q.nodes += 1u;
            float entryLeft, entryRight;
            const bool hitLeft =
                boxTest(q, left.lo.xyz, left.hi.xyz, entryLeft) && q.isActive;
            const bool hitRight =
                boxTest(q, right.lo.xyz, right.hi.xyz, entryRight) && q.isActive;
            const bool rightFirst = hitRight && (!hitLeft || entryRight < entryLeft);
            const PacketVote votes = packetVote(hitLeft, hitRight, rightFirst, q.isActive,
                                                countActive, parity);
            if (countActive && votes.stillActive == 0u) break;  // all shadow rays occluded
            if (votes.hitting != 0u) {
                // Sum of +1 (right first) and -1 (left first): left when the sum is below 1. The
                // child that more rays want first is entered; the other is visited later when at
                // least one ray wants it (the report's order, not the paper's swapped pseudocode).
                // A ray that hits the other child wants it (first or second).
                const int sum = 2 * int(votes.rightFirst) - int(votes.hitting);
                const bool goRight = sum >= 1;
                const bool otherWanted = (goRight ? votes.hitLeft : votes.hitRight) != 0u;
                const GpuNode chosen = goRight ? right : left;
                const GpuNode other = goRight ? left : right;
                const bool wantChosen = goRight ? hitRight : hitLeft;
                const bool wantOther = goRight ? hitLeft : hitRight;
                current = nodeEntry(chosen);
                wantCurrent = wantChosen;
                if (otherWanted) {
                    if (current.y != 0u) {
                        // The chosen child is a leaf: visit the other right after it.
                        haveNext = true;
                        next = nodeEntry(other);
                        wantNext = wantOther;
                    } else {
                        if (stackSize == kPacketStackEntries) {
                            // Cannot happen with the host's sizing; never overflow silently.
                            if (gl_LocalInvocationIndex == 0u) atomicOr(status, kStatusStackOverflow);
                            break;
                        }
                        pushEntry(stackSize, nodeEntry(other));
                        if (stackSize < 32u) {
                            const uint bit = 1u << stackSize;
                            wantedBits = wantOther ? (wantedBits | bit) : (wantedBits & ~bit);
                        }
                        ++stackSize;
                    }
                }
                if (current.y == 0u) continue;  // descend into the chosen inner child
            } else {
                current = uvec2(0u);  // no ray wants either child: pop
            }
        }
        if (current.y != 0u) {
            // Leaf: the rays that wanted it test its triangles.
            steps += current.y;
            if (q.isActive && wantCurrent) {
                if (kStatistics) q.nodes += 1u;
                intersectLeaf(q, current.x, current.y);
            }
            if (shadowPacket && kPacketIsOneSubgroup && !subgroupAny(q.isActive)) break;
            if (haveNext) {
                current = next;
                wantCurrent = wantNext;
                continue;
            }
        }
        // Pop. Across subgroups the entry was written before at least one vote (a barrier) since.
        if (stackSize == 0u) break;
        --stackSize;
        current = popEntry(stackSize);
        wantCurrent = stackSize < 32u ? (wantedBits & (1u << stackSize)) != 0u : true;
    }
}

// Half the surface area of a node's box.
float halfArea(GpuNode n) {
    const vec3 d = n.hi.xyz - n.lo.xyz;
    return d.x * d.y + d.y * d.z + d.z * d.x;
}

// Whether a ray that hits both children enters the right one first. A closest-hit ray takes the
// nearer (then the farther one rarely needs a visit); an any-hit (shadow) ray needs any occluder,
// so distance matters less than finding one soon: kShadowOrder picks the nearer, the left one
// without comparing (tree order), or the larger box, the more likely to hold an occluder.
bool secondChildFirst(RayQuery q, GpuNode left, GpuNode right, float entryLeft, float entryRight) {
    if (q.anyHit && kShadowOrder == kShadowOrderTree) return false;
    if (q.anyHit && kShadowOrder == kShadowOrderLarger) return halfArea(right) > halfArea(left);
    return entryRight < entryLeft;
}

// A ray's own stack (the single-ray kernel; the hybrid kernel after its split), at module scope so
// that singleRayLoop uses it without an array parameter, which GLSL would copy in and out.
uvec2 rayStack[kRayStackEntries];
uint rayStackSize = 0u;

// The single-ray while-while loop (Aila and Laine 2009) from `current` and rayStack until the ray is
// done: nearer child first, the farther one pushed. `steps` (inner nodes visited plus triangles
// tested) is bounded by kMaxTraversalSteps.
void singleRayLoop(inout RayQuery q, inout uvec2 current, inout uint steps) {
    while (true) {
        while (current.y == 0u) {
            if (++steps > kMaxTraversalSteps) {
                atomicOr(status, kStatusTraversalTruncated);
                return;
            }
            const GpuNode left = loadNode(current.x);
            const GpuNode right = loadNode(current.x + 1u);
            if (kStatistics) q.nodes += 1u;
            float entryLeft, entryRight;
            const bool hitLeft = boxTest(q, left.lo.xyz, left.hi.xyz, entryLeft);
            const bool hitRight = boxTest(q, right.lo.xyz, right.hi.xyz, entryRight);
            if (hitLeft && hitRight) {
                const bool rightFirst = secondChildFirst(q, left, right, entryLeft, entryRight);
                current = nodeEntry(rightFirst ? right : left);
                if (rayStackSize == kRayStackEntries) {
                    atomicOr(status, kStatusStackOverflow);
                    return;
                }
                rayStack[rayStackSize++] = nodeEntry(rightFirst ? left : right);
            } else if (hitLeft || hitRight) {
                current = nodeEntry(hitLeft ? left : right);
            } else if (rayStackSize == 0u) {
                return;
            } else {
                current = rayStack[--rayStackSize];
            }
        }
        while (current.y != 0u) {
            steps += 1u + current.y;
            if (steps > kMaxTraversalSteps) {
                atomicOr(status, kStatusTraversalTruncated);
                return;
            }
            if (kStatistics) q.nodes += 1u;
            intersectLeaf(q, current.x, current.y);
            if (!q.isActive || rayStackSize == 0u) return;
            current = rayStack[--rayStackSize];
        }
    }
}

// Starts a single-ray traversal: an empty stack and the root, when the ray is active and hits the
// root's box. Returns false when there is nothing to traverse.
bool startSingle(RayQuery q, out uvec2 current) {
    rayStackSize = 0u;
    const GpuNode root = loadNode(0u);
    current = nodeEntry(root);
    float entry;
    return q.isActive && !isEmptyRoot(current) && boxTest(q, root.lo.xyz, root.hi.xyz, entry);
}

// The single-ray traversal (Aila and Laine 2009): each ray its own stack.
void traceSingle(inout RayQuery q) {
    uvec2 current;
    uint steps = 0u;
    if (startSingle(q, current)) singleRayLoop(q, current, steps);
}

// The children of `node` that the ray meets: the inner ones as bits 24 + (slot ^ octant) of the
// result, with the node's inner mask in its low byte (traceWide's node group), the leaves' triangles
// as bits of triangleHits (bit k: the node's first triangle + k). The slab test is the grid's fused
// form made conservative by its error bound (shaders/wide_node.h, kWideSlabError), or for rays
// parallel to an axis and nodes of huge distances the decoded box and the slab test of
// shaders/intersect.h; the box test's tmax is the closest hit's, widened as there.
uint wideNodeHits(RayQuery q, GpuWideNode node, uint octant, out uint triangleHits) {
    const vec3 scale = wideScales(node);
    const uint innerMask = floatBitsToUint(node.origin.w) >> 24u;
    uint innerHits = 0u;
    triangleHits = 0u;
    const vec3 a = scale * q.ray.invDir;
    const vec3 b = (node.origin.xyz - q.ray.org) * q.ray.invDir;
    const vec3 reach = abs(b) + 255.0f * abs(a);
    if (!q.ray.anyParallel && max(max(reach.x, reach.y), reach.z) < kWideFastLimit) {
        const vec3 error = kFastIntersect ? vec3(0.0f) : reach * kWideSlabError;
        const vec3 bNear = b - error;
        const vec3 bFar = b + error;
        const float tmax = kFastIntersect ? q.tmax : q.tmax * kBoxTmaxWiden;
        // Each axis's near plane is the low one where the ray runs forwards on it, else the high one.
        const bool negX = (octant & 1u) != 0u, negY = (octant & 2u) != 0u, negZ = (octant & 4u) != 0u;
        const uvec2 nearX = negX ? node.quant[1].zw : node.quant[0].xy;
        const uvec2 farX = negX ? node.quant[0].xy : node.quant[1].zw;
        const uvec2 nearY = negY ? node.quant[2].xy : node.quant[0].zw;
        const uvec2 farY = negY ? node.quant[0].zw : node.quant[2].xy;
        const uvec2 nearZ = negZ ? node.quant[2].zw : node.quant[1].xy;
        const uvec2 farZ = negZ ? node.quant[1].xy : node.quant[2].zw;
        [[unroll]] for (uint i = 0u; i < 8u; ++i) {
            // An empty slot's planes are computed and its result dropped: skipping it first, a branch
            // per slot, measured 0.93-0.99x (docs/gpu.md).
            const uint meta = wideMeta(node, i);
            const float nx = fma(float(wideSlotValue(nearX.x, nearX.y, i)), a.x, bNear.x);
            const float ny = fma(float(wideSlotValue(nearY.x, nearY.y, i)), a.y, bNear.y);
            const float nz = fma(float(wideSlotValue(nearZ.x, nearZ.y, i)), a.z, bNear.z);
            const float fx = fma(float(wideSlotValue(farX.x, farX.y, i)), a.x, bFar.x);
            const float fy = fma(float(wideSlotValue(farY.x, farY.y, i)), a.y, bFar.y);
            const float fz = fma(float(wideSlotValue(farZ.x, farZ.y, i)), a.z, bFar.z);
            const float tNear = max(max(nx, ny), max(nz, 0.0f));
            const float tFar = min(min(fx, fy), min(fz, tmax));
            if (meta == 0u || tNear > tFar) continue;
            if ((innerMask & (1u << i)) != 0u) innerHits |= 1u << (24u + (i ^ octant));
            else triangleHits |= (meta >> 5u) << (meta & 31u);
        }
    } else {
        [[unroll]] for (uint i = 0u; i < 8u; ++i) {
            const uint meta = wideMeta(node, i);
            if (meta == 0u) continue;
            vec3 lo, hi;
            wideChildBox(node, scale, i, lo, hi);
            float entry;
            if (!boxTest(q, lo, hi, entry)) continue;
            if ((innerMask & (1u << i)) != 0u) innerHits |= 1u << (24u + (i ^ octant));
            else triangleHits |= (meta >> 5u) << (meta & 31u);
        }
    }
    return innerHits | innerMask;
}

// The single-ray traversal of the compressed 8-wide tree (Ylitie, Karras and Laine 2017, their
// algorithm without postponed triangles): a node's eight child boxes are tested (wideNodeHits), the
// hit inner children become one node group (the first child's index, the hit slots as bits
// 24 + (slot ^ octant), and the node's inner mask in the low byte) and the hit leaves one triangle
// group (the node's first triangle and a bit per triangle). The triangles are tested at once; the
// node group hands out its children lowest bit first (front to back for the ray's octant), and a
// group with children left waits on the ray's stack while the ray descends, one entry per level at
// most (the host sizes the stack from the wide tree's depth). Nothing is sorted: the order comes
// from the slots (GpuWideNode). The root is entered without a box test (an empty scene's has no
// children).
void traceWide(inout RayQuery q) {
    if (!q.isActive) return;
    const uint octant = rayOctant(q.ray.dir);
    uvec2 group = uvec2(0u, (1u << (24u + octant)) | 1u);  // the root, as inner slot 0 of base 0
    uint triangleBase = 0u, triangleHits = 0u;
    uint stackSize = 0u;
    uint steps = 0u;
    while (true) {
        if (group.y > 0x00FFFFFFu) {
            const uint bit = findLSB(group.y >> 24u);
            group.y &= ~(1u << (24u + bit));
            const uint slot = bit ^ octant;
            const uint child = group.x + bitCount(group.y & ((1u << slot) - 1u) & 0xFFu);
            if (group.y > 0x00FFFFFFu) {
                if (stackSize == kRayStackEntries) {
                    atomicOr(status, kStatusStackOverflow);
                    return;
                }
                rayStack[stackSize++] = group;
            }
            if (++steps > kMaxTraversalSteps) {
                atomicOr(status, kStatusTraversalTruncated);
                return;
            }
            if (kStatistics) q.nodes += 1u;
            const GpuWideNode node = wideNodes[child];
            group = uvec2(node.index.x, wideNodeHits(q, node, octant, triangleHits));
            triangleBase = node.index.y;
        }
        while (triangleHits != 0u) {
            const uint k = findLSB(triangleHits);
            triangleHits &= triangleHits - 1u;
            if (++steps > kMaxTraversalSteps) {
                atomicOr(status, kStatusTraversalTruncated);
                return;
            }
            intersectLeaf(q, triangleBase + k, 1u);
            if (!q.isActive) return;  // a shadow ray's occluder
        }
        if (group.y <= 0x00FFFFFFu) {
            if (stackSize == 0u) return;
            group = rayStack[--stackSize];
        }
    }
}

// Whether the hybrid packet keeps its stack in every ray's own (rayStack) instead of sStack. A packet
// of one subgroup runs in lockstep, so every ray can push the same entry onto its own stack, which
// the split then compacts in place; neither the elected write to shared memory nor the barrier
// before the other lanes read it are needed. Measured on an H100 (docs/gpu.md, "The hybrid
// kernel's gap in steps"), against sStack: 1.007-1.084x with four packets a workgroup, 1.006-1.053x
// for primary rays with one, 0.932-0.976x for shadow rays with one, which keep sStack.
// A function, not a constant made of specialization constants: for such a constant glslang emitted
// its negation before the constant itself, invalid SPIR-V. The driver folds the function the same.
bool hybridOwnStack() { return kPacketIsOneSubgroup && (kPacketsPerGroup > 1u || kPass != kPassShadowShade); }

// The hybrid kernel's vote: packetVote's counts plus `wanting`, the active rays that want the node
// being visited (its box was hit when it was entered or pushed), which both split rules read. The
// same four rotating slots as packetVote, the fourth component of each slot (packetVote leaves it
// 0) carrying `wanting` across subgroups, so the two votes can follow each other in one traversal.
struct HybridVote {
    PacketVote packet;
    uint wanting;
};

HybridVote hybridVote(bool leftHit, bool rightHit, bool rightFirst, bool wants, bool isActive, bool countActive,
                      inout uint parity) {
    HybridVote h;
    const uvec4 left = subgroupBallot(leftHit);
    const uvec4 right = subgroupBallot(rightHit);
    PacketVote v;
    v.rightFirst = subgroupBallotBitCount(subgroupBallot(rightFirst));
    v.hitting = subgroupBallotBitCount(left | right);
    v.hitLeft = subgroupBallotBitCount(left);
    v.hitRight = subgroupBallotBitCount(right);
    v.stillActive = countActive ? subgroupBallotBitCount(subgroupBallot(isActive)) : 0u;
    h.wanting = subgroupBallotBitCount(subgroupBallot(wants));
    uvec2 packed = uvec2(v.rightFirst | (v.hitting << 16u), v.hitLeft | (v.hitRight << 16u));
    // A packet of one subgroup that keeps its stack in every ray's own (hybridOwnStack) needs no
    // barrier: no lane reads what another wrote.
    if (kPacketIsOneSubgroup) {
        if (!hybridOwnStack()) subgroupBarrier();
    } else {
        const uint slot = parity & 3u;
        if (subgroupElect()) {
            atomicAdd(sVote[slot].x, packed.x);
            atomicAdd(sVote[slot].y, packed.y);
            if (countActive) atomicAdd(sVote[slot].z, v.stillActive);
            atomicAdd(sVote[slot].w, h.wanting);
        }
        barrier();
        const uvec4 total = sVote[slot];
        if (gl_LocalInvocationIndex == 0u) sVote[(slot + 2u) & 3u] = uvec4(0u);
        parity += 1u;
        packed = total.xy;
        v.stillActive = total.z;
        h.wanting = total.w;
    }
    v.rightFirst = packed.x & 0xFFFFu;
    v.hitting = packed.x >> 16u;
    v.hitLeft = packed.y & 0xFFFFu;
    v.hitRight = packed.y >> 16u;
    h.packet = v;
    return h;
}

// The hybrid packet's stack (hybridPush, hybridPop): sStack as tracePacket's, or with
// hybridOwnStack (above hybridVote) every ray's own.
void hybridPush(uint slot, uvec2 entry) {
    if (hybridOwnStack()) rayStack[slot] = entry;
    else pushEntry(slot, entry);
}

uvec2 hybridPop(uint slot) { return hybridOwnStack() ? rayStack[slot] : popEntry(slot); }

// Hybrid packet / single-ray traversal after Benthin, Wald, Woop, Ernst and Mark 2012 ("Combining
// Single and Packet-Ray Tracing for Arbitrary Ray Distributions on the Intel MIC Architecture"):
// the packet traverses as tracePacket does (one vote per inner node; the stack shared, or for a
// packet of one subgroup the same entries in every ray's own, hybridPush) while it is coherent, and
// once a vote shows it is not, every ray continues alone with traceSingle's while-while loop and
// its own stack, seeded with the packet's pending entries that the ray wanted and with its own
// step at the node of that vote. The split is for the rest of the traversal (Benthin et al. return
// to packet mode after the subtree; a GPU packet whose rays have diverged in a subgroup has no
// cheap way back). The decision is packet-uniform (it reads only the vote's totals), so every
// invocation leaves the voting loop at the same iteration and no barrier follows the split.
void traceHybrid(inout RayQuery q) {
    // Each ray's own stack after the split: the packet's pending entries plus its own pushes (the
    // host sizes it as the two stacks together).
    rayStackSize = 0u;
    const GpuNode root = loadNode(0u);
    float entry;
    uvec2 current = nodeEntry(root);
    bool wantCurrent = q.isActive && !isEmptyRoot(current) && boxTest(q, root.lo.xyz, root.hi.xyz, entry);
    q.isActive = wantCurrent;
    uint parity = 0u;
    uint stackSize = 0u;
    const bool shadowPacket = kPass == kPassShadowShade;
    const bool visitRule = kHybridVisitRatio != 0u;
    // The visit rule weighs each visit by the rays still active: shadow packets count them at
    // every vote; primary rays stay active, so the root's count holds throughout.
    const bool countActive = shadowPacket && (!kPacketIsOneSubgroup || visitRule);
    if (kPacketIsOneSubgroup) {
        // Packet k of the workgroup: rows [k PH, (k + 1) PH), one subgroup, as the host assumed.
        const uint packetHeight = gl_WorkGroupSize.y / kPacketsPerGroup;
        const uint packet = gl_LocalInvocationID.y / packetHeight;
        packetStackBase = packet * kPacketStackEntries;
        if (subgroupAdd(1u) != gl_WorkGroupSize.x * packetHeight || !subgroupAllEqual(packet)) {
            if (subgroupElect()) atomicOr(status, kStatusSubgroupMismatch);
            return;
        }
    } else {
        if (gl_LocalInvocationIndex == 0u) sVote[0] = sVote[1] = uvec4(0u);
        barrier();
    }
    uint wantedBits = 0u;  // bit s: this ray wanted stack entry s (s < 32; deeper entries: assumed)
    const uint rootActive = packetVote(false, false, false, q.isActive, true, parity).stillActive;
    if (rootActive == 0u) return;

    // The visit rule's sums over the packet's inner-node visits: the active rays (the packet's N_TR
    // summed over its rays) and the rays that wanted the node (what the rays alone would visit).
    float packetVisits = 0.0f;
    float wantedVisits = 0.0f;
    bool split = false;
    bool done = false;  // after the split: this ray has nothing left to visit
    uint steps = 0u;
    while (true) {
        if (++steps > kMaxTraversalSteps) {
            if (gl_LocalInvocationIndex == 0u) atomicOr(status, kStatusTraversalTruncated);
            break;
        }
        bool haveNext = false;
        uvec2 next = uvec2(0u);
        bool wantNext = false;
        if (current.y == 0u) {
            const GpuNode left = loadNode(current.x);
            const GpuNode right = loadNode(current.x + 1u);
            if (kStatistics && q.isActive) q.nodes += 1u;
            float entryLeft, entryRight;
            const bool hitLeft = boxTest(q, left.lo.xyz, left.hi.xyz, entryLeft) && q.isActive;
            const bool hitRight = boxTest(q, right.lo.xyz, right.hi.xyz, entryRight) && q.isActive;
            const bool rightFirst = hitRight && (!hitLeft || entryRight < entryLeft);
            const HybridVote hv =
                hybridVote(hitLeft, hitRight, rightFirst, q.isActive && wantCurrent, q.isActive, countActive, parity);
            const PacketVote votes = hv.packet;
            if (countActive && votes.stillActive == 0u) break;  // all shadow rays occluded
            const uint activeRays = countActive ? votes.stillActive : rootActive;
            packetVisits += float(activeRays);
            wantedVisits += float(hv.wanting);
            if (hv.wanting < kHybridMinRays ||
                (visitRule && packetVisits * 100.0f > float(kHybridVisitRatio) * wantedVisits)) {
                // Split. The ray keeps the pending entries it wanted, bottom first, so that it pops
                // them in the packet's order (in place where they are its own already: entry s moves
                // to a slot at or below s). Shared entries were written before this vote's barrier.
                split = true;
                done = !q.isActive;
                if (!done) {
                    for (uint s = 0u; s < stackSize; ++s)
                        if (s >= 32u || (wantedBits & (1u << s)) != 0u) rayStack[rayStackSize++] = hybridPop(s);
                    // This ray's own step at the voted node, as traceSingle's: the nearer child
                    // hit first, the farther pushed. A ray that did not want the node skips it.
                    const bool l = hitLeft && wantCurrent;
                    const bool r = hitRight && wantCurrent;
                    if (l && r) {
                        const bool nearRight = entryRight < entryLeft;
                        current = nodeEntry(nearRight ? right : left);
                        if (rayStackSize == kRayStackEntries) {
                            atomicOr(status, kStatusStackOverflow);
                            done = true;
                        } else {
                            rayStack[rayStackSize++] = nodeEntry(nearRight ? left : right);
                        }
                    } else if (l || r) {
                        current = nodeEntry(l ? left : right);
                    } else if (rayStackSize == 0u) {
                        done = true;
                    } else {
                        current = rayStack[--rayStackSize];
                    }
                }
                break;
            }
            if (votes.hitting != 0u) {
                // tracePacket's choice of child and what it pushes.
                const int sum = 2 * int(votes.rightFirst) - int(votes.hitting);
                const bool goRight = sum >= 1;
                const bool otherWanted = (goRight ? votes.hitLeft : votes.hitRight) != 0u;
                const GpuNode chosen = goRight ? right : left;
                const GpuNode other = goRight ? left : right;
                const bool wantChosen = goRight ? hitRight : hitLeft;
                const bool wantOther = goRight ? hitLeft : hitRight;
                current = nodeEntry(chosen);
                wantCurrent = wantChosen;
                if (otherWanted) {
                    if (current.y != 0u) {
                        haveNext = true;
                        next = nodeEntry(other);
                        wantNext = wantOther;
                    } else {
                        if (stackSize == kPacketStackEntries) {
                            if (gl_LocalInvocationIndex == 0u) atomicOr(status, kStatusStackOverflow);
                            break;
                        }
                        hybridPush(stackSize, nodeEntry(other));
                        if (stackSize < 32u) {
                            const uint bit = 1u << stackSize;
                            wantedBits = wantOther ? (wantedBits | bit) : (wantedBits & ~bit);
                        }
                        ++stackSize;
                    }
                }
                if (current.y == 0u) continue;
            } else {
                current = uvec2(0u);
            }
        }
        if (current.y != 0u) {
            steps += current.y;
            if (q.isActive && wantCurrent) {
                if (kStatistics) q.nodes += 1u;
                intersectLeaf(q, current.x, current.y);
            }
            if (shadowPacket && kPacketIsOneSubgroup && !subgroupAny(q.isActive)) break;
            if (haveNext) {
                current = next;
                wantCurrent = wantNext;
                continue;
            }
        }
        if (stackSize == 0u) break;
        --stackSize;
        current = hybridPop(stackSize);
        wantCurrent = stackSize < 32u ? (wantedBits & (1u << stackSize)) != 0u : true;
    }
    if (!split) return;

    // Each ray alone: traceSingle's while-while loop from the seeded state.
    if (!done) singleRayLoop(q, current, steps);
}

void trace(inout RayQuery q) {
    if (kKernel == kKernelPacket) tracePacket(q);
    else if (kKernel == kKernelHybrid) traceHybrid(q);
    else if (kWideBvh) traceWide(q);
    else traceSingle(q);
}

void main() {
    const uint width = params.frame.x;
    const uint height = params.frame.y;
    // Images not a multiple of the packet are padded; padding rays follow the packet but trace
    // nothing and write nothing (report 3.4).
    const uvec2 pixel = gl_GlobalInvocationID.xy;
    const bool inside = pixel.x < width && pixel.y < height;
    const uint index = inside ? pixel.y * width + pixel.x : 0u;
    const vec3 eye = cameraEye(params.camera);
    const vec3 dir = primaryRayDirection(params.camera, min(pixel.x, width - 1u), min(pixel.y, height - 1u));

    float t = kInfinity;
    uint leafTri = kNoHit;
    vec2 bary = vec2(0.0f);
    RayCounters counts = RayCounters(0u, 0u, 0u, 0u);
    uint shadow = kShadowNone;

    if (kPass == kPassPrimary || kPass == kPassPrimaryShade) {
        RayQuery q = makeQuery(eye, dir, kInfinity, false, kNoHit, inside);
        trace(q);
        t = q.tmax;
        leafTri = q.leafTri;
        bary = q.bary;
        if (leafTri != kNoHit && q.inexactT) {
            // The kept hit's distance from its plane (shaders/intersect.h), as the CPU tracers do.
            const GpuTriangle tri = triangles[leafTri];
#ifdef RP_FLOAT64
            t = accurateHitDistanceF64(eye, dir, tri.v0.xyz, tri.v1.xyz, tri.v2.xyz, t);
#else
            t = accurateHitDistance(eye, dir, tri.v0.xyz, tri.v1.xyz, tri.v2.xyz, t);
#endif
        }
        counts.primaryNodes = q.nodes;
        counts.primaryTests = q.tests;
        if (kPass == kPassPrimary) {
            if (inside) {
                primaryHits[index].data = vec4(t, uintBitsToFloat(leafTri), bary.x, bary.y);
                if (kStatistics) counters[index] = counts;
            }
            return;
        }
    } else {
        // Shadow packet (report 2.3): from the light to each hit point, the stack restarted. Rays
        // whose primary ray missed follow the packet's control flow without voting (report 3.5).
        const vec4 kept = inside ? primaryHits[index].data : vec4(kInfinity, uintBitsToFloat(kNoHit), 0.0f, 0.0f);
        t = kept.x;
        leafTri = floatBitsToUint(kept.y);
        bary = kept.zw;
        if (kStatistics && inside) counts = counters[index];
        const bool hit = leafTri != kNoHit;
        const vec3 light = params.light.xyz;
        ShadowRay s;
        s.org = light;
        s.dir = vec3(1.0f);
        s.tmax = 0.0f;
        s.skipPrim = kNoHit;
        bool traceShadow = false;
        if (hit) {
            const uint file = floatBitsToUint(triangles[leafTri].v0.w);
            s = makeShadowRay(light, hitPosition(eye, dir, t), file);
            traceShadow = !isDegenerateShadowRay(s);
            shadow = kShadowLit;
        }
        RayQuery q = makeQuery(s.org, traceShadow ? s.dir : vec3(1.0f), s.tmax, true, s.skipPrim, traceShadow);
        trace(q);
        if (traceShadow && q.leafTri != kNoHit) shadow = kShadowOccluded;
        counts.shadowNodes = q.nodes;
        counts.shadowTests = q.tests;
    }
    if (!inside) return;

    // Shading (shaders/shading.h, the CPU reference's text).
    vec3 color = params.background.xyz;
    if (kView == kViewHeatTraversal || kView == kViewHeatIntersections) {
        color = heatViewColor(kView == kViewHeatTraversal, counts, params.background.w);
    } else if (leafTri != kNoHit) {
        const GpuTriangle tri = triangles[leafTri];
        const vec3 geometric = geometricNormal(tri.v0.xyz, tri.v1.xyz, tri.v2.xyz, dir);
        vec3 normal = geometric;
        if ((params.frame.z & kFrameHasNormals) != 0u) {
            const GpuTriangleNormals n = normals[leafTri];
            normal = interpolatedNormal(n.n0.xyz, n.n1.xyz, n.n2.xyz, bary, geometric, dir);
        }
        // Material x texture x vertex colour, as the CPU's diffuseAt (renderer/cpu_tracer.cpp).
        const bool hasColors = (params.frame.z & kFrameHasColors) != 0u;
        vec3 materialColor = defaultMaterialColor(hasColors);
        uint texture = kNoTextureIndex;
        if ((params.frame.z & kFrameHasMaterials) != 0u) {
            const GpuMaterial m = materials[floatBitsToUint(tri.v1.w)];
            materialColor = m.diffuse.xyz;
            texture = floatBitsToUint(m.diffuse.w);
        }
        vec4 texel = vec4(1.0f);
        if (texture != kNoTextureIndex && (params.frame.z & kFrameHasUvs) != 0u) {
            const GpuTriangleUvs u = uvs[leafTri];
            const GpuTexture tex = textures[texture];
            const vec2 uv = interpolateUv(u.uv01.xy, u.uv01.zw, u.uv2.xy, bary);
            const float lod = textureLod(tex, tri.v0.xyz, tri.v1.xyz, tri.v2.xyz, u.uv01.xy,
                                         u.uv01.zw, u.uv2.xy, dir, t, pixelSpread(params.camera));
            const uint level = uint(lod);
            texel = sampleLevel(tex, level, uv);
            if (level + 1u < textureLevels(tex))
                texel = lerpPrecise(texel, sampleLevel(tex, level + 1u, uv), lod - float(level));
        }
        vec3 vertexColor = vec3(1.0f);
        if (hasColors) {
            const uvec4 c = colors[leafTri].rgba;
            vertexColor = interpolateColor(c.x, c.y, c.z, bary);
        }
        const vec3 diffuse = surfaceColor(materialColor, texel, vertexColor);
        color = shadeHit(params.phong, eye, dir, t, normal, diffuse, params.light.xyz, shadow == kShadowOccluded);
    }
    uint rgba = packRgba8(vec4(color, 1.0f));
    if ((params.frame.z & kFrameBgra) != 0u) rgba = swapRedBlue(rgba);
    outputRgba[index] = rgba;

    if ((params.frame.z & kFrameWriteHits) != 0u) {
        const uint prim = leafTri == kNoHit ? kNoHit : floatBitsToUint(triangles[leafTri].v0.w);
        hitRecords[index] = makeHitRecord(eye, dir, t, prim, shadow);
    }
    if (kStatistics) counters[index] = counts;
}
