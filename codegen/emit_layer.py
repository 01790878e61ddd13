"""The layer's entry points and the name lookup behind its vkGet*ProcAddr.

Every forwarded command gets an entry point in namespace splitvk::entry, of one of five kinds
(layer/README.md, step 3; the lists are in layer_overrides.py):
- forwarded: the call down through the dispatch table of the object it is called on, then its
  capture (a destroy's before the call);
- observed (OBSERVED_COMMANDS): the same, and a call to the hand-written observe::<Name> (given the
  returned value, for a command that returns one other than VkResult);
- rewritten (REWRITTEN_COMMANDS, canonical names, aliases follow): the capture of the application's
  call, then the hand-written rewrite::<Name>, which makes the driver call with the split's changes;
- edited (EDITED_COMMANDS, canonical names, aliases follow): the call down, then the hand-written
  edit::<Name>, which changes the outputs the application is given;
- manual (MANUAL_COMMANDS): declared here, defined by hand in layer/.
The observe::, rewrite:: and edit:: hooks are declared in the generated header. Every call down on
a handle of LOCKED_HANDLES (queues) holds that handle's lock. The captures of the descriptor update
template commands (codec_policy.TEMPLATE_COMMANDS) encode pData with the template's layout, which
the template's observer keeps.

What the loader is handed is none of those but its exception boundary in namespace splitvk::boundary
(layer/vk/entry_boundary.h), one per command, generated here for the five kinds alike: the entry point
called in a try block, and a catch that turns whatever was thrown into one line and the command's
error result, so that no exception unwinds into the application.
"""
from allowlist import DEVICE_EXTENSIONS
from codec_overrides import RESETS_CHILDREN
from codec_policy import FORWARD, POLICY, TEMPLATE_COMMANDS
from cpp import HEADER, guarded
from layer_overrides import (EDITED_COMMANDS, LOADER_ANSWERED, LOCKED_HANDLES, MANUAL_COMMANDS,
                             OBSERVED_COMMANDS, REWRITTEN_COMMANDS)

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


def _canonical(c, by_name):
    """The command an alias names (KHR names of promoted commands encode under the core name)."""
    while c.alias:
        c = by_name[c.alias]
    return c


def _created_handle(c, handle_types):
    """The single handle a vkCreate* command returns through its last parameter, or None."""
    if not c.name.startswith("vkCreate") or not c.params:
        return None
    last = c.params[-1]
    if last.length or last.is_const or not last.is_pointer or last.type not in handle_types:
        return None
    return last.name


def _destroyed_handle(c):
    if (c.name.startswith("vkDestroy") or c.name == "vkFreeMemory") and len(c.params) >= 2:
        return c.params[1].name
    return None


# Destroyed objects that objects created later may name (layer/capture/session.h: "retired").
_RETIRED = {"vkDestroyShaderModule", "vkDestroyRenderPass", "vkDestroyPipelineLayout",
            "vkDestroyPipelineCache", "vkDestroyDescriptorSetLayout"}


def _releases_first(c, canon):
    """Whether `c` frees objects without destroying the handle it names (vkFree*: the freed ones
    are its array, vkResetDescriptorPool: the pool's children) and cannot fail, so that, as a
    destroy, its observer and capture go in front of the driver call without waiting for a result."""
    releases = c.name.startswith("vkFree") or canon.name in RESETS_CHILDREN
    return releases and (c.return_type == "void" or (c.return_type == "VkResult" and not canon.error_codes))


