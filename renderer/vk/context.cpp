#include "renderer/vk/context.h"

#include "renderer/error.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>

namespace raypack::vk {

const char* resultName(VkResult result) {
    switch (result) {
#define RP_CASE(x) \
    case x: return #x;
        RP_CASE(VK_SUCCESS)
        RP_CASE(VK_NOT_READY)
        RP_CASE(VK_TIMEOUT)
        RP_CASE(VK_INCOMPLETE)
        RP_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
        RP_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        RP_CASE(VK_ERROR_INITIALIZATION_FAILED)
        RP_CASE(VK_ERROR_DEVICE_LOST)
        RP_CASE(VK_ERROR_MEMORY_MAP_FAILED)
        RP_CASE(VK_ERROR_LAYER_NOT_PRESENT)
        RP_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
        RP_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
        RP_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
        RP_CASE(VK_ERROR_TOO_MANY_OBJECTS)
        RP_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
        RP_CASE(VK_ERROR_FRAGMENTED_POOL)
        RP_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
        RP_CASE(VK_ERROR_SURFACE_LOST_KHR)
        RP_CASE(VK_ERROR_OUT_OF_DATE_KHR)
        RP_CASE(VK_SUBOPTIMAL_KHR)
#undef RP_CASE
    default: return "VK_ERROR_UNKNOWN";
    }
}

void check(VkResult result, const char* what) {
    if (result >= 0) return;
    throw Error(std::string("Vulkan: ") + what + " failed: " + resultName(result));
}

const char* toString(VkPhysicalDeviceType type) {
    switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "CPU";
    default: return "other";
    }
}

std::string describe(const DeviceInfo& info) {
    std::ostringstream s;
    s << info.name << " (" << toString(info.type) << ", " << info.driver << ", subgroup " << info.subgroupSize << ")";
    return s.str();
}

namespace {

// What the driver's ray tracing needs; VK_KHR_deferred_host_operations is a dependency of
// VK_KHR_acceleration_structure even when no deferred operation is used.
const char* const kRayTracingExtensions[] = {VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME,
                                             VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME,
                                             VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME};

VKAPI_ATTR VkBool32 VKAPI_CALL debugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                             VkDebugUtilsMessageTypeFlagsEXT,
                                             const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
    auto* log = static_cast<ValidationLog*>(user);
    const char* level = (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) ? "error" : "warning";
    std::fprintf(stderr, "raypack: validation %s: %s\n", level, data->pMessage);
    std::lock_guard lock(log->mutex);
    ++log->count;
    log->messages.emplace_back(data->pMessage);
    return VK_FALSE;
}

bool layerAvailable(const char* name) {
    uint32_t count = 0;
    vkEnumerateInstanceLayerProperties(&count, nullptr);
    std::vector<VkLayerProperties> layers(count);
    vkEnumerateInstanceLayerProperties(&count, layers.data());
    for (const VkLayerProperties& layer : layers)
        if (std::strcmp(layer.layerName, name) == 0) return true;
    return false;
}

VkInstance createInstance(const VulkanContextOptions& options, bool withDebugUtils) {
    VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.pApplicationName = options.applicationName.c_str();
    app.pEngineName = "raypack";
    app.apiVersion = VK_API_VERSION_1_2;

    std::vector<const char*> extensions;
    for (const std::string& e : options.instanceExtensions) extensions.push_back(e.c_str());
    if (withDebugUtils) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    std::vector<const char*> layers;
    if (options.validation) {
        if (!layerAvailable("VK_LAYER_KHRONOS_validation"))
            throw Error(
                "Vulkan: validation was requested but VK_LAYER_KHRONOS_validation is not installed "
                "(Debian package vulkan-validationlayers)");
        layers.push_back("VK_LAYER_KHRONOS_validation");
    }

    VkInstanceCreateInfo info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    info.pApplicationInfo = &app;
    info.enabledExtensionCount = uint32_t(extensions.size());
    info.ppEnabledExtensionNames = extensions.data();
    info.enabledLayerCount = uint32_t(layers.size());
    info.ppEnabledLayerNames = layers.data();
    VkInstance instance = VK_NULL_HANDLE;
    const VkResult result = vkCreateInstance(&info, nullptr, &instance);
    if (result == VK_ERROR_INCOMPATIBLE_DRIVER || result == VK_ERROR_INITIALIZATION_FAILED)
        throw Error(std::string("Vulkan: no Vulkan 1.2 driver found (vkCreateInstance: ") + resultName(result) +
                    "); install a GPU driver or Mesa's lavapipe (mesa-vulkan-drivers)");
    if (result == VK_ERROR_EXTENSION_NOT_PRESENT)
        throw Error("Vulkan: a required instance extension is missing (window system?)");
    check(result, "vkCreateInstance");
    return instance;
}

