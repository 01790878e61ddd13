"""vk_envelope_tables.h: what the device envelope (protocol/device_envelope.h) combines, from vk.xml.

The envelope is what the layer tells the application about its device: values that both the
client's GPU and any agent GPU can honour. vk.xml says how each limit compares (`limittype`):
"max" (a larger value is more capable), "min" (smaller is), "bits" (more bits is), "bitmask"
(more bits set is), "range" ([min, max] pairs, wider is), and "pot" / "mul" on alignments. The
generator turns that into one table, so combining, checking and naming limits is one loop in
C++ instead of a hundred hand-written lines.

One policy is splitvk's, not the spec's: a few limits describe only the client's own driver
(memory it maps, queries it answers), because the agent never sees the application's memory
layout or timestamps. CLIENT_LOCAL keeps the client's value for those.
"""
import re

import allowlist
from cpp import HEADER

# Limits whose truth is the client's own device. The agent rebinds every resource into its own
# allocations (docs/architecture.md §3), answers no query, and maps no memory of the application's.
CLIENT_LOCAL = {
    "minMemoryMapAlignment": "pointers the client's vkMapMemory returns",
    "nonCoherentAtomSize": "flush/invalidate ranges of the client's memory",
    "bufferImageGranularity": "placement in the client's allocations; the agent rebinds",
    "timestampPeriod": "timestamps are the client's queries",
    "timestampComputeAndGraphics": "timestamps are the client's queries",
    "discreteQueuePriorities": "the client's queues; the agent replays on one",
    "maxMemoryAllocationCount": "the client's allocations; the agent rebinds per resource",
}

_SCALARS = {
    "uint32_t": "U32", "VkSampleCountFlags": "U32", "VkBool32": "U32",
    "int32_t": "I32", "VkDeviceSize": "U64", "size_t": "SizeT", "float": "F32",
}

# The feature structures whose members the envelope intersects, by name: core 1.0 and the
# Vulkan 1.1-1.3 aggregates. Extension structures carry the same names for promoted features,
# so masking by name covers them too (layer/core/physical_device.cpp).
FEATURE_STRUCTS = ["VkPhysicalDeviceFeatures", "VkPhysicalDeviceVulkan11Features",
                   "VkPhysicalDeviceVulkan12Features", "VkPhysicalDeviceVulkan13Features"]


def _extension_feature_structs(model):
    """The feature structures (VkBool32 members only) that forwarded device extensions introduce."""
    forwarded = set(allowlist.DEVICE_EXTENSIONS) - set(allowlist.CLIENT_ONLY_EXTENSIONS)
    out = []
    for struct in sorted(model.structs.values(), key=lambda s: s.name):
        if struct.origin not in forwarded or "VkPhysicalDeviceFeatures2" not in struct.extends:
            continue
        if not struct.stype or struct.protect:
            continue
        body = [m for m in struct.members if m.name not in ("sType", "pNext")]
        if body and all(m.type == "VkBool32" and not m.array_dims for m in body):
            out.append(struct)
    return out


def _combine(limittype: str) -> str:
    kinds = limittype.split(",")
    for kind, value in (("max", "Max"), ("min", "Min"), ("bits", "Bits"), ("bitmask", "Bitmask"),
                        ("range", "Range")):
        if kind in kinds:
            return value
    raise SystemExit(f"emit_envelope: limittype '{limittype}' has no combining rule")


def _bool_members(struct) -> list[str]:
    return [m.name for m in struct.members if m.type == "VkBool32"]


