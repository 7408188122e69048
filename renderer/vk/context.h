#pragma once
// Vulkan set-up, kept small and apart from the tracer (../shared/STYLE.md; the scope of
// vk-bootstrap and of niagara's device.cpp): instance, optional validation, device choice, one
// queue, plain buffers and one-shot command submission. No window code: the viewer passes its
// surface extensions and a present-support callback through VulkanContextOptions.
#include <vulkan/vulkan.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

namespace raypack::vk {

// Throws raypack::Error naming `what` and the VkResult when `result` is an error.
void check(VkResult result, const char* what);
const char* resultName(VkResult result);

struct VulkanContextOptions {
    // "" = automatic (discrete > integrated > virtual > CPU), a decimal index into the list of
    // devices, or a case-insensitive substring of the device name ("llvmpipe", "H100").
    std::string device;
    // VK_LAYER_KHRONOS_validation plus a debug messenger that prints and counts every message.
    bool validation = false;
    std::vector<std::string> instanceExtensions;  // e.g. glfwGetRequiredInstanceExtensions()
    std::vector<std::string> deviceExtensions;    // e.g. VK_KHR_swapchain
    // When set, the queue family must also present: called with the instance, a candidate
    // physical device and a queue family index. Devices without such a family are skipped.
    std::function<bool(VkInstance, VkPhysicalDevice, uint32_t)> presentSupport;
    std::string applicationName = "raypack";
    // Enable the driver's ray tracing (renderer/vk/rt_peer.h) when the chosen device offers it:
    // VK_KHR_acceleration_structure, VK_KHR_ray_tracing_pipeline and VK_KHR_deferred_host_operations
    // with the features accelerationStructure, rayTracingPipeline and bufferDeviceAddress. A device
    // without them is still chosen and used; VulkanContext::rayTracing then stays false.
    bool enableRayTracing = false;
    // Enable VK_KHR_pipeline_executable_properties (feature pipelineExecutableInfo) where offered,
    // so that compute pipelines can report the compiler's statistics (registers, spills, ...).
    // Without it VulkanContext::pipelineStatistics stays false.
    bool enablePipelineStatistics = false;
};

// What the tracer and the panel need to know about the chosen device.
struct DeviceInfo {
    uint32_t index = 0;  // position in vkEnumeratePhysicalDevices
    std::string name;
    VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
    std::string driver;  // driver name and info (VkPhysicalDeviceDriverProperties)
    uint32_t apiVersion = 0;
    uint32_t subgroupSize = 0;
    uint32_t maxSharedMemoryBytes = 0;          // maxComputeSharedMemorySize
    uint32_t maxStorageBufferBytes = 0;         // maxStorageBufferRange
    uint32_t maxTexelBufferElements = 0;        // maxTexelBufferElements
    bool rgba32fTexelBuffers = false;           // R32G32B32A32_SFLOAT uniform texel buffers
    uint32_t maxWorkgroupInvocations = 0;       // maxComputeWorkGroupInvocations
    uint32_t maxWorkgroupSize[3] = {0, 0, 0};   // maxComputeWorkGroupSize
    uint32_t maxWorkgroupCount[3] = {0, 0, 0};  // maxComputeWorkGroupCount
    float timestampPeriodNs = 0.0f;             // nanoseconds per timestamp tick
    bool timestamps = false;                    // the queue family writes timestamps
};

const char* toString(VkPhysicalDeviceType type);
// "NAME (TYPE, DRIVER, subgroup N)": the line the CLI prints and the viewer shows.
std::string describe(const DeviceInfo& info);

// Validation messages seen so far; tests fail when count > 0.
struct ValidationLog {
    std::mutex mutex;
    uint32_t count = 0;
    std::vector<std::string> messages;
};

struct VulkanContext {
    VkInstance instance = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
    VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;
    VkDevice device = VK_NULL_HANDLE;
    uint32_t queueFamily = 0;
    VkQueue queue = VK_NULL_HANDLE;
    bool universalQueue = false;  // the family does graphics and compute
    VkPhysicalDeviceMemoryProperties memoryProperties{};
    DeviceInfo info;
    std::unique_ptr<ValidationLog> validation;  // null when validation is off
    // The ray tracing extensions and features are enabled (VulkanContextOptions::enableRayTracing
    // on a device that offers them); buffers with VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT then
    // get memory allocated with VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT.
    bool rayTracing = false;
    // VK_KHR_pipeline_executable_properties is enabled (VulkanContextOptions::enablePipelineStatistics).
    bool pipelineStatistics = false;
    // shaderFloat64 is enabled (wherever the device offers it): the kernels may compute the
    // accurate hit distance in doubles (HitDistanceMath, renderer/settings.h).
    bool float64 = false;
    // The queue's external synchronisation: the viewer's render thread and its build worker both
    // submit to `queue`, so every vkQueueSubmit, vkQueueWaitIdle, vkQueuePresentKHR and
    // vkDeviceWaitIdle goes through lockQueue (or the helpers below that take it).
    std::unique_ptr<std::mutex> queueMutex = std::make_unique<std::mutex>();
};

// Holds the context's queue for one submission, present or wait.
[[nodiscard]] std::unique_lock<std::mutex> lockQueue(const VulkanContext& context);
// vkQueueSubmit of one VkSubmitInfo under the queue's lock; throws naming `what` on an error.
void queueSubmit(const VulkanContext& context, const VkSubmitInfo& submit, VkFence fence, const char* what);
// vkQueueWaitIdle and vkDeviceWaitIdle under the queue's lock.
void queueWaitIdle(const VulkanContext& context);
void deviceWaitIdle(const VulkanContext& context);

// Throws raypack::Error when there is no Vulkan loader or driver, no usable device, or the
// requested device is not found (the message lists the devices).
VulkanContext createVulkanContext(const VulkanContextOptions& options);
void destroyVulkanContext(VulkanContext& context);

// Every device the loader reports, for `--device` help and error messages.
std::vector<DeviceInfo> listDevices(const VulkanContextOptions& options = {});

uint32_t validationMessageCount(const VulkanContext& context);

// What `physical` lacks for the driver's ray tracing (extensions, then features), comma-separated,
// or "" when it offers everything VulkanContextOptions::enableRayTracing enables.
std::string rayTracingMissing(VkPhysicalDevice physical);

// ---- Buffers (niagara's Buffer / createBuffer): a plain struct, created and destroyed by functions.
struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    void* mapped = nullptr;  // host-visible buffers stay mapped
    VkDeviceSize size = 0;
};