DeviceInfo queryDevice(VkPhysicalDevice physical, uint32_t index) {
    VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceDriverProperties driver{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    subgroup.pNext = &driver;
    VkPhysicalDeviceProperties2 props{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    props.pNext = &subgroup;
    vkGetPhysicalDeviceProperties2(physical, &props);
    const VkPhysicalDeviceLimits& limits = props.properties.limits;

    DeviceInfo info;
    info.index = index;
    info.name = props.properties.deviceName;
    info.type = props.properties.deviceType;
    info.driver = std::string(driver.driverName) + " " + driver.driverInfo;
    info.apiVersion = props.properties.apiVersion;
    info.subgroupSize = subgroup.subgroupSize;
    info.maxSharedMemoryBytes = limits.maxComputeSharedMemorySize;
    info.maxStorageBufferBytes = limits.maxStorageBufferRange;
    info.maxTexelBufferElements = limits.maxTexelBufferElements;
    VkFormatProperties rgba32f{};
    vkGetPhysicalDeviceFormatProperties(physical, VK_FORMAT_R32G32B32A32_SFLOAT, &rgba32f);
    info.rgba32fTexelBuffers = (rgba32f.bufferFeatures & VK_FORMAT_FEATURE_UNIFORM_TEXEL_BUFFER_BIT) != 0;
    info.maxWorkgroupInvocations = limits.maxComputeWorkGroupInvocations;
    for (int i = 0; i < 3; ++i) {
        info.maxWorkgroupSize[i] = limits.maxComputeWorkGroupSize[i];
        info.maxWorkgroupCount[i] = limits.maxComputeWorkGroupCount[i];
    }
    info.timestampPeriodNs = limits.timestampPeriod;
    return info;
}

// Why a device cannot run raypack, or "" when it can. The kernels need Vulkan 1.2, a compute
// queue and subgroup arithmetic and ballot in compute shaders.
std::string rejectReason(VkInstance instance, VkPhysicalDevice physical, const VulkanContextOptions& options,
                         uint32_t* queueFamily, bool* universal) {
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(physical, &props);
    if (props.apiVersion < VK_API_VERSION_1_2) return "Vulkan 1.2 not supported";
    VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceProperties2 props2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    props2.pNext = &subgroup;
    vkGetPhysicalDeviceProperties2(physical, &props2);
    const VkSubgroupFeatureFlags needed =
        VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT | VK_SUBGROUP_FEATURE_BALLOT_BIT;
    if (!(subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) || (subgroup.supportedOperations & needed) != needed)
        return "no subgroup arithmetic/ballot in compute shaders";

    uint32_t extensionCount = 0;
    vkEnumerateDeviceExtensionProperties(physical, nullptr, &extensionCount, nullptr);
    std::vector<VkExtensionProperties> extensions(extensionCount);
    vkEnumerateDeviceExtensionProperties(physical, nullptr, &extensionCount, extensions.data());
    for (const std::string& wanted : options.deviceExtensions) {
        const bool found =
            std::any_of(extensions.begin(), extensions.end(), [&](const auto& e) { return wanted == e.extensionName; });
        if (!found) return "extension " + wanted + " missing";
    }

    uint32_t familyCount = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &familyCount, nullptr);
    std::vector<VkQueueFamilyProperties> families(familyCount);
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &familyCount, families.data());
    // Prefer a universal graphics+compute family (the viewer copies into the swapchain on it).
    int best = -1;
    bool bestUniversal = false;
    for (uint32_t f = 0; f < familyCount; ++f) {
        if (!(families[f].queueFlags & VK_QUEUE_COMPUTE_BIT)) continue;
        if (options.presentSupport && !options.presentSupport(instance, physical, f)) continue;
        const bool isUniversal = (families[f].queueFlags & VK_QUEUE_GRAPHICS_BIT) != 0;
        if (best < 0 || (isUniversal && !bestUniversal)) {
            best = int(f);
            bestUniversal = isUniversal;
        }
    }
    if (best < 0) return options.presentSupport ? "no compute queue that can present" : "no compute queue";
    *queueFamily = uint32_t(best);
    *universal = bestUniversal;
    return "";
}

}  // namespace

