// The start view (renderer/start_view.h): the file's camera when it has one; the framing of the
// whole scene for objects; a view from inside for closed rooms (Conference, Sponza, Sibenik and a
// generated closed box), checked by probing what the start view sees.
#include "renderer/bvh.h"
#include "renderer/start_view.h"
#include "scenes/load.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

namespace raypack::test {
namespace {

std::string sharedScene(const char* relative) { return std::string(RAYPACK_SHARED_SCENES) + "/" + relative; }

void printProbe(const std::string& what, const ViewProbe& p) {
    std::printf("%-34s rays %4u, hits %4u, back faces %4u, near %4u\n", what.c_str(), p.rays, p.hits, p.backHits,
                p.nearHits);
}

bool sameCamera(const Camera& a, const Camera& b) {
    return a.eye == b.eye && a.at == b.at && a.up == b.up && a.fovYDegrees == b.fovYDegrees;
}

// The start view of a room sees its inside: the eye inside the box, nearly every ray hitting a
// wall's front face, and not only walls right in front of it.
void expectStartsInside(const Scene& scene, const std::string& what) {
    const Bvh bvh = buildBvh(scene, BvhBuildOptions{});
    EXPECT_TRUE(centreIsInARoom(scene, bvh)) << what;
    const Camera start = startCamera(scene, bvh);
    EXPECT_FALSE(sameCamera(start, frameScene(scene.bounds()))) << what;
    EXPECT_TRUE(scene.bounds().contains(Aabb{start.eye, start.eye})) << what;
    const ViewProbe p = probeView(scene, bvh, start);
    printProbe(what + " start view", p);
    EXPECT_GE(p.hits, 0.9 * p.rays) << what;
    EXPECT_LE(p.backHits, 0.2 * p.hits) << what;
    EXPECT_LE(p.nearHits, 0.5 * p.hits) << what;
    // Looking along the longest horizontal axis.
    const glm::vec3 extent = scene.bounds().extent();
    const glm::vec3 view = start.at - start.eye;
    if (extent.x >= extent.z)
        EXPECT_EQ(view, glm::vec3(1, 0, 0)) << what;
    else
        EXPECT_EQ(view, glm::vec3(0, 0, 1)) << what;
}

TEST(StartView, SharedRoomsStartInside) {
    for (const char* file : {"conference/conference_geom.ply", "dabrovic_sponza/sponza.obj", "sibenik/sibenik.obj",
                             "sibenik/sibenik_geom_75284.ply"})
        expectStartsInside(openScene(sharedScene(file)), file);
}

// A closed box room, 4 x 2 x 3, its twelve triangles facing inwards, and a small cube inside.
Scene closedBoxRoom(bool facingInwards) {
    Scene scene;
    scene.source = "closed box";
    for (int i = 0; i < 8; ++i)
        scene.positions.emplace_back((i & 1) ? 2.0f : -2.0f, (i & 2) ? 1.0f : -1.0f, (i & 4) ? 1.5f : -1.5f);
    // Outward-wound quads (counter-clockwise seen from outside), flipped for a room.
    const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads) {
        if (facingInwards) {
            scene.triangles.emplace_back(q[0], q[2], q[1]);
            scene.triangles.emplace_back(q[0], q[3], q[2]);
        } else {
            scene.triangles.emplace_back(q[0], q[1], q[2]);
            scene.triangles.emplace_back(q[0], q[2], q[3]);
        }
    }
    return scene;
}

TEST(StartView, GeneratedClosedBoxStartsInside) { expectStartsInside(closedBoxRoom(true), "generated closed box"); }

TEST(StartView, ObjectsKeepTheFraming) {
    // The same box as a solid object (faces outwards) is framed from outside.
    const Scene solid = closedBoxRoom(false);
    const Bvh solidBvh = buildBvh(solid, BvhBuildOptions{});
    EXPECT_FALSE(centreIsInARoom(solid, solidBvh));
    EXPECT_TRUE(sameCamera(startCamera(solid, solidBvh), frameScene(solid.bounds())));
    for (const std::string& spec :
         {sharedScene("gltf/BoxTextured/BoxTextured.glb"), sharedScene("gltf/Avocado/glTF/Avocado.gltf"),
          sharedScene("gltf/DamagedHelmet/DamagedHelmet.glb"), sharedScene("gltf/2CylinderEngine/2CylinderEngine.glb"),
          sharedScene("stanford/bun_zipper.ply"), sharedScene("stanford/dragon_vrip_res3.ply"),
          std::string("gen:default"), std::string("gen:terrain:10k"), std::string("gen:sphereflake:10k"),
          std::string("gen:deep:20")}) {
        const Scene scene = openScene(spec);
        const Bvh bvh = buildBvh(scene, BvhBuildOptions{});
        printProbe(spec + " around its centre", probeAround(scene, bvh, scene.bounds().center()));
        EXPECT_FALSE(centreIsInARoom(scene, bvh)) << spec;
        // (2CylinderEngine has a camera of its own.)
        EXPECT_TRUE(
            sameCamera(startCamera(scene, bvh), scene.fileCamera ? *scene.fileCamera : frameScene(scene.bounds())))
            << spec;
    }
}

TEST(StartView, TheFilesCameraComesFirst) {
    Scene room = closedBoxRoom(true);
    Camera file;
    file.eye = {0.5f, 0.25f, 0.0f};
    file.at = {0.5f, 0.25f, -1.0f};
    file.fovYDegrees = 45.0f;
    room.fileCamera = file;
    EXPECT_TRUE(sameCamera(startCamera(room, buildBvh(room, BvhBuildOptions{})), file));
    const Scene duck = openScene(sharedScene("gltf/Duck/Duck.glb"));  // the Khronos Duck has a camera
    ASSERT_TRUE(duck.fileCamera.has_value());
    EXPECT_TRUE(sameCamera(startCamera(duck, buildBvh(duck, BvhBuildOptions{})), *duck.fileCamera));
}

}  // namespace
}  // namespace raypack::test
