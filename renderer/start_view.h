#pragma once
// The view a scene opens with, for the CLI's default camera and the viewer's first frame: the
// file's own camera when it has one; else the framing of the whole scene (frameScene), unless the
// scene is a closed room (Conference, Sponza, a cathedral), whose framing shows only its outside:
// then a view from inside it.
#include "renderer/bvh.h"
#include "renderer/camera.h"
#include "renderer/scene.h"

namespace raypack {

// What a low-resolution probe of rays through the CPU tracer saw.
struct ViewProbe {
    uint32_t rays = 0;
    uint32_t hits = 0;
    uint32_t backHits = 0;  // hits on a triangle's back face (its shading normals where the scene
                            // has them, else its winding)
    uint32_t nearHits = 0;  // hits closer than 2% of the bounding box's diagonal
};

constexpr uint32_t kProbeSide = 24;

// Primary rays of `camera` through a kProbeSide x kProbeSide image.
ViewProbe probeView(const Scene& scene, const Bvh& bvh, const Camera& camera);
// Rays from `point` in every direction: six 90-degree views (a cube's faces) of kProbeSide x
// kProbeSide rays each.
ViewProbe probeAround(const Scene& scene, const Bvh& bvh, glm::vec3 point);

// Whether the bounding box's centre lies in a room: probeAround it hits on at least 90% of its
// rays (enclosed), at most 20% of the hits are back faces (walls facing in, not the inside of a
// solid object) and at most half are nearer than 2% of the diagonal (not inside a thin part).
// Measured on the shared scenes (2026-12-01): Conference, Sponza and both Sibeniks have 93-100% of
// rays hitting and 0-3% back faces; every object (Box, Duck, Avocado, DamagedHelmet, the bunny,
// the dragon, the armadillo, the engine, the saw, gen:default, gen:sphereflake) has 99-100% back
// faces or most hits near, gen:terrain and gen:deep at most 53% hitting. The framing's own view
// does not tell: Sibenik's outside is modelled (front faces, not on the box), and a box object's
// faces are the bounding box's.
bool centreIsInARoom(const Scene& scene, const Bvh& bvh);

// The start view of `scene` (bvh built over it):
//  1. scene.fileCamera, when the file has one (glTF cameras);
//  2. frameScene(bounds), unless centreIsInARoom;
//  3. else a view from inside: on the bounding box's centre line along its longest horizontal
//     axis (x or z), a third of the way in from the low end (the box's centre instead when most of
//     what that view sees is very near: a pillar or a wall in the way), looking along that axis
//     towards the other end, up +y, vertical fov 70 degrees; at the box's height centre, lower
//     where the default light (RenderSettings::lightHeight times the box's height above the
//     camera) would be less than a tenth of the room's height under the ceiling found straight
//     above, but at least a tenth of the way up from the floor found straight below.
Camera startCamera(const Scene& scene, const Bvh& bvh);

// The parts of a camera that were given (command-line flags, a settings file's camera); the others
// come from the start view. With both points given the start view is not needed.
struct CameraParts {
    bool eye = false, at = false, up = false, fov = false;
    bool bothPoints() const { return eye && at; }
};

// `given` with each part that `parts` does not name taken from `start` (startCamera): how
// raypack-cli render and the viewer combine their camera flags with the start view.
Camera withStartView(const Camera& given, CameraParts parts, const Camera& start);

}  // namespace raypack
