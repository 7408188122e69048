#include "renderer/measure/statistics.h"

namespace raypack {

nlohmann::json table1Json(const SceneInfo& scene, const BvhStats& bvh, const BvhBuildOptions& options) {
    const double triangles = double(scene.triangles);
    // The clustering device builders, whose radius and treelet rounds apply.
    const bool clustered = options.builder == BvhBuilder::GpuPloc || options.builder == BvhBuilder::GpuHploc;
    return {
        {"scene", scene.spec},
        {"triangles", scene.triangles},
        {"degenerate_triangles", scene.degenerateTriangles},
        {"t_load_s", scene.loadSeconds},
        {"input_bytes", scene.inputBytes},
        {"load_mb_s", scene.loadMegabytesPerSecond()},
        {"builder", toString(options.builder)},
        {"leaf_size", options.leafSize},
        {"ploc_radius", clustered ? nlohmann::json(plocRadiusOf(options, scene.triangles)) : nlohmann::json()},
        {"treelet_rounds", clustered ? nlohmann::json(options.treeletRounds) : nlohmann::json()},
        {"treelet_gamma", clustered ? nlohmann::json(options.treeletGamma) : nlohmann::json()},
        {"top_rebuild", clustered ? nlohmann::json(topRebuildOf(options, scene.triangles)) : nlohmann::json()},
        {"top_rebuild_items", clustered ? nlohmann::json(bvh.topRebuildItems) : nlohmann::json()},
        {"n_l_leaves", bvh.leafCount},
        {"d_avg_leaf_depth", bvh.avgLeafDepth},
        {"d_max_leaf_depth", bvh.maxLeafDepth},
        {"o_avg_prims_per_leaf", bvh.avgPrimsPerLeaf},
        {"t_b_s", bvh.buildSeconds},
        {"t_b_device_s", bvh.deviceBuildSeconds},
        {"t_b_device_sort_s", bvh.deviceSortSeconds},
        {"t_b_device_hierarchy_s", bvh.deviceHierarchySeconds},
        {"t_b_device_layout_s", bvh.deviceLayoutSeconds},
        {"build_scratch_bytes", bvh.buildScratchBytes},
        {"t_b_allocation_s", bvh.buildAllocationSeconds},
        {"nodes", bvh.nodeCount},
        {"sah_cost", bvh.sahCost},
        {"bvh_bytes", uint64_t(bvh.bytes)},
        {"bvh_bytes_per_triangle", triangles > 0 ? double(bvh.bytes) / triangles : 0.0},
        // O_AVG counts references: sah-split lists a triangle in every leaf it overlaps.
        {"triangle_references", bvh.references},
        {"references_per_triangle", triangles > 0 ? double(bvh.references) / triangles : 0.0},
        {"textures", scene.textureCount},
        {"texture_bytes", scene.textureBytes},
    };
}

void printTable1(std::FILE* out, const SceneInfo& scene, const BvhStats& bvh, const BvhBuildOptions& options) {
    std::fprintf(out, "scene      %s\n", scene.spec.c_str());
    std::fprintf(out, "triangles  %llu (%llu degenerate)\n", (unsigned long long)scene.triangles,
                 (unsigned long long)scene.degenerateTriangles);
    std::fprintf(out, "load       %.3f s, %.1f MB/s (%llu bytes)\n", scene.loadSeconds, scene.loadMegabytesPerSecond(),
                 (unsigned long long)scene.inputBytes);
    std::fprintf(out, "BVH        builder %s, leaf size %u\n", toString(options.builder), options.leafSize);
    std::fprintf(out, "Table 1    %10s %8s %6s %7s %9s\n", "N_L", "D_AVG", "D_MAX", "O_AVG", "T_B[s]");
    std::fprintf(out, "           %10u %8.3f %6u %7.3f %9.3f\n", bvh.leafCount, bvh.avgLeafDepth, bvh.maxLeafDepth,
                 bvh.avgPrimsPerLeaf, bvh.buildSeconds);
    if (bvh.deviceBuildSeconds > 0.0)
        std::fprintf(out,
                     "           built on the device in %.4f s by its timestamps (%.1f Mtri/s; sort %.4f, hierarchy "
                     "%.4f, layout %.4f), %.1f MB of scratch\n",
                     bvh.deviceBuildSeconds, double(scene.triangles) / bvh.deviceBuildSeconds / 1e6,
                     bvh.deviceSortSeconds, bvh.deviceHierarchySeconds, bvh.deviceLayoutSeconds,
                     double(bvh.buildScratchBytes) / 1e6);
    if (bvh.topRebuildItems > 0)
        std::fprintf(out, "           top rebuilt by the binned SAH over %u subtrees (nodes of %u or more triangles)\n",
                     bvh.topRebuildItems, topRebuildOf(options, scene.triangles));
    std::fprintf(out, "           nodes %u, SAH cost %.3f, %.2f MB (%.1f bytes/triangle)\n", bvh.nodeCount, bvh.sahCost,
                 double(bvh.bytes) / 1e6, scene.triangles ? double(bvh.bytes) / double(scene.triangles) : 0.0);
    std::fprintf(out, "           triangle references %llu (%.3f per triangle; O_AVG counts references)\n",
                 (unsigned long long)bvh.references,
                 scene.triangles ? double(bvh.references) / double(scene.triangles) : 0.0);
    std::fprintf(out, "textures   %llu, %.2f MB of RGBA8 texels\n", (unsigned long long)scene.textureCount,
                 double(scene.textureBytes) / 1e6);
}

FrameStats summarizeRuns(const CounterSummary& counters, const std::vector<FrameTimings>& timedRuns,
                         double uploadSeconds) {
    FrameStats stats;
    stats.repeats = uint32_t(timedRuns.size());
    std::vector<double> primary, shadow, frame;
    for (const FrameTimings& t : timedRuns) {
        primary.push_back(t.primarySeconds);
        shadow.push_back(t.shadowSeconds);
        frame.push_back(t.totalSeconds);
    }
    stats.primary.rays = counters.primaryRays;
    stats.primary.nodesPerRay = counters.primaryNodes;
    stats.primary.testsPerRay = counters.primaryTests;
    stats.primary.kernelSeconds = spreadOf(primary);
    stats.primary.uploadSeconds = uploadSeconds;
    stats.shadow.rays = counters.shadowRays;
    stats.shadow.nodesPerRay = counters.shadowNodes;
    stats.shadow.testsPerRay = counters.shadowTests;
    stats.shadow.kernelSeconds = spreadOf(shadow);
    stats.shadow.uploadSeconds = uploadSeconds;
    stats.frameSeconds = spreadOf(frame);
    return stats;
}

nlohmann::json toJson(const GpuWarmUp& w) {
    return {{"gpu_warm_up_s", w.seconds}, {"gpu_warm_up_frames", w.frames}, {"gpu_warm_up_steady", w.steady}};
}

nlohmann::json toJson(const RayKindStats& s) {
    return {
        {"n_q_rays", s.rays},
        {"n_tr_nodes_per_ray", s.nodesPerRay},
        {"n_it_tests_per_ray", s.testsPerRay},
        {"t_r_us_per_ray", s.microsecondsPerRay()},
        {"t_f_s", s.traversalSeconds()},
        {"t_cu_s", s.uploadSeconds},
        {"t_k_s", s.kernelSeconds.median},
        {"t_k_min_s", s.kernelSeconds.min},
        {"t_k_max_s", s.kernelSeconds.max},
        {"perf_mrays_s", s.mraysPerSecond()},
        {"perf_with_upload_mrays_s", s.mraysPerSecondWithUpload()},
    };
}

nlohmann::json toJson(const FrameStats& s) {
    return {
        {"device", s.device},
        {"width_px", s.width},
        {"height_px", s.height},
        {"repeats", s.repeats},
        {"frame_s", s.frameSeconds.median},
        {"frame_min_s", s.frameSeconds.min},
        {"frame_max_s", s.frameSeconds.max},
        {"primary", toJson(s.primary)},
        {"shadow", toJson(s.shadow)},
    };
}

void printTable2(std::FILE* out, const FrameStats& s) {
    std::fprintf(out, "device     %s\n", s.device.c_str());
    std::fprintf(out, "image      %ux%u, %u timed run%s after untimed warm-ups; times are medians\n", s.width, s.height,
                 s.repeats, s.repeats == 1 ? "" : "s");
    std::fprintf(out, "Table 2    %-8s %12s %8s %8s %10s %9s %9s %9s %12s %12s\n", "rays", "T_R[us/ray]", "N_IT",
                 "N_TR", "N_Q", "T_F[s]", "T_CU[s]", "T_K[s]", "PERF[Mray/s]", "+T_CU[Mray/s]");
    const auto row = [&](const char* name, const RayKindStats& r) {
        std::fprintf(out, "           %-8s %12.4f %8.2f %8.2f %10llu %9.4f %9.4f %9.4f %12.3f %12.3f\n", name,
                     r.microsecondsPerRay(), r.testsPerRay, r.nodesPerRay, (unsigned long long)r.rays,
                     r.traversalSeconds(), r.uploadSeconds, r.kernelSeconds.median, r.mraysPerSecond(),
                     r.mraysPerSecondWithUpload());
    };
    row("primary", s.primary);
    if (s.shadow.rays)
        row("shadow", s.shadow);
    else
        std::fprintf(out, "           %-8s (no shadow rays)\n", "shadow");
    if (s.repeats > 1)
        std::fprintf(out,
                     "           T_K min/max [s]: primary %.4f / %.4f, shadow %.4f / %.4f; "
                     "frame %.4f s (min %.4f, max %.4f)\n",
                     s.primary.kernelSeconds.min, s.primary.kernelSeconds.max, s.shadow.kernelSeconds.min,
                     s.shadow.kernelSeconds.max, s.frameSeconds.median, s.frameSeconds.min, s.frameSeconds.max);
    else
        std::fprintf(out, "           frame %.4f s\n", s.frameSeconds.median);
}

}  // namespace raypack
