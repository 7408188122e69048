#pragma once
// The viewer's window and what presents into it: GLFW window, Vulkan surface and swapchain, the
// ImGui context with its GLFW and Vulkan backends, and one frame in flight (a command buffer, a
// fence, an acquire semaphore). It knows nothing of scenes or tracers: a frame is
//   beginFrame -> (caller records the tracer into target.cmd) -> copyImage -> finishFrame,
// where copyImage puts a tightly packed 4-byte-per-texel buffer into the swapchain image and
// finishFrame draws the panel over it and presents. Resize and minimise re-create the swapchain.
#include "renderer/vk/context.h"
#include "ui/swapchain.h"

#include <vulkan/vulkan.h>
#include <glm/glm.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

struct GLFWwindow;
struct ImDrawData;

namespace raypack::ui {

struct ViewerWindowOptions {
    uint32_t width = 1280;
    uint32_t height = 800;
    std::string title = "raypack";
    VkPresentModeKHR presentMode = VK_PRESENT_MODE_FIFO_KHR;
    bool visible = true;
};

// Throws raypack::Error with a clear message when there is no display (GLFW cannot initialise) or
// Vulkan cannot present to it. Also fills `contextOptions` with what the window needs: GLFW's
// instance extensions, VK_KHR_swapchain and the present-support test.
void initWindowSystem();
void addWindowRequirements(vk::VulkanContextOptions& contextOptions);

struct ViewerWindow {
    GLFWwindow* window = nullptr;
    VkSurfaceKHR surface = VK_NULL_HANDLE;
    VkRenderPass overlayPass = VK_NULL_HANDLE;
    Swapchain swapchain;
    VkPresentModeKHR wantedPresentMode = VK_PRESENT_MODE_FIFO_KHR;
    std::vector<VkPresentModeKHR> presentModes;
    VkCommandPool commandPool = VK_NULL_HANDLE;
    VkCommandBuffer commandBuffer = VK_NULL_HANDLE;
    VkFence frameDone = VK_NULL_HANDLE;
    VkSemaphore imageAcquired = VK_NULL_HANDLE;
    VkDescriptorPool imguiPool = VK_NULL_HANDLE;
    bool swapchainStale = false;  // resized, or the present mode changed
    uint32_t swapchainRecreations = 0;
    // Read-back of the composed window image (traced image + panel), for window screenshots.
    vk::Buffer windowReadback;
};

ViewerWindow createViewerWindow(const vk::VulkanContext& context, const ViewerWindowOptions& options);
void destroyViewerWindow(const vk::VulkanContext& context, ViewerWindow& window);

// Asks for another present mode; takes effect at the next frame (the swapchain is re-created).
void setPresentMode(ViewerWindow& window, VkPresentModeKHR mode);

struct FrameTarget {
    VkCommandBuffer cmd = VK_NULL_HANDLE;  // begun; the caller records into it
    uint32_t imageIndex = 0;
    VkExtent2D extent{};  // the swapchain image's size: render at this size
    bool bgra = false;    // the swapchain wants B8G8R8A8 bytes
};

// Waits for the previous frame, re-creates the swapchain if needed and acquires an image. Returns
// nullopt when there is nothing to draw into (minimised: zero-sized framebuffer, or out of date);
// then the caller skips the frame and polls events again.
std::optional<FrameTarget> beginFrame(const vk::VulkanContext& context, ViewerWindow& window);

// Copies `source` (extent.width x extent.height texels, 4 bytes each, row 0 at the top, in the
// swapchain's byte order) into the acquired image. The caller has made `source` readable by
// transfer (a barrier to VK_PIPELINE_STAGE_TRANSFER_BIT / VK_ACCESS_TRANSFER_READ_BIT).
void copyImage(ViewerWindow& window, const FrameTarget& target, VkBuffer source);
// The same for an image of width x height texels placed `x` texels from the left edge (the part of
// the window a panel beside the image leaves free); the rest of the swapchain image is cleared to
// `background`.
struct ImageRegion {
    uint32_t x = 0;
    uint32_t width = 0;
    uint32_t height = 0;
    glm::vec3 background{0.0f};
};
void copyImage(ViewerWindow& window, const FrameTarget& target, VkBuffer source, const ImageRegion& region);
// Clears the acquired image instead (no scene yet).
void clearImage(ViewerWindow& window, const FrameTarget& target, float r, float g, float b);

// Draws ImGui's draw data over the image, submits and presents. With `captureWindow`, also copies
// the composed image to window.windowReadback (see readWindowImage).
void finishFrame(const vk::VulkanContext& context, ViewerWindow& window, const FrameTarget& target,
                 ImDrawData* drawData, bool captureWindow = false);

// After a finishFrame with captureWindow: waits for it and returns RGBA8 texels, row 0 at the top.
std::vector<uint32_t> readWindowImage(const vk::VulkanContext& context, ViewerWindow& window, uint32_t& width,
                                      uint32_t& height);

}  // namespace raypack::ui
