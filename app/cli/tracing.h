#pragma once
// The Vulkan device the CLI's GPU tracers run on, opened from its flags (--gpu, --validation) and
// closed after the tracers made on it (renderer/tracers/registry.h) are gone.
#include "renderer/vk/context.h"

#include <string>

namespace raypack::cli {

struct VulkanSession {
    vk::VulkanContext context;
    // `device`: "" automatic, an index or a name substring (vk::VulkanContextOptions::device).
    // Throws raypack::Error when there is no usable Vulkan device.
    // `rayTracing` also enables the driver's ray tracing where the device offers it (for the
    // bench's driver ray tracing peer); the device is chosen the same way either way.
    // `pipelineStatistics`: VulkanContextOptions::enablePipelineStatistics.
    VulkanSession(const std::string& device, bool validation, bool rayTracing = false, bool pipelineStatistics = false);
    ~VulkanSession();
    VulkanSession(const VulkanSession&) = delete;
    VulkanSession& operator=(const VulkanSession&) = delete;
};

}  // namespace raypack::cli
