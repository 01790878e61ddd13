// VkDescriptorUpdateTemplate: the layout pData is encoded with (docs/architecture.md §8, GFXReconstruct:
// update templates need the template's entries to encode pData). Kept only while a session exists.

#include "descriptor_template.h"

#include "capture.h"
#include "descriptor_set.h"
#include "layer_entry_points.h"
#include "object_map.h"

namespace splitvk {

struct DescriptorTemplateTable {
    ObjectMap<VkDescriptorUpdateTemplate, codec::DescriptorTemplateLayout> templates;
};

std::shared_ptr<DescriptorTemplateTable> make_descriptor_template_table() {
    return std::make_shared<DescriptorTemplateTable>();
}

namespace {

VkResult create_template(PFN_vkCreateDescriptorUpdateTemplate next, VkDevice device,
                         const VkDescriptorUpdateTemplateCreateInfo *pCreateInfo,
                         const VkAllocationCallbacks *pAllocator, VkDescriptorUpdateTemplate *pTemplate) {
    DeviceState &dev = device_state(device);
    const VkResult result = next(device, pCreateInfo, pAllocator, pTemplate);
    if (result != VK_SUCCESS || !capturing(dev)) return result;
    dev.descriptor_templates->templates.insert(*pTemplate,
                                               std::make_unique<codec::DescriptorTemplateLayout>(
                                                   codec::DescriptorTemplateLayout::from(*pCreateInfo)));
    record_global(dev, LiveChange::Created, codec::handle_value(*pTemplate), [&](codec::Encoder &e) {
        encode_vkCreateDescriptorUpdateTemplate(e, device, pCreateInfo, pAllocator, pTemplate);
    });
    return result;
}

void destroy_template(PFN_vkDestroyDescriptorUpdateTemplate next, VkDevice device,
                      VkDescriptorUpdateTemplate descriptorUpdateTemplate,
                      const VkAllocationCallbacks *pAllocator) {
    DeviceState &dev = device_state(device);
    // Forgotten and recorded before the driver may hand the value to a template another thread
    // creates (as every destroy: codegen/emit_layer.py): the new template keeps its layout, and the
    // agent and the live state keep the new template.
    if (dev.session && descriptorUpdateTemplate != VK_NULL_HANDLE) {
        dev.descriptor_templates->templates.remove(descriptorUpdateTemplate);
        if (capturing(dev))
            record_global(dev, LiveChange::Destroyed, codec::handle_value(descriptorUpdateTemplate),
                          [&](codec::Encoder &e) {
                              encode_vkDestroyDescriptorUpdateTemplate(e, device, descriptorUpdateTemplate,
                                                                       pAllocator);
                          });
    }
    next(device, descriptorUpdateTemplate, pAllocator);
}

void update_with_template(PFN_vkUpdateDescriptorSetWithTemplate next, VkDevice device, VkDescriptorSet set,
                          VkDescriptorUpdateTemplate descriptorUpdateTemplate, const void *pData) {
    DeviceState &dev = device_state(device);
    next(device, set, descriptorUpdateTemplate, pData);
    if (!capturing(dev)) return;
    const codec::DescriptorTemplateLayout *layout =
        dev.descriptor_templates->templates.find(descriptorUpdateTemplate);
    if (!layout) return;
    record_global(dev, LiveChange::Unchanged, 0, [&](codec::Encoder &e) {
        encode_vkUpdateDescriptorSetWithTemplate(e, device, set, descriptorUpdateTemplate, pData, *layout);
    });
    note_descriptor_template_update(dev, set, *layout, pData);
}

} // namespace

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL CreateDescriptorUpdateTemplate(
    VkDevice device, const VkDescriptorUpdateTemplateCreateInfo *pCreateInfo,
    const VkAllocationCallbacks *pAllocator, VkDescriptorUpdateTemplate *pDescriptorUpdateTemplate) {
    return create_template(device_dispatch(device).CreateDescriptorUpdateTemplate, device, pCreateInfo,
                           pAllocator, pDescriptorUpdateTemplate);
}

VKAPI_ATTR VkResult VKAPI_CALL CreateDescriptorUpdateTemplateKHR(
    VkDevice device, const VkDescriptorUpdateTemplateCreateInfo *pCreateInfo,
    const VkAllocationCallbacks *pAllocator, VkDescriptorUpdateTemplate *pDescriptorUpdateTemplate) {
    return create_template(device_dispatch(device).CreateDescriptorUpdateTemplateKHR, device, pCreateInfo,
                           pAllocator, pDescriptorUpdateTemplate);
}

VKAPI_ATTR void VKAPI_CALL
DestroyDescriptorUpdateTemplate(VkDevice device, VkDescriptorUpdateTemplate descriptorUpdateTemplate,
                                const VkAllocationCallbacks *pAllocator) {
    destroy_template(device_dispatch(device).DestroyDescriptorUpdateTemplate, device,
                     descriptorUpdateTemplate, pAllocator);
}

VKAPI_ATTR void VKAPI_CALL
DestroyDescriptorUpdateTemplateKHR(VkDevice device, VkDescriptorUpdateTemplate descriptorUpdateTemplate,
                                   const VkAllocationCallbacks *pAllocator) {
    destroy_template(device_dispatch(device).DestroyDescriptorUpdateTemplateKHR, device,
                     descriptorUpdateTemplate, pAllocator);
}

VKAPI_ATTR void VKAPI_CALL
UpdateDescriptorSetWithTemplate(VkDevice device, VkDescriptorSet descriptorSet,
                                VkDescriptorUpdateTemplate descriptorUpdateTemplate, const void *pData) {
    update_with_template(device_dispatch(device).UpdateDescriptorSetWithTemplate, device, descriptorSet,
                         descriptorUpdateTemplate, pData);
}

VKAPI_ATTR void VKAPI_CALL
UpdateDescriptorSetWithTemplateKHR(VkDevice device, VkDescriptorSet descriptorSet,
                                   VkDescriptorUpdateTemplate descriptorUpdateTemplate, const void *pData) {
    update_with_template(device_dispatch(device).UpdateDescriptorSetWithTemplateKHR, device, descriptorSet,
                         descriptorUpdateTemplate, pData);
}

VKAPI_ATTR void VKAPI_CALL CmdPushDescriptorSetWithTemplateKHR(
    VkCommandBuffer commandBuffer, VkDescriptorUpdateTemplate descriptorUpdateTemplate,
    VkPipelineLayout layout, uint32_t set, const void *pData) {
    DeviceState &dev = device_state(commandBuffer);
    dev.dispatch.CmdPushDescriptorSetWithTemplateKHR(commandBuffer, descriptorUpdateTemplate, layout, set,
                                                     pData);
    if (!capturing(dev)) return;
    const codec::DescriptorTemplateLayout *template_layout =
        dev.descriptor_templates->templates.find(descriptorUpdateTemplate);
    codec::Encoder *e = command_buffer_encoder(commandBuffer);
    if (template_layout && e)
        encode_vkCmdPushDescriptorSetWithTemplateKHR(*e, commandBuffer, descriptorUpdateTemplate, layout, set,
                                                     pData, *template_layout);
}

} // namespace entry
} // namespace splitvk
