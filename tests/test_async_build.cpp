// The viewer's worker that loads and builds off the render thread (renderer/async_build.h): the tree
// it hands back is buildBvh's, rapid rebuilds end in the last request, a bad file fails with its
// name, and destroying it cancels a running build. Its own program so that CI's ThreadSanitizer
// stage builds the library and this file only (not the viewer and the CLI).
#include "renderer/async_build.h"
#include "renderer/bvh.h"
#include "renderer/error.h"
#include "scenes/load.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <thread>

namespace raypack {
namespace {

namespace fs = std::filesystem;

Scene loadForTest(const std::string& spec, LoadProgress& progress) { return openScene(spec, &progress); }

// The worker's tree must be the tree buildBvh makes directly: same nodes, same order.
void expectSameTree(const Bvh& a, const Bvh& b) {
    ASSERT_EQ(a.nodes.size(), b.nodes.size());
    ASSERT_EQ(a.primIndices, b.primIndices);
    for (size_t i = 0; i < a.nodes.size(); ++i) {
        EXPECT_EQ(a.nodes[i].index, b.nodes[i].index) << "node " << i;
        EXPECT_EQ(a.nodes[i].count, b.nodes[i].count) << "node " << i;
    }
}

TEST(AsyncSceneBuilder, LoadsAndBuildsTheSameTreeAsADirectBuild) {
    AsyncSceneBuilder builder(loadForTest);
    BvhBuildOptions options;
    options.leafSize = 3;
    const uint64_t id = builder.requestLoad("gen:default", options);
    builder.waitIdle();
    EXPECT_FALSE(builder.takeFailure());
    std::optional<SceneBuild> build = builder.takeFinished();
    ASSERT_TRUE(build);
    EXPECT_EQ(build->requestId, id);
    EXPECT_EQ(build->scenePath, "gen:default");
    const Scene direct = openScene("gen:default");
    EXPECT_EQ(build->scene->triangleCount(), direct.triangleCount());
    expectSameTree(*build->bvh, buildBvh(direct, options));
    EXPECT_EQ(build->bvh->options.leafSize, 3u);
    EXPECT_FALSE(builder.takeFinished()) << "a result is handed back once";
}

TEST(AsyncSceneBuilder, RapidRebuildsEndInTheLastRequestedTree) {
    AsyncSceneBuilder builder(loadForTest);
    builder.requestLoad("gen:terrain:200k", {});
    builder.waitIdle();
    std::optional<SceneBuild> first = builder.takeFinished();
    ASSERT_TRUE(first);
    // A slider dragged through leaf sizes 1..8 within a few milliseconds: each request cancels
    // the running build; only builds that finished before the next request may come back.
    for (uint32_t leaf = 1; leaf <= 8; ++leaf) {
        BvhBuildOptions options;
        options.leafSize = leaf;
        builder.requestRebuild(first->scene, options);
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    builder.waitIdle();
    std::optional<SceneBuild> last = builder.takeFinished();
    ASSERT_TRUE(last);
    EXPECT_EQ(last->bvh->options.leafSize, 8u);
    EXPECT_EQ(last->scene, first->scene) << "a rebuild reuses the scene, it does not read it again";
    BvhBuildOptions eight;
    eight.leafSize = 8;
    expectSameTree(*last->bvh, buildBvh(*first->scene, eight));
    EXPECT_FALSE(builder.takeFailure());
}

TEST(AsyncSceneBuilder, ABadFileFailsWithItsNameAndHandsBackNoScene) {
    const fs::path bad = fs::temp_directory_path() / "raypack_test_viewer_bad.ply";
    {
        std::ofstream out(bad);
        out << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n";
    }
    AsyncSceneBuilder builder(loadForTest);
    builder.requestLoad(bad.string(), {});
    builder.waitIdle();
    EXPECT_FALSE(builder.takeFinished());
    std::optional<BuildFailure> failure = builder.takeFailure();
    ASSERT_TRUE(failure);
    EXPECT_NE(failure->message.find("raypack_test_viewer_bad.ply"), std::string::npos) << failure->message;
    fs::remove(bad);
}

TEST(AsyncSceneBuilder, ARebuildDuringALoadAppliesToTheNewScene) {
    AsyncSceneBuilder builder(loadForTest);
    builder.requestLoad("gen:default", {});
    builder.waitIdle();
    std::optional<SceneBuild> old = builder.takeFinished();
    ASSERT_TRUE(old);
    builder.requestLoad("gen:terrain:100k", {});
    BvhBuildOptions options;
    options.leafSize = 5;
    builder.requestRebuild(old->scene, options);  // the panel still holds the old scene
    builder.waitIdle();
    std::optional<SceneBuild> result = builder.takeFinished();
    ASSERT_TRUE(result);
    EXPECT_EQ(result->scenePath, "gen:terrain:100k");
    EXPECT_NE(result->scene, old->scene);
    EXPECT_EQ(result->bvh->options.leafSize, 5u);
}

TEST(AsyncSceneBuilder, ReportsProgressAndCancelsARunningBuildOnDestruction) {
    std::optional<AsyncSceneBuilder> builder(std::in_place, loadForTest);
    builder->requestLoad("gen:terrain:1M", {});
    BuildStatus status;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while ((status = builder->status()).phase != BuildPhase::Building || status.placed == 0) {
        ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the build never started";
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_GT(status.total, 0u);
    EXPECT_LE(status.placed, status.total);
    EXPECT_GT(status.elapsedSeconds, 0.0);
    const auto start = std::chrono::steady_clock::now();
    builder.reset();  // cancels the running build and joins the worker
    const auto destroyTook = std::chrono::steady_clock::now() - start;
    const double seconds = std::chrono::duration<double>(destroyTook).count();
    std::printf("cancelling a running 1M-triangle build took %.3f s\n", seconds);
    EXPECT_LT(seconds, 5.0);
}

}  // namespace
}  // namespace raypack
