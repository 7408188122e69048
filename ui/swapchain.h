#pragma once
// The window's side of Vulkan, apart from the tracer (../shared/STYLE.md: niagara's swapchain.cpp):
// the surface, the swapchain with its image views and framebuffers, and the render pass that draws
// the panel over the traced image. Plain structs with create/destroy functions.
#include "renderer/vk/context.h"

#include <vulkan/vulkan.h>

#include <vector>

struct GLFWwindow;

namespace raypack::ui {

// Throws raypack::Error when GLFW cannot make a Vulkan surface for the window.
VkSurfaceKHR createSurface(VkInstance instance, GLFWwindow* window);

std::vector<VkPresentModeKHR> supportedPresentModes(const vk::VulkanContext& context, VkSurfaceKHR surface);
const char* toString(VkPresentModeKHR mode);

// B8G8R8A8_UNORM or R8G8B8A8_UNORM: UNORM, not sRGB, so the traced bytes reach the screen as they
// are and a screenshot equals what is shown.
VkSurfaceFormatKHR chooseSurfaceFormat(const vk::VulkanContext& context, VkSurfaceKHR surface);

// The pass that draws ImGui over the swapchain image: it keeps the traced image copied in before
// (loadOp LOAD from TRANSFER_DST_OPTIMAL) and leaves the image ready to present.
VkRenderPass createOverlayRenderPass(const vk::VulkanContext& context, VkFormat format);

struct Swapchain {
    VkSwapchainKHR swapchain = VK_NULL_HANDLE;
    VkSurfaceFormatKHR format{};
    VkPresentModeKHR presentMode = VK_PRESENT_MODE_FIFO_KHR;
    VkExtent2D extent{};
    uint32_t minImageCount = 0;
    bool transferSource = false;  // images can be read back (window screenshots)
    std::vector<VkImage> images;
    std::vector<VkImageView> views;
    std::vector<VkFramebuffer> framebuffers;
    // One per image: a semaphore may only be signalled again once its present has consumed it.
    std::vector<VkSemaphore> renderFinished;
};

// Creates the swapchain for a framebuffer of width x height (clamped to what the surface allows),
// with `presentMode` when the surface offers it and FIFO otherwise. `old` (may be null) is passed
// as oldSwapchain and must be destroyed by the caller afterwards.
Swapchain createSwapchain(const vk::VulkanContext& context, VkSurfaceKHR surface, VkRenderPass renderPass,
                          VkSurfaceFormatKHR format, uint32_t width, uint32_t height, VkPresentModeKHR presentMode,
                          VkSwapchainKHR old);
void destroySwapchain(const vk::VulkanContext& context, Swapchain& swapchain);

}  // namespace raypack::ui
