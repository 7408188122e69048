#include "ui/file_browser.h"

#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <cctype>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

namespace raypack::ui {

namespace fs = std::filesystem;

namespace {

std::string lowerCase(std::string text) {
    std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return text;
}

// Absolute and normalized, without a trailing separator (except for the root).
std::string normalizedDirectory(const fs::path& path) {
    std::error_code error;
    fs::path result = fs::weakly_canonical(fs::absolute(path, error), error);
    if (error) result = fs::absolute(path).lexically_normal();
    std::string text = result.string();
    while (text.size() > 1 && text.back() == '/') text.pop_back();
    return text;
}

// "~" and "~/x" name the home folder.
fs::path expandHome(const std::string& typed) {
    const char* home = std::getenv("HOME");
    if (home && *home && (typed == "~" || typed.rfind("~/", 0) == 0))
        return fs::path(home) / typed.substr(std::min<size_t>(2, typed.size()));
    return typed;
}

std::string humanBytes(uintmax_t bytes) {
    char text[32];
    if (bytes < 1024)
        std::snprintf(text, sizeof text, "%ju B", bytes);
    else if (bytes < 1024u * 1024u)
        std::snprintf(text, sizeof text, "%.1f KiB", double(bytes) / 1024.0);
    else if (bytes < 1024ull * 1024u * 1024u)
        std::snprintf(text, sizeof text, "%.1f MiB", double(bytes) / (1024.0 * 1024.0));
    else
        std::snprintf(text, sizeof text, "%.2f GiB", double(bytes) / (1024.0 * 1024.0 * 1024.0));
    return text;
}

}  // namespace

const std::vector<FileFilter>& fileFilters() {
    static const std::vector<FileFilter> filters = {
        {"scene files (.ply .obj .gltf .glb)", {".ply", ".obj", ".gltf", ".glb"}},
        {"PLY (.ply)", {".ply"}},
        {"OBJ (.obj)", {".obj"}},
        {"glTF (.gltf .glb)", {".gltf", ".glb"}},
        {"every file", {}},
    };
    return filters;
}

bool matchesFilter(const std::string& name, const std::vector<std::string>& extensions) {
    if (extensions.empty()) return true;
    const std::string lower = lowerCase(name);
    return std::any_of(extensions.begin(), extensions.end(), [&](const std::string& extension) {
        return lower.size() > extension.size() &&
               lower.compare(lower.size() - extension.size(), extension.size(), extension) == 0;
    });
}

DirectoryListing listDirectory(const std::string& directory, size_t filter, bool showHidden) {
    DirectoryListing listing;
    listing.directory = normalizedDirectory(directory.empty() ? fs::path(".") : fs::path(directory));
    const std::vector<std::string>& extensions = fileFilters()[std::min(filter, fileFilters().size() - 1)].extensions;
    std::error_code error;
    fs::directory_iterator it(listing.directory, fs::directory_options::skip_permission_denied, error);
    if (error) {
        listing.error = listing.directory + ": cannot be listed: " + error.message();
        return listing;
    }
    for (; it != fs::directory_iterator(); it.increment(error)) {
        if (error) {
            listing.error = listing.directory + ": listing stopped: " + error.message();
            break;
        }
        const std::string name = it->path().filename().string();
        if (!showHidden && !name.empty() && name[0] == '.') continue;
        std::error_code entryError;
        const fs::file_status status = it->status(entryError);  // follows links
        if (entryError) continue;
        if (fs::is_directory(status)) {
            listing.entries.push_back({name, true, 0});
        } else if (fs::is_regular_file(status) && matchesFilter(name, extensions)) {
            const uintmax_t bytes = it->file_size(entryError);
            listing.entries.push_back({name, false, entryError ? 0 : bytes});
        }
    }
    std::sort(listing.entries.begin(), listing.entries.end(), [](const DirectoryEntry& a, const DirectoryEntry& b) {
        if (a.directory != b.directory) return a.directory;
        const std::string la = lowerCase(a.name), lb = lowerCase(b.name);
        return la != lb ? la < lb : a.name < b.name;
    });
    return listing;
}

void FileBrowser::open(const std::string& directory) {
    std::error_code error;
    fs::path start = directory.empty() ? fs::current_path(error) : fs::path(directory);
    if (fs::is_regular_file(start, error)) start = fs::absolute(start, error).parent_path();
    if (!fs::is_directory(start, error)) start = fs::current_path(error);
    visible_ = true;
    justOpened_ = true;
    error_.clear();
    navigate(start.string());
}

void FileBrowser::relist() {
    listing_ = listDirectory(listing_.directory, filter_);
    selected_.reset();
}

bool FileBrowser::navigate(const std::string& directory) {
    std::error_code error;
    if (!fs::is_directory(directory, error)) {
        error_ = directory + ": not a folder";
        return false;
    }
    DirectoryListing listing = listDirectory(directory, filter_);
    if (!listing.error.empty() && listing.entries.empty()) {
        error_ = listing.error;
        return false;
    }
    listing_ = std::move(listing);
    typed_ = listing_.directory;
    error_.clear();
    selected_.reset();
    return true;
}

void FileBrowser::up() {
    const fs::path current(listing_.directory);
    if (current.has_parent_path() && current.parent_path() != current) navigate(current.parent_path().string());
}

void FileBrowser::setFilter(size_t filter) {
    filter_ = std::min(filter, fileFilters().size() - 1);
    relist();
}

std::optional<std::string> FileBrowser::submit(const std::string& typed) {
    if (typed.empty()) return std::nullopt;
    fs::path path = expandHome(typed);
    if (path.is_relative()) path = fs::path(listing_.directory) / path;
    std::error_code error;
    if (fs::is_directory(path, error)) {
        navigate(path.string());
        return std::nullopt;
    }
    if (fs::is_regular_file(path, error)) {
        visible_ = false;
        error_.clear();
        return fs::absolute(path).lexically_normal().string();
    }
    error_ = path.lexically_normal().string() + ": no such file or folder";
    return std::nullopt;
}

std::optional<std::string> FileBrowser::activate(size_t index) {
    if (index >= listing_.entries.size()) return std::nullopt;
    return submit((fs::path(listing_.directory) / listing_.entries[index].name).string());
}

std::optional<std::string> FileBrowser::draw() {
    if (!visible_) return std::nullopt;
    std::optional<std::string> chosen;
    const ImGuiViewport* viewport = ImGui::GetMainViewport();
    ImGui::SetNextWindowPos(
        ImVec2(viewport->WorkPos.x + viewport->WorkSize.x * 0.5f, viewport->WorkPos.y + viewport->WorkSize.y * 0.5f),
        ImGuiCond_Appearing, ImVec2(0.5f, 0.5f));
    ImGui::SetNextWindowSize(ImVec2(600, 440), ImGuiCond_FirstUseEver);
    if (justOpened_) ImGui::SetNextWindowFocus();
    justOpened_ = false;
    if (!ImGui::Begin("Open a scene###raypack-file-browser", &visible_, ImGuiWindowFlags_NoCollapse)) {
        ImGui::End();
        return std::nullopt;
    }
    if (ImGui::Button("Up")) up();
    ImGui::SameLine();
    ImGui::SetNextItemWidth(-1);
    if (ImGui::InputText("##browser-path", &typed_, ImGuiInputTextFlags_EnterReturnsTrue)) chosen = submit(typed_);

    ImGui::SetNextItemWidth(ImGui::GetContentRegionAvail().x * 0.6f);
    if (ImGui::BeginCombo("filter", fileFilters()[filter_].label)) {
        for (size_t i = 0; i < fileFilters().size(); ++i)
            if (ImGui::Selectable(fileFilters()[i].label, i == filter_)) setFilter(i);
        ImGui::EndCombo();
    }
    const std::string& problem = !error_.empty() ? error_ : listing_.error;
    if (!problem.empty()) {
        ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.45f, 0.4f, 1.0f));
        ImGui::TextWrapped("%s", problem.c_str());
        ImGui::PopStyleColor();
    }

    const float buttonRow = ImGui::GetFrameHeightWithSpacing();
    if (ImGui::BeginChild("##entries", ImVec2(0, -buttonRow), true)) {
        if (listing_.entries.empty()) ImGui::TextDisabled("no folders or matching files here");
        for (size_t i = 0; i < listing_.entries.size() && !chosen; ++i) {
            const DirectoryEntry& entry = listing_.entries[i];
            const std::string label = entry.directory ? "[dir]  " + entry.name + "/" : "       " + entry.name;
            ImGui::PushID(int(i));
            // A folder is entered on one click: a double-click needs two clicks within 0.3 s of
            // ImGui's clock, which a viewer drawing a frame every few seconds (lavapipe) never
            // sees. A file is selected by one click, opened by a double-click or Open.
            if (ImGui::Selectable(label.c_str(), selected_ == i, ImGuiSelectableFlags_AllowDoubleClick)) {
                selected_ = i;
                if (entry.directory) {
                    activate(i);
                    ImGui::PopID();
                    break;  // the listing changed under the loop
                }
                if (ImGui::IsMouseDoubleClicked(ImGuiMouseButton_Left)) chosen = activate(i);
            }
            if (!entry.directory) {
                ImGui::SameLine(ImGui::GetContentRegionAvail().x - 80.0f);
                ImGui::TextDisabled("%s", humanBytes(entry.bytes).c_str());
            }
            ImGui::PopID();
        }
    }
    ImGui::EndChild();

    const bool canOpen = selected_.has_value() && *selected_ < listing_.entries.size();
    if (!canOpen) ImGui::BeginDisabled();
    if (ImGui::Button("Open") && canOpen) chosen = activate(*selected_);
    if (!canOpen) ImGui::EndDisabled();
    ImGui::SameLine();
    if (ImGui::Button("Cancel")) visible_ = false;
    ImGui::SameLine();
    ImGui::TextDisabled("click a folder to enter it; double-click a file or select it and Open");
    ImGui::End();
    return chosen;
}

}  // namespace raypack::ui
