// VK_LAYER_SPLITVK_test_reuse: a test-only layer that stages a handle-reuse race. Once the driver
// has destroyed an object it may hand the same handle value to an object that another thread
// creates, before the destroying call has returned through the layers above. The tests put this
// layer BELOW splitvk, next to the driver: right after the driver destroyed a command pool, a
// descriptor pool or a descriptor set layout, or freed descriptor sets (vkFreeDescriptorSets,
// vkResetDescriptorPool), it creates one of the same kind through the top of the chain (the
// loader's entry point, so splitvk sees and captures the create, as it would another thread's),
// then destroys that one again the same way. The create runs on the destroying thread,
// with nothing allocated in between, so the driver's allocator (lavapipe: malloc, whose per-thread
// cache hands back the chunk just freed) gives it the destroyed object's value. It prints, on
// stderr, "reuse: <destroy>: the next <create> got the same handle value" (or "another handle
// value", which leaves the test without its race).
//
// A splitvk that records (or forgets its state of) a destroy after the driver call records it after
// the new object's create: the agent then holds two objects under one id, and ends the session.
// Built into the build tree only and never installed.
#include "../test_layer/test_layer.h"

#include <cstdio>
#include <cstring>
#include <mutex>
#include <unordered_map>

#include <dlfcn.h>