// Throws raypack::Error naming the device, `what` and the size on out-of-memory.
Buffer createBuffer(const VulkanContext& context, VkDeviceSize size, VkBufferUsageFlags usage,
                    VkMemoryPropertyFlags properties, const char* what);
void destroyBuffer(const VulkanContext& context, Buffer& buffer);

// A command pool on the context's queue family (`flags`: e.g. reset-per-buffer, transient).
VkCommandPool createCommandPool(const VulkanContext& context, VkCommandPoolCreateFlags flags, const char* what);

// Records with `record` into a fresh command buffer from `pool`, submits it and waits.
void submitAndWait(const VulkanContext& context, VkCommandPool pool,
                   const std::function<void(VkCommandBuffer)>& record);

// Copies `bytes` from host memory into a device-local buffer through a staging buffer.
void uploadToBuffer(const VulkanContext& context, VkCommandPool pool, const Buffer& destination, const void* data,
                    VkDeviceSize bytes);

// ---- Compute layouts: one descriptor set of storage buffers at bindings 0..count-1, a push-constant
// range, and the one set allocated (the tracer's and the GPU builder's kernels all bind so).
struct StorageSetLayout {
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
    VkPipelineLayout pipelineLayout = VK_NULL_HANDLE;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet set = VK_NULL_HANDLE;
};
// Throws raypack::Error naming the call that failed; what was created is destroyed first.
// Bindings 0 .. bindingCount - 1 are storage buffers, the texelBindings after them uniform texel
// buffers (writeTexelBuffer).
StorageSetLayout createStorageSetLayout(const VulkanContext& context, uint32_t bindingCount, uint32_t pushConstantBytes,
                                        uint32_t texelBindings = 0);