def _logged_call(c):
    """Live-state log keys of a call that is one entry held by several ids (session.h), as lines
    that define `holders` and `killers`; None for the other calls."""
    if c.name in ("vkCreateGraphicsPipelines", "vkCreateComputePipelines"):
        return ["        const std::vector<uint64_t> holders = handle_ids(pPipelines, createInfoCount);",
                "        const std::span<const uint64_t> killers;"]
    if c.name == "vkAllocateDescriptorSets":
        return ["        const std::vector<uint64_t> holders = handle_ids(pDescriptorSets, pAllocateInfo->descriptorSetCount);",
                "        const std::span<const uint64_t> killers;"]
    if c.name in ("vkBindBufferMemory", "vkBindImageMemory"):
        resource = "buffer" if "Buffer" in c.name else "image"
        return [f"        const uint64_t holders[] = {{codec::handle_value({resource})}};",
                "        const uint64_t killers[] = {codec::handle_value(memory)};"]
    if c.name in ("vkBindBufferMemory2", "vkBindImageMemory2"):
        resource = "buffer" if "Buffer" in c.name else "image"
        return ["        std::vector<uint64_t> holders, killers;",
                "        for (uint32_t i = 0; i < bindInfoCount; ++i) {",
                f"            holders.push_back(codec::handle_value(pBindInfos[i].{resource}));",
                "            killers.push_back(codec::handle_value(pBindInfos[i].memory));",
                "        }"]
    return None


def _template_layout(c):
    """For a command whose pData a descriptor update template lays out (TEMPLATE_COMMANDS): the
    condition that finds the template's layout as `template_layout` (vkCmdPushDescriptorSet*'s
    `layout` is its pipeline layout). Only a template created while the device had a session has
    one (descriptor_template.cpp), and without it pData cannot be encoded, so the call is not
    captured."""
    template = next(p.name for p in c.params if p.type == "VkDescriptorUpdateTemplate")
    return (f"const codec::DescriptorTemplateLayout *template_layout = "
            f"descriptor_template_layout(dev, {template})")


def _capture_block(c, canon, handle_types, ok):
    """The capture of the application's call `c` (encoded under its canonical command `canon`), as
    the lines of one `if (capturing(dev)...)` block.

    Command-buffer commands go into the command buffer's own stream (command_buffer.cpp); other
    device-level commands into the device's global stream (session.cpp), in call order, with their
    effect on the live-state log.
    """
    handle = c.params[0]
    templated = canon.name in TEMPLATE_COMMANDS
    encode = f"encode_{canon.name}(e, {c.arguments}{', *template_layout' if templated else ''});"
    if handle.type == "VkCommandBuffer":
        lines = [f"    if (capturing(dev){ok}) [[unlikely]] {{",
                 f"        if (codec::Encoder *enc = command_buffer_encoder({handle.name})) {{",
                 "            codec::Encoder &e = *enc;"]
        if templated:
            lines += [f"            if ({_template_layout(c)}) {encode}"]
        else:
            lines += [f"            {encode}"]
        return lines + ["        }", "    }"]
    if templated:
        if canon.name != "vkUpdateDescriptorSetWithTemplate":
            raise SystemExit(f"template command {c.name}: no capture rule outside command buffers")
        # The set's descriptor contents in the live-state log, as vkUpdateDescriptorSets' below.
        return [f"    if (capturing(dev){ok}) [[unlikely]] {{",
                f"        if ({_template_layout(c)}) {{",
                f"            record_global(dev, LiveChange::Unchanged, 0, [&](codec::Encoder &e) {{ {encode} }});",
                "            note_descriptor_template_update(dev, descriptorSet, *template_layout, pData);",
                "        }",
                "    }"]
    created = _created_handle(c, handle_types)
    destroyed = _destroyed_handle(c)
    logged = _logged_call(canon)
    # A destroy of VK_NULL_HANDLE does nothing: nothing for the agent to replay.
    if destroyed and not logged:
        ok += f" && {destroyed} != VK_NULL_HANDLE"
    lines = [f"    if (capturing(dev){ok}) [[unlikely]] {{"]
    if logged:
        lines += logged
        lines.append(f"        record_logged(dev, holders, killers, [&](codec::Encoder &e) {{ {encode} }});")
    else:
        if created:
            live = f"LiveChange::Created, codec::handle_value(*{created})"
        elif destroyed:
            kind = "Retired" if canon.name in _RETIRED else "Destroyed"
            live = f"LiveChange::{kind}, codec::handle_value({destroyed})"
        else:
            live = "LiveChange::Unchanged, 0"
        lines.append(f"        record_global(dev, {live}, [&](codec::Encoder &e) {{ {encode} }});")
    if canon.name == "vkUpdateDescriptorSets":
        lines.append("        note_descriptor_updates(dev, descriptorWriteCount, pDescriptorWrites, "
                     "descriptorCopyCount, pDescriptorCopies);")
    lines.append("    }")
    return lines


