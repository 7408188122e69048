// Descriptor binding indices and specialization-constant IDs of raypack's Vulkan pipelines, defined
// once for GLSL and C++ (../shared/STYLE.md, "One definition of what the GPU reads"): the shaders
// name them in their layout qualifiers (GLSL 4.30 and later take any integral constant expression
// there, so a `const uint` serves both languages) and the host builds its descriptor-set layouts,
// descriptor writes and VkSpecializationMapEntry tables from the same names. Before, the indices
// were written twice (renderer/gpu_tracer.cpp and shaders/trace.comp) and kept in sync by a comment.
#ifndef RAYPACK_SHADERS_BINDINGS_H
#define RAYPACK_SHADERS_BINDINGS_H
#include "common.h"

#ifdef __cplusplus
#include <array>
#include <cstddef>  // offsetof
#endif

RP_BEGIN_NAMESPACE

// ---- shaders/trace.comp (renderer/gpu_tracer.cpp): set 0, every binding a storage buffer.
const uint kBindNodes = 0u;        // GpuNode[]
const uint kBindTriangles = 1u;    // GpuTriangle[], leaf order
const uint kBindNormals = 2u;      // GpuTriangleNormals[] (kFrameHasNormals)
const uint kBindMaterials = 3u;    // GpuMaterial[] (kFrameHasMaterials)
const uint kBindPrimaryHits = 4u;  // GpuPrimaryHit[] per pixel, primary pass -> shadow pass
const uint kBindOutput = 5u;       // RGBA8 (or BGRA8) per pixel
const uint kBindHits = 6u;         // HitRecord[] per pixel (kFrameWriteHits)
const uint kBindCounters = 7u;     // RayCounters[] per pixel
const uint kBindStatus = 8u;       // the status word (kStatus* bits)
const uint kBindUvs = 9u;          // GpuTriangleUvs[] (kFrameHasUvs)
const uint kBindColors = 10u;      // GpuTriangleColors[] (kFrameHasColors)
const uint kBindTextures = 11u;    // GpuTexture[] (kFrameHasUvs)
const uint kBindTexels = 12u;      // uint[] texels of every texture (kFrameHasUvs)
const uint kBindingCount = 13u;    // the storage buffers above
// After the storage buffers: the nodes again, as a uniform texel buffer of RGBA32F texels (two a
// GpuNode), which the binary kernels read instead of kBindNodes where kSpecTexelNodes says so.
const uint kBindNodeTexels = kBindingCount;

// Specialization constants of shaders/trace.comp (constant_id, local_size_*_id).
const uint kSpecPacketWidth = 0u;          // local_size_x: packet width PW
const uint kSpecPacketHeight = 1u;         // local_size_y: packet height PH
const uint kSpecKernel = 2u;               // kKernelPacket, kKernelSingle or kKernelHybrid
const uint kSpecPass = 3u;                 // kPass*
const uint kSpecStatistics = 4u;           // bool: count N_TR / N_IT per ray
const uint kSpecView = 5u;                 // kView*
const uint kSpecPacketStackEntries = 6u;   // the packet's shared stack (1 for the single-ray kernel)
const uint kSpecRayStackEntries = 7u;      // each ray's own stack (1 for the packet kernel)
const uint kSpecPacketIsOneSubgroup = 8u;  // bool: the packet is exactly one subgroup
const uint kSpecFastIntersect = 9u;        // bool: IntersectMode::Fast (shaders/intersect.h)
const uint kSpecShadowOrder = 10u;         // kShadowOrder*: a shadow ray's first child (single-ray kernel)
const uint kSpecHybridMinRays = 11u;       // hybrid kernel: split when fewer rays want the node (K)
const uint kSpecHybridVisitRatio = 12u;    // hybrid kernel: split at this visit ratio, in 1/100 (0: off)
const uint kSpecPacketsPerGroup = 13u;     // hybrid kernel: one-subgroup packets per workgroup, stacked in y
const uint kSpecWideBvh = 14u;             // bool: the single-ray kernel traces the compressed 8-wide tree
const uint kSpecTexelNodes = 15u;          // bool: binary nodes read through kBindNodeTexels
const uint kSpecCount = 16u;

// Values of kSpecShadowOrder, as ShadowOrder (renderer/settings.h).
const uint kShadowOrderNearest = 0u;
const uint kShadowOrderTree = 1u;
const uint kShadowOrderLarger = 2u;

// ---- shaders/rt/rt_peer.rgen (renderer/vk/rt_peer.cpp): set 0.
const uint kRtBindTlas = 0u;  // the top-level acceleration structure
const uint kRtBindHits = 1u;  // HitRecord[] per pixel, a storage buffer
const uint kRtBindingCount = 2u;

