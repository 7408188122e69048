#pragma once
// How fast a Vulkan device runs 64-bit floats against 32-bit ones, measured: the choice of
// HitDistanceMath::Auto (renderer/settings.h). Doubles are half the float rate on the data-centre
// GPUs (H100, H200, A100) and on CPUs, but 1/16 to 1/64 on most others, where the float-pair form
// of the accurate hit distance is the faster one; no Vulkan property says which.
#include "renderer/vk/context.h"

namespace raypack::vk {

// Double multiply-adds per second over float multiply-adds per second on `context`'s device
// (shaders/float64_rate.comp: the same four chains in each, the shortest of three timed dispatches
// each, after an untimed one). Needs VulkanContext::float64; well under 0.1 s on a GPU or a CPU
// device, besides building its two pipelines. Throws raypack::Error where a Vulkan call fails.
double measureFloat64Rate(const VulkanContext& context);

// The rate at and above which Auto takes doubles. The double form of the distance is some 45
// double operations where the float-pair form is about 400 float ones (shaders/intersect.h), so
// doubles win from about 1/8 of the float rate; the bound leaves room for the conversions and the
// division, which the count does not weigh.
inline constexpr double kFloat64RateForDoubles = 0.25;

}  // namespace raypack::vk