def _records_first(c, canon):
    """Whether the capture goes in front of the driver call: a destroy's, since once the object is
    gone another thread may create one with the same handle value, and a destroy logged after that
    create would end the new object on the agent and in the live state."""
    if c.params[0].type == "VkCommandBuffer" or _logged_call(canon):
        return False
    return (_destroyed_handle(c) is not None and c.return_type == "void") or _releases_first(c, canon)


def _lock_lines(c):
    """The lock a call down on `c`'s handle holds (LOCKED_HANDLES), held to the end of the entry
    point, as its line; none for the other handles."""
    handle = c.params[0]
    lock = LOCKED_HANDLES.get(handle.type)
    return [f"    const auto lock = {lock}({handle.name});"] if lock else []


def _observer_arguments(c):
    """What observe::<Name> is given after the DeviceState: the returned value of a command that
    returns one other than VkResult (VkResult commands are observed on success only), then the
    command's parameters."""
    if c.return_type in ("void", "VkResult"):
        return c.arguments
    return f"result, {c.arguments}"


def _observer_signature(c):
    if c.return_type in ("void", "VkResult"):
        return f"DeviceState &dev, {c.signature}"
    return f"DeviceState &dev, {c.return_type} result, {c.signature}"


def _forward_body(c, by_name, handle_types, captured=True):
    """Entry point body of a forwarded command: the down-call, then (with a live session) its
    observer and its capture (none when `captured` is false: a command the codec does not encode)."""
    canon = _canonical(c, by_name)
    handle = c.params[0]
    ret = c.return_type
    call = f"dev.dispatch.{c.short_name}({c.arguments})"
    lines = [f"    DeviceState &dev = device_state({handle.name});"]
    observe = f"observe::{c.short_name}(dev, {_observer_arguments(c)});"
    # A destroy's observer runs before the driver call: once the driver has destroyed the object it
    # may hand the handle value to an object another thread creates, whose state the observer would
    # then remove. So does a free's (_releases_first), and neither waits for a result.
    observe_first = c.name in OBSERVED_COMMANDS and (
        (ret == "void" and _destroyed_handle(c) is not None) or _releases_first(c, canon))
    if observe_first:
        lines.append(f"    if (dev.session) [[unlikely]] {observe}")
    ok = " && result >= 0" if ret == "VkResult" and not _releases_first(c, canon) else ""
    capture = _capture_block(c, canon, handle_types, ok) if captured else []
    if captured and _records_first(c, canon):
        lines += capture
        capture = []
    lines += _lock_lines(c)
    if ret == "void":
        lines.append(f"    {call};")
    else:
        lines.append(f"    const {ret} result = {call};")
    if c.name in OBSERVED_COMMANDS and not observe_first:
        lines.append(f"    if (dev.session{ok}) [[unlikely]] {observe}")
    lines += capture
    if ret != "void":
        lines.append("    return result;")
    return lines


def _rewritten_body(c, by_name, handle_types):
    """Entry point body of a rewritten command (REWRITTEN_COMMANDS): with a session, the capture of
    the application's original call, and the hand-written hook that passes the rewritten call down
    through `c`'s own dispatch slot (an alias's hook is its canonical command's)."""
    canon = _canonical(c, by_name)
    handle = c.params[0]
    ret = c.return_type
    hook = f"rewrite::{canon.short_name}(dev, dev.dispatch.{c.short_name}, {c.arguments})"
    # The session is fixed for the device's lifetime (device.h): without one nothing is rewritten or
    # captured, and the hook is not called at all.
    lines = [f"    DeviceState &dev = device_state({handle.name});",
             f"    if (!dev.session) return dev.dispatch.{c.short_name}({c.arguments});"]
    if handle.type == "VkCommandBuffer":
        if ret != "void":
            raise SystemExit(f"rewritten command {c.name}: no capture rule for a command-buffer command "
                             f"that returns {ret}")
        # The stream gets the application's call before the hook runs: it is the layer's own, the
        # driver never reads it, so this is the stream a capture after the down-call would give, and
        # it holds what the app recorded whatever the hook passes down (scaled, as another command,
        # or nothing).
        return lines + _capture_block(c, canon, handle_types, "") + [f"    {hook};"]
    if _records_first(c, canon):
        return lines + _capture_block(c, canon, handle_types, "") + [f"    {hook};"]
    if ret != "VkResult" or not (_created_handle(c, handle_types) or _logged_call(canon)):
        raise SystemExit(f"rewritten command {c.name}: no capture rule (command-buffer commands, creates "
                         "and destroys have one)")
    # A create is captured after the hook, on success: its capture names the handle the driver made.
    return (lines + [f"    const VkResult result = {hook};"] +
            _capture_block(c, canon, handle_types, " && result >= 0") + ["    return result;"])


