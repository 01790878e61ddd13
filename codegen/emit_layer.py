"""The layer's entry points and the name lookup behind its vkGet*ProcAddr.

Every forwarded command gets an entry point in namespace splitvk::entry. Those listed in
layer_overrides.MANUAL_COMMANDS are declared here and defined by hand in layer/; the rest are
generated as calls through the dispatch table of the object they are called on.
"""
from cpp import HEADER, guarded
from layer_overrides import LOADER_ANSWERED, MANUAL_COMMANDS

_LEVEL_ENUM = {
    "global": "EntryLevel::Global",
    "instance": "EntryLevel::Instance",
    "physical_device": "EntryLevel::PhysicalDevice",
    "device": "EntryLevel::Device",
}


def _dispatch_expr(c):
    handle = c.params[0].name
    if c.level == "device":
        return f"device_dispatch({handle})"
    return f"instance_dispatch({handle})"


def emit(model):
    commands = [c for c in model.commands if c.name not in LOADER_ANSWERED]
    missing = MANUAL_COMMANDS - {c.name for c in commands}
    if missing:
        raise SystemExit(f"manual commands not in the forwarded set: {', '.join(sorted(missing))}")

    header = [HEADER.format(script="emit_layer.py"), "#pragma once", "",
              "#include <vulkan/vulkan.h>", "", "namespace splitvk {", "",
              "enum class EntryLevel { Global, Instance, PhysicalDevice, Device };", "",
              "struct EntryPoint {",
              "    const char *name;",
              "    PFN_vkVoidFunction function;",
              "    EntryLevel level;",
              "};", "",
              "// The layer's entry point for `name`, or nullptr when splitvk does not forward it.",
              "const EntryPoint *find_entry_point(const char *name);", "",
              "namespace entry {", ""]
    for c in commands:
        header += guarded(c.protect, [
            f"VKAPI_ATTR {c.return_type} VKAPI_CALL {c.short_name}({c.signature});"])
    header += ["", "} // namespace entry", "} // namespace splitvk", ""]

    source = [HEADER.format(script="emit_layer.py"), '#include "layer_entry_points.h"', "",
              '#include "dispatch.h"', "", "#include <algorithm>", "#include <cstring>", "#include <iterator>", "",
              "namespace splitvk {", "namespace entry {", ""]
    for c in commands:
        if c.name in MANUAL_COMMANDS:
            continue
        source += guarded(c.protect, [
            f"VKAPI_ATTR {c.return_type} VKAPI_CALL {c.short_name}({c.signature}) {{",
            f"    return {_dispatch_expr(c)}.{c.short_name}({c.arguments});",
            "}", ""])
    source += ["} // namespace entry", "",
               "namespace {", "",
               "// Sorted by name (strcmp order) for binary search.",
               "const EntryPoint kEntryPoints[] = {"]
    for c in sorted(commands, key=lambda c: c.name.encode()):
        source += guarded(c.protect, [
            f"    {{\"{c.name}\", reinterpret_cast<PFN_vkVoidFunction>(entry::{c.short_name}), "
            f"{_LEVEL_ENUM[c.level]}}},"])
    source += ["};", "", "} // namespace", "",
               "const EntryPoint *find_entry_point(const char *name) {",
               "    const auto *end = std::end(kEntryPoints);",
               "    const auto *it = std::lower_bound(std::begin(kEntryPoints), end, name,",
               "                                      [](const EntryPoint &e, const char *n) {",
               "                                          return std::strcmp(e.name, n) < 0;",
               "                                      });",
               "    return it != end && std::strcmp(it->name, name) == 0 ? it : nullptr;",
               "}", "", "} // namespace splitvk", ""]
    return {"layer_entry_points.h": "\n".join(header), "layer_entry_points.cpp": "\n".join(source)}
