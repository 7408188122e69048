#pragma once
// Camera bookmarks: nine slots per scene (Ctrl+1..9 saves, 1..9 recalls), kept in one small JSON
// file in the user's config folder, $XDG_CONFIG_HOME/raypack/bookmarks.json or
// ~/.config/raypack/bookmarks.json:
//   {"<absolute scene path>": {"1": {"eye": [..], "at": [..], "up": [..], "fov_y_degrees": 60}, ...}}
#include "renderer/camera.h"

#include <array>
#include <optional>
#include <string>

namespace raypack::ui {

constexpr int kBookmarkSlots = 9;

// The folder the viewer keeps its files in (not created here).
std::string configDirectory();

// The arguments of `raypack-cli render` that give this view: "--eye x,y,z --at x,y,z --up x,y,z
// --fov F", each float printed so that it reads back to the same value.
std::string cameraCliArguments(const Camera& camera);

class BookmarkStore {
public:
    // Reads the bookmarks of `scenePath` from `file`. A missing file means no bookmarks; a file
    // that cannot be parsed throws raypack::Error naming it.
    BookmarkStore(std::string file, std::string scenePath);

    const std::optional<Camera>& slot(int number) const;  // number in 1..9
    // Stores the camera in the slot and writes the whole file (other scenes' entries kept).
    // Throws raypack::Error when the file cannot be written.
    void save(int number, const Camera& camera);

    const std::string& file() const { return file_; }

private:
    std::string file_;
    std::string sceneKey_;
    std::array<std::optional<Camera>, kBookmarkSlots> slots_;
};

}  // namespace raypack::ui
