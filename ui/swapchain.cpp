#include "ui/swapchain.h"

#include "renderer/error.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include <algorithm>
#include <string>

namespace raypack::ui {

using vk::check;

VkSurfaceKHR createSurface(VkInstance instance, GLFWwindow* window) {
    VkSurfaceKHR surface = VK_NULL_HANDLE;
    const VkResult result = glfwCreateWindowSurface(instance, window, nullptr, &surface);
    if (result != VK_SUCCESS)
        throw Error(std::string("cannot create a Vulkan surface for the window: ") + vk::resultName(result));
    return surface;
}

std::vector<VkPresentModeKHR> supportedPresentModes(const vk::VulkanContext& context, VkSurfaceKHR surface) {
    uint32_t count = 0;
    check(vkGetPhysicalDeviceSurfacePresentModesKHR(context.physicalDevice, surface, &count, nullptr),
          "vkGetPhysicalDeviceSurfacePresentModesKHR");
    std::vector<VkPresentModeKHR> modes(count);
    check(vkGetPhysicalDeviceSurfacePresentModesKHR(context.physicalDevice, surface, &count, modes.data()),
          "vkGetPhysicalDeviceSurfacePresentModesKHR");
    return modes;
}

const char* toString(VkPresentModeKHR mode) {
    switch (mode) {
    case VK_PRESENT_MODE_FIFO_KHR: return "FIFO (vsync)";
    case VK_PRESENT_MODE_FIFO_RELAXED_KHR: return "FIFO relaxed";
    case VK_PRESENT_MODE_MAILBOX_KHR: return "mailbox";
    case VK_PRESENT_MODE_IMMEDIATE_KHR: return "immediate";
    default: return "other";
    }
}

VkSurfaceFormatKHR chooseSurfaceFormat(const vk::VulkanContext& context, VkSurfaceKHR surface) {
    uint32_t count = 0;
    check(vkGetPhysicalDeviceSurfaceFormatsKHR(context.physicalDevice, surface, &count, nullptr),
          "vkGetPhysicalDeviceSurfaceFormatsKHR");
    std::vector<VkSurfaceFormatKHR> formats(count);
    check(vkGetPhysicalDeviceSurfaceFormatsKHR(context.physicalDevice, surface, &count, formats.data()),
          "vkGetPhysicalDeviceSurfaceFormatsKHR");
    for (VkFormat wanted : {VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_R8G8B8A8_UNORM})
        for (const VkSurfaceFormatKHR& f : formats)
            if (f.format == wanted && f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) return f;
    throw Error("device " + context.info.name +
                ": the window surface offers neither B8G8R8A8_UNORM nor R8G8B8A8_UNORM");
}

VkRenderPass createOverlayRenderPass(const vk::VulkanContext& context, VkFormat format) {
    VkAttachmentDescription color{};
    color.format = format;
    color.samples = VK_SAMPLE_COUNT_1_BIT;
    color.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
    color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    color.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    color.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    color.initialLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    color.finalLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    VkAttachmentReference reference{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = 1;
    subpass.pColorAttachments = &reference;
    // The blit of the traced image into the swapchain image happens before the pass.
    VkSubpassDependency dependency{};
    dependency.srcSubpass = VK_SUBPASS_EXTERNAL;
    dependency.dstSubpass = 0;
    dependency.srcStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
    dependency.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    dependency.dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    dependency.dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    VkRenderPassCreateInfo info{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
    info.attachmentCount = 1;
    info.pAttachments = &color;
    info.subpassCount = 1;
    info.pSubpasses = &subpass;
    info.dependencyCount = 1;
    info.pDependencies = &dependency;
    VkRenderPass pass = VK_NULL_HANDLE;
    check(vkCreateRenderPass(context.device, &info, nullptr, &pass), "vkCreateRenderPass (panel overlay)");
    return pass;
}

Swapchain createSwapchain(const vk::VulkanContext& context, VkSurfaceKHR surface, VkRenderPass renderPass,
                          VkSurfaceFormatKHR format, uint32_t width, uint32_t height, VkPresentModeKHR presentMode,
                          VkSwapchainKHR old) {
    VkSurfaceCapabilitiesKHR caps{};
    check(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(context.physicalDevice, surface, &caps),
          "vkGetPhysicalDeviceSurfaceCapabilitiesKHR");
    const std::vector<VkPresentModeKHR> modes = supportedPresentModes(context, surface);
    if (std::find(modes.begin(), modes.end(), presentMode) == modes.end())
        presentMode = VK_PRESENT_MODE_FIFO_KHR;  // every surface offers FIFO

    Swapchain sc;
    sc.format = format;
    sc.presentMode = presentMode;
    if (caps.currentExtent.width != UINT32_MAX) {
        sc.extent = caps.currentExtent;
    } else {
        sc.extent.width = std::clamp(width, caps.minImageExtent.width, caps.maxImageExtent.width);
        sc.extent.height = std::clamp(height, caps.minImageExtent.height, caps.maxImageExtent.height);
    }
    RAYPACK_CHECK_MSG(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                      "swapchain images must accept the traced image (TRANSFER_DST)");
    sc.transferSource = (caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) != 0;
    sc.minImageCount = std::max(caps.minImageCount + 1, 2u);
    if (caps.maxImageCount > 0) sc.minImageCount = std::min(sc.minImageCount, caps.maxImageCount);

    VkSwapchainCreateInfoKHR info{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
    info.surface = surface;
    info.minImageCount = sc.minImageCount;
    info.imageFormat = format.format;
    info.imageColorSpace = format.colorSpace;
    info.imageExtent = sc.extent;
    info.imageArrayLayers = 1;
    info.imageUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                      (sc.transferSource ? VK_IMAGE_USAGE_TRANSFER_SRC_BIT : 0);
    info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.preTransform = (caps.supportedTransforms & VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR)
                            ? VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR
                            : caps.currentTransform;
    info.compositeAlpha =
        (caps.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR)
            ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
            : VkCompositeAlphaFlagBitsKHR(caps.supportedCompositeAlpha & -caps.supportedCompositeAlpha);
    info.presentMode = presentMode;
    info.clipped = VK_TRUE;
    info.oldSwapchain = old;
    check(vkCreateSwapchainKHR(context.device, &info, nullptr, &sc.swapchain), "vkCreateSwapchainKHR");

    uint32_t count = 0;
    check(vkGetSwapchainImagesKHR(context.device, sc.swapchain, &count, nullptr), "vkGetSwapchainImagesKHR");
    sc.images.resize(count);
    check(vkGetSwapchainImagesKHR(context.device, sc.swapchain, &count, sc.images.data()), "vkGetSwapchainImagesKHR");
    for (VkImage image : sc.images) {
        VkImageViewCreateInfo view{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
        view.image = image;
        view.viewType = VK_IMAGE_VIEW_TYPE_2D;
        view.format = format.format;
        view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        VkImageView imageView = VK_NULL_HANDLE;
        check(vkCreateImageView(context.device, &view, nullptr, &imageView), "vkCreateImageView (swapchain)");
        sc.views.push_back(imageView);
        VkFramebufferCreateInfo fb{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
        fb.renderPass = renderPass;
        fb.attachmentCount = 1;
        fb.pAttachments = &imageView;
        fb.width = sc.extent.width;
        fb.height = sc.extent.height;
        fb.layers = 1;
        VkFramebuffer framebuffer = VK_NULL_HANDLE;
        check(vkCreateFramebuffer(context.device, &fb, nullptr, &framebuffer), "vkCreateFramebuffer");
        sc.framebuffers.push_back(framebuffer);
        VkSemaphoreCreateInfo semaphoreInfo{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
        VkSemaphore semaphore = VK_NULL_HANDLE;
        check(vkCreateSemaphore(context.device, &semaphoreInfo, nullptr, &semaphore), "vkCreateSemaphore");
        sc.renderFinished.push_back(semaphore);
    }
    return sc;
}

void destroySwapchain(const vk::VulkanContext& context, Swapchain& sc) {
    for (VkSemaphore s : sc.renderFinished) vkDestroySemaphore(context.device, s, nullptr);
    for (VkFramebuffer fb : sc.framebuffers) vkDestroyFramebuffer(context.device, fb, nullptr);
    for (VkImageView v : sc.views) vkDestroyImageView(context.device, v, nullptr);
    if (sc.swapchain) vkDestroySwapchainKHR(context.device, sc.swapchain, nullptr);
    sc = Swapchain{};
}

}  // namespace raypack::ui
