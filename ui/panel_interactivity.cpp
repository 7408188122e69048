// The panel's "Interactivity" section (declared in ui/panel.h): which tracer draws and why, the
// frame budget and what the frame loop does with it.
#include "ui/panel.h"

#include "renderer/cpu_packet_tracer.h"

#include <imgui.h>

#include <algorithm>
#include <cinttypes>

namespace raypack::ui {

void drawInteractivitySection(PanelState& state, const PanelInfo& info, PanelActions& actions) {
    if (!ImGui::CollapsingHeader("Interactivity", ImGuiTreeNodeFlags_DefaultOpen)) return;
    if (ImGui::BeginCombo("tracer", toString(state.tracer))) {
        for (const TracerChoice t : info.tracers)
            if (ImGui::Selectable(toString(t), t == state.tracer) && t != state.tracer) {
                state.tracer = t;
                actions.tracerChanged = true;
            }
        ImGui::EndCombo();
    }
    if (!info.tracerReason.empty()) ImGui::TextWrapped("%s", info.tracerReason.c_str());
    ImGui::Checkbox("side by side: the right half traced by", &state.sideBySide);
    if (state.sideBySide) {
        if (ImGui::BeginCombo("right half", toString(state.sideBySideTracer))) {
            for (const TracerChoice t : info.tracers)
                if (ImGui::Selectable(toString(t), t == state.sideBySideTracer) && t != state.sideBySideTracer) {
                    state.sideBySideTracer = t;
                    state.sideBySidePacket = t == TracerChoice::CpuPacket ? kDefaultCpuPacket : PacketShape{};
                }
            ImGui::EndCombo();
        }
        if (tracesPackets(state.sideBySideTracer)) {
            int shape[2] = {int(state.sideBySidePacket.width), int(state.sideBySidePacket.height)};
            if (ImGui::InputInt2("right packet WxH", shape)) {
                shape[0] = std::clamp(shape[0], 1, 1024);
                shape[1] = std::clamp(shape[1], 1, 1024);
                if (state.sideBySideTracer == TracerChoice::CpuPacket ||
                    uint32_t(shape[0] * shape[1]) <= info.maxPacketRays)
                    state.sideBySidePacket = PacketShape{uint32_t(shape[0]), uint32_t(shape[1])};
            }
        }
        const SideBySideTimes& t = info.sideBySideTimes;
        if (t.width > 0)
            ImGui::Text("T_K left %.2f ms, right %.2f ms (%ux%u)", t.left * 1e3, t.right * 1e3, t.width, t.height);
    }

    FrameLoopSettings& loop = state.frameLoop;
    ImGui::SliderFloat("frame budget", &loop.frameBudgetMs, 5.0f, 500.0f, "%.0f ms", ImGuiSliderFlags_Logarithmic);
    ImGui::Checkbox("reduce resolution while moving", &loop.adaptiveResolution);
    int samples = int(loop.samples);
    if (ImGui::SliderInt("samples when still", &samples, 1, 256, "%d", ImGuiSliderFlags_Logarithmic))
        loop.samples = uint32_t(std::max(samples, 1));

    const FrameLoopStatus& st = info.frameLoop;
    if (st.lastKind == FrameKind::Moving && st.scale > 1)
        ImGui::Text("moving: 1/%u resolution (%ux%u traced)", st.scale,
                    (state.settings.width + st.scale - 1) / st.scale,
                    (state.settings.height + st.scale - 1) / st.scale);
    else if (st.samplesShown > 0 && st.samplesShown < st.samplesWanted)
        ImGui::Text("refining: %u of %u samples", st.samplesShown, st.samplesWanted);
    else if (st.samplesShown > 0)
        ImGui::Text("converged: %u samples per pixel, not tracing", st.samplesShown);
    else if (st.framesTraced > 0)
        ImGui::Text("full resolution");
    if (st.costMeasured)
        ImGui::Text("cost: %.2f ms per megapixel traced + %.1f ms a frame", st.secondsPerMegapixel * 1e3,
                    st.fixedSeconds * 1e3);
    else
        ImGui::TextDisabled("cost: not measured yet (no frame traced)");
    ImGui::TextDisabled("%" PRIu64 " frames traced, %" PRIu64 " presented", st.framesTraced, st.framesPresented);
}

}  // namespace raypack::ui
