"""Instance and device dispatch tables: one function pointer per forwarded command.

The instance table holds instance- and physical-device-level commands, filled from the next
layer's vkGetInstanceProcAddr; the device table holds device-level commands, filled from the
next vkGetDeviceProcAddr so calls skip the loader's trampolines.
"""
from cpp import HEADER, guarded
from layer_overrides import LOADER_ANSWERED


def _members(commands):
    lines = []
    for c in commands:
        lines += guarded(c.protect, [f"    PFN_{c.name} {c.short_name} = nullptr;"])
    return lines


def _loads(commands, getter, handle):
    lines = []
    for c in commands:
        lines += guarded(c.protect, [
            f"    table.{c.short_name} = reinterpret_cast<PFN_{c.name}>({getter}({handle}, \"{c.name}\"));"])
    return lines


def emit(model):
    instance_cmds = [c for c in model.by_level("instance", "physical_device")]
    device_cmds = model.by_level("device")
    global_cmds = [c for c in model.by_level("global") if c.name not in LOADER_ANSWERED]

    header = [HEADER.format(script="emit_dispatch.py"), "#pragma once", "",
              "#include <vulkan/vulkan.h>", "", "namespace splitvk {", "",
              "struct InstanceDispatchTable {"]
    header += _members(global_cmds + instance_cmds)
    header += ["};", "", "struct DeviceDispatchTable {"]
    header += _members(device_cmds)
    header += ["};", "",
               "void load_instance_dispatch_table(InstanceDispatchTable &table, VkInstance instance,",
               "                                  PFN_vkGetInstanceProcAddr get_instance_proc_addr);",
               "void load_device_dispatch_table(DeviceDispatchTable &table, VkDevice device,",
               "                                PFN_vkGetDeviceProcAddr get_device_proc_addr);",
               "", "} // namespace splitvk", ""]

    source = [HEADER.format(script="emit_dispatch.py"), '#include "vk_dispatch_table.h"', "",
              "namespace splitvk {", "",
              "void load_instance_dispatch_table(InstanceDispatchTable &table, VkInstance instance,",
              "                                  PFN_vkGetInstanceProcAddr get_instance_proc_addr) {"]
    source += _loads(global_cmds + instance_cmds, "get_instance_proc_addr", "instance")
    source += ["}", "",
               "void load_device_dispatch_table(DeviceDispatchTable &table, VkDevice device,",
               "                                PFN_vkGetDeviceProcAddr get_device_proc_addr) {"]
    source += _loads(device_cmds, "get_device_proc_addr", "device")
    source += ["}", "", "} // namespace splitvk", ""]
    return {"vk_dispatch_table.h": "\n".join(header), "vk_dispatch_table.cpp": "\n".join(source)}