void destroyStorageSetLayout(const VulkanContext& context, StorageSetLayout& layout);
// Points binding b of `set` at the whole of buffers[b].
void writeStorageSet(const VulkanContext& context, VkDescriptorSet set, std::span<const VkBuffer> buffers);
// Points the uniform texel buffer `binding` of `set` at `view`.
void writeTexelBuffer(const VulkanContext& context, VkDescriptorSet set, uint32_t binding, VkBufferView view);

// Device-local buffers filled from the host: add() creates one and returns memory to write (null for
// an empty array, which still gets its device buffer), submit() makes every write reach the device.
// Where the device's memory is mappable in full (mappableDeviceMemory: resizable BAR on a discrete
// GPU, every CPU device), that memory is the device buffer's own mapping and submit() copies
// nothing; else (or with RAYPACK_UPLOAD=staged in the environment, for measuring the two) a mapped
// staging buffer of the same size, copied in one submission. Staging buffers are freed on every
// path out.
class StagedUpload {
public:
    StagedUpload(const VulkanContext& context, VkCommandPool pool);
    ~StagedUpload();
    StagedUpload(const StagedUpload&) = delete;
    StagedUpload& operator=(const StagedUpload&) = delete;
    // Throws raypack::Error when `bytes` exceed what one storage buffer binds on the device (naming
    // `what`) or the device is out of memory.
    // `extraUsage` is added to kUsage (the nodes: VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT).
    void* add(Buffer& device, size_t bytes, const char* what, VkBufferUsageFlags extraUsage = 0);
    void submit();
    // Host seconds spent creating buffers in `add`, and in `submit` (copies and the wait).
    double allocationSeconds() const { return allocationSeconds_; }
    double transferSeconds() const { return transferSeconds_; }
    // Storage, transfer source and destination: what the tracers' and the builder's arrays use.
    static constexpr VkBufferUsageFlags kUsage =
        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;

private:
    struct Staged {
        Buffer* device;
        Buffer staging;
    };
    const VulkanContext& context_;
    VkCommandPool pool_;
    std::vector<Staged> staged_;
    bool direct_ = false;
    double allocationSeconds_ = 0.0;
    double transferSeconds_ = 0.0;
};
// Whether a heap holds both the first device-local memory type and a device-local, host-visible,
// host-coherent one, i.e. device memory can be mapped in full (StagedUpload).
bool mappableDeviceMemory(const VulkanContext& context);
// Throws raypack::Error when `bytes` exceed maxStorageBufferRange (the texels of large textures are
// the likeliest to), naming `what` and the device.
void checkBindable(const VulkanContext& context, size_t bytes, const char* what);

VkShaderModule createShaderModule(const VulkanContext& context, const uint32_t* code, size_t codeBytes,
                                  const char* name);
// The compute pipeline of `module`'s "main" with `specialization` over `layout`, through `cache`
// (none: VK_NULL_HANDLE) with `flags`. Throws raypack::Error "WHAT on DEVICE: RESULT" where it fails.
VkPipeline createComputePipeline(const VulkanContext& context, VkShaderModule module,
                                 const VkSpecializationInfo& specialization, VkPipelineLayout layout,
                                 const std::string& what, VkPipelineCache cache = VK_NULL_HANDLE,
                                 VkPipelineCreateFlags flags = 0);

// Records a global memory barrier: the writes `srcAccess` of stages `srcStage` are made available
// and visible to the accesses `dstAccess` of stages `dstStage`. Every buffer the tracers share
// between passes is covered by one such barrier (no per-buffer or image barriers needed there).
void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags srcStage, VkAccessFlags srcAccess,
                   VkPipelineStageFlags dstStage, VkAccessFlags dstAccess);

}  // namespace raypack::vk