namespace splitvk::reuse_layer {
namespace {

using test_layer::key;

// The next layer's commands this layer calls.
struct Device {
    PFN_vkDestroyCommandPool destroy_command_pool = nullptr;
    PFN_vkDestroyDescriptorPool destroy_descriptor_pool = nullptr;
    PFN_vkDestroyDescriptorSetLayout destroy_set_layout = nullptr;
    PFN_vkAllocateDescriptorSets allocate_sets = nullptr;
    PFN_vkFreeDescriptorSets free_sets = nullptr;
    PFN_vkResetDescriptorPool reset_pool = nullptr;
};

// The last set allocated from a pool, and its layout: what a staged allocation after a free or a
// reset allocates again (the same layout, so the driver allocates the same size).
struct PoolSet {
    VkDescriptorSet set = VK_NULL_HANDLE;
    VkDescriptorSetLayout layout = VK_NULL_HANDLE;
};

std::mutex g_mutex;
std::unordered_map<test_layer::DispatchKey, Device> g_devices;
std::unordered_map<VkDescriptorPool, PoolSet> g_pool_sets;
// The queue family of the device's first queue: what a command pool is created for.
uint32_t g_family = 0;
thread_local bool t_staging = false; // inside a staged create/destroy: not staged again

Device device_of(VkDevice device) {
    std::lock_guard lock(g_mutex);
    return g_devices[key(device)];
}

// The top of the chain: the loader's own entry point, which dispatches to the first layer.
template <class Fn>
Fn top(const char *name) {
    static void *loader = dlopen("libvulkan.so.1", RTLD_NOW | RTLD_NOLOAD);
    return loader ? reinterpret_cast<Fn>(dlsym(loader, name)) : nullptr;
}

template <class Handle>
void report(const char *destroy, const char *create, Handle destroyed, Handle created) {
    std::fprintf(stderr, "reuse: %s: the next %s got %s handle value\n", destroy, create,
                 created == destroyed ? "the same" : "another");
    std::fflush(stderr);
}

// Right after the driver destroyed `destroyed`: one of the same kind created and destroyed again
// through the top of the chain.
template <class Handle, class Info, class Create, class Destroy>
void stage(VkDevice device, Handle destroyed, const Info &info, Create create, Destroy destroy,
           const char *create_name, const char *destroy_name) {
    if (!create || !destroy) {
        std::fprintf(stderr, "reuse: the loader's %s is not found\n", create_name);
        return;
    }
    t_staging = true;
    Handle created = VK_NULL_HANDLE;
    if (create(device, &info, nullptr, &created) == VK_SUCCESS) {
        report(destroy_name, create_name, destroyed, created);
        destroy(device, created, nullptr);
    }
    t_staging = false;
}

VKAPI_ATTR void VKAPI_CALL DestroyCommandPool(VkDevice device, VkCommandPool pool,
                                              const VkAllocationCallbacks *alloc) {
    const auto destroy_next = device_of(device).destroy_command_pool;
    if (t_staging || pool == VK_NULL_HANDLE) return destroy_next(device, pool, alloc);
    VkCommandPoolCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    info.queueFamilyIndex = g_family;
    static const auto create = top<PFN_vkCreateCommandPool>("vkCreateCommandPool");
    static const auto destroy = top<PFN_vkDestroyCommandPool>("vkDestroyCommandPool");
    destroy_next(device, pool, alloc);
    stage(device, pool, info, create, destroy, "vkCreateCommandPool", "vkDestroyCommandPool");
}

// The same create infos as the probe's (tests/e2e/probe), so that the driver allocates the same size.
VKAPI_ATTR void VKAPI_CALL DestroyDescriptorPool(VkDevice device, VkDescriptorPool pool,
                                                 const VkAllocationCallbacks *alloc) {
    const auto destroy_next = device_of(device).destroy_descriptor_pool;
    if (t_staging || pool == VK_NULL_HANDLE) return destroy_next(device, pool, alloc);
    static const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1};
    VkDescriptorPoolCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    info.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
    info.maxSets = 1;
    info.poolSizeCount = 1;
    info.pPoolSizes = &size;
    static const auto create = top<PFN_vkCreateDescriptorPool>("vkCreateDescriptorPool");
    static const auto destroy = top<PFN_vkDestroyDescriptorPool>("vkDestroyDescriptorPool");
    destroy_next(device, pool, alloc);
    stage(device, pool, info, create, destroy, "vkCreateDescriptorPool", "vkDestroyDescriptorPool");
}

VKAPI_ATTR void VKAPI_CALL DestroyDescriptorSetLayout(VkDevice device, VkDescriptorSetLayout layout,
                                                      const VkAllocationCallbacks *alloc) {
    const auto destroy_next = device_of(device).destroy_set_layout;
    if (t_staging || layout == VK_NULL_HANDLE) return destroy_next(device, layout, alloc);
    static const VkDescriptorSetLayoutBinding binding{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1,
                                                      VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
    VkDescriptorSetLayoutCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    info.bindingCount = 1;
    info.pBindings = &binding;
    static const auto create = top<PFN_vkCreateDescriptorSetLayout>("vkCreateDescriptorSetLayout");
    static const auto destroy = top<PFN_vkDestroyDescriptorSetLayout>("vkDestroyDescriptorSetLayout");
    destroy_next(device, layout, alloc);
    stage(device, layout, info, create, destroy, "vkCreateDescriptorSetLayout",
          "vkDestroyDescriptorSetLayout");
}

VKAPI_ATTR VkResult VKAPI_CALL AllocateDescriptorSets(VkDevice device,
                                                      const VkDescriptorSetAllocateInfo *info,
                                                      VkDescriptorSet *sets) {
    const VkResult result = device_of(device).allocate_sets(device, info, sets);
    if (result == VK_SUCCESS && !t_staging && info->descriptorSetCount > 0) {
        std::lock_guard lock(g_mutex);
        g_pool_sets[info->descriptorPool] = {sets[0], info->pSetLayouts[0]};
    }
    return result;
}

// Right after the driver freed `freed` (from `pool`): one set of the same layout allocated from the
// same pool through the top of the chain, then released again with `release` (a free or a reset).
template <class Release>
void stage_set(VkDevice device, VkDescriptorPool pool, VkDescriptorSet freed, Release release,
               const char *destroy_name) {
    PoolSet last;
    {
        std::lock_guard lock(g_mutex);
        last = g_pool_sets[pool];
    }
    static const auto allocate = top<PFN_vkAllocateDescriptorSets>("vkAllocateDescriptorSets");
    if (!allocate) {
        std::fprintf(stderr, "reuse: the loader's vkAllocateDescriptorSets is not found\n");
        return;
    }
    if (last.layout == VK_NULL_HANDLE) return;
    VkDescriptorSetAllocateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    info.descriptorPool = pool;
    info.descriptorSetCount = 1;
    info.pSetLayouts = &last.layout;
    t_staging = true;
    VkDescriptorSet created = VK_NULL_HANDLE;
    if (allocate(device, &info, &created) == VK_SUCCESS) {
        report(destroy_name, "vkAllocateDescriptorSets", freed, created);
        release(created);
    }
    t_staging = false;
}

VKAPI_ATTR VkResult VKAPI_CALL FreeDescriptorSets(VkDevice device, VkDescriptorPool pool, uint32_t count,
                                                  const VkDescriptorSet *sets) {
    const auto free_next = device_of(device).free_sets;
    if (t_staging || count == 0) return free_next(device, pool, count, sets);
    const VkResult result = free_next(device, pool, count, sets);
    static const auto free_top = top<PFN_vkFreeDescriptorSets>("vkFreeDescriptorSets");
    if (!free_top) {
        std::fprintf(stderr, "reuse: the loader's vkFreeDescriptorSets is not found\n");
        return result;
    }
    stage_set(
        device, pool, sets[0], [&](VkDescriptorSet created) { free_top(device, pool, 1, &created); },
        "vkFreeDescriptorSets");
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL ResetDescriptorPool(VkDevice device, VkDescriptorPool pool,
                                                   VkDescriptorPoolResetFlags flags) {
    const auto reset_next = device_of(device).reset_pool;
    if (t_staging) return reset_next(device, pool, flags);
    VkDescriptorSet freed = VK_NULL_HANDLE;
    {
        std::lock_guard lock(g_mutex);
        freed = g_pool_sets[pool].set;
    }
    const VkResult result = reset_next(device, pool, flags);
    static const auto reset_top = top<PFN_vkResetDescriptorPool>("vkResetDescriptorPool");
    if (!reset_top) {
        std::fprintf(stderr, "reuse: the loader's vkResetDescriptorPool is not found\n");
        return result;
    }
    stage_set(
        device, pool, freed, [&](VkDescriptorSet) { reset_top(device, pool, flags); },
        "vkResetDescriptorPool");
    return result;
}

} // namespace
} // namespace splitvk::reuse_layer

namespace splitvk::test_layer {

PFN_vkVoidFunction device_entry_point(const char *name) {
    using namespace reuse_layer;
    if (!std::strcmp(name, "vkDestroyCommandPool"))
        return reinterpret_cast<PFN_vkVoidFunction>(DestroyCommandPool);
    if (!std::strcmp(name, "vkDestroyDescriptorPool"))
        return reinterpret_cast<PFN_vkVoidFunction>(DestroyDescriptorPool);
    if (!std::strcmp(name, "vkDestroyDescriptorSetLayout"))
        return reinterpret_cast<PFN_vkVoidFunction>(DestroyDescriptorSetLayout);
    if (!std::strcmp(name, "vkAllocateDescriptorSets"))
        return reinterpret_cast<PFN_vkVoidFunction>(AllocateDescriptorSets);
    if (!std::strcmp(name, "vkFreeDescriptorSets"))
        return reinterpret_cast<PFN_vkVoidFunction>(FreeDescriptorSets);
    if (!std::strcmp(name, "vkResetDescriptorPool"))
        return reinterpret_cast<PFN_vkVoidFunction>(ResetDescriptorPool);
    return nullptr;
}

void device_created(VkPhysicalDevice, VkDevice device, PFN_vkGetDeviceProcAddr next,
                    const VkDeviceCreateInfo &info) {
    using namespace reuse_layer;
    Device d;
    d.destroy_command_pool = reinterpret_cast<PFN_vkDestroyCommandPool>(next(device, "vkDestroyCommandPool"));
    d.destroy_descriptor_pool =
        reinterpret_cast<PFN_vkDestroyDescriptorPool>(next(device, "vkDestroyDescriptorPool"));
    d.destroy_set_layout =
        reinterpret_cast<PFN_vkDestroyDescriptorSetLayout>(next(device, "vkDestroyDescriptorSetLayout"));
    d.allocate_sets =
        reinterpret_cast<PFN_vkAllocateDescriptorSets>(next(device, "vkAllocateDescriptorSets"));
    d.free_sets = reinterpret_cast<PFN_vkFreeDescriptorSets>(next(device, "vkFreeDescriptorSets"));
    d.reset_pool = reinterpret_cast<PFN_vkResetDescriptorPool>(next(device, "vkResetDescriptorPool"));
    std::lock_guard lock(g_mutex);
    g_devices[key(device)] = d;
    if (info.queueCreateInfoCount > 0) g_family = info.pQueueCreateInfos[0].queueFamilyIndex;
}

void device_destroying(VkDevice device) {
    using namespace reuse_layer;
    std::lock_guard lock(g_mutex);
    g_devices.erase(key(device));
}

} // namespace splitvk::test_layer
