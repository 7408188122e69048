#include "app/cli/tracing.h"

namespace raypack::cli {

VulkanSession::VulkanSession(const std::string& device, bool validation, bool rayTracing, bool pipelineStatistics) {
    vk::VulkanContextOptions options;
    options.device = device;
    options.validation = validation;
    options.enableRayTracing = rayTracing;
    options.enablePipelineStatistics = pipelineStatistics;
    options.applicationName = "raypack-cli";
    context = vk::createVulkanContext(options);
}

VulkanSession::~VulkanSession() { vk::destroyVulkanContext(context); }

}  // namespace raypack::cli
