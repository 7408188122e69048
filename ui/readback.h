#pragma once
// Images between the device and the host for the viewer: the traced image read back for a
// screenshot, host-traced images copied into a host-visible buffer for presenting, both with the
// swap of the swapchain's B8G8R8A8 order; and the offscreen run's command submission. The Vulkan
// commands live here so that the viewer session (ui/viewer.cpp) only passes values.
#include "renderer/image.h"
#include "renderer/vk/context.h"

#include <cstddef>
#include <cstdint>
#include <functional>

namespace raypack::ui {

// Copies `count` 4-byte texels from `src` to `dst` (distinct), swapping bytes 0 and 2 (RGBA8 <->
// BGRA8) when `bgra` (the swapchain's format is B8G8R8A8).
void copyTexels(uint32_t* dst, const uint32_t* src, size_t count, bool bgra);

// A host-visible, coherent buffer of exactly `bytes`, created again (after the device is idle)
// when its size changes.
void ensureHostBuffer(const vk::VulkanContext& context, vk::Buffer& buffer, VkDeviceSize bytes,
                      VkBufferUsageFlags usage, const char* what);

// The RGBA8 image of `width` x `height` texels in device buffer `source`, copied through `staging`
// (kept for the next read-back) after the device is idle; `bgra`: the texels are in B8G8R8A8.
Image readBackImage(const vk::VulkanContext& context, VkCommandPool pool, VkBuffer source, uint32_t width,
                    uint32_t height, bool bgra, vk::Buffer& staging);

}  // namespace raypack::ui