namespace {

bool offersExtension(VkPhysicalDevice physical, const char* name) {
    uint32_t count = 0;
    vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, nullptr);
    std::vector<VkExtensionProperties> offered(count);
    vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, offered.data());
    return std::any_of(offered.begin(), offered.end(),
                       [&](const VkExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
}

}  // namespace

std::string rayTracingMissing(VkPhysicalDevice physical) {
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(physical, &props);
    // The feature query below chains VkPhysicalDeviceVulkan12Features.
    if (props.apiVersion < VK_API_VERSION_1_2) return "Vulkan 1.2";
    uint32_t count = 0;
    vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, nullptr);
    std::vector<VkExtensionProperties> offered(count);
    vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, offered.data());
    std::string missing;
    auto note = [&](const std::string& what) { missing += (missing.empty() ? "" : ", ") + what; };
    for (const char* e : kRayTracingExtensions) {
        const bool found = std::any_of(offered.begin(), offered.end(),
                                       [&](const auto& x) { return std::strcmp(x.extensionName, e) == 0; });
        if (!found) note(e);
    }
    if (!missing.empty()) return missing;
    VkPhysicalDeviceVulkan12Features vulkan12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    VkPhysicalDeviceAccelerationStructureFeaturesKHR accelerationStructure{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR};
    VkPhysicalDeviceRayTracingPipelineFeaturesKHR rayTracingPipeline{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR};
    vulkan12.pNext = &accelerationStructure;
    accelerationStructure.pNext = &rayTracingPipeline;
    VkPhysicalDeviceFeatures2 features{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
    features.pNext = &vulkan12;
    vkGetPhysicalDeviceFeatures2(physical, &features);
    if (!vulkan12.bufferDeviceAddress) note("feature bufferDeviceAddress");
    if (!accelerationStructure.accelerationStructure) note("feature accelerationStructure");
    if (!rayTracingPipeline.rayTracingPipeline) note("feature rayTracingPipeline");
    return missing;
}

namespace {

int typeRank(VkPhysicalDeviceType type) {
    switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
    }
}

std::string lower(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

std::vector<VkPhysicalDevice> enumerate(VkInstance instance) {
    uint32_t count = 0;
    check(vkEnumeratePhysicalDevices(instance, &count, nullptr), "vkEnumeratePhysicalDevices");
    std::vector<VkPhysicalDevice> devices(count);
    check(vkEnumeratePhysicalDevices(instance, &count, devices.data()), "vkEnumeratePhysicalDevices");
    return devices;
}

}  // namespace

std::vector<DeviceInfo> listDevices(const VulkanContextOptions& options) {
    VulkanContextOptions plain = options;
    plain.validation = false;
    VkInstance instance = createInstance(plain, false);
    std::vector<DeviceInfo> infos;
    const std::vector<VkPhysicalDevice> devices = enumerate(instance);
    for (uint32_t i = 0; i < devices.size(); ++i) infos.push_back(queryDevice(devices[i], i));
    vkDestroyInstance(instance, nullptr);
    return infos;
}

