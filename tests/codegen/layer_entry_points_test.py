#!/usr/bin/env python3
"""The layer's generated entry points (codegen/emit_layer.py), read from the file the layer is built
from: the rules the hand-written entry points used to follow one by one, and which the generator
now applies to every command of a kind.

Usage: layer_entry_points_test.py GENERATED_DIR (the build tree's generated/)
"""
import os
import re
import sys
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "codegen"))

import layer_overrides  # noqa: E402

GENERATED_DIR = ""

_DEFINITION = re.compile(r"^VKAPI_ATTR (\S+) VKAPI_CALL (\w+)\((.*)\) \{$")


def _functions(text, namespace):
    """The bodies (lists of lines) of the functions defined in `namespace` of the generated source,
    by name, each with the type of its first parameter."""
    start = text.index(f"namespace {namespace} {{\n")
    end = text.index(f"}} // namespace {namespace}", start)
    functions = {}
    name = None
    for line in text[start:end].splitlines():
        m = _DEFINITION.match(line)
        if m:
            name = m.group(2)
            first = m.group(3).split(",")[0].split()[-2] if m.group(3) != "void" else ""
            functions[name] = (first, [])
        elif line == "}":
            name = None
        elif name:
            functions[name][1].append(line.strip())
    return functions


def _index(body, needle):
    """The index of the first line of `body` containing `needle`; fails the test when none does."""
    for i, line in enumerate(body):
        if needle in line:
            return i
    raise AssertionError(f"no line with {needle!r} in:\n" + "\n".join(body))