def _edited_body(c, by_name):
    """Entry point body of an edited command (EDITED_COMMANDS): the call down through `c`'s own
    dispatch slot, then the hand-written hook of its canonical command, which edits the outputs."""
    canon = _canonical(c, by_name)
    return (_lock_lines(c) + [f"    {_dispatch_expr(c)}.{c.short_name}({c.arguments});",
                              f"    edit::{canon.short_name}({c.arguments});"])


def _boundary_function(c):
    """The exception boundary of `c`'s entry point (layer/vk/entry_boundary.h): what vkGet*ProcAddr hand out."""
    ret = c.return_type
    call = f"entry::{c.short_name}({c.arguments})"
    # The device whose split an exception ends: the one a device-level call is made on. None for
    # vkDestroyDevice, whose handle the driver may have freed by then (and whose state is gone).
    first = c.params[0]
    on_device = c.level == "device" and c.name != "vkDestroyDevice"
    key = f"find_device(dispatch_key({first.name}))" if on_device else "nullptr"
    creates = "true" if c.name.startswith(("vkCreate", "vkAllocate")) else "false"
    returns = {"void": "Nothing", "VkResult": "VkResult"}.get(ret, "Value")
    threw = (f'entry_threw("{c.name}", {key}, EntryReturns::{returns}, {creates}, said)')
    if ret == "void":
        body = [f"        {call};", f'        test_throw_point("{c.name}");']
        caught = [f"        {threw};"]
    else:
        body = [f"        const {ret} result = {call};", f'        test_throw_point("{c.name}");',
                "        return result;"]
        if ret == "VkResult":
            caught = [f"        return vk_result_of_throw({threw});"]
        else:
            caught = [f"        {threw};", "        return {};"]
    return [f"VKAPI_ATTR {ret} VKAPI_CALL {c.short_name}({c.signature}) {{",
            "    try {", *body,
            "    } catch (...) {",
            "        static std::atomic<bool> said{false};", *caught,
            "    }", "}", ""]


