#include "ui/script.h"

#include "renderer/error.h"
#include "renderer/progressive.h"
#include "renderer/settings_text.h"
#include "ui/bookmarks.h"

#include <algorithm>
#include <charconv>
#include <iterator>

namespace raypack::ui {
namespace {

struct ActionName {
    ScriptAction action;
    const char* name;
};
constexpr ActionName kActionNames[] = {
    {ScriptAction::Resize, "resize"},
    {ScriptAction::Packet, "packet"},
    {ScriptAction::LeafSize, "leaf-size"},
    {ScriptAction::Builder, "builder"},
    {ScriptAction::Shadows, "shadows"},
    {ScriptAction::Kernel, "kernel"},
    {ScriptAction::Intersect, "intersect"},
    {ScriptAction::Tracer, "tracer"},
    {ScriptAction::SideBySide, "side-by-side"},
    {ScriptAction::View, "view"},
    {ScriptAction::Open, "open"},
    {ScriptAction::Wait, "wait"},
    {ScriptAction::Screenshot, "screenshot"},
    {ScriptAction::WindowScreenshot, "window-screenshot"},
    {ScriptAction::Move, "move"},
    {ScriptAction::Look, "look"},
    {ScriptAction::Bookmark, "bookmark"},
    {ScriptAction::SaveBookmark, "save-bookmark"},
    {ScriptAction::FrameAll, "frame-all"},
    {ScriptAction::Scale, "scale"},
    {ScriptAction::Samples, "samples"},
    {ScriptAction::Budget, "budget"},
};

// The highest forced resolution scale: a 1/64 image of a 4K window is still 60x34 pixels.
constexpr uint32_t kMaxScriptScale = 64;

// Decodes the step's value; throws raypack::Error `ACTION: ...` (the caller adds the step).
void decodeValue(ScriptStep& step) {
    const std::string what = toString(step.action);
    const std::string& value = step.value;
    const auto needsValue = [&] {
        if (value.empty()) throw Error(what + " needs a value");
    };
    const auto takesNone = [&] {
        if (!value.empty()) throw Error(what + " takes no value, got \"" + value + "\"");
    };
    switch (step.action) {
    case ScriptAction::Resize:
    case ScriptAction::Packet: step.shape = parsePacketShape(what, value); break;
    case ScriptAction::LeafSize:
    case ScriptAction::Samples:
    case ScriptAction::Budget: step.number = parsePositiveCount(what, value); break;
    case ScriptAction::Builder: step.builder = parseBvhBuilder(value); break;
    case ScriptAction::Shadows:
        if (value != "on" && value != "off") throw Error(what + ": \"" + value + "\" is not on or off");
        step.on = value == "on";
        break;
    case ScriptAction::Kernel: step.kernel = requireKernelKind(what, value); break;
    case ScriptAction::Intersect: step.intersect = requireIntersectMode(what, value); break;
    case ScriptAction::Tracer: step.tracer = requireTracerChoice(what, value); break;
    case ScriptAction::SideBySide:
        step.on = value != "off";
        if (step.on) step.tracer = requireTracerChoice(what, value);
        break;
    case ScriptAction::View: step.view = requireViewMode(what, value); break;
    case ScriptAction::Open:
    case ScriptAction::Screenshot:
    case ScriptAction::WindowScreenshot: needsValue(); break;
    case ScriptAction::Wait:
    case ScriptAction::FrameAll: takesNone(); break;
    case ScriptAction::Move: step.move = parseVec3(what, value); break;
    case ScriptAction::Look: step.look = parseVec2(what, value); break;
    case ScriptAction::Bookmark:
    case ScriptAction::SaveBookmark:
        step.number = parsePositiveCount(what, value);
        if (step.number > uint32_t(kBookmarkSlots))
            throw Error(what + ": slot " + value + " is not 1.." + std::to_string(kBookmarkSlots));
        break;
    case ScriptAction::Scale:
        step.number = parsePositiveCount(what, value);
        if (step.number > kMaxScriptScale)
            throw Error(what + ": " + value + " is above " + std::to_string(kMaxScriptScale));
        break;
    }
}

}  // namespace

const char* toString(ScriptAction action) {
    for (const ActionName& entry : kActionNames)
        if (entry.action == action) return entry.name;
    return "?";
}

ScriptStep parseScriptStep(std::string_view text) {
    const std::string quoted = "script step \"" + std::string(text) + "\"";
    const size_t first = text.find(':');
    if (first == std::string_view::npos) throw Error(quoted + ": expected FRAME:ACTION[:VALUE]");
    ScriptStep step;
    const std::string_view frame = text.substr(0, first);
    const auto [end, ec] = std::from_chars(frame.data(), frame.data() + frame.size(), step.frame);
    if (frame.empty() || ec != std::errc() || end != frame.data() + frame.size())
        throw Error(quoted + ": \"" + std::string(frame) + "\" is not a frame number");
    const size_t second = text.find(':', first + 1);
    const std::string_view action =
        text.substr(first + 1, second == std::string_view::npos ? std::string_view::npos : second - first - 1);
    if (action.empty()) throw Error(quoted + ": no action");
    const auto named = std::find_if(std::begin(kActionNames), std::end(kActionNames),
                                    [&](const ActionName& entry) { return action == entry.name; });
    if (named == std::end(kActionNames)) throw Error(quoted + ": unknown action \"" + std::string(action) + "\"");
    step.action = named->action;
    if (second != std::string_view::npos) step.value = std::string(text.substr(second + 1));
    try {
        decodeValue(step);
    } catch (const Error& e) {
        throw Error(quoted + ": " + e.what());
    }
    return step;
}

void applyScriptStep(const ScriptStep& step, PanelState& panel, PanelActions& actions, ScriptEffects& effects) {
    switch (step.action) {
    case ScriptAction::Resize: effects.resize = step.shape; break;
    case ScriptAction::Packet: panel.settings.packet = step.shape; break;
    case ScriptAction::LeafSize:
        panel.bvh.leafSize = step.number;
        actions.rebuild = true;
        break;
    case ScriptAction::Builder:
        panel.bvh.builder = step.builder;
        actions.rebuild = true;
        break;
    case ScriptAction::Shadows: panel.settings.shadows = step.on; break;
    case ScriptAction::Kernel:
        // As the panel's kernel buttons: they pick among the Vulkan kernels; a CPU tracer keeps
        // drawing and the kernel is the one a later switch to Vulkan starts with.
        panel.settings.kernel = step.kernel;
        if (!isCpuTracer(panel.tracer)) effects.tracer = vulkanTracerFor(step.kernel);
        break;
    case ScriptAction::Intersect: panel.settings.intersect = step.intersect; break;
    case ScriptAction::Tracer: effects.tracer = step.tracer; break;
    case ScriptAction::SideBySide:
        if (step.on)
            effects.sideBySide = step.tracer;
        else
            panel.sideBySide = false;
        break;
    case ScriptAction::View: panel.settings.view = step.view; break;
    case ScriptAction::Open: effects.open = step.value; break;
    case ScriptAction::Wait: effects.wait = true; break;
    case ScriptAction::Screenshot: effects.screenshot = step.value; break;
    case ScriptAction::WindowScreenshot: effects.windowScreenshot = step.value; break;
    case ScriptAction::Move: effects.input.heldSeconds += step.move; break;
    case ScriptAction::Look: effects.input.lookPixels += step.look; break;
    case ScriptAction::Bookmark: actions.recallBookmark = int(step.number); break;
    case ScriptAction::SaveBookmark: actions.saveBookmark = int(step.number); break;
    case ScriptAction::FrameAll: actions.frameAll = true; break;
    case ScriptAction::Scale: effects.scale = step.number; break;
    case ScriptAction::Samples: panel.frameLoop.samples = std::min(step.number, kMaxSamplesPerPixel); break;
    case ScriptAction::Budget: panel.frameLoop.frameBudgetMs = float(step.number); break;
    }
}

}  // namespace raypack::ui
