// VkDescriptorSetLayout / VkDescriptorSet: which bindings of a set have immutable samplers. For
// those, VkDescriptorImageInfo::sampler is ignored by the specification and may hold anything, so
// the encoder must not send it (EncodeHooks::has_immutable_samplers). Kept only while a session
// exists: layouts by handle, sets by handle with their layout (shared, since a layout may be
// destroyed while sets allocated from it live on) and their pool.

#include "capture.h"
#include "layer_entry_points.h"

#include <memory>
#include <mutex>
#include <shared_mutex>
#include <unordered_map>
#include <unordered_set>

namespace splitvk {
namespace {

struct LayoutInfo {
    std::unordered_set<uint32_t> immutable_sampler_bindings;
};

struct SetInfo {
    std::shared_ptr<const LayoutInfo> layout;
    VkDescriptorPool pool = VK_NULL_HANDLE;
};

std::shared_mutex g_mutex;
std::unordered_map<VkDescriptorSetLayout, std::shared_ptr<const LayoutInfo>> g_layouts;
std::unordered_map<VkDescriptorSet, SetInfo> g_sets;
std::unordered_map<VkDescriptorPool, std::unordered_set<VkDescriptorSet>> g_pool_sets;

void forget_pool_sets_locked(VkDescriptorPool pool) {
    const auto it = g_pool_sets.find(pool);
    if (it == g_pool_sets.end()) return;
    for (VkDescriptorSet set : it->second)
        g_sets.erase(set);
    g_pool_sets.erase(it);
}

} // namespace

bool set_binding_has_immutable_samplers(VkDescriptorSet set, uint32_t binding) {
    std::shared_lock lock(g_mutex);
    const auto it = g_sets.find(set);
    return it != g_sets.end() && it->second.layout &&
           it->second.layout->immutable_sampler_bindings.count(binding);
}

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL CreateDescriptorSetLayout(VkDevice device,
                                                         const VkDescriptorSetLayoutCreateInfo *pCreateInfo,
                                                         const VkAllocationCallbacks *pAllocator,
                                                         VkDescriptorSetLayout *pSetLayout) {
    DeviceState &dev = device_state(device);
    const VkResult result =
        dev.dispatch.CreateDescriptorSetLayout(device, pCreateInfo, pAllocator, pSetLayout);
    if (result != VK_SUCCESS || !capturing(dev)) return result;
    auto info = std::make_shared<LayoutInfo>();
    for (uint32_t i = 0; i < pCreateInfo->bindingCount; ++i) {
        const VkDescriptorSetLayoutBinding &b = pCreateInfo->pBindings[i];
        if ((b.descriptorType == VK_DESCRIPTOR_TYPE_SAMPLER ||
             b.descriptorType == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER) &&
            b.pImmutableSamplers && b.descriptorCount > 0)
            info->immutable_sampler_bindings.insert(b.binding);
    }
    {
        std::unique_lock lock(g_mutex);
        g_layouts[*pSetLayout] = std::move(info);
    }
    record_global(dev, LiveChange::Created, codec::handle_value(*pSetLayout), [&](codec::Encoder &e) {
        encode_vkCreateDescriptorSetLayout(e, device, pCreateInfo, pAllocator, pSetLayout);
    });
    return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyDescriptorSetLayout(VkDevice device,
                                                      VkDescriptorSetLayout descriptorSetLayout,
                                                      const VkAllocationCallbacks *pAllocator) {
    DeviceState &dev = device_state(device);
    dev.dispatch.DestroyDescriptorSetLayout(device, descriptorSetLayout, pAllocator);
    if (!dev.session || descriptorSetLayout == VK_NULL_HANDLE) return;
    {
        std::unique_lock lock(g_mutex);
        g_layouts.erase(descriptorSetLayout);
    }
    if (capturing(dev))
        record_global(dev, LiveChange::Destroyed, codec::handle_value(descriptorSetLayout),
                      [&](codec::Encoder &e) {
                          encode_vkDestroyDescriptorSetLayout(e, device, descriptorSetLayout, pAllocator);
                      });
}

VKAPI_ATTR VkResult VKAPI_CALL AllocateDescriptorSets(VkDevice device,
                                                      const VkDescriptorSetAllocateInfo *pAllocateInfo,
                                                      VkDescriptorSet *pDescriptorSets) {
    DeviceState &dev = device_state(device);
    const VkResult result = dev.dispatch.AllocateDescriptorSets(device, pAllocateInfo, pDescriptorSets);
    if (result != VK_SUCCESS || !capturing(dev)) return result;
    {
        std::unique_lock lock(g_mutex);
        for (uint32_t i = 0; i < pAllocateInfo->descriptorSetCount; ++i) {
            const auto layout = g_layouts.find(pAllocateInfo->pSetLayouts[i]);
            g_sets[pDescriptorSets[i]] = {layout == g_layouts.end() ? nullptr : layout->second,
                                          pAllocateInfo->descriptorPool};
            g_pool_sets[pAllocateInfo->descriptorPool].insert(pDescriptorSets[i]);
        }
    }
    record_global(dev, LiveChange::Unchanged, 0, [&](codec::Encoder &e) {
        encode_vkAllocateDescriptorSets(e, device, pAllocateInfo, pDescriptorSets);
    });
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL FreeDescriptorSets(VkDevice device, VkDescriptorPool descriptorPool,
                                                  uint32_t descriptorSetCount,
                                                  const VkDescriptorSet *pDescriptorSets) {
    DeviceState &dev = device_state(device);
    const VkResult result =
        dev.dispatch.FreeDescriptorSets(device, descriptorPool, descriptorSetCount, pDescriptorSets);
    if (!dev.session) return result;
    {
        std::unique_lock lock(g_mutex);
        const auto pool = g_pool_sets.find(descriptorPool);
        for (uint32_t i = 0; i < descriptorSetCount; ++i) {
            g_sets.erase(pDescriptorSets[i]);
            if (pool != g_pool_sets.end()) pool->second.erase(pDescriptorSets[i]);
        }
    }
    if (result == VK_SUCCESS && capturing(dev))
        record_global(dev, LiveChange::Unchanged, 0, [&](codec::Encoder &e) {
            encode_vkFreeDescriptorSets(e, device, descriptorPool, descriptorSetCount, pDescriptorSets);
        });
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL ResetDescriptorPool(VkDevice device, VkDescriptorPool descriptorPool,
                                                   VkDescriptorPoolResetFlags flags) {
    DeviceState &dev = device_state(device);
    const VkResult result = dev.dispatch.ResetDescriptorPool(device, descriptorPool, flags);
    if (!dev.session) return result;
    {
        std::unique_lock lock(g_mutex);
        forget_pool_sets_locked(descriptorPool);
    }
    if (result == VK_SUCCESS && capturing(dev))
        record_global(dev, LiveChange::Unchanged, 0, [&](codec::Encoder &e) {
            encode_vkResetDescriptorPool(e, device, descriptorPool, flags);
        });
    return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyDescriptorPool(VkDevice device, VkDescriptorPool descriptorPool,
                                                 const VkAllocationCallbacks *pAllocator) {
    DeviceState &dev = device_state(device);
    dev.dispatch.DestroyDescriptorPool(device, descriptorPool, pAllocator);
    if (!dev.session || descriptorPool == VK_NULL_HANDLE) return;
    {
        std::unique_lock lock(g_mutex);
        forget_pool_sets_locked(descriptorPool);
    }
    if (capturing(dev))
        record_global(dev, LiveChange::Destroyed, codec::handle_value(descriptorPool),
                      [&](codec::Encoder &e) {
                          encode_vkDestroyDescriptorPool(e, device, descriptorPool, pAllocator);
                      });
}

} // namespace entry
} // namespace splitvk
