#include "ui/screenshot.h"

#include <ctime>
#include <filesystem>

namespace raypack::ui {

namespace fs = std::filesystem;

std::string sidecarPath(const std::string& pngPath) { return fs::path(pngPath).replace_extension(".json").string(); }

void writeScreenshot(const std::string& pngPath, const Image& image, const RenderSetup& setup,
                     const nlohmann::json& statistics, const std::string& deviceKind) {
    writePng(pngPath, image);
    nlohmann::json sidecar = toJson(setup);
    if (!deviceKind.empty()) sidecar["device_kind"] = deviceKind;
    sidecar["image"] = fs::path(pngPath).filename().string();
    sidecar["stats"] = statistics;
    writeJsonFile(sidecarPath(pngPath), sidecar);
}

std::string nextScreenshotName() {
    const std::time_t now = std::time(nullptr);
    std::tm local{};
    localtime_r(&now, &local);
    char stamp[32];
    std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &local);
    std::string name = std::string("raypack-") + stamp + ".png";
    for (int n = 2; fs::exists(name); ++n) name = std::string("raypack-") + stamp + "-" + std::to_string(n) + ".png";
    return name;
}

}  // namespace raypack::ui