#ifdef __cplusplus
// The values the host gives trace.comp's specialization constants, one member per constant. A bool
// constant takes a VkBool32 (4 bytes, Vulkan spec, VkSpecializationMapEntry: "If the
// specialization constant is of type boolean, size must be the byte size of VkBool32"), so every
// member is a 32-bit word; the map below takes each member's offset and size from the struct, so
// adding a constant of another size stays right.
struct TraceSpecialization {
    uint packetWidth;
    uint packetHeight;
    uint kernel;
    uint pass;
    uint statistics;  // VkBool32
    uint view;
    uint packetStackEntries;
    uint rayStackEntries;
    uint packetIsOneSubgroup;  // VkBool32
    uint fastIntersect;        // VkBool32
    uint shadowOrder;
    uint hybridMinRays;
    uint hybridVisitRatio;
    uint packetsPerGroup;
    uint wideBvh;     // VkBool32
    uint texelNodes;  // VkBool32
};
RP_CHECK_SIZE(TraceSpecialization, 64);
RP_CHECK_OFFSET(TraceSpecialization, packetWidth, 0);
RP_CHECK_OFFSET(TraceSpecialization, packetHeight, 4);
RP_CHECK_OFFSET(TraceSpecialization, kernel, 8);
RP_CHECK_OFFSET(TraceSpecialization, pass, 12);
RP_CHECK_OFFSET(TraceSpecialization, statistics, 16);
RP_CHECK_OFFSET(TraceSpecialization, view, 20);
RP_CHECK_OFFSET(TraceSpecialization, packetStackEntries, 24);
RP_CHECK_OFFSET(TraceSpecialization, rayStackEntries, 28);
RP_CHECK_OFFSET(TraceSpecialization, packetIsOneSubgroup, 32);
RP_CHECK_OFFSET(TraceSpecialization, fastIntersect, 36);
RP_CHECK_OFFSET(TraceSpecialization, shadowOrder, 40);
RP_CHECK_OFFSET(TraceSpecialization, hybridMinRays, 44);
RP_CHECK_OFFSET(TraceSpecialization, hybridVisitRatio, 48);
RP_CHECK_OFFSET(TraceSpecialization, packetsPerGroup, 52);
RP_CHECK_OFFSET(TraceSpecialization, wideBvh, 56);
RP_CHECK_OFFSET(TraceSpecialization, texelNodes, 60);

// One VkSpecializationMapEntry's fields (constantID, offset, size), without Vulkan's header here.
struct SpecializationEntry {
    uint constantId;
    uint offset;
    uint size;
};

#define RP_SPEC_ENTRY(id, member) \
    SpecializationEntry { id, uint(offsetof(TraceSpecialization, member)), uint(sizeof(TraceSpecialization::member)) }
inline constexpr std::array<SpecializationEntry, kSpecCount> kTraceSpecializationEntries = {
    RP_SPEC_ENTRY(kSpecPacketWidth, packetWidth),
    RP_SPEC_ENTRY(kSpecPacketHeight, packetHeight),
    RP_SPEC_ENTRY(kSpecKernel, kernel),
    RP_SPEC_ENTRY(kSpecPass, pass),
    RP_SPEC_ENTRY(kSpecStatistics, statistics),
    RP_SPEC_ENTRY(kSpecView, view),
    RP_SPEC_ENTRY(kSpecPacketStackEntries, packetStackEntries),
    RP_SPEC_ENTRY(kSpecRayStackEntries, rayStackEntries),
    RP_SPEC_ENTRY(kSpecPacketIsOneSubgroup, packetIsOneSubgroup),
    RP_SPEC_ENTRY(kSpecFastIntersect, fastIntersect),
    RP_SPEC_ENTRY(kSpecShadowOrder, shadowOrder),
    RP_SPEC_ENTRY(kSpecHybridMinRays, hybridMinRays),
    RP_SPEC_ENTRY(kSpecHybridVisitRatio, hybridVisitRatio),
    RP_SPEC_ENTRY(kSpecPacketsPerGroup, packetsPerGroup),
    RP_SPEC_ENTRY(kSpecWideBvh, wideBvh),
    RP_SPEC_ENTRY(kSpecTexelNodes, texelNodes),
};
#undef RP_SPEC_ENTRY

// Every constant ID appears once, and every entry lies inside the data.
constexpr bool specializationEntriesAreComplete() {
    for (uint id = 0; id < kSpecCount; ++id) {
        uint seen = 0;
        for (const SpecializationEntry& e : kTraceSpecializationEntries) {
            if (e.constantId == id) ++seen;
            if (e.offset + e.size > sizeof(TraceSpecialization)) return false;
        }
        if (seen != 1) return false;
    }
    return true;
}
static_assert(specializationEntriesAreComplete(), "kTraceSpecializationEntries: one entry per constant ID");
#endif

RP_END_NAMESPACE

#endif  // RAYPACK_SHADERS_BINDINGS_H
