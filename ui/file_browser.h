#pragma once
// The viewer's file dialog: a small ImGui directory browser (no dependency beyond ImGui). It lists
// a folder's sub-folders and scene files (.ply .obj .gltf .glb, or one format, or every file),
// goes up, takes a typed path (a folder to enter or a file to open, relative to the folder shown,
// ~ for the home folder), and hands back the chosen file once, as the panel's open action.
//
// The listing and the navigation are plain functions and methods over the file system, apart
// from the drawing (FileBrowser::draw), so they are testable headless.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace raypack::ui {

struct FileFilter {
    const char* label;
    std::vector<std::string> extensions;  // lower case with the dot; empty: every file
};
// 0: scene files (every format raypack opens), then one per format, last: every file.
const std::vector<FileFilter>& fileFilters();

// Whether `name` ends in one of `extensions` (case-insensitive); true for an empty list.
bool matchesFilter(const std::string& name, const std::vector<std::string>& extensions);

struct DirectoryEntry {
    std::string name;  // file name only
    bool directory = false;
    uintmax_t bytes = 0;  // files only
};

struct DirectoryListing {
    std::string directory;                // absolute, normalized
    std::vector<DirectoryEntry> entries;  // folders first, then files, each by name ignoring case
    std::string error;                    // empty, or one line naming the folder and why it could not be listed
};

// The folders and the files matching `filter` (an index into fileFilters()) of `directory`.
// Names starting with '.' are left out unless `showHidden`; entries that cannot be examined
// (a dangling link, no permission) are left out. Never throws.
DirectoryListing listDirectory(const std::string& directory, size_t filter = 0, bool showHidden = false);

class FileBrowser {
public:
    // Shows the browser on `directory` (or, when it is a file, the folder holding it; the current
    // folder when it names nothing that exists).
    void open(const std::string& directory);
    void close() { visible_ = false; }
    bool isOpen() const { return visible_; }

    // Navigation, each re-listing the folder. navigate returns false (and keeps the folder shown,
    // with the reason in error()) when `directory` is not a folder that can be listed.
    bool navigate(const std::string& directory);
    void up();
    void setFilter(size_t filter);
    // The typed path, relative to the folder shown: a folder is entered (nullopt back), an
    // existing file is chosen (its absolute path back, and the browser closes); anything else
    // leaves an error and gives nullopt.
    std::optional<std::string> submit(const std::string& typed);
    // Entry `index` of the listing: a folder is entered, a file chosen as by submit.
    std::optional<std::string> activate(size_t index);

    const DirectoryListing& listing() const { return listing_; }
    size_t filter() const { return filter_; }
    const std::string& error() const { return error_; }

    // Draws the browser's window when it is open; returns the chosen file in the frame it is
    // chosen (a double-click on it, Open on the selected one, or Enter in the path field), nullopt
    // otherwise. One click enters a folder.
    std::optional<std::string> draw();

private:
    void relist();

    bool visible_ = false;
    bool justOpened_ = false;
    DirectoryListing listing_;
    size_t filter_ = 0;
    std::string typed_;
    std::string error_;
    std::optional<size_t> selected_;
};

}  // namespace raypack::ui
