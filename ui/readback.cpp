#include "ui/readback.h"

#include "renderer/error.h"
#include "shaders/texture.h"  // swapRedBlue

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstring>

namespace raypack::ui {

void copyTexels(uint32_t* dst, const uint32_t* src, size_t count, bool bgra) {
    if (!bgra) {
        std::memcpy(dst, src, count * 4);
        return;
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 1 << 16), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
            dst[i] = gpu::swapRedBlue(src[i]);
        }
    });
}

void ensureHostBuffer(const vk::VulkanContext& context, vk::Buffer& buffer, VkDeviceSize bytes,
                      VkBufferUsageFlags usage, const char* what) {
    if (buffer.size == bytes) return;
    vk::deviceWaitIdle(context);
    vk::destroyBuffer(context, buffer);
    buffer = vk::createBuffer(context, bytes, usage,
                              VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, what);
}

Image readBackImage(const vk::VulkanContext& context, VkCommandPool pool, VkBuffer source, uint32_t width,
                    uint32_t height, bool bgra, vk::Buffer& staging) {
    const VkDeviceSize bytes = VkDeviceSize(width) * height * 4;
    ensureHostBuffer(context, staging, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, "screenshot");
    vk::deviceWaitIdle(context);
    vk::submitAndWait(context, pool, [&](VkCommandBuffer cmd) {
        const VkBufferCopy region{0, 0, bytes};
        vkCmdCopyBuffer(cmd, source, staging.buffer, 1, &region);
    });
    Image image{width, height, std::vector<uint32_t>(size_t(width) * height)};
    copyTexels(image.rgba.data(), static_cast<const uint32_t*>(staging.mapped), image.rgba.size(), bgra);
    return image;
}

}  // namespace raypack::ui
