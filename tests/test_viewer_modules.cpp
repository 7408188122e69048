// The viewer's modules that work without a window: the orbit camera (ui/orbit_camera.h), the
// pick of the point under a pixel (renderer/pick.h), the recent files and the config file
// (ui/recent_files.h, ui/viewer_config.h), the file browser's listing and navigation
// (ui/file_browser.h), and the panel's layout rules (ui/panel.h), drawn by ImGui without a
// renderer backend.
#include "renderer/bvh.h"
#include "renderer/camera.h"
#include "renderer/cpu_tracer.h"
#include "renderer/error.h"
#include "renderer/pick.h"
#include "scenes/load.h"
#include "ui/file_browser.h"
#include "ui/fly_camera.h"
#include "ui/orbit_camera.h"
#include "ui/panel.h"
#include "ui/pointer.h"
#include "ui/recent_files.h"
#include "ui/run_statistics.h"
#include "ui/script.h"
#include "ui/viewer_config.h"

#include <gtest/gtest.h>
#include <imgui.h>
#include <imgui_internal.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

namespace raypack {
namespace {

namespace fs = std::filesystem;
using ui::OrbitCamera;
using ui::OrbitInput;

// ---- Helpers

Aabb unitBox() {
    Aabb bounds;
    bounds.grow(glm::vec3(-1.0f));
    bounds.grow(glm::vec3(1.0f));
    return bounds;
}

// Where a world point lands in a width x height image of `camera`, in pixel coordinates whose
// pixel centres are at +0.5 (the inverse of shaders/camera.h).
glm::vec2 project(const Camera& camera, uint32_t width, uint32_t height, const glm::vec3& point) {
    const GpuCamera c = makeGpuCamera(camera, width, height);
    const glm::vec3 d = point - glm::vec3(c.eye);
    const float depth = glm::dot(d, glm::vec3(c.forward));
    const float u = glm::dot(d, glm::vec3(c.right)) / depth;
    const float v = glm::dot(d, glm::vec3(c.up)) / depth;
    // shaders/camera.h: u = x step + u0 (eye.w, right.w), v = v0 - y step (up.w, forward.w).
    return {(u - c.right.w) / c.eye.w + 0.5f, (c.up.w - v) / c.forward.w + 0.5f};
}

float viewPitch(const Camera& camera) {
    const glm::vec3 forward = glm::normalize(camera.at - camera.eye);
    return std::asin(glm::dot(forward, glm::normalize(camera.up)));
}

// A folder of its own under the temporary folder, removed at the end of the test. The process id is
// part of its name: ctest runs every test as a process of its own, two at a time, and two tests of
// one fixture would otherwise share (and remove) one folder.
struct TempFolder {
    fs::path path;
    explicit TempFolder(const std::string& name)
        : path(fs::temp_directory_path() / ("raypack_test_" + name + "_" + std::to_string(getpid()))) {
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~TempFolder() { fs::remove_all(path); }
    fs::path file(const std::string& name, const std::string& text = "x") const {
        const fs::path p = path / name;
        fs::create_directories(p.parent_path());
        std::ofstream(p) << text;
        return p;
    }
};

// ---- Orbit camera

TEST(OrbitCamera, OrbitKeepsTheDistanceAndThePivotOnItsPixel) {
    const Aabb bounds = unitBox();
    OrbitCamera orbit;
    const glm::vec3 pivot(0.3f, -0.2f, 0.1f);  // off the view axis: a picked point
    orbit.reset(frameScene(bounds), bounds, pivot);
    const Camera before = orbit.camera();
    const glm::vec2 pixelBefore = project(before, 800, 600, pivot);
    ASSERT_TRUE(orbit.update(OrbitInput{glm::vec2(120.0f, -45.0f)}));
    const Camera& after = orbit.camera();
    EXPECT_EQ(orbit.pivot(), pivot);
    EXPECT_NEAR(glm::length(after.eye - pivot), glm::length(before.eye - pivot), 1e-4f);
    EXPECT_NEAR(glm::length(after.at - after.eye), glm::length(before.at - before.eye), 1e-4f);
    EXPECT_EQ(after.up, before.up);
    EXPECT_EQ(after.fovYDegrees, before.fovYDegrees);
    const glm::vec2 pixelAfter = project(after, 800, 600, pivot);
    EXPECT_NEAR(pixelAfter.x, pixelBefore.x, 0.01f);
    EXPECT_NEAR(pixelAfter.y, pixelBefore.y, 0.01f);
    EXPECT_GT(glm::length(after.eye - before.eye), 0.1f) << "the camera moved";
}

TEST(OrbitCamera, DraggingRightMovesTheCameraLeftAndDraggingDownMovesItUp) {
    const Aabb bounds = unitBox();
    OrbitCamera orbit;
    orbit.reset(frameScene(bounds), bounds);
    const Camera start = orbit.camera();
    const glm::vec3 forward = glm::normalize(start.at - start.eye);
    const glm::vec3 right = glm::normalize(glm::cross(forward, start.up));
    orbit.update(OrbitInput{glm::vec2(50.0f, 0.0f)});
    EXPECT_LT(glm::dot(orbit.camera().eye - start.eye, right), 0.0f);
    EXPECT_NEAR(viewPitch(orbit.camera()), viewPitch(start), 1e-5f) << "a horizontal drag only yaws";
    orbit.reset(start, bounds);
    orbit.update(OrbitInput{glm::vec2(0.0f, 50.0f)});
    EXPECT_GT(orbit.camera().eye.y, start.eye.y);
    EXPECT_LT(viewPitch(orbit.camera()), viewPitch(start)) << "the view tilts down toward the pivot";
}

TEST(OrbitCamera, PitchStopsShortOfThePoles) {
    const Aabb bounds = unitBox();
    OrbitCamera orbit;
    orbit.reset(frameScene(bounds), bounds);
    orbit.update(OrbitInput{glm::vec2(0.0f, 100000.0f)});
    EXPECT_NEAR(viewPitch(orbit.camera()), -OrbitCamera::kMaxPitchRadians, 1e-4f);
    EXPECT_NO_THROW(makeGpuCamera(orbit.camera(), 64, 64));
    orbit.update(OrbitInput{glm::vec2(0.0f, -200000.0f)});
    EXPECT_NEAR(viewPitch(orbit.camera()), OrbitCamera::kMaxPitchRadians, 1e-4f);
    EXPECT_NO_THROW(makeGpuCamera(orbit.camera(), 64, 64));
}

TEST(OrbitCamera, PanMovesThePointsAtThePivotsDepthWithTheCursor) {
    const Aabb bounds = unitBox();
    OrbitCamera orbit;
    orbit.reset(frameScene(bounds), bounds);
    const glm::vec3 fixedPoint = orbit.pivot();  // a scene point at the pivot's depth
    const glm::vec2 before = project(orbit.camera(), 800, 600, fixedPoint);
    OrbitInput input;
    input.panPixels = glm::vec2(37.0f, -21.0f);
    input.viewportHeight = 600;
    ASSERT_TRUE(orbit.update(input));
    const glm::vec2 after = project(orbit.camera(), 800, 600, fixedPoint);
    EXPECT_NEAR(after.x - before.x, 37.0f, 0.02f);
    EXPECT_NEAR(after.y - before.y, -21.0f, 0.02f);
    // The pivot moved with the view: it stays at the image centre.
    const glm::vec2 pivotPixel = project(orbit.camera(), 800, 600, orbit.pivot());
    EXPECT_NEAR(pivotPixel.x, 400.0f, 0.02f);
    EXPECT_NEAR(pivotPixel.y, 300.0f, 0.02f);
}

TEST(OrbitCamera, TheWheelZoomsTowardThePointUnderTheCursor) {
    const Aabb bounds = unitBox();
    OrbitCamera orbit;
    orbit.reset(frameScene(bounds), bounds);
    const Camera start = orbit.camera();
    const glm::vec3 target(0.8f, 0.5f, 0.9f);  // off centre
    const glm::vec2 targetPixel = project(start, 800, 600, target);
    const float pivotDistance = glm::length(orbit.pivot() - start.eye);
    OrbitInput input;
    input.wheel = 3.0f;
    input.zoomTarget = target;
    ASSERT_TRUE(orbit.update(input));
    const float factor = std::pow(OrbitCamera::kZoomFactor, 3.0f);
    const glm::vec2 after = project(orbit.camera(), 800, 600, target);
    EXPECT_NEAR(after.x, targetPixel.x, 0.01f);
    EXPECT_NEAR(after.y, targetPixel.y, 0.01f);
    EXPECT_NEAR(glm::length(target - orbit.camera().eye), glm::length(target - start.eye) * factor, 1e-4f);
    EXPECT_NEAR(glm::length(orbit.pivot() - orbit.camera().eye), pivotDistance * factor, 1e-4f);
    // Over the background: toward the pivot, which stays where it is.
    const glm::vec3 pivot = orbit.pivot();
    OrbitInput background;
    background.wheel = -2.0f;
    orbit.update(background);
    EXPECT_EQ(orbit.pivot(), pivot);
    EXPECT_NEAR(glm::length(pivot - orbit.camera().eye),
                pivotDistance * factor / std::pow(OrbitCamera::kZoomFactor, 2.0f), 1e-4f);
}

TEST(OrbitCamera, TheWheelNeitherReachesThePivotNorLosesTheScene) {
    const Aabb bounds = unitBox();
    const float diagonal = glm::length(bounds.extent());
    OrbitCamera orbit;
    orbit.reset(frameScene(bounds), bounds);
    OrbitInput in;
    in.wheel = 1000.0f;
    orbit.update(in);
    EXPECT_NEAR(glm::length(orbit.pivot() - orbit.camera().eye), OrbitCamera::kMinDistancePerDiagonal * diagonal,
                1e-6f);
    EXPECT_NO_THROW(makeGpuCamera(orbit.camera(), 64, 64));
    in.wheel = -1000.0f;
    orbit.update(in);
    EXPECT_NEAR(glm::length(orbit.pivot() - orbit.camera().eye), OrbitCamera::kMaxDistancePerDiagonal * diagonal,
                1e-2f);
}

TEST(OrbitCamera, TabBetweenFlyAndOrbitKeepsTheCameraBitForBit) {
    const Aabb bounds = unitBox();
    ui::FlyCamera fly;
    fly.reset(frameScene(bounds), bounds);
    ui::FlyInput look;
    look.lookPixels = glm::vec2(13.0f, 7.0f);
    look.forward = true;
    fly.update(look, 0.1f);
    OrbitCamera orbit;
    ui::switchToOrbit(fly, orbit, bounds);
    const auto sameGpuCamera = [](const Camera& a, const Camera& b) {
        const GpuCamera ga = makeGpuCamera(a, 640, 480), gb = makeGpuCamera(b, 640, 480);
        return std::memcmp(&ga, &gb, sizeof ga) == 0;
    };
    EXPECT_TRUE(sameGpuCamera(orbit.camera(), fly.camera()));
    EXPECT_EQ(orbit.pivot(), fly.camera().at);
    orbit.update(OrbitInput{glm::vec2(40.0f, 10.0f)});
    ui::switchToFly(orbit, fly);
    EXPECT_TRUE(sameGpuCamera(orbit.camera(), fly.camera()));
    // A picked pivot given on the switch: the view still does not move.
    const glm::vec3 picked(0.1f, 0.2f, 0.3f);
    ui::switchToOrbit(fly, orbit, bounds, picked);
    EXPECT_TRUE(sameGpuCamera(orbit.camera(), fly.camera()));
    EXPECT_EQ(orbit.pivot(), picked);
}

TEST(OrbitCamera, SetCameraKeepsAPickedPivotUnlessTheViewMoved) {
    const Aabb bounds = unitBox();
    OrbitCamera orbit;
    orbit.reset(frameScene(bounds), bounds);
    const glm::vec3 picked(0.5f, 0.0f, 0.0f);
    orbit.setPivot(picked);
    EXPECT_EQ(orbit.camera().at, frameScene(bounds).at) << "setting the pivot does not move the view";
    Camera wider = orbit.camera();
    wider.fovYDegrees = 80.0f;  // the panel's fov slider, given back every frame
    orbit.setCamera(wider);
    EXPECT_EQ(orbit.pivot(), picked);
    EXPECT_EQ(orbit.camera().fovYDegrees, 80.0f);
    Camera moved = wider;  // a bookmark recalled: the pivot goes onto the new view axis
    moved.eye = glm::vec3(0.0f, 0.0f, 6.0f);
    moved.at = glm::vec3(0.0f);
    const float distance = glm::length(picked - wider.eye);
    orbit.setCamera(moved);
    EXPECT_NEAR(glm::length(orbit.pivot() - glm::vec3(0.0f, 0.0f, 6.0f - distance)), 0.0f, 1e-5f);
    orbit.frameAll();
    EXPECT_EQ(orbit.camera().eye, frameScene(bounds).eye);
    EXPECT_EQ(orbit.pivot(), frameScene(bounds).at);
}

// ---- Pick

TEST(Pick, EqualsTheReferenceFramesHitAtEveryPixelAndMissesTheBackground) {
    const Scene scene = openScene("gen:default");
    const Bvh bvh = buildBvh(scene, {});
    RenderSettings settings;
    settings.width = 96;
    settings.height = 72;
    settings.shadows = false;
    settings.camera = frameScene(scene.bounds());
    FrameRequest request;
    request.image = false;
    request.hits = true;
    const Frame frame = renderCpu(scene, bvh, settings, request);
    uint32_t hits = 0, misses = 0;
    for (uint32_t y = 0; y < settings.height; ++y) {
        for (uint32_t x = 0; x < settings.width; ++x) {
            const HitRecord& expected = frame.hits[size_t(y) * settings.width + x];
            const std::optional<PickHit> pick =
                pickPixel(scene, bvh, settings.camera, settings.width, settings.height, x, y);
            if (expected.prim == gpu::kNoHit) {
                EXPECT_FALSE(pick) << "pixel " << x << "," << y;
                ++misses;
                continue;
            }
            ASSERT_TRUE(pick) << "pixel " << x << "," << y;
            ++hits;
            EXPECT_EQ(pick->prim, expected.prim);
            EXPECT_EQ(pick->t, expected.t);
            const glm::vec3 fromRecord = glm::vec3(expected.orgX, expected.orgY, expected.orgZ) +
                                         expected.t * glm::vec3(expected.dirX, expected.dirY, expected.dirZ);
            EXPECT_EQ(pick->point, fromRecord);
            // On the triangle's plane.
            const glm::vec3 a = scene.vertex(pick->prim, 0), b = scene.vertex(pick->prim, 1),
                            c = scene.vertex(pick->prim, 2);
            const glm::vec3 normal = glm::normalize(glm::cross(b - a, c - a));
            EXPECT_NEAR(glm::dot(pick->point - a, normal), 0.0f, 1e-4f * glm::length(scene.bounds().extent()));
        }
    }
    EXPECT_GT(hits, 100u) << "the framing camera sees the scene";
    EXPECT_GT(misses, 0u) << "and some background";
    EXPECT_FALSE(pickPixel(scene, bvh, settings.camera, 96, 72, 96, 0)) << "outside the image";
    Camera away = settings.camera;  // looking away from the scene: nothing to pick
    away.at = away.eye + (away.eye - settings.camera.at);
    for (uint32_t y = 0; y < 72; y += 9)
        for (uint32_t x = 0; x < 96; x += 8) EXPECT_FALSE(pickPixel(scene, bvh, away, 96, 72, x, y));
}

// ---- The pointer over the image

TEST(Pointer, TheCursorMapsToTheTracedPixelThroughHiDpiFramingAndReducedResolution) {
    // A 1000x700 window with a 2000x1400 framebuffer; the image shown right of a 760-pixel panel,
    // traced at a quarter of the shown size in each axis.
    ui::ShownImage image;
    image.origin = glm::vec2(760.0f, 0.0f);
    image.size = glm::vec2(1240.0f, 1400.0f);
    image.traced = glm::uvec2(310u, 350u);
    const glm::ivec2 window(1000, 700), framebuffer(2000, 1400);
    EXPECT_FALSE(ui::imagePixelUnderCursor({100.0, 300.0}, window, framebuffer, image)) << "over the panel";
    EXPECT_FALSE(ui::imagePixelUnderCursor({500.0, 700.0}, window, framebuffer, image)) << "below the window";
    EXPECT_EQ(ui::imagePixelUnderCursor({380.0, 0.0}, window, framebuffer, image), glm::uvec2(0u, 0u));
    // Window x 690 -> framebuffer 1380 -> 620 into the image -> pixel 620 / 4 = 155.
    EXPECT_EQ(ui::imagePixelUnderCursor({690.0, 350.0}, window, framebuffer, image), glm::uvec2(155u, 175u));
    EXPECT_EQ(ui::imagePixelUnderCursor({999.9, 699.9}, window, framebuffer, image), glm::uvec2(309u, 349u));
    image.traced = glm::uvec2(0u, 0u);
    EXPECT_FALSE(ui::imagePixelUnderCursor({690.0, 350.0}, window, framebuffer, image)) << "nothing traced yet";
}

TEST(Pointer, ADoubleClickIsTwoNearPressesWithinItsTimeWhateverTheFrameRate) {
    ui::DoubleClickDetector clicks;
    EXPECT_FALSE(clicks.press(10.0, {100.0, 100.0}));
    EXPECT_TRUE(clicks.press(10.2, {103.0, 102.0}));
    EXPECT_FALSE(clicks.press(10.35, {103.0, 102.0})) << "a third press starts over";
    EXPECT_FALSE(clicks.press(11.0, {103.0, 102.0})) << "too late";
    EXPECT_FALSE(clicks.press(11.1, {140.0, 102.0})) << "too far";
    EXPECT_TRUE(clicks.press(11.3, {141.0, 103.0}));
}

// ---- Recent files

TEST(RecentFiles, KeepTheLastTenMostRecentFirstWithoutDuplicates) {
    TempFolder folder("recent");
    std::vector<std::string> paths;
    for (int i = 0; i < 12; ++i) paths.push_back(folder.file("scene" + std::to_string(i) + ".ply").string());
    ui::RecentFiles recent;
    for (const std::string& p : paths) EXPECT_TRUE(recent.add(p));
    ASSERT_EQ(recent.entries().size(), ui::RecentFiles::kMaxEntries);
    EXPECT_EQ(recent.entries().front(), paths[11]);
    EXPECT_EQ(recent.entries().back(), paths[2]) << "the two oldest fell off";
    // Opened again, under another spelling of the same file: moves to the front, once.
    const fs::path other = folder.path / "." / "sub" / ".." / "scene5.ply";
    fs::create_directories(folder.path / "sub");
    EXPECT_TRUE(recent.add(other.string()));
    EXPECT_EQ(recent.entries().size(), ui::RecentFiles::kMaxEntries);
    EXPECT_EQ(recent.entries().front(), paths[5]);
    EXPECT_EQ(std::count(recent.entries().begin(), recent.entries().end(), paths[5]), 1);
    EXPECT_EQ(recent.entries()[1], paths[11]);
    // Not files: not recorded.
    const std::vector<std::string> before = recent.entries();
    EXPECT_FALSE(recent.add("gen:default"));
    EXPECT_FALSE(recent.add((folder.path / "missing.ply").string()));
    EXPECT_FALSE(recent.add(folder.path.string()));
    EXPECT_EQ(recent.entries(), before);
}

TEST(RecentFiles, MissingFilesArePrunedAndTheOrderKept) {
    TempFolder folder("recent_prune");
    const std::string a = folder.file("a.obj").string(), b = folder.file("b.obj").string(),
                      c = folder.file("c.obj").string();
    ui::RecentFiles recent;
    recent.add(a);
    recent.add(b);
    recent.add(c);
    EXPECT_FALSE(recent.pruneMissing());
    fs::remove(b);
    EXPECT_TRUE(recent.pruneMissing());
    EXPECT_EQ(recent.entries(), (std::vector<std::string>{c, a}));
}

TEST(RecentFiles, FromJsonDropsDuplicatesAndExtrasAndRejectsWhatIsNotAList) {
    nlohmann::json list = nlohmann::json::array();
    for (int i = 0; i < 14; ++i) list.push_back("/x/" + std::to_string(i % 12) + ".ply");
    const ui::RecentFiles recent = ui::RecentFiles::fromJson(list);
    ASSERT_EQ(recent.entries().size(), 10u);
    EXPECT_EQ(recent.entries().front(), "/x/0.ply");
    EXPECT_EQ(recent.entries().back(), "/x/9.ply");
    EXPECT_EQ(ui::RecentFiles::fromJson(recent.toJson()).entries(), recent.entries());
    EXPECT_THROW(ui::RecentFiles::fromJson(nlohmann::json(3)), Error);
    EXPECT_THROW(ui::RecentFiles::fromJson(nlohmann::json::array({"/a.ply", 4})), Error);
}

// ---- Config file

TEST(ViewerConfig, RoundTripsThePanelLayoutAndTheRecentFiles) {
    TempFolder folder("config");
    ui::ViewerConfig config;
    config.panel.width = 455.5f;
    config.panel.collapsed = true;
    config.panel.uiScale = 1.75f;
    config.panel.overlay = true;
    config.recent.add(folder.file("a.glb").string());
    config.recent.add(folder.file("b.gltf").string());
    const std::string file = (folder.path / "deeper" / "viewer.json").string();  // its folder is made
    ui::saveViewerConfig(file, config);
    const ui::ViewerConfigLoad loaded = ui::loadViewerConfig(file);
    EXPECT_EQ(loaded.warning, "");
    EXPECT_EQ(loaded.config.panel, config.panel);
    EXPECT_EQ(loaded.config.recent.entries(), config.recent.entries());
    EXPECT_FALSE(fs::exists(file + ".tmp"));
}

TEST(ViewerConfig, AMissingFileGivesTheDefaultsSilently) {
    const ui::ViewerConfigLoad loaded = ui::loadViewerConfig("/nonexistent/raypack/viewer.json");
    EXPECT_EQ(loaded.warning, "");
    EXPECT_EQ(loaded.config.panel, ui::PanelLayout{});
    EXPECT_TRUE(loaded.config.recent.entries().empty());
}

TEST(ViewerConfig, ABrokenFileGivesTheDefaultsAndOneLineNamingIt) {
    TempFolder folder("config_broken");
    const std::string file = folder.file("viewer.json", "{\"panel\": {\"width\": 300,").string();
    const ui::ViewerConfigLoad loaded = ui::loadViewerConfig(file);
    EXPECT_EQ(loaded.config.panel, ui::PanelLayout{});
    EXPECT_NE(loaded.warning.find(file), std::string::npos) << loaded.warning;
    EXPECT_NE(loaded.warning.find("not valid JSON"), std::string::npos) << loaded.warning;
    EXPECT_EQ(loaded.warning.find('\n'), std::string::npos);

    const std::string array = folder.file("array.json", "[1, 2]").string();
    EXPECT_NE(ui::loadViewerConfig(array).warning.find("not a JSON object"), std::string::npos);
}

TEST(ViewerConfig, BadFieldsFallBackOneByOneAndAreNamed) {
    TempFolder folder("config_fields");
    const std::string file = folder
                                 .file("viewer.json",
                                       R"({"panel": {"width": "wide", "collapsed": true, "ui_scale": 50, "overlay": 1},
            "recent_files": 7})")
                                 .string();
    const ui::ViewerConfigLoad loaded = ui::loadViewerConfig(file);
    EXPECT_EQ(loaded.config.panel.width, ui::PanelLayout::kDefaultWidth);
    EXPECT_TRUE(loaded.config.panel.collapsed) << "the good field is kept";
    EXPECT_EQ(loaded.config.panel.uiScale, 1.0f);
    EXPECT_FALSE(loaded.config.panel.overlay);
    EXPECT_TRUE(loaded.config.recent.entries().empty());
    for (const char* named : {"panel.width", "panel.ui_scale", "panel.overlay", "recent_files"})
        EXPECT_NE(loaded.warning.find(named), std::string::npos) << named << " in: " << loaded.warning;
    EXPECT_EQ(loaded.warning.find("collapsed"), std::string::npos) << loaded.warning;
}

TEST(ViewerConfig, LivesBesideTheBookmarksAndSavingWhereItCannotThrowsNamingTheFile) {
    const char* old = std::getenv("XDG_CONFIG_HOME");
    const std::string saved = old ? old : "";
    setenv("XDG_CONFIG_HOME", "/tmp/raypack_test_xdg", 1);
    EXPECT_EQ(ui::viewerConfigFile(), "/tmp/raypack_test_xdg/raypack/viewer.json");
    if (old)
        setenv("XDG_CONFIG_HOME", saved.c_str(), 1);
    else
        unsetenv("XDG_CONFIG_HOME");

    TempFolder folder("config_unwritable");
    const std::string underAFile = (folder.file("plain") / "viewer.json").string();
    try {
        ui::saveViewerConfig(underAFile, {});
        FAIL() << "saving under a plain file succeeded";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(underAFile), std::string::npos) << e.what();
    }
}

// ---- File browser

struct BrowserFolder : TempFolder {
    BrowserFolder() : TempFolder("browser") {
        fs::create_directories(path / "b_dir");
        fs::create_directories(path / "A_dir");
        fs::create_directories(path / ".hidden_dir");
        file("scene.PLY", "12345");
        file("model.obj");
        file("x.gltf");
        file("y.glb");
        file("notes.txt");
        file(".hidden.ply");
        file("A_dir/inner.glb");
    }
};

std::vector<std::string> names(const ui::DirectoryListing& listing) {
    std::vector<std::string> out;
    for (const ui::DirectoryEntry& e : listing.entries) out.push_back(e.directory ? e.name + "/" : e.name);
    return out;
}

TEST(FileBrowser, ListsFoldersFirstThenSceneFilesByNameIgnoringCase) {
    BrowserFolder folder;
    const ui::DirectoryListing scenes = ui::listDirectory(folder.path.string());
    EXPECT_EQ(scenes.error, "");
    EXPECT_EQ(scenes.directory, fs::weakly_canonical(folder.path).string());
    EXPECT_EQ(names(scenes),
              (std::vector<std::string>{"A_dir/", "b_dir/", "model.obj", "scene.PLY", "x.gltf", "y.glb"}));
    EXPECT_EQ(scenes.entries[3].bytes, 5u);
    const auto filterNamed = [](const std::string& label) {
        for (size_t i = 0; i < ui::fileFilters().size(); ++i)
            if (ui::fileFilters()[i].label == label) return i;
        ADD_FAILURE() << "no filter " << label;
        return size_t(0);
    };
    EXPECT_EQ(names(ui::listDirectory(folder.path.string(), filterNamed("PLY (.ply)"))),
              (std::vector<std::string>{"A_dir/", "b_dir/", "scene.PLY"}));
    EXPECT_EQ(names(ui::listDirectory(folder.path.string(), filterNamed("glTF (.gltf .glb)"))),
              (std::vector<std::string>{"A_dir/", "b_dir/", "x.gltf", "y.glb"}));
    EXPECT_EQ(names(ui::listDirectory(folder.path.string(), filterNamed("every file"))),
              (std::vector<std::string>{"A_dir/", "b_dir/", "model.obj", "notes.txt", "scene.PLY", "x.gltf", "y.glb"}));
    EXPECT_EQ(names(ui::listDirectory(folder.path.string(), 0, /*showHidden=*/true)),
              (std::vector<std::string>{".hidden_dir/", "A_dir/", "b_dir/", ".hidden.ply", "model.obj", "scene.PLY",
                                        "x.gltf", "y.glb"}));
}

TEST(FileBrowser, AFolderThatCannotBeListedGivesAnErrorNamingIt) {
    const ui::DirectoryListing listing = ui::listDirectory("/nonexistent/raypack");
    EXPECT_TRUE(listing.entries.empty());
    EXPECT_NE(listing.error.find("/nonexistent/raypack"), std::string::npos) << listing.error;
}

TEST(FileBrowser, NavigatesUpDownAndByTypedPathsAndHandsBackTheChosenFile) {
    BrowserFolder folder;
    const std::string root = fs::weakly_canonical(folder.path).string();
    ui::FileBrowser browser;
    browser.open((folder.path / "model.obj").string());  // a file: its folder is shown
    EXPECT_TRUE(browser.isOpen());
    EXPECT_EQ(browser.listing().directory, root);
    EXPECT_FALSE(browser.activate(0)) << "entry 0 is A_dir: entered, nothing chosen";
    EXPECT_EQ(browser.listing().directory, root + "/A_dir");
    EXPECT_EQ(names(browser.listing()), (std::vector<std::string>{"inner.glb"}));
    browser.up();
    EXPECT_EQ(browser.listing().directory, root);
    EXPECT_FALSE(browser.submit("b_dir"));
    EXPECT_EQ(browser.listing().directory, root + "/b_dir");
    EXPECT_FALSE(browser.submit("../nothing.ply"));
    EXPECT_NE(browser.error().find("nothing.ply: no such file or folder"), std::string::npos) << browser.error();
    EXPECT_EQ(browser.listing().directory, root + "/b_dir") << "a bad path keeps the folder";
    EXPECT_TRUE(browser.isOpen());
    const std::optional<std::string> chosen = browser.submit("../A_dir/inner.glb");
    ASSERT_TRUE(chosen);
    EXPECT_EQ(*chosen, root + "/A_dir/inner.glb");
    EXPECT_FALSE(browser.isOpen()) << "choosing closes the browser";

    browser.open(root);
    browser.setFilter(ui::fileFilters().size() - 1);  // every file
    EXPECT_EQ(browser.filter(), ui::fileFilters().size() - 1);
    EXPECT_EQ(names(browser.listing()).size(), 7u);
    const std::optional<std::string> notes = browser.activate(3);
    ASSERT_TRUE(notes);
    EXPECT_EQ(*notes, root + "/notes.txt");

    const char* home = std::getenv("HOME");
    const std::string savedHome = home ? home : "";
    setenv("HOME", root.c_str(), 1);
    browser.open("/");
    EXPECT_FALSE(browser.submit("~/A_dir"));
    EXPECT_EQ(browser.listing().directory, root + "/A_dir");
    if (home)
        setenv("HOME", savedHome.c_str(), 1);
    else
        unsetenv("HOME");

    browser.open("/nonexistent/raypack");  // names nothing: the current folder
    EXPECT_EQ(browser.listing().directory, fs::current_path().string());
    EXPECT_FALSE(browser.navigate((folder.path / "model.obj").string()));
    EXPECT_NE(browser.error().find("not a folder"), std::string::npos);
}

TEST(FileBrowser, MatchesExtensionsIgnoringCase) {
    EXPECT_TRUE(ui::matchesFilter("Duck.GLB", {".gltf", ".glb"}));
    EXPECT_FALSE(ui::matchesFilter("duck.glb.txt", {".glb"}));
    EXPECT_FALSE(ui::matchesFilter(".glb", {".glb"})) << "a name that is only the extension";
    EXPECT_TRUE(ui::matchesFilter("anything", {}));
}

// ---- Panel

TEST(Panel, TheSceneLineSaysFailedNotLoadingAfterAFailedLoad) {
    ui::PanelInfo info;
    info.scene = "/nonexistent/scene.ply (loading)";  // what the viewer sets before the first load
    info.build.phase = BuildPhase::Loading;
    info.build.scenePath = "/nonexistent/scene.ply";
    EXPECT_EQ(ui::sceneLine(info), "Scene: loading /nonexistent/scene.ply");
    info.build = {};
    info.error = "/nonexistent/scene.ply: cannot open";
    EXPECT_EQ(ui::sceneLine(info), "Scene: none (the load failed)");
    info.failedScene = "/nonexistent/scene.ply";
    EXPECT_EQ(ui::sceneLine(info), "Scene: none (/nonexistent/scene.ply failed to load)");
    info.error.clear();
    EXPECT_EQ(ui::sceneLine(info).find("loading"), std::string::npos);

    info.hasBvh = true;
    info.scene = "gen:default";
    info.triangles = 1234;
    info.failedScene.clear();
    EXPECT_EQ(ui::sceneLine(info), "Scene: gen:default (1234 triangles)");
    info.failedScene = "/x/bad.glb";
    EXPECT_EQ(ui::sceneLine(info), "Scene: gen:default (1234 triangles); /x/bad.glb failed to load");
    info.build.phase = BuildPhase::Building;  // a rebuild has no path: nothing is loading
    EXPECT_EQ(ui::sceneLine(info), "Scene: gen:default (1234 triangles); /x/bad.glb failed to load");
    info.build.scenePath = "/x/next.glb";
    EXPECT_EQ(ui::sceneLine(info), "Scene: gen:default (1234 triangles); loading /x/next.glb");
}

// The shadow Mrays/s divides the timed frame's shadow rays by its T_K: where the counters come from a
// smaller counting frame (GPU devices), its share of shadow rays scales to the timed frame's pixels.
// Before, the 80x50 counting frame's 3,994 shadow rays were divided by a 640x400 frame's T_K (the
// panel showed 0.0 Mrays/s on lavapipe).
TEST(Panel, ShadowRaysOfTheTimedFrameScaleFromASmallerCountingFrame) {
    ui::LiveStatistics stats;
    bool estimated = true;
    EXPECT_EQ(ui::timedShadowRays(stats, &estimated), 0.0);
    stats.countersValid = true;
    stats.primaryRays = 640 * 400;
    stats.counters.primaryRays = 80 * 50;
    stats.counters.shadowRays = 3994;
    EXPECT_DOUBLE_EQ(ui::timedShadowRays(stats, &estimated), 3994.0 * 64.0);
    EXPECT_TRUE(estimated);
    stats.counters.primaryRays = 640 * 400;
    stats.counters.shadowRays = 250000;
    EXPECT_DOUBLE_EQ(ui::timedShadowRays(stats, &estimated), 250000.0);
    EXPECT_FALSE(estimated);
}

TEST(Panel, TheTitleShowsFramesPerSecondUnderAFixedId) {
    ui::LiveStatistics stats;
    EXPECT_EQ(ui::panelTitle(stats), "raypack###raypack-panel");
    stats.frameSeconds = 0.08;
    EXPECT_EQ(ui::panelTitle(stats), "raypack  12.5 fps###raypack-panel");
    stats.frameSeconds = 3.0;
    EXPECT_EQ(ui::panelTitle(stats), "raypack  0.333 fps###raypack-panel");
}

// ImGui without a renderer: frames are laid out but never drawn, enough to check the panel's
// window rules.
class HeadlessImGui : public ::testing::Test {
protected:
    void SetUp() override {
        ImGui::CreateContext();
        ImGuiIO& io = ImGui::GetIO();
        io.IniFilename = nullptr;
        unsigned char* pixels = nullptr;
        int width = 0, height = 0;
        io.Fonts->GetTexDataAsRGBA32(&pixels, &width, &height);  // builds the font atlas
        io.DisplayFramebufferScale = ImVec2(2.0f, 2.0f);         // a HiDPI screen
        info.device = "headless";
        info.bookmarkSet.assign(9, false);
        info.stats.frameSeconds = 0.05;
    }
    void TearDown() override { ImGui::DestroyContext(); }

