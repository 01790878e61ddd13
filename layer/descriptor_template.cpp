// VkDescriptorUpdateTemplate: the layout pData is encoded with (docs/architecture.md §8, GFXReconstruct:
// update templates need the template's entries to encode pData). Kept only while a session exists,
// by the observers of the generated create and destroy; the generated updates' captures look it up.

#include "descriptor_template.h"

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

const codec::DescriptorTemplateLayout *
descriptor_template_layout(const DeviceState &dev, VkDescriptorUpdateTemplate update_template) {
    return dev.descriptor_templates->templates.find(update_template);
}

namespace observe {

void CreateDescriptorUpdateTemplate(DeviceState &dev, VkDevice,
                                    const VkDescriptorUpdateTemplateCreateInfo *pCreateInfo,
                                    const VkAllocationCallbacks *, VkDescriptorUpdateTemplate *pTemplate) {
    dev.descriptor_templates->templates.insert(*pTemplate,
                                               std::make_unique<codec::DescriptorTemplateLayout>(
                                                   codec::DescriptorTemplateLayout::from(*pCreateInfo)));
}

void CreateDescriptorUpdateTemplateKHR(DeviceState &dev, VkDevice device,
                                       const VkDescriptorUpdateTemplateCreateInfo *pCreateInfo,
                                       const VkAllocationCallbacks *pAllocator,
                                       VkDescriptorUpdateTemplate *pTemplate) {
    CreateDescriptorUpdateTemplate(dev, device, pCreateInfo, pAllocator, pTemplate);
}

// Before the driver may hand the value to a template another thread creates (as every destroy's
// observer): the new template keeps its layout.
void DestroyDescriptorUpdateTemplate(DeviceState &dev, VkDevice,
                                     VkDescriptorUpdateTemplate descriptorUpdateTemplate,
                                     const VkAllocationCallbacks *) {
    if (descriptorUpdateTemplate != VK_NULL_HANDLE)
        dev.descriptor_templates->templates.remove(descriptorUpdateTemplate);
}

void DestroyDescriptorUpdateTemplateKHR(DeviceState &dev, VkDevice device,
                                        VkDescriptorUpdateTemplate descriptorUpdateTemplate,
                                        const VkAllocationCallbacks *pAllocator) {
    DestroyDescriptorUpdateTemplate(dev, device, descriptorUpdateTemplate, pAllocator);
}

} // namespace observe
} // namespace splitvk
