#pragma once
// What the viewer remembers between runs besides the bookmarks: the panel's layout and the recent
// files, in one small JSON file in the config folder beside bookmarks.json
// ($XDG_CONFIG_HOME/raypack/viewer.json or ~/.config/raypack/viewer.json, ui/bookmarks.h):
//   {"panel": {"width": 380, "collapsed": false, "ui_scale": 1.0, "overlay": false},
//    "recent_files": ["/abs/path/a.glb", ...]}
// A missing file gives the defaults silently; a broken one (not JSON, a field of the wrong type or
// out of range) gives the defaults for what is broken and one line saying what, never an
// exception, so a bad config file cannot stop the viewer from starting.
#include "ui/recent_files.h"

#include <string>

namespace raypack::ui {

// The panel's layout (ui/panel.h), in ImGui window units (screen coordinates before the
// framebuffer scale).
struct PanelLayout {
    static constexpr float kDefaultWidth = 380.0f;
    static constexpr float kMinWidth = 220.0f;
    static constexpr float kMaxWidth = 4096.0f;
    static constexpr float kMinUiScale = 0.5f;
    static constexpr float kMaxUiScale = 3.0f;

    float width = kDefaultWidth;
    bool collapsed = false;
    float uiScale = 1.0f;  // ImGui's font and style scale, for HiDPI screens
    bool overlay = false;  // the panel lies over the image (transparent) instead of beside it

    bool operator==(const PanelLayout&) const = default;
};

struct ViewerConfig {
    PanelLayout panel;
    RecentFiles recent;
};

// configDirectory()/viewer.json.
std::string viewerConfigFile();

struct ViewerConfigLoad {
    ViewerConfig config;
    std::string warning;  // empty, or one line naming the file and what was wrong with it
};
// Never throws (see the top of this file).
ViewerConfigLoad loadViewerConfig(const std::string& file);
// Writes the whole file (its folder created when missing) through a temporary file renamed over
// it, so a crash mid-write leaves the old file. Throws raypack::Error naming the file on failure.
void saveViewerConfig(const std::string& file, const ViewerConfig& config);

}  // namespace raypack::ui
