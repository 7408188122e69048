#include "ui/viewer_window.h"

#include "renderer/error.h"
#include "shaders/texture.h"  // swapRedBlue

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_vulkan.h>
#include <imgui.h>

#include <cstdio>
#include <cstring>

namespace raypack::ui {

using vk::check;

namespace {

std::string lastGlfwError;

void onGlfwError(int code, const char* description) {
    lastGlfwError = std::string(description) + " (GLFW error " + std::to_string(code) + ")";
}

void checkImGuiVk(VkResult result) {
    if (result < 0) throw Error(std::string("ImGui Vulkan backend: ") + vk::resultName(result));
}

VkImageMemoryBarrier imageBarrier(VkImage image, VkImageLayout from, VkImageLayout to, VkAccessFlags srcAccess,
                                  VkAccessFlags dstAccess) {
    VkImageMemoryBarrier barrier{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
    barrier.srcAccessMask = srcAccess;
    barrier.dstAccessMask = dstAccess;
    barrier.oldLayout = from;
    barrier.newLayout = to;
    barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.image = image;
    barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    return barrier;
}

void recreateSwapchain(const vk::VulkanContext& context, ViewerWindow& w, uint32_t width, uint32_t height) {
    vk::deviceWaitIdle(context);
    Swapchain old = w.swapchain;
    w.swapchain = createSwapchain(context, w.surface, w.overlayPass, old.format, width, height, w.wantedPresentMode,
                                  old.swapchain);
    destroySwapchain(context, old);
    ImGui_ImplVulkan_SetMinImageCount(w.swapchain.minImageCount);
    w.swapchainStale = false;
    ++w.swapchainRecreations;
}

}  // namespace

void initWindowSystem() {
    glfwSetErrorCallback(onGlfwError);
    if (!glfwInit()) {
        const char* display = std::getenv("DISPLAY");
        const char* wayland = std::getenv("WAYLAND_DISPLAY");
        throw Error("cannot open a window: " + lastGlfwError +
                    ((display && *display) || (wayland && *wayland)
                         ? std::string()
                         : std::string("; no display: DISPLAY is not set (use raypack-cli for "
                                       "headless rendering, or run under xvfb-run)")));
    }
    if (!glfwVulkanSupported()) {
        glfwTerminate();
        throw Error("cannot open a window: GLFW finds no Vulkan loader able to present (" + lastGlfwError + ")");
    }
}

void addWindowRequirements(vk::VulkanContextOptions& options) {
    uint32_t count = 0;
    const char** extensions = glfwGetRequiredInstanceExtensions(&count);
    if (!extensions) throw Error("cannot open a window: GLFW knows no Vulkan surface extensions for this display");
    for (uint32_t i = 0; i < count; ++i) options.instanceExtensions.emplace_back(extensions[i]);
    options.deviceExtensions.emplace_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
    options.presentSupport = [](VkInstance instance, VkPhysicalDevice device, uint32_t family) {
        return glfwGetPhysicalDevicePresentationSupport(instance, device, family) == GLFW_TRUE;
    };
}

ViewerWindow createViewerWindow(const vk::VulkanContext& context, const ViewerWindowOptions& options) {
    ViewerWindow w;
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    glfwWindowHint(GLFW_VISIBLE, options.visible ? GLFW_TRUE : GLFW_FALSE);
    w.window = glfwCreateWindow(int(options.width), int(options.height), options.title.c_str(), nullptr, nullptr);
    if (!w.window)
        throw Error("cannot create a window of " + std::to_string(options.width) + "x" +
                    std::to_string(options.height) + ": " + lastGlfwError);
    w.surface = createSurface(context.instance, w.window);
    VkBool32 supported = VK_FALSE;
    check(vkGetPhysicalDeviceSurfaceSupportKHR(context.physicalDevice, context.queueFamily, w.surface, &supported),
          "vkGetPhysicalDeviceSurfaceSupportKHR");
    if (!supported) throw Error("device " + context.info.name + " cannot present to this window");
    if (!context.universalQueue)
        throw Error("device " + context.info.name + ": its queue has no graphics, which the panel needs");

    const VkSurfaceFormatKHR format = chooseSurfaceFormat(context, w.surface);
    w.overlayPass = createOverlayRenderPass(context, format.format);
    w.presentModes = supportedPresentModes(context, w.surface);
    w.wantedPresentMode = options.presentMode;
    int fbWidth = 0, fbHeight = 0;
    glfwGetFramebufferSize(w.window, &fbWidth, &fbHeight);
    w.swapchain = createSwapchain(context, w.surface, w.overlayPass, format, uint32_t(fbWidth), uint32_t(fbHeight),
                                  w.wantedPresentMode, VK_NULL_HANDLE);

    w.commandPool =
        vk::createCommandPool(context, VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT, "vkCreateCommandPool (viewer)");
    VkCommandBufferAllocateInfo alloc{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    alloc.commandPool = w.commandPool;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(context.device, &alloc, &w.commandBuffer), "vkAllocateCommandBuffers (viewer)");
    VkFenceCreateInfo fenceInfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    fenceInfo.flags = VK_FENCE_CREATE_SIGNALED_BIT;
    check(vkCreateFence(context.device, &fenceInfo, nullptr, &w.frameDone), "vkCreateFence (viewer)");
    VkSemaphoreCreateInfo semaphoreInfo{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    check(vkCreateSemaphore(context.device, &semaphoreInfo, nullptr, &w.imageAcquired), "vkCreateSemaphore (viewer)");

    // ImGui: the GLFW backend installs its callbacks (chaining any set before), the Vulkan backend
    // draws in the overlay pass. It needs one combined image sampler (the font texture).
    VkDescriptorPoolSize poolSize{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 4};
    VkDescriptorPoolCreateInfo dpInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    dpInfo.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
    dpInfo.maxSets = 4;
    dpInfo.poolSizeCount = 1;
    dpInfo.pPoolSizes = &poolSize;
    check(vkCreateDescriptorPool(context.device, &dpInfo, nullptr, &w.imguiPool), "vkCreateDescriptorPool (ImGui)");
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;  // the panel's layout is fixed; no imgui.ini in the cwd
    ImGui::StyleColorsDark();
    ImGui_ImplGlfw_InitForVulkan(w.window, true);
    ImGui_ImplVulkan_InitInfo info{};
    info.Instance = context.instance;
    info.PhysicalDevice = context.physicalDevice;
    info.Device = context.device;
    info.QueueFamily = context.queueFamily;
    info.Queue = context.queue;
    info.DescriptorPool = w.imguiPool;
    info.Subpass = 0;
    info.MinImageCount = w.swapchain.minImageCount;
    info.ImageCount = uint32_t(w.swapchain.images.size());
    info.MSAASamples = VK_SAMPLE_COUNT_1_BIT;
    info.CheckVkResultFn = checkImGuiVk;
    ImGui_ImplVulkan_Init(&info, w.overlayPass);
    vk::submitAndWait(context, w.commandPool, [](VkCommandBuffer cmd) { ImGui_ImplVulkan_CreateFontsTexture(cmd); });
    ImGui_ImplVulkan_DestroyFontUploadObjects();
    return w;
}

void destroyViewerWindow(const vk::VulkanContext& context, ViewerWindow& w) {
    if (context.device) vk::deviceWaitIdle(context);
    if (w.imguiPool) {
        ImGui_ImplVulkan_Shutdown();
        ImGui_ImplGlfw_Shutdown();
        ImGui::DestroyContext();
        vkDestroyDescriptorPool(context.device, w.imguiPool, nullptr);
    }
    vk::destroyBuffer(context, w.windowReadback);
    if (w.imageAcquired) vkDestroySemaphore(context.device, w.imageAcquired, nullptr);
    if (w.frameDone) vkDestroyFence(context.device, w.frameDone, nullptr);
    if (w.commandPool) vkDestroyCommandPool(context.device, w.commandPool, nullptr);
    destroySwapchain(context, w.swapchain);
    if (w.overlayPass) vkDestroyRenderPass(context.device, w.overlayPass, nullptr);
    if (w.surface) vkDestroySurfaceKHR(context.instance, w.surface, nullptr);
    if (w.window) glfwDestroyWindow(w.window);
    w = ViewerWindow{};
}

void setPresentMode(ViewerWindow& w, VkPresentModeKHR mode) {
    if (mode == w.wantedPresentMode) return;
    w.wantedPresentMode = mode;
    w.swapchainStale = true;
}

std::optional<FrameTarget> beginFrame(const vk::VulkanContext& context, ViewerWindow& w) {
    check(vkWaitForFences(context.device, 1, &w.frameDone, VK_TRUE, UINT64_MAX), "vkWaitForFences (viewer frame)");
    int fbWidth = 0, fbHeight = 0;
    glfwGetFramebufferSize(w.window, &fbWidth, &fbHeight);
    if (fbWidth <= 0 || fbHeight <= 0) return std::nullopt;  // minimised
    if (w.swapchainStale || uint32_t(fbWidth) != w.swapchain.extent.width ||
        uint32_t(fbHeight) != w.swapchain.extent.height)
        recreateSwapchain(context, w, uint32_t(fbWidth), uint32_t(fbHeight));

    FrameTarget target;
    const VkResult acquired = vkAcquireNextImageKHR(context.device, w.swapchain.swapchain, UINT64_MAX, w.imageAcquired,
                                                    VK_NULL_HANDLE, &target.imageIndex);
    if (acquired == VK_ERROR_OUT_OF_DATE_KHR) {
        w.swapchainStale = true;
        return std::nullopt;
    }
    if (acquired == VK_SUBOPTIMAL_KHR)
        w.swapchainStale = true;  // usable now, re-created next frame
    else
        check(acquired, "vkAcquireNextImageKHR");

    check(vkResetFences(context.device, 1, &w.frameDone), "vkResetFences (viewer frame)");
    check(vkResetCommandBuffer(w.commandBuffer, 0), "vkResetCommandBuffer (viewer frame)");
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    check(vkBeginCommandBuffer(w.commandBuffer, &begin), "vkBeginCommandBuffer (viewer frame)");
    target.cmd = w.commandBuffer;
    target.extent = w.swapchain.extent;
    target.bgra = w.swapchain.format.format == VK_FORMAT_B8G8R8A8_UNORM;
    return target;
}

void copyImage(ViewerWindow& w, const FrameTarget& target, VkBuffer source) {
    const VkImage image = w.swapchain.images[target.imageIndex];
    const VkImageMemoryBarrier toTransfer = imageBarrier(
        image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT);
    vkCmdPipelineBarrier(target.cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0,
                         nullptr, 1, &toTransfer);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {target.extent.width, target.extent.height, 1};
    vkCmdCopyBufferToImage(target.cmd, source, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
}

void copyImage(ViewerWindow& w, const FrameTarget& target, VkBuffer source, const ImageRegion& region) {
    const VkImage image = w.swapchain.images[target.imageIndex];
    RAYPACK_CHECK(region.x + region.width <= target.extent.width && region.height <= target.extent.height);
    const VkImageMemoryBarrier toTransfer = imageBarrier(
        image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT);
    vkCmdPipelineBarrier(target.cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0,
                         nullptr, 1, &toTransfer);
    if (region.x != 0 || region.width != target.extent.width || region.height != target.extent.height) {
        const VkClearColorValue color{{region.background.x, region.background.y, region.background.z, 1.0f}};
        const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        vkCmdClearColorImage(target.cmd, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &color, 1, &range);
        // The copy below writes what the clear wrote: order them.
        const VkImageMemoryBarrier afterClear =
            imageBarrier(image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                         VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_TRANSFER_WRITE_BIT);
        vkCmdPipelineBarrier(target.cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr,
                             0, nullptr, 1, &afterClear);
    }
    VkBufferImageCopy copy{};
    copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    copy.imageOffset = {int32_t(region.x), 0, 0};
    copy.imageExtent = {region.width, region.height, 1};
    vkCmdCopyBufferToImage(target.cmd, source, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
}

void clearImage(ViewerWindow& w, const FrameTarget& target, float r, float g, float b) {
    const VkImage image = w.swapchain.images[target.imageIndex];
    const VkImageMemoryBarrier toTransfer = imageBarrier(
        image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT);
    vkCmdPipelineBarrier(target.cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0,
                         nullptr, 1, &toTransfer);
    const VkClearColorValue color{{r, g, b, 1.0f}};
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(target.cmd, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &color, 1, &range);
}

void finishFrame(const vk::VulkanContext& context, ViewerWindow& w, const FrameTarget& target, ImDrawData* drawData,
                 bool captureWindow) {
    VkRenderPassBeginInfo pass{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
    pass.renderPass = w.overlayPass;
    pass.framebuffer = w.swapchain.framebuffers[target.imageIndex];
    pass.renderArea.extent = target.extent;
    vkCmdBeginRenderPass(target.cmd, &pass, VK_SUBPASS_CONTENTS_INLINE);
    if (drawData) ImGui_ImplVulkan_RenderDrawData(drawData, target.cmd);
    vkCmdEndRenderPass(target.cmd);

    const VkImage image = w.swapchain.images[target.imageIndex];
    if (captureWindow && w.swapchain.transferSource) {
        const VkDeviceSize bytes = VkDeviceSize(target.extent.width) * target.extent.height * 4;
        if (w.windowReadback.size != bytes) {
            vk::destroyBuffer(context, w.windowReadback);
            w.windowReadback = vk::createBuffer(
                context, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, "window screenshot");
        }
        const VkImageMemoryBarrier toSource =
            imageBarrier(image, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                         VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT);
        vkCmdPipelineBarrier(target.cmd, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                             0, 0, nullptr, 0, nullptr, 1, &toSource);
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {target.extent.width, target.extent.height, 1};
        vkCmdCopyImageToBuffer(target.cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, w.windowReadback.buffer, 1,
                               &region);
        const VkImageMemoryBarrier toPresent =
            imageBarrier(image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                         VK_ACCESS_TRANSFER_READ_BIT, 0);
        VkBufferMemoryBarrier toHost{VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER};
        toHost.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        toHost.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
        toHost.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        toHost.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        toHost.buffer = w.windowReadback.buffer;
        toHost.size = VK_WHOLE_SIZE;
        vkCmdPipelineBarrier(target.cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                             VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT | VK_PIPELINE_STAGE_HOST_BIT, 0, 0, nullptr, 1,
                             &toHost, 1, &toPresent);
    }
    check(vkEndCommandBuffer(target.cmd), "vkEndCommandBuffer (viewer frame)");

    const VkSemaphore renderFinished = w.swapchain.renderFinished[target.imageIndex];
    // The first use of the swapchain image is the transfer that copies the traced image into it.
    const VkPipelineStageFlags waitStage = VK_PIPELINE_STAGE_TRANSFER_BIT;
    VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    submit.waitSemaphoreCount = 1;
    submit.pWaitSemaphores = &w.imageAcquired;
    submit.pWaitDstStageMask = &waitStage;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &target.cmd;
    submit.signalSemaphoreCount = 1;
    submit.pSignalSemaphores = &renderFinished;
    const auto queueLock = vk::lockQueue(context);
    check(vkQueueSubmit(context.queue, 1, &submit, w.frameDone), "vkQueueSubmit (viewer frame)");

    VkPresentInfoKHR present{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
    present.waitSemaphoreCount = 1;
    present.pWaitSemaphores = &renderFinished;
    present.swapchainCount = 1;
    present.pSwapchains = &w.swapchain.swapchain;
    present.pImageIndices = &target.imageIndex;
    const VkResult presented = vkQueuePresentKHR(context.queue, &present);
    if (presented == VK_ERROR_OUT_OF_DATE_KHR || presented == VK_SUBOPTIMAL_KHR)
        w.swapchainStale = true;
    else
        check(presented, "vkQueuePresentKHR");
}

std::vector<uint32_t> readWindowImage(const vk::VulkanContext& context, ViewerWindow& w, uint32_t& width,
                                      uint32_t& height) {
    if (!w.swapchain.transferSource || !w.windowReadback.mapped)
        throw Error("this window's swapchain images cannot be read back (no TRANSFER_SRC usage)");
    check(vkWaitForFences(context.device, 1, &w.frameDone, VK_TRUE, UINT64_MAX), "vkWaitForFences (window screenshot)");
    width = w.swapchain.extent.width;
    height = w.swapchain.extent.height;
    std::vector<uint32_t> texels(size_t(width) * height);
    std::memcpy(texels.data(), w.windowReadback.mapped, texels.size() * 4);
    if (w.swapchain.format.format == VK_FORMAT_B8G8R8A8_UNORM)
        for (uint32_t& t : texels)  // BGRA -> RGBA: swap the low and third bytes
            t = gpu::swapRedBlue(t);
    return texels;
}

}  // namespace raypack::ui
