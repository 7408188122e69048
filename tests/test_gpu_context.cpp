// The Vulkan set-up (renderer/vk/context.h): device choice, what is reported, and the clear errors
// issue 3 asks for (device not found, out of device memory), with validation on.
#include "test_gpu_common.h"

#include "renderer/error.h"

namespace raypack::test {
namespace {

TEST(GpuContext, ChoosesADeviceAndReportsItsLimits) {
    const vk::VulkanContext& ctx = validatedContext();
    EXPECT_NE(ctx.device, VK_NULL_HANDLE);
    EXPECT_FALSE(ctx.info.name.empty());
    EXPECT_GE(ctx.info.subgroupSize, 1u);
    EXPECT_GE(ctx.info.maxSharedMemoryBytes, 16384u);  // Vulkan's guaranteed minimum
    EXPECT_GE(ctx.info.maxWorkgroupInvocations, 128u);
    EXPECT_NE(vk::describe(ctx.info).find(ctx.info.name), std::string::npos);
    // Automatic choice prefers a GPU over a CPU device.
    const std::vector<vk::DeviceInfo> all = vk::listDevices();
    ASSERT_FALSE(all.empty());
    for (const vk::DeviceInfo& d : all) {
        if (d.type == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU) {
            EXPECT_NE(ctx.info.type, VK_PHYSICAL_DEVICE_TYPE_CPU);
        }
    }
    expectNoValidationMessages();
}

TEST(GpuContext, SelectsByNameSubstringAndIndex) {
    const std::vector<vk::DeviceInfo> all = vk::listDevices();
    ASSERT_FALSE(all.empty());
    vk::VulkanContextOptions byIndex;
    byIndex.device = std::to_string(all.size() - 1);
    vk::VulkanContext a = vk::createVulkanContext(byIndex);
    EXPECT_EQ(a.info.name, all.back().name);
    vk::destroyVulkanContext(a);

    vk::VulkanContextOptions byName;
    byName.device = all.front().name.substr(0, 4);
    vk::VulkanContext b = vk::createVulkanContext(byName);
    EXPECT_EQ(b.info.name.substr(0, 4), all.front().name.substr(0, 4));
    vk::destroyVulkanContext(b);
}

TEST(GpuContext, UnknownDeviceIsAClearErrorListingTheDevices) {
    const std::vector<vk::DeviceInfo> all = vk::listDevices();
    vk::VulkanContextOptions options;
    options.device = "no-such-gpu-xyz";
    try {
        vk::createVulkanContext(options);
        FAIL() << "expected raypack::Error";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("no-such-gpu-xyz"), std::string::npos) << message;
        EXPECT_NE(message.find(all.front().name), std::string::npos) << message;
    }
    options.device = "999";
    EXPECT_THROW(vk::createVulkanContext(options), Error);
}

TEST(GpuContext, OutOfDeviceMemoryIsAClearError) {
    // Without validation: asking for more than a heap holds is what this test is about.
    vk::VulkanContext ctx = vk::createVulkanContext({});
    const VkDeviceSize tooMuch = VkDeviceSize(1) << 46;  // 64 TiB
    try {
        vk::Buffer b = vk::createBuffer(ctx, tooMuch, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                        VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, "a test buffer");
        vk::destroyBuffer(ctx, b);
        ADD_FAILURE() << "a 64 TiB buffer was allocated";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("a test buffer"), std::string::npos) << message;
    }
    vk::destroyVulkanContext(ctx);
}

TEST(GpuContext, BuffersRoundTripThroughUpload) {
    const vk::VulkanContext& ctx = validatedContext();
    VkCommandPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    poolInfo.queueFamilyIndex = ctx.queueFamily;
    VkCommandPool pool;
    ASSERT_EQ(vkCreateCommandPool(ctx.device, &poolInfo, nullptr, &pool), VK_SUCCESS);
    std::vector<uint32_t> data(1000);
    for (uint32_t i = 0; i < data.size(); ++i) data[i] = i * 2654435761u;
    const VkDeviceSize bytes = data.size() * 4;
    vk::Buffer device =
        vk::createBuffer(ctx, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                         VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, "test data");
    vk::Buffer host =
        vk::createBuffer(ctx, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                         VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, "read-back");
    vk::uploadToBuffer(ctx, pool, device, data.data(), bytes);
    vk::submitAndWait(ctx, pool, [&](VkCommandBuffer cmd) {
        VkBufferCopy region{0, 0, bytes};
        vkCmdCopyBuffer(cmd, device.buffer, host.buffer, 1, &region);
    });
    EXPECT_EQ(std::memcmp(host.mapped, data.data(), bytes), 0);
    vk::destroyBuffer(ctx, device);
    vk::destroyBuffer(ctx, host);
    vkDestroyCommandPool(ctx.device, pool, nullptr);
    expectNoValidationMessages();
}

}  // namespace
}  // namespace raypack::test
