// splitvk-e2e-probe: the smallest Vulkan program the end-to-end tests need, headless (no window,
// no X server). It creates an instance (with the application name the tests look for in the
// layer's log), a device and a queue, records two vkCmdFillBuffer into one buffer and submits them,
// and creates and destroys a descriptor set layout and a descriptor pool.
//
//   splitvk-e2e-probe [--app-name NAME] [--sync-hazard] [--device-extension NAME]...
//                     [--list-device-extensions] [--concurrent-queues ROUNDS]
//
// With --sync-hazard the barrier between the two fills is left out: a write-after-write hazard that
// only synchronization validation reports. The validation tests use it to prove that
// synchronization validation is really on (a negative control), so a clean run means something.
// It prints the limits it was told, for the device envelope tests. --device-extension enables a
// device extension whether or not vkEnumerateDeviceExtensionProperties lists it, as an application
// that enables extensions blindly does (the unsupported-extension tests). --list-device-extensions
// prints `device extension: NAME` for each extension vkEnumerateDeviceExtensionProperties lists, and
// stops before creating a device.
// --concurrent-queues ROUNDS creates and destroys ROUNDS devices instead; on each, several threads
// released at once call vkGetDeviceQueue for the same queues (legal: it needs no external
// synchronisation), then the main thread calls vkDeviceWaitIdle. It prints
// `concurrent queues: R rounds, T threads` once all returned.
#include <vulkan/vulkan.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace {

