#pragma once
// The viewer's recent files: the last kMaxEntries scene files opened, most recent first, each
// once. They are kept in the viewer's config file (ui/viewer_config.h) beside the bookmarks;
// files that no longer exist are pruned when the list is shown. Generator specs (gen:...) are not
// files and are not recorded.
#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>
#include <vector>

namespace raypack::ui {

class RecentFiles {
public:
    static constexpr size_t kMaxEntries = 10;

    // A file that was just opened: moves to the front (absolute, normalized, so that two spellings
    // of one file are one entry); the oldest falls off past kMaxEntries. Returns false (and
    // changes nothing) for what is not an existing regular file, e.g. a generator spec.
    bool add(const std::string& path);
    // Drops the entries whose file no longer exists. Returns whether any was dropped.
    bool pruneMissing();
    const std::vector<std::string>& entries() const { return entries_; }

    // The JSON form is an array of paths, most recent first. fromJson keeps the strings of an
    // array (no file-system check, so a file on an unmounted disk comes back when the disk does),
    // drops duplicates and what is past kMaxEntries, and throws raypack::Error for a value that
    // is not an array of strings.
    nlohmann::json toJson() const;
    static RecentFiles fromJson(const nlohmann::json& value);

private:
    std::vector<std::string> entries_;
};

}  // namespace raypack::ui
