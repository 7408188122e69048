// The viewer (its build worker is tests/test_async_build.cpp): the fly camera and the bookmarks
// (ui/), and `raypack` itself in scripted runs under Xvfb with
// lavapipe: its screenshot must equal raypack-cli's render of the same view and settings, and a
// resize and a scene load during a rebuild must pass the validation layer without a message.
#include "renderer/bvh.h"
#include "renderer/error.h"
#include "renderer/image.h"
#include "renderer/settings_json.h"
#include "scenes/load.h"

#include "renderer/progressive.h"

#ifdef RAYPACK_VIEWER
#include "ui/bookmarks.h"
#include "ui/camera_path.h"
#include "ui/fly_camera.h"
#include "ui/frame_budget.h"
#include "ui/frame_loop.h"
#include "ui/input.h"
#include "ui/screenshot.h"
#endif

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <sys/wait.h>
#include <unistd.h>

namespace raypack {
namespace {

namespace fs = std::filesystem;

#ifdef RAYPACK_VIEWER

TEST(FlyCamera, MovesAtASpeedScaledToTheSceneAndLooksAround) {
    Aabb bounds;
    bounds.grow(glm::vec3(0.0f));
    bounds.grow(glm::vec3(30.0f, 40.0f, 0.0f));  // diagonal 50
    ui::FlyCamera fly;
    const Camera start = frameScene(bounds);
    fly.reset(start, bounds);
    EXPECT_FLOAT_EQ(fly.speed(), 50.0f * ui::FlyCamera::kBaseSpeedPerDiagonal);
    ui::FlyInput forward;
    forward.forward = true;
    ASSERT_TRUE(fly.update(forward, 0.05f));
    const glm::vec3 moved = fly.camera().eye - start.eye;
    EXPECT_NEAR(glm::length(moved), 0.05f * fly.speed(), 1e-4f);
    EXPECT_NEAR(glm::dot(glm::normalize(moved), glm::normalize(start.at - start.eye)), 1.0f, 1e-5f);
    forward.fast = true;
    const glm::vec3 before = fly.camera().eye;
    fly.update(forward, 0.05f);
    EXPECT_NEAR(glm::length(fly.camera().eye - before), 0.05f * fly.speed() * ui::FlyCamera::kFastFactor, 1e-4f);

    ui::FlyInput wheel;
    wheel.wheel = 2.0f;
    const float slow = fly.speed();
    fly.update(wheel, 0.016f);
    EXPECT_NEAR(fly.speed(), slow * ui::FlyCamera::kWheelFactor * ui::FlyCamera::kWheelFactor, 1e-3f);

    // Looking far up stops short of the pole: the view never becomes parallel to up.
    ui::FlyInput look;
    look.lookPixels = glm::vec2(100.0f, -100000.0f);
    const float distance = glm::length(fly.camera().at - fly.camera().eye);
    fly.update(look, 0.016f);
    const glm::vec3 view = glm::normalize(fly.camera().at - fly.camera().eye);
    EXPECT_NEAR(glm::length(fly.camera().at - fly.camera().eye), distance, 1e-3f * distance);
    EXPECT_LT(glm::dot(view, glm::vec3(0, 1, 0)), std::sin(ui::FlyCamera::kMaxPitchRadians) + 1e-4f);
    EXPECT_NO_THROW(makeGpuCamera(fly.camera(), 64, 64));

    fly.frameAll();
    EXPECT_EQ(fly.camera().eye, start.eye);
    EXPECT_EQ(fly.camera().at, start.at);
}

// A fly camera over a 30 x 40 box (diagonal 50), at the box's default framing.
Camera startFlyCamera(ui::FlyCamera& fly) {
    Aabb bounds;
    bounds.grow(glm::vec3(0.0f));
    bounds.grow(glm::vec3(30.0f, 40.0f, 0.0f));
    const Camera start = frameScene(bounds);
    fly.reset(start, bounds);
    return start;
}

TEST(FlyInput, AKeyTappedBetweenTwoFramesMovesTheCamera) {
    ui::FlyCamera fly;
    const Camera start = startFlyCamera(fly);
    // Pressed and released within one poll (both callbacks at the same time), before the frame.
    ui::HeldKeys keys;
    keys.take(10.0);
    keys.press(ui::FlyKey::Forward, 10.02);
    keys.release(ui::FlyKey::Forward, 10.02);
    const std::array<double, ui::kFlyKeyCount> held = keys.take(10.05);
    EXPECT_DOUBLE_EQ(held[uint32_t(ui::FlyKey::Forward)], ui::HeldKeys::kTapSeconds);
    ui::FlyInput input;
    input.heldSeconds.z = float(held[uint32_t(ui::FlyKey::Forward)]);
    ASSERT_TRUE(fly.update(input, 0.05f));
    EXPECT_NEAR(glm::length(fly.camera().eye - start.eye), float(ui::HeldKeys::kTapSeconds) * fly.speed(), 1e-4f);
    // The tap is consumed: the next frame does not move.
    input.heldSeconds = glm::vec3(keys.take(10.1)[uint32_t(ui::FlyKey::Forward)]);
    EXPECT_FALSE(fly.update(ui::FlyInput{}, 0.05f));
}

TEST(FlyInput, HeldKeysCountWallTimeAcrossFramesAndReleaseAll) {
    ui::HeldKeys keys;
    keys.take(0.0);
    keys.press(ui::FlyKey::Left, 0.25);
    EXPECT_NEAR(keys.take(1.0)[uint32_t(ui::FlyKey::Left)], 0.75, 1e-12);  // pressed mid-interval
    EXPECT_NEAR(keys.take(1.5)[uint32_t(ui::FlyKey::Left)], 0.5, 1e-12);   // held all interval
    keys.release(ui::FlyKey::Left, 1.6);
    EXPECT_NEAR(keys.take(2.0)[uint32_t(ui::FlyKey::Left)], 0.1, 1e-12);
    EXPECT_EQ(keys.take(3.0)[uint32_t(ui::FlyKey::Left)], 0.0);
    keys.press(ui::FlyKey::Up, 3.0);
    EXPECT_TRUE(keys.anyDown());
    keys.releaseAll(3.5);  // focus lost: no key sticks
    EXPECT_FALSE(keys.anyDown());
    EXPECT_NEAR(keys.take(4.0)[uint32_t(ui::FlyKey::Up)], 0.5, 1e-12);
}

TEST(FlyInput, AOneSecondFrameMovesNoMoreThanTheMaximumStep) {
    ui::FlyCamera fly;
    const Camera start = startFlyCamera(fly);
    ui::FlyInput input;
    input.forward = true;
    input.heldSeconds = glm::vec3(0.0f, 0.0f, 1.0f);  // and the key held for the whole second
    input.fast = true;
    ASSERT_TRUE(fly.update(input, 1.0f));
    EXPECT_LE(glm::length(fly.camera().eye - start.eye),
              ui::FlyCamera::kMaxStepSeconds * ui::FlyCamera::kFastFactor * fly.speed() * 1.0001f);
}

TEST(FrameLoop, MovingThenFullResolutionThenSamplesThenIdle) {
    ui::FrameLoop loop;
    ui::FrameLoopSettings settings;
    settings.samples = 4;
    // Before any measurement a moving frame is at full resolution.
    ui::FramePlan plan = loop.plan(settings, 640, 480, true);
    EXPECT_EQ(plan.kind, ui::FrameKind::Moving);
    EXPECT_EQ(plan.scale, 1u);
    // 10 ms for 307,200 pixels and 5 ms of the rest: at a 33 ms budget the full image fits...
    loop.traced(plan, 640 * 480, 0.010, 0.015);
    EXPECT_TRUE(loop.fullDone());
    EXPECT_EQ(loop.plan(settings, 640, 480, true).scale, 1u);
    // ... at 100 ms for the same pixels only a quarter of them do (scale 2: 76,800 pixels, 25 ms).
    loop.traced(plan, 640 * 480, 0.100, 0.105);
    loop.traced(plan, 640 * 480, 0.100, 0.105);
    loop.traced(plan, 640 * 480, 0.100, 0.105);
    loop.traced(plan, 640 * 480, 0.100, 0.105);
    plan = loop.plan(settings, 640, 480, true);
    EXPECT_EQ(plan.kind, ui::FrameKind::Moving);
    EXPECT_EQ(plan.scale, 2u);
    EXPECT_EQ(plan.jitter, glm::vec2(0.0f));
    loop.traced(plan, 320 * 240, 0.025, 0.030);
    EXPECT_FALSE(loop.fullDone()) << "a reduced frame needs a full one after it";
    plan = loop.plan(settings, 640, 480, false);
    EXPECT_EQ(plan.kind, ui::FrameKind::Full);
    EXPECT_EQ(plan.scale, 1u);
    loop.traced(plan, 640 * 480, 0.1, 0.1);
    for (uint32_t k = 0; k < 4; ++k) {
        plan = loop.plan(settings, 640, 480, false);
        ASSERT_EQ(plan.kind, ui::FrameKind::Refine);
        EXPECT_EQ(plan.sampleIndex, k);
        EXPECT_EQ(plan.jitter, samplePatternOffset(k, 4));
        loop.traced(plan, 640 * 480, 0.1, 0.1);
    }
    EXPECT_EQ(loop.plan(settings, 640, 480, false).kind, ui::FrameKind::Idle);
    EXPECT_EQ(loop.plan(settings, 640, 480, false).kind, ui::FrameKind::Idle);
    // Heat maps are not refined; any change starts over.
    EXPECT_EQ(loop.plan(settings, 640, 480, true).kind, ui::FrameKind::Moving);
    ui::FrameLoop heat;
    heat.traced(heat.plan(settings, 64, 64, true), 64 * 64, 0.001, 0.002);
    EXPECT_EQ(heat.plan(settings, 64, 64, false, std::nullopt, false).kind, ui::FrameKind::Idle);
}

TEST(FrameBudget, TheLargestScaleWhenNothingFits) {
    ui::FrameCostModel model;
    model.addFrame(1000, 1.0, 1.5);  // 1 ms a pixel, 0.5 s a frame besides
    EXPECT_EQ(ui::chooseResolutionScale(model, 1280, 800, 0.033), 8u);
    EXPECT_NEAR(model.predictSeconds(2000), 2.5, 1e-12);
}

TEST(Progressive, SamplePatternIsStratifiedAndPrefixStable) {
    EXPECT_EQ(samplePatternOffset(0, 1), glm::vec2(0.0f));
    std::vector<glm::vec2> sixteen;
    for (uint32_t k = 0; k < 16; ++k) {
        const glm::vec2 o = samplePatternOffset(k, 16);
        EXPECT_GE(o.x, -0.5f);
        EXPECT_LT(o.x, 0.5f);
        EXPECT_GE(o.y, -0.5f);
        EXPECT_LT(o.y, 0.5f);
        if (k < 4) {
            EXPECT_EQ(o, samplePatternOffset(k, 4)) << "a longer pattern starts with the shorter";
        }
        sixteen.push_back(o);
    }
    // Stratified: each quarter of the pixel in x holds 4 of the 16 samples (base 2 radical inverse).
    for (int quarter = 0; quarter < 4; ++quarter)
        EXPECT_EQ(std::count_if(sixteen.begin(), sixteen.end(),
                                [&](glm::vec2 o) { return int((o.x + 0.5f) * 4.0f) == quarter; }),
                  4);
    EXPECT_THROW(samplePatternOffset(0, 0), Error);
    EXPECT_THROW(samplePatternOffset(4, 4), Error);
}

TEST(Progressive, AccumulationIsTheRoundedMeanAndScalingReplicates) {
    SampleAccumulator accumulator;
    accumulator.reset(2, 1);
    accumulator.add({0x00000000u, 0xFF0000FFu});
    accumulator.add({0x01010101u, 0xFF0000FEu});
    // (0 + 1) / 2 = 0.5 rounds up; (255 + 254) / 2 = 254.5 rounds up.
    EXPECT_EQ(accumulator.resolve(), (std::vector<uint32_t>{0x01010101u, 0xFF0000FFu}));
    EXPECT_THROW(accumulator.add({1u}), Error);

    EXPECT_EQ(scaledExtent(641, 4), 161u);
    EXPECT_EQ(scaledExtent(3, 8), 1u);
    const Image small{2, 2, {1u, 2u, 3u, 4u}};
    const Image nearest = scaleImage(small, 4, 4, ScaleFilter::Nearest);
    EXPECT_EQ(nearest.rgba, (std::vector<uint32_t>{1, 1, 2, 2, 1, 1, 2, 2, 3, 3, 4, 4, 3, 3, 4, 4}));
    // Bilinear: texel (1, 0) of the 4x4 image sits a quarter of the way from texel 0 to texel 1.
    const Image grey{2, 1, {0xFF000000u, 0xFF0000FFu}};
    const Image bilinear = scaleImage(grey, 4, 1, ScaleFilter::Bilinear);
    EXPECT_EQ(bilinear.rgba[0] & 0xFFu, 0u);
    EXPECT_EQ(bilinear.rgba[1] & 0xFFu, 64u);   // 255 * 0.25 = 63.75
    EXPECT_EQ(bilinear.rgba[2] & 0xFFu, 191u);  // 255 * 0.75 = 191.25
    EXPECT_EQ(bilinear.rgba[3] & 0xFFu, 255u);
}

TEST(CameraPath, RoundTripsAndInterpolates) {
    ui::CameraPath path;
    path.scene = "gen:default";
    Camera a, b;
    a.eye = glm::vec3(0.1f, 0.2f, 0.3f);
    b.eye = glm::vec3(1.1f, 0.2f, 0.3f);
    b.fovYDegrees = 70.0f;
    path.keys = {{0.0, a}, {2.0, b}};
    const std::string file = (fs::temp_directory_path() / "raypack_test_path.json").string();
    ui::writeCameraPath(file, path);
    const ui::CameraPath back = ui::readCameraPath(file);
    ASSERT_EQ(back.keys.size(), 2u);
    EXPECT_EQ(back.keys[1].camera.eye, b.eye);
    EXPECT_EQ(back.keys[1].seconds, 2.0);
    const Camera middle = ui::cameraAt(back, 1.0);
    EXPECT_NEAR(middle.eye.x, 0.6f, 1e-6f);
    EXPECT_NEAR(middle.fovYDegrees, 65.0f, 1e-5f);
    EXPECT_EQ(ui::cameraAt(back, 5.0).eye, b.eye);
    std::ofstream(file) << "{\"format\": \"raypack-camera-path-1\", \"keys\": [{\"t\": 1}, {\"t\": 0}]}";
    EXPECT_THROW(ui::readCameraPath(file), Error);
    fs::remove(file);
}

TEST(Bookmarks, RoundTripExactlyPerSceneAndPrintAsCliArguments) {
    const fs::path file = fs::temp_directory_path() / "raypack_test_viewer_config" / "bookmarks.json";
    fs::remove_all(file.parent_path());
    Camera camera;
    camera.eye = glm::vec3(0.1f, -2.7182817f, 1e-7f);
    camera.at = glm::vec3(3.3333333f, 4.0f, -5.5f);
    camera.up = glm::vec3(0.0f, 0.0f, 1.0f);
    camera.fovYDegrees = 47.123456f;
    {
        ui::BookmarkStore a(file.string(), "scene-a.ply");
        a.save(3, camera);
        ui::BookmarkStore b(file.string(), "gen:default");
        b.save(9, frameScene(Aabb{glm::vec3(0.0f), glm::vec3(1.0f)}));
    }
    ui::BookmarkStore a(file.string(), "scene-a.ply");
    ASSERT_TRUE(a.slot(3));
    EXPECT_FALSE(a.slot(9));
    EXPECT_EQ(a.slot(3)->eye, camera.eye);
    EXPECT_EQ(a.slot(3)->at, camera.at);
    EXPECT_EQ(a.slot(3)->up, camera.up);
    EXPECT_EQ(a.slot(3)->fovYDegrees, camera.fovYDegrees);
    EXPECT_TRUE(ui::BookmarkStore(file.string(), "gen:default").slot(9));

    const std::string arguments = ui::cameraCliArguments(camera);
    Camera parsed;
    char eye[64], at[64], up[64];
    ASSERT_EQ(
        std::sscanf(arguments.c_str(), "--eye %63s --at %63s --up %63s --fov %f", eye, at, up, &parsed.fovYDegrees), 4)
        << arguments;
    ASSERT_EQ(std::sscanf(eye, "%f,%f,%f", &parsed.eye.x, &parsed.eye.y, &parsed.eye.z), 3);
    EXPECT_EQ(parsed.eye, camera.eye) << arguments;
    EXPECT_EQ(parsed.fovYDegrees, camera.fovYDegrees) << arguments;

    // A broken file is an error naming it, not a crash.
    std::ofstream(file) << "{not json";
    try {
        ui::BookmarkStore broken(file.string(), "scene-a.ply");
        ADD_FAILURE() << "no error for a broken bookmarks file";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("bookmarks.json"), std::string::npos) << e.what();
    }
    fs::remove_all(file.parent_path());
}

// ---- `raypack` end to end, under Xvfb.

struct CommandRun {
    int exitCode = -1;
    std::string output;
};

CommandRun runCommand(const std::string& command) {
    const fs::path log = fs::temp_directory_path() / ("raypack_test_viewer_" + std::to_string(::getpid()) + ".log");
    const int status = std::system((command + " >" + log.string() + " 2>&1").c_str());
    CommandRun run;
    run.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::ifstream in(log);
    std::stringstream text;
    text << in.rdbuf();
    run.output = text.str();
    fs::remove(log);
    return run;
}

bool haveXvfb() { return std::system("command -v xvfb-run >/dev/null 2>&1 && command -v Xvfb >/dev/null 2>&1") == 0; }

// Each run gets its own server (-a picks a free display number); the config folder is private so
// the user's bookmarks are untouched.
std::string viewerCommand(const std::string& arguments) {
    const fs::path config = fs::temp_directory_path() / "raypack_test_viewer_xdg";
    return "XDG_RUNTIME_DIR=/tmp XDG_CONFIG_HOME=" + config.string() + " xvfb-run -a -s '-screen 0 1024x768x24' " +
           RAYPACK_VIEWER + " " + arguments;
}

class ViewerUnderXvfb : public ::testing::Test {
protected:
    void SetUp() override {
        if (!haveXvfb()) GTEST_SKIP() << "Xvfb / xvfb-run not installed";
        dir_ = fs::temp_directory_path() / ("raypack_test_viewer_" + std::to_string(::getpid()));
        fs::create_directories(dir_);
    }
    void TearDown() override {
        if (!dir_.empty()) fs::remove_all(dir_);
    }
    fs::path dir_;
};

TEST_F(ViewerUnderXvfb, ScriptedScreenshotEqualsTheCliRenderOfTheSameView) {
    const std::string shot = (dir_ / "viewer.png").string();
    // Packet shape, leaf size and shadows changed by the script while it runs, then a screenshot.
    const CommandRun viewer =
        runCommand(viewerCommand("--width 256 --height 192 --frames 8 --validation --no-counters --samples 1 --tracer "
                                 "vulkan-packet --screenshot " +
                                 shot + " --script 2:packet:5x6 --script 3:leaf-size:4 --script 4:shadows:off"));
    ASSERT_EQ(viewer.exitCode, 0) << viewer.output;
    EXPECT_NE(viewer.output.find("0 validation messages"), std::string::npos) << viewer.output;
    ASSERT_TRUE(fs::exists(shot)) << viewer.output;

    const nlohmann::json sidecar = readJsonFile(ui::sidecarPath(shot));
    const RenderSetup setup = renderSetupFromJson(sidecar);
    EXPECT_EQ(setup.scene, "gen:default");
    EXPECT_EQ(setup.settings.packet, (PacketShape{5, 6}));
    EXPECT_EQ(setup.bvh.leafSize, 4u);
    EXPECT_FALSE(setup.settings.shadows);
    EXPECT_EQ(setup.settings.width, 256u);
    EXPECT_EQ(setup.settings.height, 192u);
    EXPECT_TRUE(sidecar.contains("stats"));

    // The CLI from the sidecar, and from plain flags with the default framing.
    const std::string fromSidecar = (dir_ / "cli_from.png").string();
    CommandRun cli = runCommand(std::string("XDG_RUNTIME_DIR=/tmp ") + RAYPACK_CLI + " render --device gpu --from " +
                                ui::sidecarPath(shot) + " --out " + fromSidecar);
    ASSERT_EQ(cli.exitCode, 0) << cli.output;
    const std::string fromFlags = (dir_ / "cli_flags.png").string();
    cli = runCommand(std::string("XDG_RUNTIME_DIR=/tmp ") + RAYPACK_CLI +
                     " render gen:default --device gpu --width 256 --height 192 --packet 5x6 --leaf-size 4"
                     " --no-shadows --out " +
                     fromFlags);
    ASSERT_EQ(cli.exitCode, 0) << cli.output;

    const Image viewerImage = readPng(shot);
    for (const std::string& other : {fromSidecar, fromFlags}) {
        const ImageDiff diff = diffImages(viewerImage, readPng(other), 0, shot, other);
        EXPECT_EQ(diff.differingPixels, 0u) << other << ": max channel difference " << diff.maxChannelDifference;
    }
}

TEST_F(ViewerUnderXvfb, ResizeAndSceneLoadDuringARebuildPassValidation) {
    const std::string shot = (dir_ / "after.png").string();
    const std::string sibenik = std::string(RAYPACK_SHARED_SCENES) + "/sibenik/sibenik_geom_75284.ply";
    ASSERT_TRUE(fs::exists(sibenik)) << sibenik;
    // Frame 1 waits for the first tree; frame 2 starts a rebuild of a 500k-triangle terrain
    // (hundreds of milliseconds) and resizes the window; frame 3 opens another scene while that
    // rebuild runs, which cancels it.
    const CommandRun viewer = runCommand(viewerCommand(
        "--scene gen:terrain:500k --width 200 --height 160 --frames 7 --validation --no-counters --screenshot " + shot +
        " --script 1:wait --script 2:leaf-size:1 --script 2:resize:240x136 --script 3:open:" + sibenik));
    ASSERT_EQ(viewer.exitCode, 0) << viewer.output;
    EXPECT_NE(viewer.output.find("0 validation messages"), std::string::npos) << viewer.output;
    EXPECT_NE(viewer.output.find("worker building when the load was requested"), std::string::npos)
        << "the load did not meet a running rebuild:\n"
        << viewer.output;
    const RenderSetup setup = renderSetupFromJson(readJsonFile(ui::sidecarPath(shot)));
    EXPECT_EQ(setup.scene, fs::absolute(sibenik).lexically_normal().string());
    EXPECT_EQ(setup.settings.width, 240u);
    EXPECT_EQ(setup.settings.height, 136u);
    EXPECT_EQ(readPng(shot).width, 240u);
}

TEST_F(ViewerUnderXvfb, ABadFileIsReportedAndTheSceneStays) {
    const fs::path bad = dir_ / "broken.obj";
    std::ofstream(bad) << "v 0 0 0\nv 1 0 0\nf 1 2 7\n";
    const std::string shot = (dir_ / "still.png").string();
    const CommandRun viewer =
        runCommand(viewerCommand("--width 128 --height 96 --frames 5 --no-counters --screenshot " + shot +
                                 " --script 1:wait --script 2:open:" + bad.string()));
    ASSERT_EQ(viewer.exitCode, 0) << viewer.output;
    EXPECT_NE(viewer.output.find("broken.obj"), std::string::npos) << viewer.output;
    EXPECT_EQ(renderSetupFromJson(readJsonFile(ui::sidecarPath(shot))).scene, "gen:default");
    // The open step is logged once, and the error names the file once.
    const std::string step = "frame 2: open " + bad.string();
    const size_t first = viewer.output.find(step);
    EXPECT_NE(first, std::string::npos) << viewer.output;
    EXPECT_EQ(viewer.output.find(step, first + 1), std::string::npos) << viewer.output;
    EXPECT_EQ(viewer.output.find(bad.string() + ": " + bad.string()), std::string::npos) << viewer.output;
}

// Renders with raypack-cli from a sidecar and compares with the viewer's screenshot, pixel for pixel.
void expectCliReproduces(const fs::path& dir, const std::string& shot, const std::string& extra) {
    const std::string again = (dir / "cli_again.png").string();
    const CommandRun cli = runCommand(std::string("XDG_RUNTIME_DIR=/tmp ") + RAYPACK_CLI + " render --from " +
                                      ui::sidecarPath(shot) + " " + extra + " --out " + again);
    ASSERT_EQ(cli.exitCode, 0) << cli.output;
    const ImageDiff diff = diffImages(readPng(shot), readPng(again), 0, shot, again);
    EXPECT_EQ(diff.differingPixels, 0u) << extra << ": max channel difference " << diff.maxChannelDifference;
}

TEST_F(ViewerUnderXvfb, AConvergedScreenshotEqualsTheCliRenderWithAsManySamples) {
    for (const std::string tracer : {"cpu-packet", "cpu-reference", "vulkan-single"}) {
        const std::string shot = (dir_ / ("converged-" + tracer + ".png")).string();
        const CommandRun viewer =
            runCommand(viewerCommand("--width 160 --height 120 --frames 12 --samples 4 --validation "
                                     "--tracer " +
                                     tracer + " --script 1:wait --screenshot " + shot));
        ASSERT_EQ(viewer.exitCode, 0) << viewer.output;
        const nlohmann::json sidecar = readJsonFile(ui::sidecarPath(shot));
        EXPECT_EQ(sidecar["samples_per_pixel"], 4) << viewer.output;
        EXPECT_EQ(sidecar["sample_pattern"], kSamplePatternName);
        expectCliReproduces(dir_, shot, tracer == "vulkan-single" ? "--device gpu" : "--device cpu");
        // The refined image is not the plain one: the samples moved the rays.
        const std::string plain = (dir_ / "plain.png").string();
        const CommandRun cli = runCommand(std::string("XDG_RUNTIME_DIR=/tmp ") + RAYPACK_CLI + " render --from " +
                                          ui::sidecarPath(shot) + " --spp 1 --out " + plain);
        ASSERT_EQ(cli.exitCode, 0) << cli.output;
        EXPECT_GT(diffImages(readPng(shot), readPng(plain)).differingPixels, 0u);
    }
}

TEST_F(ViewerUnderXvfb, AReducedResolutionFrameEqualsTheCliRenderAtThatResolutionScaledUp) {
    for (const std::string view : {"shaded", "nodes"}) {
        const std::string shot = (dir_ / ("reduced-" + view + ".png")).string();
        const CommandRun viewer =
            runCommand(viewerCommand("--width 200 --height 150 --frames 4 --validation --view " + view +
                                     " --script 1:wait --script 2:scale:4 --script 2:screenshot:" + shot));
        ASSERT_EQ(viewer.exitCode, 0) << viewer.output;
        const nlohmann::json sidecar = readJsonFile(ui::sidecarPath(shot));
        EXPECT_EQ(sidecar["resolution_scale"], 4) << viewer.output;
        EXPECT_EQ(readPng(shot).width, 200u);
        // The heat map's full scale follows the frame (its 99th percentile), not the constant 256.
        if (view == "nodes") {
            const float scale = sidecar["heat_full_scale"].get<float>();
            EXPECT_GT(scale, 0.0f) << viewer.output;
            EXPECT_NE(scale, 256.0f);
        }
        expectCliReproduces(dir_, shot, "--device cpu");
    }
}

TEST_F(ViewerUnderXvfb, AStillViewerStopsTracing) {
    // 4 samples: the first frame (full resolution), then 4 refinement samples, then nothing more,
    // however many frames follow.
    const std::string summary = (dir_ / "summary.json").string();
    for (const uint32_t frames : {30u, 60u}) {
        const CommandRun viewer =
            runCommand(viewerCommand("--width 96 --height 64 --samples 4 --validation --frames " +
                                     std::to_string(frames) + " --script 1:wait --summary " + summary));
        ASSERT_EQ(viewer.exitCode, 0) << viewer.output;
        const nlohmann::json s = readJsonFile(summary);
        EXPECT_EQ(s["frames"], frames);
        EXPECT_EQ(s["frames_traced"], 5) << viewer.output;
        EXPECT_GT(s["idle_frames"].get<uint64_t>(), frames / 2);
    }
}

TEST_F(ViewerUnderXvfb, ScriptedMovesAndARecordedPathReplayFrameForFrame) {
    const std::string first = (dir_ / "first.json").string(), second = (dir_ / "second.json").string();
    CommandRun viewer = runCommand(
        viewerCommand("--width 96 --height 64 --frames 12 --validation --script 1:wait --script 3:move:0,0,0.05 "
                      "--script 5:look:40,-10 --script 7:move:0.05,0.02,0 --record-path " +
                      first));
    ASSERT_EQ(viewer.exitCode, 0) << viewer.output;
    viewer = runCommand(viewerCommand("--width 96 --height 64 --frames 12 --script 1:wait --play-path " + first +
                                      " --play-frames --record-path " + second));
    ASSERT_EQ(viewer.exitCode, 0) << viewer.output;
    const ui::CameraPath a = ui::readCameraPath(first), b = ui::readCameraPath(second);
    ASSERT_GE(a.keys.size(), 8u);
    ASSERT_EQ(a.keys.size(), b.keys.size());
    size_t moves = 0;
    for (size_t i = 0; i < a.keys.size(); ++i) {
        EXPECT_EQ(a.keys[i].camera.eye, b.keys[i].camera.eye) << "frame " << i;
        EXPECT_EQ(a.keys[i].camera.at, b.keys[i].camera.at) << "frame " << i;
        moves += i > 0 && a.keys[i].camera.eye != a.keys[i - 1].camera.eye;
    }
    EXPECT_EQ(moves, 2u) << "two scripted moves";
}

TEST_F(ViewerUnderXvfb, OffscreenRunsTheSameFrameLoopWithoutADisplay) {
    // No display at all: --offscreen plays a path, refines and exits when converged; its
    // screenshot is reproduced by the CLI as the window's would be.
    const std::string path = (dir_ / "path.json").string(), shot = (dir_ / "offscreen.png").string(),
                      summary = (dir_ / "offscreen.json").string();
    ui::CameraPath cameraPath;
    Camera a = frameScene(openScene("gen:default").bounds()), b = a;
    b.eye += 0.1f * (b.at - b.eye);
    cameraPath.keys = {{0.0, a}, {0.3, b}};
    ui::writeCameraPath(path, cameraPath);
    const CommandRun viewer =
        runCommand(std::string("env -u DISPLAY -u WAYLAND_DISPLAY XDG_RUNTIME_DIR=/tmp ") + RAYPACK_VIEWER +
                   " --offscreen --validation --width 120 --height 90 --samples 4 "
                   "--play-path " +
                   path + " --summary " + summary);
    ASSERT_EQ(viewer.exitCode, 0) << viewer.output;
    const nlohmann::json s = readJsonFile(summary);
    EXPECT_GE(s["frames_moving"].get<uint64_t>(), 1u) << viewer.output;
    EXPECT_GE(s["converged_after_stop_s"].get<double>(), 0.0) << viewer.output;
    const CommandRun still =
        runCommand(std::string("env -u DISPLAY XDG_RUNTIME_DIR=/tmp ") + RAYPACK_VIEWER +
                   " --offscreen --width 120 --height 90 --samples 4 --frames 8 --screenshot " + shot);
    ASSERT_EQ(still.exitCode, 0) << still.output;
    EXPECT_EQ(readJsonFile(ui::sidecarPath(shot))["samples_per_pixel"], 4) << still.output;
    expectCliReproduces(dir_, shot, "");
}

TEST_F(ViewerUnderXvfb, DeviceBuildsAreAdoptedByTheTracerOrBuiltOnADeviceOfTheWorkersOwn) {
    // Issue 13. RAYPACK_DEVICE_BUILD=shared (a GPU's default): the worker builds on the viewer's own
    // device and the tracer adopts the tree (no upload); a CPU tracer chosen afterwards reads that
    // tree back; a device build while a CPU tracer draws brings the host tree along. Unset (on this
    // CPU device: its own device), every device-built tree arrives as a host tree and is uploaded.
    // Either way the last frame is what the CLI renders of its setup.
    for (const std::string mode : {"shared", ""}) {
        SCOPED_TRACE("RAYPACK_DEVICE_BUILD=" + mode);
        const std::string shot = (dir_ / "device-built.png").string(),
                          summary = (dir_ / "device-built-summary.json").string();
        const CommandRun viewer =
            runCommand(std::string("env -u DISPLAY -u WAYLAND_DISPLAY XDG_RUNTIME_DIR=/tmp ") +
                       (mode.empty() ? "" : "RAYPACK_DEVICE_BUILD=" + mode + " ") + RAYPACK_VIEWER +
                       " --offscreen --validation --width 120 --height 90 --samples 1 --tracer vulkan-single --frames 9"
                       " --script 1:builder:gpu-ploc --script 2:wait --script 3:leaf-size:4 --script 4:wait"
                       " --script 5:tracer:cpu-packet --script 6:builder:gpu-lbvh --script 7:wait --summary " +
                       summary + " --screenshot " + shot);
        ASSERT_EQ(viewer.exitCode, 0) << viewer.output;
        EXPECT_NE(viewer.output.find("0 validation messages"), std::string::npos) << viewer.output;
        const nlohmann::json trees = readJsonFile(summary)["trees"];
        ASSERT_EQ(trees.size(), 4u) << trees.dump();
        EXPECT_EQ(trees[0]["taken_by"], "upload") << "the start scene's CPU-built tree";
        for (size_t k = 1; k < 4; ++k)
            EXPECT_EQ(trees[k]["taken_by"], mode == "shared" ? "adopt" : "upload") << trees[k].dump();
        EXPECT_EQ(trees[1]["builder"], "gpu-ploc");
        EXPECT_EQ(trees[2]["leaf_size"], 4u);
        EXPECT_EQ(trees[3]["builder"], "gpu-lbvh");
        const nlohmann::json sidecar = readJsonFile(ui::sidecarPath(shot));
        EXPECT_EQ(sidecar["bvh"]["builder"], "gpu-lbvh") << sidecar.dump();
        expectCliReproduces(dir_, shot, "--device cpu");
    }
}

// --kernel without --tracer starts that kernel's Vulkan tracer, on this CPU device too (where the
// default would be the CPU packet tracer); --tracer still wins over it.
TEST_F(ViewerUnderXvfb, KernelFlagPicksItsVulkanTracer) {
    const auto tracerOf = [&](const std::string& flags, const std::string& name) {
        const std::string shot = (dir_ / name).string();
        const CommandRun viewer =
            runCommand(viewerCommand("--width 120 --height 90 --frames 4 --samples 1 --validation " + flags +
                                     " --script 1:wait --screenshot " + shot));
        EXPECT_EQ(viewer.exitCode, 0) << viewer.output;
        const nlohmann::json sidecar = readJsonFile(ui::sidecarPath(shot));
        return std::make_pair(sidecar["stats"]["tracer"].get<std::string>(), sidecar["kernel"].get<std::string>());
    };
    EXPECT_EQ(tracerOf("--kernel hybrid", "hybrid.png"),
              std::make_pair(std::string("vulkan-hybrid"), std::string("hybrid")));
    EXPECT_EQ(tracerOf("--kernel single", "single.png"),
              std::make_pair(std::string("vulkan-single"), std::string("single")));
    EXPECT_EQ(tracerOf("--kernel hybrid --tracer cpu-packet", "cpu.png").first, "cpu-packet");
}

TEST_F(ViewerUnderXvfb, SideBySideHalvesAreTheTwoTracersImages) {
    const std::string shot = (dir_ / "split.png").string();
    const CommandRun viewer =
        runCommand(viewerCommand("--width 161 --height 120 --frames 4 --samples 1 --validation --tracer cpu-packet "
                                 "--side-by-side vulkan-single --script 1:wait --screenshot " +
                                 shot));
    ASSERT_EQ(viewer.exitCode, 0) << viewer.output;
    const nlohmann::json sidecar = readJsonFile(ui::sidecarPath(shot));
    ASSERT_TRUE(sidecar["stats"].contains("side_by_side")) << sidecar.dump();
    EXPECT_EQ(sidecar["stats"]["side_by_side"]["right_tracer"], "vulkan-single");
    const Image split = readPng(shot);
    const auto render = [&](const std::string& flags, const std::string& name) {
        const std::string out = (dir_ / name).string();
        const CommandRun cli = runCommand(std::string("XDG_RUNTIME_DIR=/tmp ") + RAYPACK_CLI + " render --from " +
                                          ui::sidecarPath(shot) + " " + flags + " --out " + out);
        EXPECT_EQ(cli.exitCode, 0) << cli.output;
        return readPng(out);
    };
    const Image left = render("", "left.png"), right = render("--device gpu --kernel single", "right.png");
    ASSERT_EQ(left.width, split.width);
    size_t leftDiffer = 0, rightDiffer = 0;
    for (uint32_t y = 0; y < split.height; ++y)
        for (uint32_t x = 0; x < split.width; ++x) {
            const size_t i = size_t(y) * split.width + x;
            if (x < split.width / 2)
                leftDiffer += split.rgba[i] != left.rgba[i];
            else
                rightDiffer += split.rgba[i] != right.rgba[i];
        }
    EXPECT_EQ(leftDiffer, 0u);
    EXPECT_EQ(rightDiffer, 0u);
}

TEST_F(ViewerUnderXvfb, ABadStartSceneFailsAScriptedRun) {
    const CommandRun viewer =
        runCommand(viewerCommand("--width 64 --height 48 --frames 3 --scene /nonexistent/scene.ply"));
    EXPECT_EQ(viewer.exitCode, 2) << viewer.output;
    EXPECT_NE(viewer.output.find("/nonexistent/scene.ply"), std::string::npos) << viewer.output;
    EXPECT_EQ(viewer.output.find("/nonexistent/scene.ply: /nonexistent/scene.ply"), std::string::npos)
        << "the path is said once:\n"
        << viewer.output;
}

// The scene as the one positional argument (`raypack model.ply`), as raypack-cli render takes it;
// a bad one fails the same way as --scene's, and both at once is a usage error.
TEST_F(ViewerUnderXvfb, TheSceneMayBeThePositionalArgument) {
    const CommandRun bad = runCommand(viewerCommand("/nonexistent/scene.ply --width 64 --height 48 --frames 3"));
    EXPECT_EQ(bad.exitCode, 2) << bad.output;
    EXPECT_NE(bad.output.find("/nonexistent/scene.ply"), std::string::npos) << bad.output;
    const fs::path summary = dir_ / "positional-summary.json";
    const CommandRun good =
        runCommand(viewerCommand("gen:sphereflake:1k --width 64 --height 48 --frames 3 --summary " + summary.string()));
    ASSERT_EQ(good.exitCode, 0) << good.output;
    EXPECT_EQ(readJsonFile(summary)["scene"], "gen:sphereflake:1k");
    const CommandRun both = runCommand(viewerCommand("gen:default --scene gen:default --frames 1"));
    EXPECT_EQ(both.exitCode, 2) << both.output;
}

TEST_F(ViewerUnderXvfb, F12AndTheScreenshotKeyWriteAPngAndItsSidecar) {
    // A real key press through the X server (xdotool), as a user would: F12 writes
    // raypack-DATE-TIME.png and its sidecar into the current folder.
    if (std::system("command -v xdotool >/dev/null 2>&1") != 0) GTEST_SKIP() << "xdotool not installed";
    const fs::path config = fs::temp_directory_path() / "raypack_test_viewer_xdg";
    const std::string script = "cd " + dir_.string() + " && XDG_RUNTIME_DIR=/tmp XDG_CONFIG_HOME=" + config.string() +
                               " xvfb-run -a -s '-screen 0 640x480x24' sh -c '" + RAYPACK_VIEWER +
                               " --width 320 --height 240 --frames 400 --script 1:wait & pid=$!; sleep 3; "
                               "w=$(xdotool search --sync --name raypack | head -1); xdotool key --window $w F12; "
                               "wait $pid'";
    const CommandRun run = runCommand(script);
    ASSERT_EQ(run.exitCode, 0) << run.output;
    size_t pngs = 0, sidecars = 0;
    for (const fs::directory_entry& e : fs::directory_iterator(dir_)) {
        const std::string name = e.path().filename().string();
        if (name.rfind("raypack-", 0) != 0) continue;
        pngs += e.path().extension() == ".png";
        sidecars += e.path().extension() == ".json";
    }
    EXPECT_EQ(pngs, 1u) << run.output;
    EXPECT_EQ(sidecars, 1u) << run.output;
}

// Each of --eye, --at, --up and --fov replaces its part of the start view, as in raypack-cli render.
TEST_F(ViewerUnderXvfb, ACameraFlagReplacesItsPartOfTheStartView) {
    const auto cameraOf = [&](const std::string& flags, const std::string& name) {
        const fs::path shot = dir_ / (name + ".png");
        const CommandRun run = runCommand(viewerCommand(
            "gen:default --offscreen --width 64 --height 48 --frames 1 --screenshot " + shot.string() + " " + flags));
        EXPECT_EQ(run.exitCode, 0) << run.output;
        return readJsonFile(fs::path(shot).replace_extension(".json"))["camera"];
    };
    const nlohmann::json start = cameraOf("", "start");
    const nlohmann::json eye = cameraOf("--eye 3,2,4", "eye");
    EXPECT_EQ(eye["eye"], nlohmann::json({3.0, 2.0, 4.0}));
    EXPECT_EQ(eye["at"], start["at"]);
    const nlohmann::json at = cameraOf("--at 0,1,0 --fov 30", "at");
    EXPECT_EQ(at["at"], nlohmann::json({0.0, 1.0, 0.0}));
    EXPECT_EQ(at["eye"], start["eye"]);
    EXPECT_EQ(at["fov_y_degrees"], 30.0);
}

TEST(Viewer, BadArgumentsExitWithTwoAndSaySo) {
    for (const char* flags : {"--width abc", "--fov 200", "--heat-scale 0", "--frobnicate"}) {
        const CommandRun run = runCommand(std::string(RAYPACK_VIEWER) + " " + flags + " --frames 1");
        EXPECT_EQ(run.exitCode, 2) << flags << ":\n" << run.output;
        EXPECT_NE(run.output.find("raypack: "), std::string::npos) << flags << ":\n" << run.output;
    }
}

TEST(Viewer, WithoutADisplayItFailsWithAClearMessage) {
    const CommandRun run = runCommand(std::string("env -u DISPLAY -u WAYLAND_DISPLAY XDG_RUNTIME_DIR=/tmp ") +
                                      RAYPACK_VIEWER + " --frames 1");
    EXPECT_EQ(run.exitCode, 2) << run.output;
    EXPECT_NE(run.output.find("cannot open a window"), std::string::npos) << run.output;
    EXPECT_NE(run.output.find("DISPLAY"), std::string::npos) << run.output;
}

#endif  // RAYPACK_VIEWER

}  // namespace
}  // namespace raypack
