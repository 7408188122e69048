#include "ui/viewer_config.h"

#include "renderer/error.h"
#include "ui/bookmarks.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>

namespace raypack::ui {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Reads one field of the panel object into `value` when present and of the right type, clamped to
// [lo, hi]; otherwise leaves the default and notes what was wrong in `problems`.
void readNumber(const json& panel, const char* key, float& value, float lo, float hi, std::string& problems) {
    if (!panel.contains(key)) return;
    const json& field = panel[key];
    if (!field.is_number()) {
        problems += std::string(problems.empty() ? "" : "; ") + "panel." + key + " is not a number";
        return;
    }
    const double number = field.get<double>();
    if (!(number >= lo && number <= hi)) {
        problems += std::string(problems.empty() ? "" : "; ") + "panel." + key + " = " + field.dump() +
                    " is outside [" + json(lo).dump() + ", " + json(hi).dump() + "]";
        return;
    }
    value = float(number);
}

void readBool(const json& panel, const char* key, bool& value, std::string& problems) {
    if (!panel.contains(key)) return;
    if (!panel[key].is_boolean()) {
        problems += std::string(problems.empty() ? "" : "; ") + "panel." + key + " is not true or false";
        return;
    }
    value = panel[key].get<bool>();
}

}  // namespace

std::string viewerConfigFile() { return (fs::path(configDirectory()) / "viewer.json").string(); }

ViewerConfigLoad loadViewerConfig(const std::string& file) {
    ViewerConfigLoad result;
    std::error_code error;
    if (!fs::exists(file, error)) return result;
    std::ifstream in(file, std::ios::binary);
    if (!in) {
        result.warning = file + ": cannot be read; using the default panel layout and no recent files";
        return result;
    }
    const json all = json::parse(in, nullptr, /*allow_exceptions=*/false);
    if (all.is_discarded() || !all.is_object()) {
        result.warning = file + ": " + (all.is_discarded() ? "not valid JSON" : "not a JSON object") +
                         "; using the default panel layout and no recent files";
        return result;
    }
    std::string problems;
    if (all.contains("panel")) {
        const json& panel = all["panel"];
        if (!panel.is_object()) {
            problems = "panel is not an object";
        } else {
            PanelLayout& layout = result.config.panel;
            readNumber(panel, "width", layout.width, PanelLayout::kMinWidth, PanelLayout::kMaxWidth, problems);
            readBool(panel, "collapsed", layout.collapsed, problems);
            readNumber(panel, "ui_scale", layout.uiScale, PanelLayout::kMinUiScale, PanelLayout::kMaxUiScale, problems);
            readBool(panel, "overlay", layout.overlay, problems);
        }
    }
    if (all.contains("recent_files")) {
        try {
            result.config.recent = RecentFiles::fromJson(all["recent_files"]);
        } catch (const Error& e) {
            problems += std::string(problems.empty() ? "" : "; ") + e.what();
        }
    }
    if (!problems.empty()) result.warning = file + ": " + problems + "; using the defaults for those";
    return result;
}

void saveViewerConfig(const std::string& file, const ViewerConfig& config) {
    const PanelLayout& p = config.panel;
    const json all = {
        {"panel", {{"width", p.width}, {"collapsed", p.collapsed}, {"ui_scale", p.uiScale}, {"overlay", p.overlay}}},
        {"recent_files", config.recent.toJson()},
    };
    std::error_code error;
    const fs::path path(file);
    if (path.has_parent_path()) {
        fs::create_directories(path.parent_path(), error);
        if (error) throw Error(file + ": cannot create its folder: " + error.message());
    }
    const fs::path temporary = path.string() + ".tmp";
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        out << all.dump(2) << "\n";
        out.close();
        if (!out) throw Error(file + ": cannot be written");
    }
    fs::rename(temporary, path, error);
    if (error) {
        const std::string message = error.message();
        fs::remove(temporary, error);
        throw Error(file + ": cannot be written: " + message);
    }
}

}  // namespace raypack::ui
