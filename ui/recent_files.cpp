#include "ui/recent_files.h"

#include "renderer/error.h"

#include <algorithm>
#include <filesystem>

namespace raypack::ui {

namespace fs = std::filesystem;

namespace {

std::string normalized(const std::string& path) {
    std::error_code error;
    const fs::path canonical = fs::weakly_canonical(fs::absolute(path, error), error);
    return error ? fs::absolute(path).lexically_normal().string() : canonical.string();
}

}  // namespace

bool RecentFiles::add(const std::string& path) {
    std::error_code error;
    if (path.empty() || !fs::is_regular_file(path, error)) return false;
    const std::string entry = normalized(path);
    std::erase(entries_, entry);
    entries_.insert(entries_.begin(), entry);
    if (entries_.size() > kMaxEntries) entries_.resize(kMaxEntries);
    return true;
}

bool RecentFiles::pruneMissing() {
    const size_t before = entries_.size();
    std::erase_if(entries_, [](const std::string& path) {
        std::error_code error;
        return !fs::is_regular_file(path, error);
    });
    return entries_.size() != before;
}

nlohmann::json RecentFiles::toJson() const { return nlohmann::json(entries_); }

RecentFiles RecentFiles::fromJson(const nlohmann::json& value) {
    if (!value.is_array()) throw Error("recent_files is not an array of paths");
    RecentFiles recent;
    for (const nlohmann::json& item : value) {
        if (!item.is_string()) throw Error("recent_files holds " + item.dump() + ", not a path");
        const std::string path = item.get<std::string>();
        if (path.empty() || std::find(recent.entries_.begin(), recent.entries_.end(), path) != recent.entries_.end())
            continue;
        if (recent.entries_.size() < kMaxEntries) recent.entries_.push_back(path);
    }
    return recent;
}

}  // namespace raypack::ui
