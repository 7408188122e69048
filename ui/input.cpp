#include "ui/input.h"

#include <algorithm>

namespace raypack::ui {

void HeldKeys::press(FlyKey key, double time) {
    Key& k = keys_[uint32_t(key)];
    changed_ = true;
    if (k.down) return;  // key repeat
    k.down = true;
    k.downSince = time;
    k.tapped = true;
}

void HeldKeys::release(FlyKey key, double time) {
    Key& k = keys_[uint32_t(key)];
    changed_ = true;
    if (!k.down) return;
    k.down = false;
    k.heldSeconds += std::max(0.0, time - std::max(k.downSince, intervalStart_));
}

void HeldKeys::releaseAll(double time) {
    for (uint32_t i = 0; i < kFlyKeyCount; ++i) release(FlyKey(i), time);
}

std::array<double, kFlyKeyCount> HeldKeys::take(double now) {
    std::array<double, kFlyKeyCount> held{};
    for (uint32_t i = 0; i < kFlyKeyCount; ++i) {
        Key& k = keys_[i];
        double seconds = k.heldSeconds;
        if (k.down) seconds += std::max(0.0, now - std::max(k.downSince, intervalStart_));
        if (k.tapped) seconds = std::max(seconds, kTapSeconds);
        held[i] = seconds;
        k.heldSeconds = 0.0;
        k.tapped = false;
    }
    intervalStart_ = now;
    changed_ = false;
    return held;
}

bool HeldKeys::anyDown() const {
    return std::any_of(keys_.begin(), keys_.end(), [](const Key& k) { return k.down; });
}

}  // namespace raypack::ui
