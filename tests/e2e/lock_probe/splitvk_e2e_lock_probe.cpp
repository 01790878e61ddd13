// splitvk-e2e-lock-probe: how long one thread's memory and pipeline calls take while another
// thread sends mapped memory to the agent through a slow link. Headless.
//
//   splitvk-e2e-lock-probe [--flood-mib N] [--rounds N]
//
// The main thread maps N MiB of host-visible memory once, and each round writes new bytes into all
// of it (not compressible, so each round is N MiB on the wire) and calls vkFlushMappedMemoryRanges
// and an empty vkQueueSubmit. Meanwhile a second thread, over memory and objects of its own,
// repeats vkAllocateMemory and vkFreeMemory, vkMapMemory and vkUnmapMemory of memory it mapped
// before (nothing written: nothing to send), and vkCreateGraphicsPipelines, and times each. It prints
//
//   idle: <call> max <ms> ms
//   flood: round <i> took <ms> ms
//   flooded: <call> max <ms> ms over <n> calls
//
// the first before the flood (the calls' own cost on this machine), the last for the calls the
// second thread made while the main thread was inside a round.
#include "lock_probe_shaders.h"

#include <vulkan/vulkan.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

bool check(VkResult r, const char *call) {
    if (r == VK_SUCCESS) return true;
    std::fprintf(stderr, "splitvk-e2e-lock-probe: %s failed: %d\n", call, int(r));
    return false;
}
#define CHECK(call)                                                                                          \
    do {                                                                                                     \
        if (!check((call), #call)) return 1;                                                                 \
    } while (0)

double ms_since(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

struct Timings {
    std::mutex mutex;
    std::map<std::string, std::pair<double, int>> max_and_count; // call -> (max ms, calls)
    void add(const char *call, double ms) {
        std::lock_guard lock(mutex);
        auto &[max, count] = max_and_count[call];
        max = std::max(max, ms);
        ++count;
    }
    void print(const char *phase) {
        std::lock_guard lock(mutex);
        for (const auto &[call, value] : max_and_count)
            std::printf("%s: %s max %.1f ms over %d calls\n", phase, call.c_str(), value.first, value.second);
        std::fflush(stdout);
    }
};

struct Device {
    VkDevice device = VK_NULL_HANDLE;
    uint32_t memory_type = 0;
    VkRenderPass render_pass = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkShaderModule vertex = VK_NULL_HANDLE;
    VkDeviceMemory own = VK_NULL_HANDLE; // the second thread's
};

// One round of the second thread's calls, each timed into `timings`.
bool unrelated_calls(const Device &d, Timings &timings) {
    VkMemoryAllocateInfo mai{};
    mai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    mai.allocationSize = 64 << 10;
    mai.memoryTypeIndex = d.memory_type;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    auto start = Clock::now();
    if (!check(vkAllocateMemory(d.device, &mai, nullptr, &memory), "vkAllocateMemory")) return false;
    timings.add("vkAllocateMemory", ms_since(start));
    start = Clock::now();
    vkFreeMemory(d.device, memory, nullptr);
    timings.add("vkFreeMemory", ms_since(start));

    // The thread's own memory, mapped and unmapped with nothing written: nothing to send.
    void *data = nullptr;
    start = Clock::now();
    if (!check(vkMapMemory(d.device, d.own, 0, VK_WHOLE_SIZE, 0, &data), "vkMapMemory")) return false;
    timings.add("vkMapMemory", ms_since(start));
    start = Clock::now();
    vkUnmapMemory(d.device, d.own);
    timings.add("vkUnmapMemory", ms_since(start));

    VkPipelineShaderStageCreateInfo stage{};
    stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stage.stage = VK_SHADER_STAGE_VERTEX_BIT;
    stage.module = d.vertex;
    stage.pName = "main";
    VkPipelineVertexInputStateCreateInfo vertex_input{};
    vertex_input.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
    VkPipelineInputAssemblyStateCreateInfo assembly{};
    assembly.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
    assembly.topology = VK_PRIMITIVE_TOPOLOGY_POINT_LIST;
    VkPipelineRasterizationStateCreateInfo raster{};
    raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
    raster.rasterizerDiscardEnable = VK_TRUE; // no viewport, multisample or fragment state needed
    raster.lineWidth = 1.0f;
    VkGraphicsPipelineCreateInfo gpci{};
    gpci.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
    gpci.stageCount = 1;
    gpci.pStages = &stage;
    gpci.pVertexInputState = &vertex_input;
    gpci.pInputAssemblyState = &assembly;
    gpci.pRasterizationState = &raster;
    gpci.layout = d.layout;
    gpci.renderPass = d.render_pass;
    VkPipeline pipeline = VK_NULL_HANDLE;
    start = Clock::now();
    if (!check(vkCreateGraphicsPipelines(d.device, VK_NULL_HANDLE, 1, &gpci, nullptr, &pipeline),
               "vkCreateGraphicsPipelines"))
        return false;
    timings.add("vkCreateGraphicsPipelines", ms_since(start));
    vkDestroyPipeline(d.device, pipeline, nullptr);
    return true;
}

// Bytes zstd cannot shrink, different each round (xorshift64).
void fill_incompressible(uint8_t *bytes, size_t size, uint64_t seed) {
    uint64_t x = seed * 0x9E3779B97F4A7C15ull + 1;
    for (size_t i = 0; i + 8 <= size; i += 8) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        std::memcpy(bytes + i, &x, 8);
    }
}

} // namespace

int main(int argc, char **argv) {
    size_t flood_mib = 64;
    int rounds = 4;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg == "--flood-mib" && i + 1 < argc) {
            flood_mib = std::stoul(argv[++i]);
        } else if (arg == "--rounds" && i + 1 < argc) {
            rounds = std::stoi(argv[++i]);
        } else {
            std::fprintf(stderr, "usage: splitvk-e2e-lock-probe [--flood-mib N] [--rounds N]\n");
            return 2;
        }
    }

    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "splitvk-e2e-lock-probe";
    app.apiVersion = VK_API_VERSION_1_1;
    VkInstanceCreateInfo ici{};
    ici.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    ici.pApplicationInfo = &app;
    VkInstance instance = VK_NULL_HANDLE;
    CHECK(vkCreateInstance(&ici, nullptr, &instance));
    uint32_t count = 1;
    VkPhysicalDevice gpu = VK_NULL_HANDLE;
    const VkResult enumerated = vkEnumeratePhysicalDevices(instance, &count, &gpu);
    if (enumerated != VK_INCOMPLETE) CHECK(enumerated);
    if (count == 0) {
        std::fprintf(stderr, "splitvk-e2e-lock-probe: no Vulkan device\n");
        return 1;
    }

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo qci{};
    qci.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    qci.queueFamilyIndex = 0;
    qci.queueCount = 1;
    qci.pQueuePriorities = &priority;
    VkDeviceCreateInfo dci{};
    dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    dci.queueCreateInfoCount = 1;
    dci.pQueueCreateInfos = &qci;
    Device d;
    CHECK(vkCreateDevice(gpu, &dci, nullptr, &d.device));
    VkQueue queue = VK_NULL_HANDLE;
    vkGetDeviceQueue(d.device, 0, 0, &queue);

    VkPhysicalDeviceMemoryProperties properties{};
    vkGetPhysicalDeviceMemoryProperties(gpu, &properties);
    const VkMemoryPropertyFlags wanted =
        VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    d.memory_type = UINT32_MAX;
    for (uint32_t i = 0; i < properties.memoryTypeCount && d.memory_type == UINT32_MAX; ++i)
        if ((properties.memoryTypes[i].propertyFlags & wanted) == wanted) d.memory_type = i;
    if (d.memory_type == UINT32_MAX) {
        std::fprintf(stderr, "splitvk-e2e-lock-probe: no host-visible coherent memory\n");
        return 1;
    }

    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    VkRenderPassCreateInfo rpci{};
    rpci.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
    rpci.subpassCount = 1;
    rpci.pSubpasses = &subpass;
    CHECK(vkCreateRenderPass(d.device, &rpci, nullptr, &d.render_pass));
    VkPipelineLayoutCreateInfo plci{};
    plci.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    CHECK(vkCreatePipelineLayout(d.device, &plci, nullptr, &d.layout));
    VkShaderModuleCreateInfo smci{};
    smci.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
    smci.codeSize = sizeof(lock_probe::nothing_vert);
    smci.pCode = lock_probe::nothing_vert;
    CHECK(vkCreateShaderModule(d.device, &smci, nullptr, &d.vertex));

    VkMemoryAllocateInfo own_info{};
    own_info.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    own_info.allocationSize = 64 << 10;
    own_info.memoryTypeIndex = d.memory_type;
    CHECK(vkAllocateMemory(d.device, &own_info, nullptr, &d.own));

    Timings idle;
    for (int i = 0; i < 5; ++i)
        if (!unrelated_calls(d, idle)) return 1;
    idle.print("idle");

    VkMemoryAllocateInfo mai{};
    mai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    mai.allocationSize = VkDeviceSize{flood_mib} << 20;
    mai.memoryTypeIndex = d.memory_type;
    VkDeviceMemory flood = VK_NULL_HANDLE;
    CHECK(vkAllocateMemory(d.device, &mai, nullptr, &flood));
    void *mapped = nullptr;
    CHECK(vkMapMemory(d.device, flood, 0, VK_WHOLE_SIZE, 0, &mapped));

    // The second thread counts a call only while the main thread is inside a round.
    std::atomic<bool> in_round{false}, done{false}, failed{false};
    Timings flooded;
    std::thread other([&] {
        while (!done.load()) {
            Timings one;
            const bool during = in_round.load();
            if (!unrelated_calls(d, one)) {
                failed.store(true);
                return;
            }
            if (!during || !in_round.load()) continue;
            for (const auto &[call, value] : one.max_and_count)
                flooded.add(call.c_str(), value.first);
        }
    });

    for (int round = 0; round < rounds; ++round) {
        fill_incompressible(static_cast<uint8_t *>(mapped), size_t{flood_mib} << 20, uint64_t(round) + 1);
        in_round.store(true);
        const auto start = Clock::now();
        VkMappedMemoryRange range{};
        range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
        range.memory = flood;
        range.size = VK_WHOLE_SIZE;
        CHECK(vkFlushMappedMemoryRanges(d.device, 1, &range));
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        CHECK(vkQueueSubmit(queue, 1, &submit, VK_NULL_HANDLE));
        in_round.store(false);
        std::printf("flood: round %d took %.1f ms\n", round, ms_since(start));
        std::fflush(stdout);
    }
    done.store(true);
    other.join();
    if (failed.load()) return 1;
    flooded.print("flooded");

    vkUnmapMemory(d.device, flood);
    vkFreeMemory(d.device, flood, nullptr);
    vkFreeMemory(d.device, d.own, nullptr);
    vkDestroyShaderModule(d.device, d.vertex, nullptr);
    vkDestroyPipelineLayout(d.device, d.layout, nullptr);
    vkDestroyRenderPass(d.device, d.render_pass, nullptr);
    CHECK(vkQueueWaitIdle(queue));
    vkDestroyDevice(d.device, nullptr);
    vkDestroyInstance(instance, nullptr);
    return 0;
}