def emit(model):
    commands = [c for c in model.commands if c.name not in LOADER_ANSWERED]
    by_name = {c.name: c for c in model.commands}
    forwarded = {c.name for c in commands}
    missing = (MANUAL_COMMANDS | OBSERVED_COMMANDS | REWRITTEN_COMMANDS) - forwarded
    if missing:
        raise SystemExit(f"manual, observed or rewritten commands not in the forwarded set: {', '.join(sorted(missing))}")
    both = MANUAL_COMMANDS & OBSERVED_COMMANDS
    if both:
        raise SystemExit(f"commands both manual and observed (observe in the manual code): {', '.join(sorted(both))}")
    not_device = {c.name for c in commands if c.name in OBSERVED_COMMANDS and c.level != "device"}
    if not_device:
        raise SystemExit(f"observed commands that are not device-level: {', '.join(sorted(not_device))}")
    rewritten = [c for c in commands if _canonical(c, by_name).name in REWRITTEN_COMMANDS]
    not_canonical = {n for n in REWRITTEN_COMMANDS if by_name[n].alias}
    if not_canonical:
        raise SystemExit(f"rewritten commands named by an alias (name the canonical one): {', '.join(sorted(not_canonical))}")
    clash = {c.name for c in rewritten} & (MANUAL_COMMANDS | OBSERVED_COMMANDS)
    if clash:
        raise SystemExit(f"commands (or aliases of commands) both rewritten and manual or observed: {', '.join(sorted(clash))}")
    locked = {c.name for c in rewritten if c.params[0].type in LOCKED_HANDLES}
    if locked:
        raise SystemExit(f"rewritten commands on a locked handle (no lock rule for a rewrite): {', '.join(sorted(locked))}")
    not_forwarded = {c.name for c in rewritten if POLICY.get(_canonical(c, by_name).name) != FORWARD}
    if not_forwarded:
        raise SystemExit(f"rewritten commands the codec does not encode: {', '.join(sorted(not_forwarded))}")
    rewritten = {c.name for c in rewritten}
    edited = [c for c in commands if _canonical(c, by_name).name in EDITED_COMMANDS]
    not_canonical = {n for n in EDITED_COMMANDS if by_name[n].alias}
    if not_canonical:
        raise SystemExit(f"edited commands named by an alias (name the canonical one): {', '.join(sorted(not_canonical))}")
    clash = {c.name for c in edited} & (MANUAL_COMMANDS | OBSERVED_COMMANDS | rewritten)
    if clash:
        raise SystemExit(f"commands (or aliases of commands) both edited and manual, observed or rewritten: {', '.join(sorted(clash))}")
    # An edit changes only what the application is told: a command the codec encodes would send the
    # agent the driver's answer and the application another one.
    not_edited = {c.name for c in edited if c.return_type != "void" or c.level == "device" or
                  POLICY.get(_canonical(c, by_name).name) == FORWARD}
    if not_edited:
        raise SystemExit(f"edited commands that return a value, are device-level or are encoded: {', '.join(sorted(not_edited))}")
    edited = {c.name for c in edited}
    unknown = set(LOCKED_HANDLES) - set(model.handle_types)
    if unknown:
        raise SystemExit(f"locked handle types that are not handles: {', '.join(sorted(unknown))}")

    header = [HEADER.format(script="emit_layer.py"), "#pragma once", "",
              "#include <vulkan/vulkan.h>", "", "namespace splitvk {", "",
              "enum class EntryLevel { Global, Instance, PhysicalDevice, Device };", "",
              "struct EntryPoint {",
              "    const char *name;",
              "    PFN_vkVoidFunction function;",
              "    EntryLevel level;",
              "};", "",
              "// True if splitvk forwards the device extension `name` (codegen/allowlist.py); the layer",
              "// hides every other device extension from the application.",
              "bool device_extension_forwarded(const char *name);", "",
              "// The layer's entry point for `name`, or nullptr when splitvk does not forward it.",
              "const EntryPoint *find_entry_point(const char *name);", "",
              "namespace entry {", ""]
    for c in commands:
        header += guarded(c.protect, [
            f"VKAPI_ATTR {c.return_type} VKAPI_CALL {c.short_name}({c.signature});"])
    header += ["", "} // namespace entry", "",
               "// What the loader is handed: each entry point inside its exception boundary",
               "// (entry_boundary.h). The layer's own calls go to entry:: directly.",
               "namespace boundary {", ""]
    for c in commands:
        header += guarded(c.protect, [
            f"VKAPI_ATTR {c.return_type} VKAPI_CALL {c.short_name}({c.signature});"])
    header += ["", "} // namespace boundary", "",
               "struct DeviceState;", "",
               "// Hand-written observers of generated entry points (layer_overrides.OBSERVED_COMMANDS).",
               "namespace observe {", ""]
    for c in commands:
        if c.name in OBSERVED_COMMANDS:
            header += guarded(c.protect, [f"void {c.short_name}({_observer_signature(c)});"])
    header += ["", "} // namespace observe", "",
               "// Hand-written edits of what the driver answered (layer_overrides.EDITED_COMMANDS), one per",
               "// canonical command, called after every call of it or its aliases went down.",
               "namespace edit {", ""]
    for name in sorted(EDITED_COMMANDS):
        c = by_name[name]
        header += guarded(c.protect, [f"void {c.short_name}({c.signature});"])
    header += ["", "} // namespace edit", "",
               "// Hand-written rewrites of generated entry points (layer_overrides.REWRITTEN_COMMANDS), one",
               "// per canonical command, called only on a device with a session. The application's call is",
               "// captured before it (a create's after it, on success); `down` is the dispatch slot of the",
               "// command the application called (an alias's own), which the rewritten call goes down through.",
               "namespace rewrite {", ""]
    for name in sorted(REWRITTEN_COMMANDS):
        c = by_name[name]
        header += guarded(c.protect, [
            f"{c.return_type} {c.short_name}(DeviceState &dev, PFN_{c.name} down, {c.signature});"])
    header += ["", "} // namespace rewrite", "} // namespace splitvk", ""]

    source = [HEADER.format(script="emit_layer.py"), '#include "layer_entry_points.h"', "",
              '#include "capture/capture.h"', '#include "capture/descriptor_set.h"', '#include "core/dispatch.h"', '#include "vk/entry_boundary.h"', '#include "core/queue.h"', '#include "vk_codec.h"', "", "#include <algorithm>", "#include <atomic>", "#include <cstring>", "#include <iterator>", "#include <span>", "#include <vector>", "",
              "namespace splitvk {", "namespace entry {", ""]
    for c in commands:
        if c.name in MANUAL_COMMANDS:
            continue
        forward = POLICY.get(_canonical(c, by_name).name) == FORWARD
        if c.name in rewritten:
            body = _rewritten_body(c, by_name, model.handle_types)
        elif c.name in edited:
            body = _edited_body(c, by_name)
        elif c.level == "device" and (forward or c.name in OBSERVED_COMMANDS):
            body = _forward_body(c, by_name, model.handle_types, captured=forward)
        else:
            body = _lock_lines(c) + [f"    return {_dispatch_expr(c)}.{c.short_name}({c.arguments});"]
        source += guarded(c.protect, [
            f"VKAPI_ATTR {c.return_type} VKAPI_CALL {c.short_name}({c.signature}) {{",
            *body, "}", ""])
    source += ["} // namespace entry", "", "namespace boundary {", ""]
    for c in commands:
        source += guarded(c.protect, _boundary_function(c))
    source += ["} // namespace boundary", "",
               "namespace {", "",
               "// Sorted by name (strcmp order) for binary search.",
               "const EntryPoint kEntryPoints[] = {"]
    for c in sorted(commands, key=lambda c: c.name.encode()):
        source += guarded(c.protect, [
            f"    {{\"{c.name}\", reinterpret_cast<PFN_vkVoidFunction>(boundary::{c.short_name}), "
            f"{_LEVEL_ENUM[c.level]}}},"])
    source += ["};", ""]
    source += ["const char *const kForwardedDeviceExtensions[] = {"]
    source += [f"    \"{e}\"," for e in sorted(DEVICE_EXTENSIONS, key=str.encode)]
    source += ["};", ""]
    source += ["} // namespace", "",
               "bool device_extension_forwarded(const char *name) {",
               "    const auto *end = std::end(kForwardedDeviceExtensions);",
               "    const auto *it = std::lower_bound(std::begin(kForwardedDeviceExtensions), end, name,",
               "                                      [](const char *e, const char *n) { return std::strcmp(e, n) < 0; });",
               "    return it != end && std::strcmp(*it, name) == 0;",
               "}", "",
               "const EntryPoint *find_entry_point(const char *name) {",
               "    const auto *end = std::end(kEntryPoints);",
               "    const auto *it = std::lower_bound(std::begin(kEntryPoints), end, name,",
               "                                      [](const EntryPoint &e, const char *n) {",
               "                                          return std::strcmp(e.name, n) < 0;",
               "                                      });",
               "    return it != end && std::strcmp(it->name, name) == 0 ? it : nullptr;",
               "}", "", "} // namespace splitvk", ""]
    return {"layer_entry_points.h": "\n".join(header), "layer_entry_points.cpp": "\n".join(source)}
