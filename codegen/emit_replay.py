"""The agent's default replay (docs/architecture.md §3): for every FORWARD command of the wire codec, a
CommandVisitor method that calls the agent device's function with the decoded arguments and then
apply_handle_changes(). Hand-written semantics (memory, submit, swapchain, frame marks) live in
server-agent/ and override these methods.

  vk_replay.h    ReplayDispatch (device-level function pointers of the codec's commands) and
                 ReplayVisitorBase (one override per forwarded command)
  vk_replay.cpp  their bodies
"""
from __future__ import annotations

import codec_policy
import emit_codec
from cpp import HEADER, guarded


def _call_args(c) -> str:
    return ", ".join(f"c.{p.name}" for p in c.params)


def _body(c) -> list[str]:
    lines = [f"if (!vk.{c.short_name}) return missing(\"{c.name}\");"]
    call = f"vk.{c.short_name}({_call_args(c)})"
    if c.return_type == "VkResult":
        lines += [f"const VkResult result = {call};",
                  f"if (result < 0) return failed(\"{c.name}\", result);"]
    else:
        lines += [f"{call};"]
    return lines


def emit(model) -> dict[str, str]:
    codec = emit_codec.Codec(model)
    forwarded = [c for c in codec.commands if codec.policy[c.name] == codec_policy.FORWARD]
    changes = {c.name for c in codec.commands if emit_codec._handle_changes(codec, c)}

    h = [HEADER.format(script="emit_replay.py"), "#pragma once", "",
         "// The agent's generated default replay: each forwarded command calls the agent device's",
         "// function with the decoded arguments, then registers created and forgets destroyed handles.",
         "// server-agent/replayer.cpp overrides what needs real semantics.", "",
         '#include "vk_codec.h"', "", "#include <vulkan/vulkan.h>", "", "#include <string>", "",
         "namespace splitvk::agent {", "",
         "// Device-level entry points of every command the codec carries (null when the device lacks it).",
         "struct ReplayDispatch {"]
    for c in codec.commands:
        if c.level == "device":
            h += guarded(c.protect, [f"    PFN_{c.name} {c.short_name} = nullptr;"])
    h += ["", "    void load(PFN_vkGetDeviceProcAddr get_device_proc_addr, VkDevice device);", "};", "",
          "class ReplayVisitorBase : public codec::CommandVisitor {", "public:",
          "    ReplayDispatch vk{};", "    codec::HandleTable *table = nullptr;", "",
          "    // The driver returned `result` (< 0) for `command`, or `detail` says what else failed.",
          "    // Returns false (the session ends).",
          "    virtual bool failed(const char *command, VkResult result, const std::string &detail = {}) = 0;",
          "    // The device has no entry point for `command` (an extension it did not enable).",
          "    bool missing(const char *command) { return failed(command, VK_SUCCESS, \"not available on this device\"); }",
          ""]
    for c in forwarded:
        h += guarded(c.protect, [f"    bool {c.name}(const codec::Decoded_{c.name} &c) override;"])
    h += ["};", "", "} // namespace splitvk::agent", ""]

    src = [HEADER.format(script="emit_replay.py"), '#include "vk_replay.h"', "", "namespace splitvk::agent {", "",
           "void ReplayDispatch::load(PFN_vkGetDeviceProcAddr get_device_proc_addr, VkDevice device) {"]
    for c in codec.commands:
        if c.level == "device":
            src += guarded(c.protect, [
                f"    {c.short_name} = reinterpret_cast<PFN_{c.name}>(get_device_proc_addr(device, \"{c.name}\"));"])
    src += ["}", ""]
    for c in forwarded:
        body = _body(c)
        if c.name in changes:
            body += ["std::string error;",
                     "if (!codec::apply_handle_changes(*table, c, &error))",
                     f"    return failed(\"{c.name}\", VK_SUCCESS, error);"]
        body += ["return true;"]
        src += guarded(c.protect, [f"bool ReplayVisitorBase::{c.name}(const codec::Decoded_{c.name} &c) {{"] +
                       ["    " + line for line in body] + ["}", ""])
    src += ["} // namespace splitvk::agent", ""]
    return {"vk_replay.h": "\n".join(h), "vk_replay.cpp": "\n".join(src)}
