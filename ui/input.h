#pragma once
// Input that is never lost. GLFW delivers key presses and releases through its key callback during
// glfwPollEvents; HeldKeys turns them into how long each fly key was held during the time since the
// last frame, so
//  - a key tapped between two frames (pressed and released before the next poll) still moves the
//    camera, by at least kTapSeconds of motion;
//  - a key held across frames moves the camera by the wall-clock time it was held, however long
//    the frames take (FlyCamera::update then bounds one frame's step).
// Pure logic over timestamps: the window code feeds it, the tests drive it directly.
#include <array>
#include <cstdint>

namespace raypack::ui {

enum class FlyKey : uint32_t { Forward, Back, Left, Right, Down, Up };
constexpr uint32_t kFlyKeyCount = 6;

class HeldKeys {
public:
    // The motion one tap gives: a key pressed and released between two frames counts as held for
    // at least this long (a 30 Hz frame).
    static constexpr double kTapSeconds = 1.0 / 30.0;

    void press(FlyKey key, double time);
    void release(FlyKey key, double time);
    // Releases every key (the window lost focus: no release event will come).
    void releaseAll(double time);
    // Seconds each key was held in (last take, now], taps raised to kTapSeconds; starts the next
    // interval at `now`.
    std::array<double, kFlyKeyCount> take(double now);
    bool anyDown() const;
    // Whether anything was pressed or released since the last take().
    bool changed() const { return changed_; }

private:
    struct Key {
        bool down = false;
        double downSince = 0.0;    // time of the press, while down
        double heldSeconds = 0.0;  // held time of presses released in this interval
        bool tapped = false;       // pressed (and maybe released) in this interval
    };
    std::array<Key, kFlyKeyCount> keys_{};
    double intervalStart_ = 0.0;
    bool changed_ = false;
};

}  // namespace raypack::ui
