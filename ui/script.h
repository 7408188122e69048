#pragma once
// Scripted runs of the viewer (`raypack --script FRAME:ACTION[:VALUE]`): each step is parsed and
// its value checked when the viewer starts, so a malformed step is refused before a window opens;
// at its frame a step edits the panel's state and actions exactly as the panel's controls would
// (the session then applies them through one path), and hands what the panel has no control for
// (window size, flight input, a forced resolution scale, screenshots) to the session as effects.
// Values are read by renderer/settings_text.h, with the rules of the command-line flags.
#include "renderer/bvh.h"
#include "renderer/settings.h"
#include "ui/fly_camera.h"
#include "ui/frame_loop.h"
#include "ui/panel.h"

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace raypack::ui {

// resize WxH | packet WxH | leaf-size N | builder NAME | shadows on|off | kernel packet|single |
// intersect robust|fast |
// tracer NAME | side-by-side TRACER|off | view shaded|nodes|tests | open SCENE | wait (block until
// the worker is idle) | screenshot FILE.png | window-screenshot FILE.png | move RIGHT,UP,FORWARD
// (seconds of flight along the camera's axes, as held keys; one frame's step is bounded as for
// keys) | look DX,DY (mouse-look pixels, as a right-button drag) | bookmark N (recall) |
// save-bookmark N | frame-all | scale S (trace this frame at 1/S resolution, as while moving) |
// samples N | budget MS
enum class ScriptAction {
    Resize,
    Packet,
    LeafSize,
    Builder,
    Shadows,
    Kernel,
    Intersect,
    Tracer,
    SideBySide,
    View,
    Open,
    Wait,
    Screenshot,
    WindowScreenshot,
    Move,
    Look,
    Bookmark,
    SaveBookmark,
    FrameAll,
    Scale,
    Samples,
    Budget,
};
const char* toString(ScriptAction action);  // the name a step is written with, "leaf-size"

// One step, applied before frame `frame` (counted from 0), with its value decoded.
struct ScriptStep {
    uint32_t frame = 0;
    ScriptAction action = ScriptAction::Wait;
    std::string value;    // as written, for the log and for paths (open, screenshots)
    PacketShape shape;    // resize, packet
    uint32_t number = 0;  // leaf-size, bookmark slot, scale, samples, budget
    BvhBuilder builder = BvhBuilder::SahExact;
    bool on = false;  // shadows; side-by-side (false: off)
    KernelKind kernel = KernelKind::Packet;
    IntersectMode intersect = IntersectMode::Robust;
    TracerChoice tracer = TracerChoice::VulkanPacket;  // tracer, side-by-side
    ViewMode view = ViewMode::Shaded;
    glm::vec3 move{0.0f};
    glm::vec2 look{0.0f};
};
// Parses "FRAME:ACTION[:VALUE]" and checks the value; throws raypack::Error naming the step and
// what is wrong ("script step \"3:packet:0x4\": packet: \"0x4\" is not a packet shape ...").
ScriptStep parseScriptStep(std::string_view text);

// What a step does that is not the panel's: the session applies these after the panel's actions.
struct ScriptEffects {
    std::optional<PacketShape> resize;       // window size
    std::optional<TracerChoice> tracer;      // who draws (packet shapes belong to the tracer)
    std::optional<TracerChoice> sideBySide;  // the right half's tracer (off: PanelState::sideBySide)
    std::string open;                        // a scene to load
    bool wait = false;                       // block until the worker is idle, take its results
    std::string screenshot, windowScreenshot;
    std::optional<uint32_t> scale;  // this frame's resolution scale
    FlyInput input;                 // scripted flight: heldSeconds, lookPixels
};

// Applies `step` to the panel's state and actions as the panel's controls would, and what the
// panel has no control for to `effects`.
void applyScriptStep(const ScriptStep& step, PanelState& panel, PanelActions& actions, ScriptEffects& effects);

}  // namespace raypack::ui