class LayerEntryPoints(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        with open(os.path.join(GENERATED_DIR, "layer_entry_points.cpp"), encoding="utf-8") as f:
            text = f.read()
        cls.entry = _functions(text, "entry")
        cls.boundary = _functions(text, "boundary")
        cls.table = re.findall(r'\{"(vk\w+)", reinterpret_cast<PFN_vkVoidFunction>\((\w+)::(\w+)\)', text)

    def test_every_queue_entry_point_holds_the_queue_lock_around_its_call_down(self):
        queue_functions = {n: body for n, (first, body) in self.entry.items() if first == "VkQueue"}
        for name in ("QueueBeginDebugUtilsLabelEXT", "QueueEndDebugUtilsLabelEXT",
                     "QueueInsertDebugUtilsLabelEXT"):
            self.assertIn(name, queue_functions)
        for name, body in queue_functions.items():
            with self.subTest(name):
                lock = _index(body, "const auto lock = lock_queue(queue);")
                self.assertLess(lock, _index(body, f".{name}(queue"))

    def test_manual_commands_only_are_left_to_layer_sources(self):
        generated = {"vk" + n for n in self.entry}
        self.assertFalse(generated & layer_overrides.MANUAL_COMMANDS)
        self.assertLessEqual(len(layer_overrides.MANUAL_COMMANDS), 40)
        for name in ("vkGetBufferDeviceAddress", "vkUpdateDescriptorSetWithTemplateKHR",
                     "vkGetPhysicalDeviceFeatures2KHR", "vkAllocateDescriptorSets", "vkCreateBuffer"):
            self.assertIn(name, generated)

    def test_the_loader_gets_every_entry_point_inside_its_exception_boundary(self):
        self.assertTrue(self.table)
        for api_name, namespace, function in self.table:
            with self.subTest(api_name):
                self.assertEqual(namespace, "boundary")
                self.assertEqual("vk" + function, api_name)
                body = self.boundary[function][1]
                self.assertLess(_index(body, "try {"), _index(body, f"entry::{function}("))
                self.assertIn("} catch (...) {", body)

    def test_an_edited_query_and_its_aliases_edit_after_their_own_call_down(self):
        for name, canonical in (("GetPhysicalDeviceFeatures2", "GetPhysicalDeviceFeatures2"),
                                ("GetPhysicalDeviceFeatures2KHR", "GetPhysicalDeviceFeatures2"),
                                ("GetPhysicalDeviceFormatProperties2KHR", "GetPhysicalDeviceFormatProperties2"),
                                ("GetPhysicalDeviceProperties", "GetPhysicalDeviceProperties")):
            with self.subTest(name):
                body = self.entry[name][1]
                self.assertLess(_index(body, f"instance_dispatch(physicalDevice).{name}("),
                                _index(body, f"edit::{canonical}(physicalDevice"))

    def test_an_observer_of_a_returned_value_gets_what_the_driver_returned(self):
        body = self.entry["GetBufferDeviceAddressKHR"][1]
        self.assertLess(_index(body, "const VkDeviceAddress result = dev.dispatch.GetBufferDeviceAddressKHR("),
                        _index(body, "observe::GetBufferDeviceAddressKHR(dev, result, device, pInfo)"))
        self.assertIn("return result;", body)

    def test_a_template_update_is_captured_with_its_templates_layout_after_the_call(self):
        body = self.entry["UpdateDescriptorSetWithTemplateKHR"][1]
        call = _index(body, "dev.dispatch.UpdateDescriptorSetWithTemplateKHR(")
        layout = _index(body, "descriptor_template_layout(dev, descriptorUpdateTemplate)")
        record = _index(body, "encode_vkUpdateDescriptorSetWithTemplate(e, device, descriptorSet, "
                              "descriptorUpdateTemplate, pData, *template_layout)")
        note = _index(body, "note_descriptor_template_update(dev, descriptorSet, *template_layout, pData)")
        self.assertLess(call, layout)
        self.assertLess(layout, record)
        self.assertLess(record, note)
        push = self.entry["CmdPushDescriptorSetWithTemplateKHR"][1]
        self.assertLess(_index(push, "dev.dispatch.CmdPushDescriptorSetWithTemplateKHR("),
                        _index(push, "pData, *template_layout)"))

    def test_destroys_and_frees_are_observed_and_captured_before_the_call_creates_after_success(self):
        for name, live in (("DestroyDescriptorUpdateTemplateKHR", "LiveChange::Destroyed"),
                           ("DestroyDescriptorSetLayout", "LiveChange::Retired"),
                           ("DestroyDescriptorPool", "LiveChange::Destroyed"),
                           ("FreeDescriptorSets", "LiveChange::Unchanged"),
                           ("ResetDescriptorPool", "LiveChange::Unchanged")):
            with self.subTest(name):
                body = self.entry[name][1]
                observe = _index(body, f"observe::{name}(dev,")
                record = _index(body, f"record_global(dev, {live}")
                self.assertLess(observe, record)
                self.assertLess(record, _index(body, f"dev.dispatch.{name}("))
        for name in ("CreateDescriptorUpdateTemplateKHR", "CreateDescriptorSetLayout", "AllocateDescriptorSets"):
            with self.subTest(name):
                body = self.entry[name][1]
                call = _index(body, f"const VkResult result = dev.dispatch.{name}(")
                observe = _index(body, f"if (dev.session && result >= 0) [[unlikely]] observe::{name}(")
                record = _index(body, "if (capturing(dev) && result >= 0)")
                self.assertLess(call, observe)
                self.assertLess(observe, record)
        self.assertTrue(any("handle_ids(pDescriptorSets, pAllocateInfo->descriptorSetCount)" in line
                            for line in self.entry["AllocateDescriptorSets"][1]))

    def test_a_destroy_of_the_null_handle_is_not_captured(self):
        for name, handle in (("DestroyDescriptorPool", "descriptorPool"), ("DestroySampler", "sampler")):
            with self.subTest(name):
                _index(self.entry[name][1], f"if (capturing(dev) && {handle} != VK_NULL_HANDLE)")


if __name__ == "__main__":
    GENERATED_DIR = sys.argv.pop(1)
    unittest.main()