    ui::PanelActions frame(float displayWidth, float displayHeight) {
        ImGuiIO& io = ImGui::GetIO();
        io.DisplaySize = ImVec2(displayWidth, displayHeight);
        io.DeltaTime = 1.0f / 60.0f;
        ImGui::NewFrame();
        const ui::PanelActions actions = ui::drawPanel(state, info);
        ImGui::Render();
        return actions;
    }
    ImGuiWindow* panelWindow() { return ImGui::FindWindowByName("###raypack-panel"); }

    ui::PanelState state;
    ui::PanelInfo info;
};

TEST_F(HeadlessImGui, ThePanelStartsAtItsRememberedWidthAndStaysOnScreenAfterAResize) {
    state.layout.width = 500.0f;
    frame(1600, 1000);
    frame(1600, 1000);
    ImGuiWindow* window = panelWindow();
    ASSERT_NE(window, nullptr);
    EXPECT_EQ(window->Pos.x, 0.0f);
    EXPECT_EQ(window->Pos.y, 0.0f);
    EXPECT_EQ(window->Size.x, 500.0f);
    EXPECT_EQ(window->Size.y, 1000.0f) << "full height";
    EXPECT_EQ(state.coveredWidthPixels, 1000.0f) << "500 window units at framebuffer scale 2";
    // The window shrinks below the panel's width: the panel shrinks with it, and keeps to the
    // window's height.
    frame(400, 300);
    frame(400, 300);
    EXPECT_LE(window->Pos.x + window->Size.x, 400.0f);
    EXPECT_EQ(window->Size.y, 300.0f);
    EXPECT_EQ(state.layout.width, 500.0f) << "the clamp to a small window is not remembered";
    EXPECT_EQ(state.coveredWidthPixels, 2.0f * window->Size.x) << "what is covered, not what is remembered";
    // The window grows again: so does the panel, back to the remembered width.
    frame(1600, 1000);
    frame(1600, 1000);
    EXPECT_EQ(window->Size.x, 500.0f);
    EXPECT_EQ(state.coveredWidthPixels, 1000.0f);
}

TEST_F(HeadlessImGui, DraggingTheRightEdgeResizesThePanelAndReportsTheWidthWhenReleased) {
    ImGuiIO& io = ImGui::GetIO();
    io.ConfigWindowsResizeFromEdges = true;
    io.BackendFlags |= ImGuiBackendFlags_HasMouseCursors;  // as the GLFW backend says
    frame(1280, 800);
    frame(1280, 800);
    const float edge = ui::PanelLayout::kDefaultWidth - 1.0f;
    io.MousePos = ImVec2(edge, 400.0f);
    frame(1280, 800);
    io.MouseDown[0] = true;
    bool reportedWhileDragging = false;
    for (float x = edge; x <= edge + 200.0f; x += 50.0f) {
        io.MousePos = ImVec2(x, 400.0f);
        reportedWhileDragging |= frame(1280, 800).layoutChanged;
    }
    EXPECT_FALSE(reportedWhileDragging) << "a drag is reported once, at its end";
    EXPECT_NEAR(state.layout.width, ui::PanelLayout::kDefaultWidth + 200.0f, 1.0f);
    io.MouseDown[0] = false;
    EXPECT_TRUE(frame(1280, 800).layoutChanged);
    EXPECT_FALSE(frame(1280, 800).layoutChanged);
    EXPECT_NEAR(state.coveredWidthPixels, 2.0f * (ui::PanelLayout::kDefaultWidth + 200.0f), 2.0f);
    EXPECT_EQ(panelWindow()->Pos.x, 0.0f);
}

TEST_F(HeadlessImGui, CollapsedAndOverlayingPanelsLeaveTheWholeImageAndReportTheChange) {
    state.layout.collapsed = true;
    frame(1280, 800);
    frame(1280, 800);
    ASSERT_NE(panelWindow(), nullptr);
    EXPECT_TRUE(panelWindow()->Collapsed);
    EXPECT_EQ(state.coveredWidthPixels, 0.0f);
    // Expanded from outside ImGui (as a click on the arrow does): the change is reported once.
    ImGui::SetWindowCollapsed("###raypack-panel", false);
    EXPECT_TRUE(frame(1280, 800).layoutChanged);
    EXPECT_FALSE(state.layout.collapsed);
    EXPECT_FALSE(frame(1280, 800).layoutChanged);
    EXPECT_EQ(state.coveredWidthPixels, ui::PanelLayout::kDefaultWidth * 2.0f);
    state.layout.overlay = true;
    frame(1280, 800);
    EXPECT_EQ(state.coveredWidthPixels, 0.0f);
}

TEST_F(HeadlessImGui, AnErrorDoesNotMoveThePanelsContent) {
    for (int i = 0; i < 3; ++i) frame(1280, 800);
    const ImVec2 contentWithout = panelWindow()->ContentSize;
    info.error = "/x/bad.glb: Invalid glTF binary";
    for (int i = 0; i < 3; ++i) frame(1280, 800);
    EXPECT_EQ(panelWindow()->ContentSize.y, contentWithout.y);
    ImGuiWindow* box = ImGui::FindWindowByName("##raypack-error");
    ASSERT_NE(box, nullptr);
    EXPECT_TRUE(box->Active);
    EXPECT_GE(box->Pos.x, ui::PanelLayout::kDefaultWidth) << "beside the panel, over the image";
    EXPECT_LE(box->Pos.y + box->Size.y, 800.0f);
}

TEST_F(HeadlessImGui, EnterInThePathFieldOpensTheTypedPath) {
    ImGuiIO& io = ImGui::GetIO();
    io.KeyMap[ImGuiKey_Enter] = 257;  // any free slot of KeysDown, as a backend maps its keys
    frame(1280, 800);
    frame(1280, 800);
    // Find the path field by moving the mouse down the panel until ImGui says it hovers it.
    const ImGuiID pathId = panelWindow()->GetID("##path");
    std::optional<ImVec2> fieldAt;
    for (float y = 0.0f; y < 800.0f && !fieldAt; y += 4.0f) {
        io.MousePos = ImVec2(60.0f, y);
        frame(1280, 800);
        if (GImGui->HoveredId == pathId) fieldAt = io.MousePos;
    }
    ASSERT_TRUE(fieldAt) << "the path field was not found";
    io.MouseDown[0] = true;
    frame(1280, 800);
    io.MouseDown[0] = false;
    frame(1280, 800);
    ASSERT_EQ(GImGui->ActiveId, pathId) << "the click put the cursor in the field";
    // Select all and type over it, as a user does; nothing opens before Enter.
    io.KeyMap[ImGuiKey_A] = 65;
    io.KeyCtrl = true;
    io.KeysDown[65] = true;
    frame(1280, 800);
    io.KeysDown[65] = false;
    io.KeyCtrl = false;
    for (char c : std::string("/x/typed.glb")) {
        io.AddInputCharacter(c);
        EXPECT_FALSE(frame(1280, 800).open);
    }
    io.KeysDown[257] = true;
    const ui::PanelActions actions = frame(1280, 800);
    io.KeysDown[257] = false;
    EXPECT_TRUE(actions.open) << "Enter opens";
    EXPECT_EQ(state.openPath, "/x/typed.glb");
}

TEST_F(HeadlessImGui, TheUiScaleScalesFontsAndSizesWithoutCompounding) {
    frame(1280, 800);
    const float padding = ImGui::GetStyle().WindowPadding.x;
    state.layout.uiScale = 2.0f;
    frame(1280, 800);
    EXPECT_EQ(ImGui::GetIO().FontGlobalScale, 2.0f);
    EXPECT_EQ(ImGui::GetStyle().WindowPadding.x, 2.0f * padding);
    state.layout.uiScale = 1.0f;
    frame(1280, 800);
    EXPECT_EQ(ImGui::GetStyle().WindowPadding.x, padding);
}

// ---- Script steps (ui/script.h): parsed and checked at start, applied as the panel would.

std::string scriptError(const std::string& text) {
    try {
        ui::parseScriptStep(text);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

TEST(ScriptSteps, EveryActionParsesWithItsValue) {
    const ui::ScriptStep packet = ui::parseScriptStep("12:packet:5x6");
    EXPECT_EQ(packet.frame, 12u);
    EXPECT_EQ(packet.action, ui::ScriptAction::Packet);
    EXPECT_EQ(packet.shape, (PacketShape{5, 6}));
    EXPECT_EQ(ui::parseScriptStep("3:move:0.5,0,-1").move, glm::vec3(0.5f, 0.0f, -1.0f));
    EXPECT_EQ(ui::parseScriptStep("3:look:40,-10").look, glm::vec2(40.0f, -10.0f));
    EXPECT_EQ(ui::parseScriptStep("0:builder:sah-binned").builder, BvhBuilder::SahBinned);
    EXPECT_EQ(ui::parseScriptStep("0:view:nodes").view, ViewMode::HeatTraversal);
    EXPECT_EQ(ui::parseScriptStep("0:tracer:cpu-packet").tracer, ui::TracerChoice::CpuPacket);
    EXPECT_FALSE(ui::parseScriptStep("0:side-by-side:off").on);
    EXPECT_EQ(ui::parseScriptStep("1:open:/a:b.ply").value, "/a:b.ply") << "a value may hold colons";
    EXPECT_EQ(ui::parseScriptStep("2:wait").action, ui::ScriptAction::Wait);
    for (const char* name : {"resize",   "packet",        "leaf-size",         "builder", "shadows",
                             "kernel",   "tracer",        "side-by-side",      "view",    "open",
                             "wait",     "screenshot",    "window-screenshot", "move",    "look",
                             "bookmark", "save-bookmark", "frame-all",         "scale",   "samples",
                             "budget"}) {
        const std::string text = std::string("0:") + name;
        // Each action is known: a missing value is the only complaint, or none.
        EXPECT_EQ(scriptError(text).find("unknown action"), std::string::npos) << text;
    }
}

TEST(ScriptSteps, AMalformedStepIsRefusedWithTheStepAndTheReason) {
    // The viewer used to accept "-1x4" (sscanf's %u) and found other mistakes only at the step's frame.
    EXPECT_EQ(scriptError("3:packet:-1x4").rfind("script step \"3:packet:-1x4\": packet: \"-1x4\" is not", 0), 0u)
        << scriptError("3:packet:-1x4");
    EXPECT_NE(scriptError("3:leaf-size:0"), "");
    EXPECT_NE(scriptError("3:shadows:maybe"), "");
    EXPECT_NE(scriptError("3:kernel:fast"), "");
    EXPECT_NE(scriptError("3:tracer:embree"), "");
    EXPECT_NE(scriptError("3:bookmark:10"), "");
    EXPECT_NE(scriptError("3:scale:65"), "");
    EXPECT_NE(scriptError("3:move:1,2"), "");
    EXPECT_NE(scriptError("3:open"), "");
    EXPECT_NE(scriptError("3:wait:now"), "");
    EXPECT_NE(scriptError("-3:wait"), "");
    EXPECT_NE(scriptError("99999999999:wait"), "");
    EXPECT_NE(scriptError("3"), "");
    EXPECT_NE(scriptError("3:"), "");
    EXPECT_NE(scriptError("3:jump").find("unknown action \"jump\""), std::string::npos) << scriptError("3:jump");
}

TEST(ScriptSteps, StepsEditThePanelAndSetItsActionsAsItsControlsWould) {
    ui::PanelState panel;
    panel.tracer = ui::TracerChoice::VulkanPacket;
    ui::PanelActions actions;
    ui::ScriptEffects effects;
    for (const char* text :
         {"0:leaf-size:4", "0:packet:5x6", "0:shadows:off", "0:view:tests", "0:samples:8", "0:budget:50",
          "0:bookmark:2", "0:save-bookmark:3", "0:frame-all", "0:kernel:single", "0:move:0.1,0,0", "0:move:0.1,0.2,0",
          "0:look:4,5", "0:scale:4", "0:open:x.ply", "0:wait", "0:screenshot:a.png", "0:side-by-side:cpu-reference"})
        ui::applyScriptStep(ui::parseScriptStep(text), panel, actions, effects);
    EXPECT_EQ(panel.bvh.leafSize, 4u);
    EXPECT_TRUE(actions.rebuild);
    EXPECT_EQ(panel.settings.packet, (PacketShape{5, 6}));
    EXPECT_FALSE(panel.settings.shadows);
    EXPECT_EQ(panel.settings.view, ViewMode::HeatIntersections);
    EXPECT_EQ(panel.frameLoop.samples, 8u);
    EXPECT_EQ(panel.frameLoop.frameBudgetMs, 50.0f);
    EXPECT_EQ(actions.recallBookmark, 2);
    EXPECT_EQ(actions.saveBookmark, 3);
    EXPECT_TRUE(actions.frameAll);
    EXPECT_EQ(panel.settings.kernel, KernelKind::Single);
    EXPECT_EQ(effects.tracer, ui::TracerChoice::VulkanSingle) << "a Vulkan tracer follows the kernel";
    EXPECT_EQ(effects.input.heldSeconds, glm::vec3(0.2f, 0.2f, 0.0f)) << "moves of one frame add up";
    EXPECT_EQ(effects.input.lookPixels, glm::vec2(4.0f, 5.0f));
    EXPECT_EQ(effects.scale, 4u);
    EXPECT_EQ(effects.open, "x.ply");
    EXPECT_TRUE(effects.wait);
    EXPECT_EQ(effects.screenshot, "a.png");
    EXPECT_EQ(effects.sideBySide, ui::TracerChoice::CpuReference);

    // On a CPU tracer the kernel step only chooses the kernel a later switch to Vulkan uses.
    ui::PanelState cpu;
    cpu.tracer = ui::TracerChoice::CpuPacket;
    ui::ScriptEffects cpuEffects;
    ui::applyScriptStep(ui::parseScriptStep("0:kernel:single"), cpu, actions, cpuEffects);
    EXPECT_EQ(cpu.settings.kernel, KernelKind::Single);
    EXPECT_FALSE(cpuEffects.tracer);
    cpu.sideBySide = true;
    ui::applyScriptStep(ui::parseScriptStep("0:side-by-side:off"), cpu, actions, cpuEffects);
    EXPECT_FALSE(cpu.sideBySide);
}

// ---- Run statistics (ui/run_statistics.h): what --summary reports.

TEST(RunStatistics, FramesLatencyIdleShareAndTheTimesAfterAStop) {
    ui::RunStatistics run;
    const auto frame = [&](double start, double end, ui::FrameKind kind, uint32_t scale, uint32_t samples,
                           double input = -1.0) {
        ui::FrameOutcome f;
        f.startSeconds = start;
        f.endSeconds = end;
        f.traced = f.presented = kind != ui::FrameKind::Idle;
        f.kind = kind;
        f.scale = scale;
        f.samplesShown = samples;
        f.samplesWanted = 4;
        f.firstInputSeconds = input;
        if (!f.presented) f.idleWallSeconds = end - start, f.idleCpuSeconds = 0.25 * (end - start);
        run.record(f);
    };
    frame(0.0, 0.05, ui::FrameKind::Moving, 4, 1, 0.0);
    frame(0.1, 0.15, ui::FrameKind::Moving, 2, 1, 0.12);
    frame(0.2, 0.3, ui::FrameKind::Full, 1, 1);
    frame(0.3, 0.35, ui::FrameKind::Refine, 1, 2);
    frame(0.4, 0.5, ui::FrameKind::Refine, 1, 4);
    frame(0.5, 1.5, ui::FrameKind::Idle, 1, 4);
    const nlohmann::json summary = run.summary();
    EXPECT_EQ(summary["frames"], 6);
    EXPECT_EQ(summary["frames_traced"], 5);
    EXPECT_EQ(summary["frames_presented"], 5);
    EXPECT_EQ(summary["frames_moving"], 2);
    EXPECT_NEAR(summary["fps_moving_median"].get<double>(), 10.0, 1e-9) << "frames start 0.1 s apart";
    EXPECT_EQ(summary["resolution_scales_moving"], (nlohmann::json{{"2", 1}, {"4", 1}}));
    EXPECT_EQ(summary["input_frames"], 2);
    EXPECT_NEAR(summary["input_to_photon_ms_median"].get<double>(), 50.0, 1e-9);
    EXPECT_EQ(summary["idle_frames"], 1);
    EXPECT_NEAR(summary["idle_cpu_share"].get<double>(), 0.25, 1e-12);
    EXPECT_NEAR(run.fullAfterChangeSeconds(), 0.15, 1e-12) << "from the last moving frame's end";
    EXPECT_NEAR(run.convergedAfterChangeSeconds(), 0.35, 1e-12);
    frame(1.5, 1.6, ui::FrameKind::Moving, 2, 1);
    EXPECT_EQ(run.fullAfterChangeSeconds(), -1.0) << "a new change starts the clocks again";
    EXPECT_EQ(run.convergedAfterChangeSeconds(), -1.0);
}
}  // namespace
}  // namespace raypack