def emit(model):
    limits = model.structs["VkPhysicalDeviceLimits"]
    lines = [HEADER.format(script="emit_envelope.py"), "#pragma once", "",
             "#include <vulkan/vulkan.h>", "", "#include <cstddef>", "#include <cstdint>", "",
             "namespace splitvk::envelope {", "",
             "enum class Scalar : uint8_t { U32, I32, U64, SizeT, F32 };",
             "// How two devices' values combine into one both honour (vk.xml limittype).",
             "enum class Combine : uint8_t { Max, Min, Bits, Bitmask, Range, ClientLocal };", "",
             "struct LimitField {",
             "    const char *name;",
             "    uint32_t offset; // in VkPhysicalDeviceLimits",
             "    Scalar scalar;",
             "    uint8_t count;   // array elements (maxComputeWorkGroupSize: 3)",
             "    Combine combine;",
             "    bool power_of_two;",
             "};", "",
             "inline constexpr LimitField kLimitFields[] = {"]
    for m in limits.members:
        if not m.limittype:
            raise SystemExit(f"emit_envelope: VkPhysicalDeviceLimits::{m.name} has no limittype")
        scalar = _SCALARS.get(m.type)
        if not scalar:
            raise SystemExit(f"emit_envelope: no scalar for {m.type} ({m.name})")
        count = int(m.array_dims[0]) if m.array_dims else 1
        combine = "ClientLocal" if m.name in CLIENT_LOCAL else _combine(m.limittype)
        pot = "true" if "pot" in m.limittype.split(",") else "false"
        lines.append(f'    {{"{m.name}", offsetof(VkPhysicalDeviceLimits, {m.name}), Scalar::{scalar}, {count}, '
                     f"Combine::{combine}, {pot}}},")
    lines += ["};", ""]

    # Every feature name once, in the order of FEATURE_STRUCTS, then those of the forwarded
    # extensions' own feature structures; where a name first appears says which structure the
    # description reads it from. Features the layer always clears (allowlist.WITHHELD_FEATURES) are
    # no part of what an application is told, so not of the envelope either.
    extension_structs = _extension_feature_structs(model)
    withheld = {m for members in allowlist.WITHHELD_FEATURES.values() for m in members}
    seen: dict[str, tuple[str, str]] = {}
    for struct_name in FEATURE_STRUCTS + [s.name for s in extension_structs]:
        for member in _bool_members(model.structs[struct_name]):
            if member not in withheld:
                seen.setdefault(member, (struct_name, member))
    lines += ["enum class FeatureStruct : uint8_t { Core, Vulkan11, Vulkan12, Vulkan13, Extension };", "",
              "// A forwarded extension's feature structure, read with vkGetPhysicalDeviceFeatures2 where",
              "// the device offers the extension.",
              "struct ExtensionFeatureStruct {",
              "    VkStructureType stype;",
              "    uint32_t size;",
              "    const char *extension;",
              "};", "",
              "inline constexpr ExtensionFeatureStruct kExtensionFeatureStructs[] = {"]
    lines += [f'    {{{s.stype}, sizeof({s.name}), "{s.origin}"}},' for s in extension_structs]
    lines += ["};", "",
              "struct FeatureField {",
              "    const char *name;",
              "    FeatureStruct source;",
              "    uint32_t offset;    // of the VkBool32 in its source structure",
              "    uint16_t extension; // source Extension: its index in kExtensionFeatureStructs",
              "};", "",
              "inline constexpr FeatureField kFeatureFields[] = {"]
    source_enum = dict(zip(FEATURE_STRUCTS, ["Core", "Vulkan11", "Vulkan12", "Vulkan13"]))
    extension_index = {s.name: i for i, s in enumerate(extension_structs)}
    for name, (struct_name, member) in seen.items():
        source = source_enum.get(struct_name, "Extension")
        index = extension_index.get(struct_name, 0)
        lines.append(f'    {{"{name}", FeatureStruct::{source}, offsetof({struct_name}, {member}), {index}}},')
    lines += ["};", ""]

    # Every structure that may extend VkPhysicalDeviceFeatures2 and holds only VkBool32 features:
    # the layer masks the envelope's names in each of them.
    lines += ["struct FeatureChainMember {",
              "    const char *name;",
              "    uint32_t offset;",
              "};", "",
              "struct FeatureChainStruct {",
              "    VkStructureType stype;",
              "    const FeatureChainMember *members;",
              "    uint32_t count;",
              "};", ""]
    chain_structs = []
    for struct in sorted(model.structs.values(), key=lambda s: s.name):
        if "VkPhysicalDeviceFeatures2" not in struct.extends or not struct.stype or struct.protect:
            continue
        names = _bool_members(struct)
        if not names:
            continue
        symbol = f"k{struct.name[2:]}Members"
        lines.append(f"inline constexpr FeatureChainMember {symbol}[] = {{")
        lines += [f'    {{"{n}", offsetof({struct.name}, {n})}},' for n in names]
        lines.append("};")
        chain_structs.append((struct.stype, symbol, len(names)))
    lines += ["", "inline constexpr FeatureChainStruct kFeatureChainStructs[] = {"]
    lines += [f"    {{{stype}, {symbol}, {count}}}," for stype, symbol, count in chain_structs]
    lines += ["};", ""]

    # Every feature structure the agent mirrors from the client's vkCreateDevice chain (VkBool32
    # members only, after sType and pNext), with what it needs there: a core version, or its
    # extension enabled on the agent's device.
    lines += ["struct DeviceFeatureStruct {",
              "    VkStructureType stype;",
              "    uint32_t size;",
              "    uint32_t core_version; // VK_API_VERSION_1_x that introduced it; 0 for an extension's",
              "    const char *extension; // the extension that introduced it; nullptr for a core one",
              "};", "",
              "inline constexpr DeviceFeatureStruct kDeviceFeatureStructs[] = {"]
    for struct in sorted(model.structs.values(), key=lambda s: s.name):
        if not {"VkPhysicalDeviceFeatures2", "VkDeviceCreateInfo"} <= set(struct.extends):
            continue
        if not struct.stype or struct.protect:
            continue
        body = [m for m in struct.members if m.name not in ("sType", "pNext")]
        if not body or any(m.type != "VkBool32" or m.array_dims for m in body):
            continue
        version = re.fullmatch(r"VK_VERSION_(\d)_(\d)", struct.origin)
        core = f"VK_API_VERSION_{version[1]}_{version[2]}" if version else "0"
        extension = "nullptr" if version else f'"{struct.origin}"'
        lines.append(f"    {{{struct.stype}, sizeof({struct.name}), {core}, {extension}}},")
    lines += ["};", ""]

    # Feature members of forwarded extensions that the layer always clears (allowlist.py).
    lines += ["struct WithheldFeature {",
              "    VkStructureType stype;",
              "    uint32_t offset; // of the VkBool32 in its structure",
              "    const char *name;",
              "    const char *reason;",
              "};", "",
              "inline constexpr WithheldFeature kWithheldFeatures[] = {"]
    for struct_name, members in sorted(allowlist.WITHHELD_FEATURES.items()):
        struct = model.structs.get(struct_name)
        if not struct:
            raise SystemExit(f"emit_envelope: WITHHELD_FEATURES names {struct_name}, which is not in the model")
        known = set(_bool_members(struct))
        for member, reason in sorted(members.items()):
            if member not in known:
                raise SystemExit(f"emit_envelope: {struct_name} has no feature {member}")
            lines.append(f'    {{{struct.stype}, offsetof({struct_name}, {member}), "{member}", "{reason}"}},')
    lines += ["};", ""]

    # The formats whose properties the envelope intersects: every single-plane format vk.xml
    # describes.
    lines += ["inline constexpr VkFormat kEnvelopeFormats[] = {"]
    lines += [f"    {f.name}," for f in model.formats]
    lines += ["};", "", "} // namespace splitvk::envelope", ""]
    return {"vk_envelope_tables.h": "\n".join(lines), "vk_withheld_extensions.h": _withheld_extensions(model)}


def _withheld_extensions(model) -> str:
    """Why each device extension is withheld (allowlist.WITHHELD_REASONS), for the Coverage test."""
    forwarded = set(model.device_extensions)
    stale = sorted(set(allowlist.WITHHELD_REASONS) & forwarded)
    if stale:
        raise SystemExit("allowlist.py: forwarded extensions still have a withheld reason (remove it from "
                         "WITHHELD_REASONS): " + ", ".join(stale))
    lines = [HEADER.format(script="emit_envelope.py"), "#pragma once", "",
             "namespace splitvk {", "",
             "struct WithheldExtension {",
             "    const char *name;",
             "    const char *reason;",
             "};", "",
             "// The device extensions splitvk withholds that a driver it is tested on offers, and why",
             "// (codegen/allowlist.py WITHHELD_REASONS).",
             "inline constexpr WithheldExtension kWithheldExtensions[] = {"]
    for name, reason in sorted(allowlist.WITHHELD_REASONS.items()):
        text = reason.replace("\\", "\\\\").replace('"', '\\"')
        lines.append(f'    {{"{name}", "{text}"}},')
    lines += ["};", "", "} // namespace splitvk", ""]
    return "\n".join(lines)