#define CHECK(call)                                                                                          \
    do {                                                                                                     \
        VkResult r_ = (call);                                                                                \
        if (r_ != VK_SUCCESS) {                                                                              \
            std::fprintf(stderr, "splitvk-e2e-probe: %s failed: %d\n", #call, r_);                           \
            return 1;                                                                                        \
        }                                                                                                    \
    } while (0)

struct Options {
    std::string app_name = "splitvk-e2e-probe";
    bool sync_hazard = false;
    std::vector<const char *> device_extensions;
    bool list_device_extensions = false;
    int concurrent_queue_rounds = 0;
};

// --concurrent-queues: each round a fresh device, so that every round's vkGetDeviceQueue calls are
// the first for their queues, which is when the layer learns of a queue.
int concurrent_queues(VkPhysicalDevice gpu, uint32_t family, uint32_t queue_count, int rounds) {
    constexpr int kThreads = 8;
    const std::vector<float> priorities(queue_count, 1.0f);
    VkDeviceQueueCreateInfo qci{};
    qci.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    qci.queueFamilyIndex = family;
    qci.queueCount = queue_count;
    qci.pQueuePriorities = priorities.data();
    VkDeviceCreateInfo dci{};
    dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    dci.queueCreateInfoCount = 1;
    dci.pQueueCreateInfos = &qci;
    for (int round = 0; round < rounds; ++round) {
        VkDevice device = VK_NULL_HANDLE;
        CHECK(vkCreateDevice(gpu, &dci, nullptr, &device));
        // Resolved once: the loader's trampoline is not what is raced.
        const auto get_queue =
            reinterpret_cast<PFN_vkGetDeviceQueue>(vkGetDeviceProcAddr(device, "vkGetDeviceQueue"));
        std::atomic<int> ready{0};
        std::atomic<bool> go{false};
        std::vector<std::thread> threads;
        std::vector<VkQueue> got(kThreads, VK_NULL_HANDLE);
        for (int t = 0; t < kThreads; ++t)
            threads.emplace_back([&, t] {
                ready.fetch_add(1);
                while (!go.load(std::memory_order_acquire))
                    std::this_thread::yield();
                get_queue(device, family, static_cast<uint32_t>(t) % queue_count, &got[t]);
            });
        while (ready.load() < kThreads)
            std::this_thread::yield();
        go.store(true, std::memory_order_release);
        for (std::thread &thread : threads)
            thread.join();
        for (int t = 0; t < kThreads; ++t)
            if (got[t] == VK_NULL_HANDLE || got[t] != got[t % queue_count]) {
                std::fprintf(stderr, "splitvk-e2e-probe: round %d: thread %d got queue %p\n", round, t,
                             static_cast<void *>(got[t]));
                return 1;
            }
        CHECK(vkDeviceWaitIdle(device));
        vkDestroyDevice(device, nullptr);
    }
    std::printf("concurrent queues: %d rounds, %d threads\n", rounds, kThreads);
    return 0;
}

int run(const Options &options) {
    const std::string &app_name = options.app_name;
    const bool sync_hazard = options.sync_hazard;
    const std::vector<const char *> &device_extensions = options.device_extensions;
    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = app_name.c_str();
    app.applicationVersion = 1;
    app.pEngineName = "splitvk-e2e";
    app.apiVersion = VK_API_VERSION_1_1;
    VkInstanceCreateInfo ici{};
    ici.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    ici.pApplicationInfo = &app;
    VkInstance instance = VK_NULL_HANDLE;
    CHECK(vkCreateInstance(&ici, nullptr, &instance));

    uint32_t count = 0;
    CHECK(vkEnumeratePhysicalDevices(instance, &count, nullptr));
    if (count == 0) {
        std::fprintf(stderr, "splitvk-e2e-probe: no physical device\n");
        return 1;
    }
    std::vector<VkPhysicalDevice> gpus(count);
    CHECK(vkEnumeratePhysicalDevices(instance, &count, gpus.data()));
    VkPhysicalDevice gpu = gpus[0];
    // What the application is told (the device envelope tests read it).
    VkPhysicalDeviceProperties properties{};
    vkGetPhysicalDeviceProperties(gpu, &properties);
    std::printf("limits: minUniformBufferOffsetAlignment=%llu minStorageBufferOffsetAlignment=%llu "
                "maxPushConstantsSize=%u maxImageDimension2D=%u\n",
                static_cast<unsigned long long>(properties.limits.minUniformBufferOffsetAlignment),
                static_cast<unsigned long long>(properties.limits.minStorageBufferOffsetAlignment),
                properties.limits.maxPushConstantsSize, properties.limits.maxImageDimension2D);

    if (options.list_device_extensions) {
        uint32_t extension_count = 0;
        CHECK(vkEnumerateDeviceExtensionProperties(gpu, nullptr, &extension_count, nullptr));
        std::vector<VkExtensionProperties> extensions(extension_count);
        CHECK(vkEnumerateDeviceExtensionProperties(gpu, nullptr, &extension_count, extensions.data()));
        for (uint32_t i = 0; i < extension_count; ++i)
            std::printf("device extension: %s\n", extensions[i].extensionName);
        vkDestroyInstance(instance, nullptr);
        return 0;
    }

    uint32_t qcount = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(gpu, &qcount, nullptr);
    std::vector<VkQueueFamilyProperties> families(qcount);
    vkGetPhysicalDeviceQueueFamilyProperties(gpu, &qcount, families.data());
    uint32_t family = UINT32_MAX;
    for (uint32_t i = 0; i < qcount; ++i)
        if (families[i].queueFlags & (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT | VK_QUEUE_TRANSFER_BIT)) {
            family = i;
            break;
        }
    if (family == UINT32_MAX) {
        std::fprintf(stderr, "splitvk-e2e-probe: no usable queue family\n");
        return 1;
    }

    if (options.concurrent_queue_rounds > 0) {
        const int result = concurrent_queues(gpu, family, std::min(families[family].queueCount, 4u),
                                             options.concurrent_queue_rounds);
        vkDestroyInstance(instance, nullptr);
        return result;
    }

    float priority = 1.0f;
    VkDeviceQueueCreateInfo qci{};
    qci.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    qci.queueFamilyIndex = family;
    qci.queueCount = 1;
    qci.pQueuePriorities = &priority;
    VkDeviceCreateInfo dci{};
    dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    dci.queueCreateInfoCount = 1;
    dci.pQueueCreateInfos = &qci;
    dci.enabledExtensionCount = static_cast<uint32_t>(device_extensions.size());
    dci.ppEnabledExtensionNames = device_extensions.data();
    VkDevice device = VK_NULL_HANDLE;
    CHECK(vkCreateDevice(gpu, &dci, nullptr, &device));
    VkQueue queue = VK_NULL_HANDLE;
    vkGetDeviceQueue(device, family, 0, &queue);

    const VkDeviceSize size = 64 * 1024;
    VkBufferCreateInfo bci{};
    bci.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    bci.size = size;
    bci.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    VkBuffer buffer = VK_NULL_HANDLE;
    CHECK(vkCreateBuffer(device, &bci, nullptr, &buffer));
    VkMemoryRequirements req{};
    vkGetBufferMemoryRequirements(device, buffer, &req);
    VkPhysicalDeviceMemoryProperties mem{};
    vkGetPhysicalDeviceMemoryProperties(gpu, &mem);
    uint32_t type = UINT32_MAX;
    for (uint32_t i = 0; i < mem.memoryTypeCount; ++i)
        if (req.memoryTypeBits & (1u << i)) {
            type = i;
            break;
        }
    VkMemoryAllocateInfo mai{};
    mai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    mai.allocationSize = req.size;
    mai.memoryTypeIndex = type;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    CHECK(vkAllocateMemory(device, &mai, nullptr, &memory));
    CHECK(vkBindBufferMemory(device, buffer, memory, 0));

    VkCommandPoolCreateInfo pci{};
    pci.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pci.queueFamilyIndex = family;
    VkCommandPool pool = VK_NULL_HANDLE;
    CHECK(vkCreateCommandPool(device, &pci, nullptr, &pool));
    VkCommandBufferAllocateInfo cai{};
    cai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    cai.commandPool = pool;
    cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cai.commandBufferCount = 1;
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    CHECK(vkAllocateCommandBuffers(device, &cai, &cmd));

    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    CHECK(vkBeginCommandBuffer(cmd, &begin));
    vkCmdFillBuffer(cmd, buffer, 0, size, 0x11111111u);
    if (!sync_hazard) {
        VkBufferMemoryBarrier barrier{};
        barrier.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
        barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        barrier.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        barrier.buffer = buffer;
        barrier.offset = 0;
        barrier.size = VK_WHOLE_SIZE;
        vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                             nullptr, 1, &barrier, 0, nullptr);
    }
    vkCmdFillBuffer(cmd, buffer, 0, size, 0x22222222u);
    CHECK(vkEndCommandBuffer(cmd));

    VkFenceCreateInfo fci{};
    fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    VkFence fence = VK_NULL_HANDLE;
    CHECK(vkCreateFence(device, &fci, nullptr, &fence));
    VkSubmitInfo si{};
    si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    CHECK(vkQueueSubmit(queue, 1, &si, fence));
    CHECK(vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX));

    // A descriptor set layout and pool, created and destroyed, and a set from the pool freed once
    // and reset once (VK_LAYER_SPLITVK_test_reuse, below splitvk, hands their values to new ones at
    // once; tests/e2e/reuse_layer).
    const VkDescriptorSetLayoutBinding binding{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1,
                                               VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
    VkDescriptorSetLayoutCreateInfo lci{};
    lci.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    lci.bindingCount = 1;
    lci.pBindings = &binding;
    VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
    CHECK(vkCreateDescriptorSetLayout(device, &lci, nullptr, &set_layout));
    const VkDescriptorPoolSize pool_size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1};
    VkDescriptorPoolCreateInfo dpci{};
    dpci.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    dpci.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
    dpci.maxSets = 1;
    dpci.poolSizeCount = 1;
    dpci.pPoolSizes = &pool_size;
    VkDescriptorPool descriptor_pool = VK_NULL_HANDLE;
    CHECK(vkCreateDescriptorPool(device, &dpci, nullptr, &descriptor_pool));
    VkDescriptorSetAllocateInfo dsai{};
    dsai.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    dsai.descriptorPool = descriptor_pool;
    dsai.descriptorSetCount = 1;
    dsai.pSetLayouts = &set_layout;
    VkDescriptorSet set = VK_NULL_HANDLE;
    CHECK(vkAllocateDescriptorSets(device, &dsai, &set));
    CHECK(vkFreeDescriptorSets(device, descriptor_pool, 1, &set));
    CHECK(vkAllocateDescriptorSets(device, &dsai, &set));
    CHECK(vkResetDescriptorPool(device, descriptor_pool, 0));
    vkDestroyDescriptorPool(device, descriptor_pool, nullptr);
    vkDestroyDescriptorSetLayout(device, set_layout, nullptr);

    vkDestroyFence(device, fence, nullptr);
    vkFreeCommandBuffers(device, pool, 1, &cmd);
    vkDestroyCommandPool(device, pool, nullptr);
    vkDestroyBuffer(device, buffer, nullptr);
    vkFreeMemory(device, memory, nullptr);
    vkDestroyDevice(device, nullptr);
    vkDestroyInstance(instance, nullptr);
    std::printf("probe ok\n");
    return 0;
}

} // namespace

int main(int argc, char **argv) {
    Options options;
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "--app-name") == 0 && i + 1 < argc) {
            options.app_name = argv[++i];
        } else if (std::strcmp(argv[i], "--sync-hazard") == 0) {
            options.sync_hazard = true;
        } else if (std::strcmp(argv[i], "--device-extension") == 0 && i + 1 < argc) {
            options.device_extensions.push_back(argv[++i]);
        } else if (std::strcmp(argv[i], "--list-device-extensions") == 0) {
            options.list_device_extensions = true;
        } else if (std::strcmp(argv[i], "--concurrent-queues") == 0 && i + 1 < argc) {
            options.concurrent_queue_rounds = std::atoi(argv[++i]);
        } else {
            std::fprintf(stderr, "usage: splitvk-e2e-probe [--app-name NAME] [--sync-hazard] "
                                 "[--device-extension NAME]... [--list-device-extensions] "
                                 "[--concurrent-queues ROUNDS]\n");
            return 2;
        }
    }
    return run(options);
}
