#include "ui/panel.h"

#include "shaders/shading.h"
#include "ui/swapchain.h"

#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <cinttypes>
#include <cstdio>

namespace raypack::ui {

namespace {

struct PacketPreset {
    const char* label;
    PacketShape shape;
};
// The report's shapes plus the two extremes the issue asks for (5x6: 30 rays, not a power of two).
constexpr PacketPreset kPacketPresets[] = {
    {"8x4", {8, 4}}, {"4x8", {4, 8}}, {"5x6", {5, 6}}, {"8x8", {8, 8}}, {"16x16", {16, 16}},
};

ImU32 heatColorU32(float value) {
    const glm::vec3 c = gpu::heatColor(value);
    return ImGui::ColorConvertFloat4ToU32(ImVec4(c.x, c.y, c.z, 1.0f));
}

// The colour scale of the heat-map views, with its full-scale value (shaders/shading.h).
void drawHeatLegend(const char* quantity, float fullScale) {
    ImGui::Text("%s per pixel (primary + shadow ray)", quantity);
    ImDrawList* draw = ImGui::GetWindowDrawList();
    const ImVec2 origin = ImGui::GetCursorScreenPos();
    const float width = ImGui::GetContentRegionAvail().x;
    const float height = 14.0f;
    constexpr int kSteps = 64;
    for (int i = 0; i < kSteps; ++i) {
        const float x0 = origin.x + width * float(i) / kSteps;
        const float x1 = origin.x + width * float(i + 1) / kSteps;
        draw->AddRectFilled(ImVec2(x0, origin.y), ImVec2(x1 + 1.0f, origin.y + height),
                            heatColorU32((float(i) + 0.5f) / kSteps));
    }
    ImGui::Dummy(ImVec2(width, height));
    ImGui::Text("0");
    for (int quarter = 1; quarter <= 4; ++quarter) {
        ImGui::SameLine(width * float(quarter) / 4.0f - (quarter == 4 ? 30.0f : 10.0f));
        ImGui::Text(quarter == 4 ? ">=%.0f" : "%.0f", fullScale * float(quarter) / 4.0f);
    }
}

bool sliderFloat(const char* label, float* value, float lo, float hi, const char* format = "%.3f") {
    return ImGui::SliderFloat(label, value, lo, hi, format);
}

}  // namespace

PanelActions drawPanel(PanelState& state, const PanelInfo& info) {
    PanelActions actions;
    RenderSettings& s = state.settings;
    ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
    ImGui::SetNextWindowSize(ImVec2(380, 0), ImGuiCond_FirstUseEver);
    ImGui::SetNextWindowBgAlpha(0.85f);
    ImGui::Begin("raypack");

    ImGui::TextWrapped("%s", info.device.c_str());
    ImGui::TextWrapped("Scene: %s (%" PRIu64 " triangles)", info.scene.c_str(), info.triangles);

    if (!info.error.empty()) {
        ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.45f, 0.4f, 1.0f));
        ImGui::TextWrapped("Error: %s", info.error.c_str());
        ImGui::PopStyleColor();
        if (ImGui::SmallButton("Dismiss")) actions.dismissError = true;
    }

    // ---- Statistics
    if (ImGui::CollapsingHeader("Statistics", ImGuiTreeNodeFlags_DefaultOpen)) {
        const LiveStatistics& st = info.stats;
        ImGui::Text("Frame %.2f ms  (%.1f fps)   %ux%u", st.frameSeconds * 1e3,
                    st.frameSeconds > 0 ? 1.0 / st.frameSeconds : 0.0, s.width, s.height);
        if (st.kernelTimesValid) {
            const double primaryMrays = st.primaryKernelSeconds > 0
                                            ? double(st.primaryRays) / st.primaryKernelSeconds / 1e6 : 0.0;
            ImGui::Text("T_K primary %.2f ms   %.1f Mrays/s", st.primaryKernelSeconds * 1e3, primaryMrays);
            if (s.shadows) {
                if (st.countersValid && st.shadowKernelSeconds > 0)
                    ImGui::Text("T_K shadow  %.2f ms   %.1f Mrays/s", st.shadowKernelSeconds * 1e3,
                                double(st.counters.shadowRays) / st.shadowKernelSeconds / 1e6);
                else
                    ImGui::Text("T_K shadow  %.2f ms", st.shadowKernelSeconds * 1e3);
            }
            ImGui::Text("Not tracing: %.0f%% of the frame", st.nonTracingShare * 100.0);
            if (!st.kernelTimesNote.empty()) ImGui::TextDisabled("%s", st.kernelTimesNote.c_str());
        } else {
            ImGui::TextDisabled("kernel times: no frame traced yet");
        }
        ImGui::Checkbox("Live N_TR / N_IT", &state.liveCounters);
        if (!st.countersNote.empty()) ImGui::TextDisabled("%s", st.countersNote.c_str());
        if (st.countersValid) {
            ImGui::Text("primary: N_TR %.1f  N_IT %.1f  (N_Q %" PRIu64 ")", st.counters.primaryNodes,
                        st.counters.primaryTests, st.counters.primaryRays);
            if (st.counters.shadowRays)
                ImGui::Text("shadow:  N_TR %.1f  N_IT %.1f  (N_Q %" PRIu64 ")", st.counters.shadowNodes,
                            st.counters.shadowTests, st.counters.shadowRays);
        }
        if (info.hasBvh) {
            const BvhStats& b = info.bvhStats;
            ImGui::Separator();
            ImGui::Text("BVH (%s, leaf size %u): Table 1", toString(info.builtWith.builder), info.builtWith.leafSize);
            if (ImGui::BeginTable("table1", 4, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingStretchSame)) {
                ImGui::TableNextRow();
                ImGui::TableNextColumn(); ImGui::Text("N_L %u", b.leafCount);
                ImGui::TableNextColumn(); ImGui::Text("D_AVG %.1f", b.avgLeafDepth);
                ImGui::TableNextColumn(); ImGui::Text("D_MAX %u", b.maxLeafDepth);
                ImGui::TableNextColumn(); ImGui::Text("O_AVG %.2f", b.avgPrimsPerLeaf);
                ImGui::TableNextRow();
                ImGui::TableNextColumn(); ImGui::Text("T_B %.3f s", b.buildSeconds);
                ImGui::TableNextColumn(); ImGui::Text("SAH %.1f", b.sahCost);
                ImGui::TableNextColumn(); ImGui::Text("%.1f MiB", double(b.bytes) / (1024.0 * 1024.0));
                ImGui::TableNextColumn(); ImGui::Text("nodes %u", b.nodeCount);
                ImGui::EndTable();
            }
        }
    }

    drawInteractivitySection(state, info, actions);

    // ---- Scene and BVH build
    if (ImGui::CollapsingHeader("Scene and BVH", ImGuiTreeNodeFlags_DefaultOpen)) {
        ImGui::InputText("##path", &state.openPath);
        ImGui::SameLine();
        if (ImGui::Button("Open")) actions.open = true;
        ImGui::TextDisabled("or drop an OBJ, PLY, glTF or GLB file on the window");

        int leafSize = int(state.bvh.leafSize);
        if (ImGui::SliderInt("leaf size", &leafSize, 1, 16)) {
            state.bvh.leafSize = uint32_t(std::max(leafSize, 1));
            actions.rebuild = true;
        }
        if (ImGui::BeginCombo("builder", toString(state.bvh.builder))) {
            for (BvhBuilder builder : kAllBvhBuilders)
                if (ImGui::Selectable(toString(builder), builder == state.bvh.builder) &&
                    builder != state.bvh.builder) {
                    state.bvh.builder = builder;
                    actions.rebuild = true;
                }
            ImGui::EndCombo();
        }
        const BuildStatus& build = info.build;
        if (build.phase == BuildPhase::Loading) {
            char overlay[96];
            std::snprintf(overlay, sizeof overlay, "loading %.0f%%  %.1f s", build.loadFraction * 100.0,
                          build.elapsedSeconds);
            ImGui::ProgressBar(float(build.loadFraction), ImVec2(-1, 0), overlay);
        } else if (build.phase == BuildPhase::Building) {
            const float share = build.total ? float(double(build.placed) / double(build.total)) : 0.0f;
            char overlay[128];
            std::snprintf(overlay, sizeof overlay, "building: %" PRIu64 " / %" PRIu64 " placed  %.1f s",
                          build.placed, build.total, build.elapsedSeconds);
            ImGui::ProgressBar(share, ImVec2(-1, 0), overlay);
        } else if (info.hasBvh) {
            ImGui::TextDisabled("load %.3f s, build %.3f s", info.loadSeconds, info.bvhStats.buildSeconds);
        }
    }

    // ---- Tracer
    if (ImGui::CollapsingHeader("Tracer", ImGuiTreeNodeFlags_DefaultOpen)) {
        int kernel = s.kernel == KernelKind::Packet ? 0 : 1;
        ImGui::RadioButton("packet", &kernel, 0);
        ImGui::SameLine();
        ImGui::RadioButton("single ray", &kernel, 1);
        s.kernel = kernel == 0 ? KernelKind::Packet : KernelKind::Single;

        ImGui::Text("Packet %ux%u (%u rays)", s.packet.width, s.packet.height, s.packet.rays());
        for (const PacketPreset& preset : kPacketPresets) {
            ImGui::SameLine();
            if (ImGui::SmallButton(preset.label)) s.packet = preset.shape;
        }
        int shape[2] = {int(s.packet.width), int(s.packet.height)};
        if (ImGui::InputInt2("width x height", shape)) {
            shape[0] = std::clamp(shape[0], 1, 1024);
            shape[1] = std::clamp(shape[1], 1, 1024);
            if (uint32_t(shape[0] * shape[1]) <= info.maxPacketRays)
                s.packet = PacketShape{uint32_t(shape[0]), uint32_t(shape[1])};
        }
        int view = int(s.view);
        ImGui::RadioButton("shaded", &view, int(ViewMode::Shaded));
        ImGui::SameLine();
        ImGui::RadioButton("N_TR heat", &view, int(ViewMode::HeatTraversal));
        ImGui::SameLine();
        ImGui::RadioButton("N_IT heat", &view, int(ViewMode::HeatIntersections));
        s.view = ViewMode(view);
        if (s.view == ViewMode::HeatTraversal) drawHeatLegend("nodes visited", gpu::kHeatFullScaleNodes);
        if (s.view == ViewMode::HeatIntersections) drawHeatLegend("triangle tests", gpu::kHeatFullScaleTests);
    }

    // ---- Light and shading
    if (ImGui::CollapsingHeader("Light and shading", ImGuiTreeNodeFlags_DefaultOpen)) {
        ImGui::Checkbox("shadows", &s.shadows);
        sliderFloat("light height", &s.lightHeight, 0.0f, 2.0f, "%.2f x scene height");
        sliderFloat("ambient", &s.phong.ambient, 0.0f, 1.0f);
        sliderFloat("diffuse", &s.phong.diffuse, 0.0f, 1.0f);
        sliderFloat("specular", &s.phong.specular, 0.0f, 1.0f);
        sliderFloat("shininess", &s.phong.shininess, 1.0f, 256.0f, "%.0f");
    }

    // ---- Camera
    if (ImGui::CollapsingHeader("Camera")) {
        ImGui::TextWrapped("W/A/S/D/Q/E fly, right drag looks, wheel: speed (%.3g units/s), Shift faster, "
                           "F frames the scene; Ctrl+1..9 saves a bookmark, 1..9 recalls it.",
                           double(info.flySpeed));
        sliderFloat("fov", &s.camera.fovYDegrees, 10.0f, 120.0f, "%.1f deg");
        if (ImGui::Button("Frame scene (F)")) actions.frameAll = true;
        ImGui::TextWrapped("%s", info.cameraArguments.c_str());
        if (ImGui::SmallButton("Copy as raypack-cli arguments")) actions.copyCameraArguments = true;
        ImGui::Text("Bookmarks:");
        for (int n = 1; n <= int(info.bookmarkSet.size()); ++n) {
            ImGui::SameLine();
            char label[16];
            std::snprintf(label, sizeof label, "%d", n);
            if (!info.bookmarkSet[n - 1]) ImGui::BeginDisabled();
            if (ImGui::SmallButton(label)) actions.recallBookmark = n;
            if (!info.bookmarkSet[n - 1]) ImGui::EndDisabled();
        }
    }

    // ---- Screenshots, compare, presentation
    if (ImGui::CollapsingHeader("Screenshot and compare", ImGuiTreeNodeFlags_DefaultOpen)) {
        if (ImGui::Button("Screenshot")) actions.screenshot = true;
        if (!info.lastScreenshot.empty()) {
            ImGui::SameLine();
            ImGui::TextWrapped("%s", info.lastScreenshot.c_str());
        }
        if (ImGui::Button("Compare with CPU reference")) actions.compare = true;
        const CompareResult& c = info.compare;
        if (c.valid) {
            ImGui::Text("%" PRIu64 " of %" PRIu64 " pixels differ (%.4f%%), max channel diff %u",
                        c.differingPixels, c.pixels, c.differingShare * 100.0, c.maxChannelDifference);
            ImGui::Text("CPU reference took %.2f s", c.cpuSeconds);
            int showing = int(state.showing);
            ImGui::RadioButton("GPU", &showing, int(Showing::Traced));
            ImGui::SameLine();
            ImGui::RadioButton("CPU", &showing, int(Showing::Reference));
            ImGui::SameLine();
            ImGui::RadioButton("difference", &showing, int(Showing::Difference));
            state.showing = Showing(showing);
        }
    }
    if (ImGui::CollapsingHeader("Presentation")) {
        for (VkPresentModeKHR mode : info.presentModes)
            if (ImGui::RadioButton(toString(mode), info.presentMode == mode)) actions.presentMode = mode;
    }
    ImGui::End();
    return actions;
}

}  // namespace raypack::ui