VulkanContext createVulkanContext(const VulkanContextOptions& options) {
    VulkanContext ctx;
    ctx.instance = createInstance(options, options.validation);
    try {
        if (options.validation) {
            ctx.validation = std::make_unique<ValidationLog>();
            VkDebugUtilsMessengerCreateInfoEXT info{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
            info.messageSeverity =
                VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
            info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
            info.pfnUserCallback = debugCallback;
            info.pUserData = ctx.validation.get();
            auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
                vkGetInstanceProcAddr(ctx.instance, "vkCreateDebugUtilsMessengerEXT"));
            RAYPACK_CHECK(create != nullptr);
            check(create(ctx.instance, &info, nullptr, &ctx.messenger), "vkCreateDebugUtilsMessengerEXT");
        }

        const std::vector<VkPhysicalDevice> devices = enumerate(ctx.instance);
        if (devices.empty())
            throw Error(
                "Vulkan: no device found; install a GPU driver or Mesa's lavapipe "
                "(mesa-vulkan-drivers)");

        std::vector<DeviceInfo> infos;
        std::vector<std::string> reasons;
        std::vector<uint32_t> families(devices.size());
        std::vector<bool> universal(devices.size());
        for (uint32_t i = 0; i < devices.size(); ++i) {
            infos.push_back(queryDevice(devices[i], i));
            bool u = false;
            reasons.push_back(rejectReason(ctx.instance, devices[i], options, &families[i], &u));
            universal[i] = u;
        }
        auto listing = [&] {
            std::string s;
            for (uint32_t i = 0; i < devices.size(); ++i) {
                s += "\n  " + std::to_string(i) + ": " + infos[i].name + " (" + toString(infos[i].type) + ")";
                if (!reasons[i].empty()) s += " - unusable: " + reasons[i];
            }
            return s;
        };

        int chosen = -1;
        const std::string& wanted = options.device;
        const bool isIndex = !wanted.empty() && std::all_of(wanted.begin(), wanted.end(), [](char c) {
            return std::isdigit(static_cast<unsigned char>(c));
        });
        if (isIndex) {
            const unsigned long index = std::stoul(wanted);
            if (index >= devices.size())
                throw Error("Vulkan: device index " + wanted + " not found; devices:" + listing());
            chosen = int(index);
        } else if (!wanted.empty()) {
            for (uint32_t i = 0; i < devices.size(); ++i)
                if (lower(infos[i].name).find(lower(wanted)) != std::string::npos) {
                    chosen = int(i);
                    break;
                }
            if (chosen < 0) throw Error("Vulkan: no device named \"" + wanted + "\"; devices:" + listing());
        } else {
            for (uint32_t i = 0; i < devices.size(); ++i) {
                if (!reasons[i].empty()) continue;
                if (chosen < 0 || typeRank(infos[i].type) > typeRank(infos[chosen].type)) chosen = int(i);
            }
            if (chosen < 0) throw Error("Vulkan: no usable device; devices:" + listing());
        }
        if (!reasons[chosen].empty())
            throw Error("Vulkan: device " + infos[chosen].name + " cannot run raypack: " + reasons[chosen]);

        ctx.physicalDevice = devices[chosen];
        ctx.info = infos[chosen];
        ctx.queueFamily = families[chosen];
        ctx.universalQueue = universal[chosen];
        vkGetPhysicalDeviceMemoryProperties(ctx.physicalDevice, &ctx.memoryProperties);

        uint32_t familyCount = 0;
        vkGetPhysicalDeviceQueueFamilyProperties(ctx.physicalDevice, &familyCount, nullptr);
        std::vector<VkQueueFamilyProperties> familyProps(familyCount);
        vkGetPhysicalDeviceQueueFamilyProperties(ctx.physicalDevice, &familyCount, familyProps.data());
        ctx.info.timestamps = familyProps[ctx.queueFamily].timestampValidBits > 0 && ctx.info.timestampPeriodNs > 0.0f;

        const float priority = 1.0f;
        VkDeviceQueueCreateInfo queueInfo{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
        queueInfo.queueFamilyIndex = ctx.queueFamily;
        queueInfo.queueCount = 1;
        queueInfo.pQueuePriorities = &priority;
        std::vector<const char*> extensions;
        for (const std::string& e : options.deviceExtensions) extensions.push_back(e.c_str());
        // Ray tracing (renderer/vk/rt_peer.h): the three extensions and their features, chained.
        VkPhysicalDeviceVulkan12Features vulkan12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
        VkPhysicalDeviceAccelerationStructureFeaturesKHR accelerationStructure{
            VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR};
        VkPhysicalDeviceRayTracingPipelineFeaturesKHR rayTracingPipeline{
            VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR};
        const void* deviceFeatures = nullptr;
        if (options.enableRayTracing && rayTracingMissing(ctx.physicalDevice).empty()) {
            for (const char* e : kRayTracingExtensions) {
                const bool listed = std::any_of(extensions.begin(), extensions.end(),
                                                [&](const char* x) { return std::strcmp(x, e) == 0; });
                if (!listed) extensions.push_back(e);
            }
            vulkan12.bufferDeviceAddress = VK_TRUE;
            accelerationStructure.accelerationStructure = VK_TRUE;
            rayTracingPipeline.rayTracingPipeline = VK_TRUE;
            vulkan12.pNext = &accelerationStructure;
            accelerationStructure.pNext = &rayTracingPipeline;
            deviceFeatures = &vulkan12;
            ctx.rayTracing = true;
        }
        // The compiler's statistics of a pipeline (registers, spills): chained in front of the rest.
        VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR executableInfo{
            VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR};
        if (options.enablePipelineStatistics &&
            offersExtension(ctx.physicalDevice, VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME)) {
            extensions.push_back(VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME);
            executableInfo.pipelineExecutableInfo = VK_TRUE;
            executableInfo.pNext = const_cast<void*>(deviceFeatures);
            deviceFeatures = &executableInfo;
            ctx.pipelineStatistics = true;
        }
        // The core features, at the chain's head: 64-bit floats where offered.
        VkPhysicalDeviceFeatures offeredCore{};
        vkGetPhysicalDeviceFeatures(ctx.physicalDevice, &offeredCore);
        VkPhysicalDeviceFeatures2 core{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
        core.features.shaderFloat64 = offeredCore.shaderFloat64;
        core.pNext = const_cast<void*>(deviceFeatures);
        ctx.float64 = offeredCore.shaderFloat64 == VK_TRUE;
        VkDeviceCreateInfo deviceInfo{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
        deviceInfo.pNext = &core;
        deviceInfo.queueCreateInfoCount = 1;
        deviceInfo.pQueueCreateInfos = &queueInfo;
        deviceInfo.enabledExtensionCount = uint32_t(extensions.size());
        deviceInfo.ppEnabledExtensionNames = extensions.data();
        const VkResult result = vkCreateDevice(ctx.physicalDevice, &deviceInfo, nullptr, &ctx.device);
        if (result < 0)
            throw Error("Vulkan: could not create a logical device on " + ctx.info.name + ": " + resultName(result));
        vkGetDeviceQueue(ctx.device, ctx.queueFamily, 0, &ctx.queue);
    } catch (...) {
        destroyVulkanContext(ctx);
        throw;
    }
    return ctx;
}

void destroyVulkanContext(VulkanContext& ctx) {
    if (ctx.device) vkDestroyDevice(ctx.device, nullptr);
    if (ctx.messenger) {
        auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(ctx.instance, "vkDestroyDebugUtilsMessengerEXT"));
        if (destroy) destroy(ctx.instance, ctx.messenger, nullptr);
    }
    if (ctx.instance) vkDestroyInstance(ctx.instance, nullptr);
    ctx.device = VK_NULL_HANDLE;
    ctx.messenger = VK_NULL_HANDLE;
    ctx.instance = VK_NULL_HANDLE;
    ctx.physicalDevice = VK_NULL_HANDLE;
    ctx.queue = VK_NULL_HANDLE;
}

uint32_t validationMessageCount(const VulkanContext& ctx) {
    if (!ctx.validation) return 0;
    std::lock_guard lock(ctx.validation->mutex);
    return ctx.validation->count;
}

// ---- Buffers

namespace {
uint32_t findMemoryType(const VulkanContext& ctx, uint32_t typeBits, VkMemoryPropertyFlags props) {
    for (uint32_t i = 0; i < ctx.memoryProperties.memoryTypeCount; ++i)
        if ((typeBits & (1u << i)) && (ctx.memoryProperties.memoryTypes[i].propertyFlags & props) == props) return i;
    return UINT32_MAX;
}
[[noreturn]] void throwOutOfMemory(const VulkanContext& ctx, VkResult result, VkDeviceSize bytes, const char* what) {
    char message[512];
    std::snprintf(message, sizeof message, "Vulkan: out of %s memory on %s allocating %.1f MiB for %s",
                  result == VK_ERROR_OUT_OF_DEVICE_MEMORY ? "device" : "host", ctx.info.name.c_str(),
                  double(bytes) / (1024.0 * 1024.0), what);
    throw Error(message);
}
}  // namespace

Buffer createBuffer(const VulkanContext& ctx, VkDeviceSize size, VkBufferUsageFlags usage,
                    VkMemoryPropertyFlags properties, const char* what) {
    Buffer buffer;
    buffer.size = std::max<VkDeviceSize>(size, 16);  // Vulkan forbids empty buffers
    VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    info.size = buffer.size;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    const VkResult created = vkCreateBuffer(ctx.device, &info, nullptr, &buffer.buffer);
    if (created == VK_ERROR_OUT_OF_DEVICE_MEMORY || created == VK_ERROR_OUT_OF_HOST_MEMORY)
        throwOutOfMemory(ctx, created, buffer.size, what);
    check(created, "vkCreateBuffer");

    VkMemoryRequirements requirements;
    vkGetBufferMemoryRequirements(ctx.device, buffer.buffer, &requirements);
    const uint32_t type = findMemoryType(ctx, requirements.memoryTypeBits, properties);
    if (type == UINT32_MAX) {
        vkDestroyBuffer(ctx.device, buffer.buffer, nullptr);
        throw Error("Vulkan: " + ctx.info.name + " has no memory type for " + what);
    }
    VkMemoryAllocateInfo allocate{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    // A buffer whose device address is taken (acceleration structure inputs, the shader binding
    // table) needs memory allocated for it.
    VkMemoryAllocateFlagsInfo allocateFlags{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO};
    allocateFlags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
    if (usage & VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT) allocate.pNext = &allocateFlags;
    allocate.allocationSize = requirements.size;
    allocate.memoryTypeIndex = type;
    const VkResult result = vkAllocateMemory(ctx.device, &allocate, nullptr, &buffer.memory);
    if (result == VK_ERROR_OUT_OF_DEVICE_MEMORY || result == VK_ERROR_OUT_OF_HOST_MEMORY) {
        vkDestroyBuffer(ctx.device, buffer.buffer, nullptr);
        throwOutOfMemory(ctx, result, requirements.size, what);
    }
    check(result, "vkAllocateMemory");
    check(vkBindBufferMemory(ctx.device, buffer.buffer, buffer.memory, 0), "vkBindBufferMemory");
    if (properties & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT)
        check(vkMapMemory(ctx.device, buffer.memory, 0, VK_WHOLE_SIZE, 0, &buffer.mapped), "vkMapMemory");
    return buffer;
}

void destroyBuffer(const VulkanContext& ctx, Buffer& buffer) {
    if (buffer.buffer) vkDestroyBuffer(ctx.device, buffer.buffer, nullptr);
    if (buffer.memory) vkFreeMemory(ctx.device, buffer.memory, nullptr);
    buffer = Buffer{};
}

VkCommandPool createCommandPool(const VulkanContext& ctx, VkCommandPoolCreateFlags flags, const char* what) {
    VkCommandPoolCreateInfo info{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    info.flags = flags;
    info.queueFamilyIndex = ctx.queueFamily;
    VkCommandPool pool = VK_NULL_HANDLE;
    check(vkCreateCommandPool(ctx.device, &info, nullptr, &pool), what);
    return pool;
}

std::unique_lock<std::mutex> lockQueue(const VulkanContext& ctx) {
    RAYPACK_CHECK(ctx.queueMutex);
    return std::unique_lock<std::mutex>(*ctx.queueMutex);
}

void queueSubmit(const VulkanContext& ctx, const VkSubmitInfo& submit, VkFence fence, const char* what) {
    const auto lock = lockQueue(ctx);
    check(vkQueueSubmit(ctx.queue, 1, &submit, fence), what);
}

void queueWaitIdle(const VulkanContext& ctx) {
    const auto lock = lockQueue(ctx);
    vkQueueWaitIdle(ctx.queue);
}

void deviceWaitIdle(const VulkanContext& ctx) {
    const auto lock = lockQueue(ctx);
    vkDeviceWaitIdle(ctx.device);
}

void submitAndWait(const VulkanContext& ctx, VkCommandPool pool, const std::function<void(VkCommandBuffer)>& record) {
    VkCommandBufferAllocateInfo allocate{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    allocate.commandPool = pool;
    allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    allocate.commandBufferCount = 1;
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    check(vkAllocateCommandBuffers(ctx.device, &allocate, &cmd), "vkAllocateCommandBuffers");
    VkFence fence = VK_NULL_HANDLE;
    try {
        VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
        begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
        record(cmd);
        check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
        VkFenceCreateInfo fenceInfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
        check(vkCreateFence(ctx.device, &fenceInfo, nullptr, &fence), "vkCreateFence");
        VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &cmd;
        queueSubmit(ctx, submit, fence, "vkQueueSubmit");
        check(vkWaitForFences(ctx.device, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    } catch (...) {
        if (fence) vkDestroyFence(ctx.device, fence, nullptr);
        vkFreeCommandBuffers(ctx.device, pool, 1, &cmd);
        throw;
    }
    vkDestroyFence(ctx.device, fence, nullptr);
    vkFreeCommandBuffers(ctx.device, pool, 1, &cmd);
}

void uploadToBuffer(const VulkanContext& ctx, VkCommandPool pool, const Buffer& destination, const void* data,
                    VkDeviceSize bytes) {
    if (bytes == 0) return;
    RAYPACK_CHECK(bytes <= destination.size);
    Buffer staging =
        createBuffer(ctx, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                     VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, "a staging buffer");
    std::memcpy(staging.mapped, data, bytes);
    try {
        submitAndWait(ctx, pool, [&](VkCommandBuffer cmd) {
            VkBufferCopy region{0, 0, bytes};
            vkCmdCopyBuffer(cmd, staging.buffer, destination.buffer, 1, &region);
        });
    } catch (...) {
        destroyBuffer(ctx, staging);
        throw;
    }
    destroyBuffer(ctx, staging);
}

StorageSetLayout createStorageSetLayout(const VulkanContext& ctx, uint32_t bindingCount, uint32_t pushConstantBytes,
                                        uint32_t texelBindings) {
    StorageSetLayout layout;
    try {
        std::vector<VkDescriptorSetLayoutBinding> bindings(bindingCount + texelBindings);
        for (uint32_t b = 0; b < bindings.size(); ++b)
            bindings[b] = {
                b, b < bindingCount ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER : VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, 1,
                VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
        VkDescriptorSetLayoutCreateInfo setInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
        setInfo.bindingCount = uint32_t(bindings.size());
        setInfo.pBindings = bindings.data();
        check(vkCreateDescriptorSetLayout(ctx.device, &setInfo, nullptr, &layout.setLayout),
              "vkCreateDescriptorSetLayout");
        VkPushConstantRange push{VK_SHADER_STAGE_COMPUTE_BIT, 0, pushConstantBytes};
        VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
        layoutInfo.setLayoutCount = 1;
        layoutInfo.pSetLayouts = &layout.setLayout;
        layoutInfo.pushConstantRangeCount = 1;
        layoutInfo.pPushConstantRanges = &push;
        check(vkCreatePipelineLayout(ctx.device, &layoutInfo, nullptr, &layout.pipelineLayout),
              "vkCreatePipelineLayout");
        const VkDescriptorPoolSize poolSizes[2] = {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, bindingCount},
                                                   {VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, texelBindings}};
        VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
        poolInfo.maxSets = 1;
        poolInfo.poolSizeCount = texelBindings > 0 ? 2 : 1;
        poolInfo.pPoolSizes = poolSizes;
        check(vkCreateDescriptorPool(ctx.device, &poolInfo, nullptr, &layout.pool), "vkCreateDescriptorPool");
        VkDescriptorSetAllocateInfo allocate{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
        allocate.descriptorPool = layout.pool;
        allocate.descriptorSetCount = 1;
        allocate.pSetLayouts = &layout.setLayout;
        check(vkAllocateDescriptorSets(ctx.device, &allocate, &layout.set), "vkAllocateDescriptorSets");
    } catch (...) {
        destroyStorageSetLayout(ctx, layout);
        throw;
    }
    return layout;
}

void destroyStorageSetLayout(const VulkanContext& ctx, StorageSetLayout& layout) {
    if (layout.pool) vkDestroyDescriptorPool(ctx.device, layout.pool, nullptr);
    if (layout.pipelineLayout) vkDestroyPipelineLayout(ctx.device, layout.pipelineLayout, nullptr);
    if (layout.setLayout) vkDestroyDescriptorSetLayout(ctx.device, layout.setLayout, nullptr);
    layout = {};
}

void writeStorageSet(const VulkanContext& ctx, VkDescriptorSet set, std::span<const VkBuffer> buffers) {
    std::vector<VkDescriptorBufferInfo> infos(buffers.size());
    std::vector<VkWriteDescriptorSet> writes(buffers.size());
    for (uint32_t b = 0; b < buffers.size(); ++b) {
        RAYPACK_CHECK_MSG(buffers[b] != VK_NULL_HANDLE, "every storage binding has a buffer");
        infos[b] = {buffers[b], 0, VK_WHOLE_SIZE};
        writes[b] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
        writes[b].dstSet = set;
        writes[b].dstBinding = b;
        writes[b].descriptorCount = 1;
        writes[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
        writes[b].pBufferInfo = &infos[b];
    }
    vkUpdateDescriptorSets(ctx.device, uint32_t(writes.size()), writes.data(), 0, nullptr);
}

void writeTexelBuffer(const VulkanContext& ctx, VkDescriptorSet set, uint32_t binding, VkBufferView view) {
    VkWriteDescriptorSet write{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    write.dstSet = set;
    write.dstBinding = binding;
    write.descriptorCount = 1;
    write.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
    write.pTexelBufferView = &view;
    vkUpdateDescriptorSets(ctx.device, 1, &write, 0, nullptr);
}

void checkBindable(const VulkanContext& ctx, size_t bytes, const char* what) {
    if (ctx.info.maxStorageBufferBytes > 0 && bytes > ctx.info.maxStorageBufferBytes)
        throw Error("GPU: the " + std::string(what) + " need " + std::to_string(bytes) + " bytes, more than " +
                    ctx.info.name + " binds in one storage buffer (" + std::to_string(ctx.info.maxStorageBufferBytes) +
                    ")");
}

StagedUpload::~StagedUpload() {
    for (Staged& b : staged_) destroyBuffer(context_, b.staging);
}

bool mappableDeviceMemory(const VulkanContext& ctx) {
    const VkPhysicalDeviceMemoryProperties& m = ctx.memoryProperties;
    const VkMemoryPropertyFlags mapped = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                         VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    const uint32_t local = findMemoryType(ctx, ~0u, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    const uint32_t visible = findMemoryType(ctx, ~0u, mapped);
    return local != UINT32_MAX && visible != UINT32_MAX &&
           m.memoryTypes[local].heapIndex == m.memoryTypes[visible].heapIndex;
}

StagedUpload::StagedUpload(const VulkanContext& context, VkCommandPool pool)
    : context_(context), pool_(pool), direct_(mappableDeviceMemory(context)) {
    if (const char* mode = std::getenv("RAYPACK_UPLOAD"); mode && std::strcmp(mode, "staged") == 0) direct_ = false;
}

void* StagedUpload::add(Buffer& device, size_t bytes, const char* what, VkBufferUsageFlags extraUsage) {
    const auto start = std::chrono::steady_clock::now();
    checkBindable(context_, bytes, what);
    if (direct_ && bytes > 0) {
        try {
            device = createBuffer(context_, bytes, kUsage | extraUsage,
                                  VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                      VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                  what);
            allocationSeconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            return device.mapped;
        } catch (const Error&) {
            // The mappable part of the heap is used up: stage the rest.
        }
    }
    device = createBuffer(context_, bytes, kUsage | extraUsage, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, what);
    if (bytes == 0) return nullptr;
    staged_.push_back({&device, createBuffer(context_, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                             VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                             "a staging buffer")});
    allocationSeconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return staged_.back().staging.mapped;
}

void StagedUpload::submit() {
    const auto start = std::chrono::steady_clock::now();
    if (!staged_.empty())
        submitAndWait(context_, pool_, [&](VkCommandBuffer cmd) {
            for (const Staged& b : staged_) {
                const VkBufferCopy region{0, 0, b.staging.size};
                vkCmdCopyBuffer(cmd, b.staging.buffer, b.device->buffer, 1, &region);
            }
        });
    transferSeconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

VkShaderModule createShaderModule(const VulkanContext& ctx, const uint32_t* code, size_t codeBytes, const char* name) {
    VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    info.codeSize = codeBytes;
    info.pCode = code;
    VkShaderModule module = VK_NULL_HANDLE;
    const VkResult result = vkCreateShaderModule(ctx.device, &info, nullptr, &module);
    if (result < 0)
        throw Error(std::string("Vulkan: could not load shader ") + name + " on " + ctx.info.name + ": " +
                    resultName(result));
    return module;
}

VkPipeline createComputePipeline(const VulkanContext& ctx, VkShaderModule module,
                                 const VkSpecializationInfo& specialization, VkPipelineLayout layout,
                                 const std::string& what, VkPipelineCache cache, VkPipelineCreateFlags flags) {
    VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    info.flags = flags;
    info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = module;
    info.stage.pName = "main";
    info.stage.pSpecializationInfo = &specialization;
    info.layout = layout;
    VkPipeline pipeline = VK_NULL_HANDLE;
    const VkResult result = vkCreateComputePipelines(ctx.device, cache, 1, &info, nullptr, &pipeline);
    if (result < 0) throw Error(what + " on " + ctx.info.name + ": " + resultName(result));
    return pipeline;
}

void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags srcStage, VkAccessFlags srcAccess,
                   VkPipelineStageFlags dstStage, VkAccessFlags dstAccess) {
    VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    barrier.srcAccessMask = srcAccess;
    barrier.dstAccessMask = dstAccess;
    vkCmdPipelineBarrier(cmd, srcStage, dstStage, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

}  // namespace raypack::vk
