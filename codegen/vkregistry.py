"""A model of the Vulkan API that splitvk forwards, read from Khronos' vk.xml through reg.py.

Every generator in this folder consumes the model built here rather than walking the XML
itself, so the question "which commands, with which parameters, from which extension" is
answered in exactly one place. The selection is core Vulkan 1.0-1.3 plus the extensions on the
allow-list in allowlist.py.
"""
from __future__ import annotations

import os
import re
import sys
import xml.etree.ElementTree as etree
from dataclasses import dataclass, field

import allowlist


def _import_khronos(registry_dir: str):
    sys.path.insert(0, registry_dir)
    import generator  # noqa: E402  (Khronos' module, from libvulkan-dev)
    import reg  # noqa: E402
    import vkconventions  # noqa: E402
    return generator, reg, vkconventions


@dataclass
class Param:
    type: str          # base type name, e.g. "VkBuffer", "uint32_t"
    name: str          # parameter name
    decl: str          # full C declaration text, e.g. "const VkBufferCreateInfo* pCreateInfo"
    is_pointer: bool
    is_const: bool
    length: str | None  # the `len` attribute: how many elements a pointer addresses
    optional: bool
    # What the wire codec needs beyond that (members of structures use the same class):
    pointer_depth: int = 0            # number of '*' in the declaration
    altlen: str | None = None         # `altlen`: a C expression for `len` when that is LaTeX
    optional_levels: list[bool] = field(default_factory=list)  # `optional` per indirection level
    noautovalidity: bool = False      # validity depends on other state (often: may be ignored)
    array_dims: list[str] = field(default_factory=list)  # fixed-size array bounds, e.g. ["4"]
    values: str | None = None         # `values` (the sType a structure must carry)
    selector: str | None = None       # union members: the member selecting the active member
    selection: str | None = None      # union members: the selector value choosing this one
    limittype: str | None = None      # `limittype` of a limit or feature member: "max", "min,pot", ...

    @property
    def lengths(self) -> list[str]:
        """The `len` attribute split per indirection level ("count,null-terminated")."""
        return self.length.split(",") if self.length else []


@dataclass
class Struct:
    name: str                 # "VkBufferCreateInfo"
    category: str             # "struct" or "union"
    members: list[Param]
    extends: list[str]        # `structextends`: structures whose pNext chain may hold this one
    returned_only: bool       # `returnedonly`: filled by the implementation, never an input
    stype: str | None         # the VK_STRUCTURE_TYPE_* value its sType member must carry
    protect: str | None
    origin: str


@dataclass
class Command:
    name: str                 # "vkCmdDraw"
    return_type: str          # "void", "VkResult", ...
    params: list[Param]
    level: str                # "global", "instance", "physical_device" or "device"
    origin: str               # "VK_VERSION_1_0" or the extension that introduced it
    protect: str | None       # platform macro guarding it, e.g. "VK_USE_PLATFORM_XCB_KHR"
    alias: str | None         # the command this one aliases, if any
    error_codes: list[str] = field(default_factory=list)  # `errorcodes`: the results that say it failed

    @property
    def short_name(self) -> str:
        """The name without its "vk" prefix: the dispatch-table member and entry-point name."""
        return self.name[2:]

    @property
    def signature(self) -> str:
        return ", ".join(p.decl for p in self.params) or "void"

    @property
    def arguments(self) -> str:
        return ", ".join(p.name for p in self.params)


@dataclass
class Format:
    """A single-plane VkFormat as vk.xml's <formats> describes it."""
    name: str
    block_bytes: int
    block_extent: tuple[int, int, int]
    components: list[str]  # "R", "G", "B", "A", "D", "S" in vk.xml order
    compressed: bool = False  # a block-compressed format (BC, ETC2, EAC, ASTC, PVRTC)
    ycbcr: bool = False  # a Y'CbCr format (vk.xml's chroma): sampled only through a conversion


@dataclass
class ApiModel:
    commands: list[Command] = field(default_factory=list)
    handle_types: dict[str, bool] = field(default_factory=dict)  # handle name -> dispatchable
    instance_extensions: list[str] = field(default_factory=list)
    device_extensions: list[str] = field(default_factory=list)
    # For the wire codec: every selected structure and union, and what each type name is.
    structs: dict[str, Struct] = field(default_factory=dict)
    type_category: dict[str, str] = field(default_factory=dict)  # "enum", "bitmask", "handle", ...
    type_alias: dict[str, str] = field(default_factory=dict)     # alias -> the type it names
    bit_width: dict[str, int] = field(default_factory=dict)      # enums and bitmasks: 32 or 64
    basetype_of: dict[str, str] = field(default_factory=dict)    # "VkDeviceSize" -> "uint64_t"
    handle_object_type: dict[str, str] = field(default_factory=dict)  # "VkBuffer" -> "VK_OBJECT_TYPE_BUFFER"
    negative_enums: set[str] = field(default_factory=set)        # enums with negative values (VkResult)
    formats: list["Format"] = field(default_factory=list)         # vk.xml <formats>, single-plane ones
    format_names: list[str] = field(default_factory=list)         # vk.xml <formats>, every one
    result_names: list[str] = field(default_factory=list)         # every VkResult, aliases left out

    def resolve(self, type_name: str) -> str:
        """The canonical name of a type (following aliases)."""
        while type_name in self.type_alias:
            type_name = self.type_alias[type_name]
        return type_name

    def by_level(self, *levels: str) -> list[Command]:
        return [c for c in self.commands if c.level in levels]


_DEVICE_LEVEL_HANDLES = {"VkDevice", "VkQueue", "VkCommandBuffer"}


def _command_level(name: str, params: list[Param]) -> str:
    if name in ("vkGetInstanceProcAddr", "vkCreateInstance") or name.startswith("vkEnumerateInstance"):
        return "global"
    first = params[0].type if params else ""
    if first == "VkInstance":
        return "instance"
    if first == "VkPhysicalDevice":
        return "physical_device"
    if first in _DEVICE_LEVEL_HANDLES:
        return "device"
    return "global"


def _parse_param(elem) -> Param:
    text = "".join(t for t in _itertext_without_comments(elem))
    decl = " ".join(text.split())
    type_name = elem.find("type").text
    name = elem.find("name").text
    tail = text.split(name)[0]
    after = text.split(name, 1)[1] if name in text else ""
    dims = []
    for dim in re.findall(r"\[([^\]]*)\]", after):
        dims.append(dim.strip())
    optional_levels = [v.strip() == "true" for v in elem.get("optional", "").split(",") if v.strip()]
    return Param(type=type_name, name=name, decl=decl, is_pointer="*" in tail or "[" in decl,
                 is_const=decl.startswith("const"), length=elem.get("len"),
                 optional=elem.get("optional", "false").startswith("true"),
                 pointer_depth=tail.count("*"), altlen=elem.get("altlen"),
                 optional_levels=optional_levels,
                 noautovalidity=elem.get("noautovalidity") == "true",
                 array_dims=dims, values=elem.get("values"), selector=elem.get("selector"),
                 selection=elem.get("selection"), limittype=elem.get("limittype"))


def _itertext_without_comments(elem):
    """The text of an element, leaving out <comment> children (vk.xml puts prose there)."""
    if elem.text:
        yield elem.text
    for child in elem:
        if child.tag != "comment":
            yield from _itertext_without_comments(child)
        if child.tail:
            yield child.tail


def _for_vulkan(elem) -> bool:
    return "vulkan" in (elem.get("api") or "vulkan").split(",")


def _result_names(tree) -> list[str]:
    """Every VkResult enumerant of vk.xml that vulkan_core.h declares, whatever the selection: its
    <enums> and what each Vulkan version and each supported extension adds. Aliases are left out
    (the value is named by the enumerant they alias)."""
    names = [e.get("name") for e in tree.findall("enums[@name='VkResult']/enum")
             if _for_vulkan(e) and not e.get("alias")]
    parents = tree.findall("feature") + tree.findall("extensions/extension")
    for parent in parents:
        if not _for_vulkan(parent) or "vulkan" not in (parent.get("supported") or "vulkan").split(","):
            continue
        for e in parent.iter("enum"):
            if e.get("extends") == "VkResult" and _for_vulkan(e) and not e.get("alias"):
                names.append(e.get("name"))
    return list(dict.fromkeys(names))


def load(registry_dir: str) -> ApiModel:
    """Run reg.py over vk.xml with our version/extension selection and collect the model."""
    generator, reg, vkconventions = _import_khronos(registry_dir)

    class Collector(generator.OutputGenerator):
        """A reg.py generator that writes nothing: it only records what apiGen() selects."""

        def __init__(self):
            super().__init__(errFile=sys.stderr, warnFile=sys.stderr, diagFile=None)
            self.model = ApiModel()
            self._extension_type = None

        def beginFile(self, genOpts):
            self.genOpts = genOpts
            self.conventions = genOpts.conventions
            self.outFile = None

        def endFile(self):
            self.genOpts = None

        def beginFeature(self, interface, emit):
            super().beginFeature(interface, emit)
            self._extension_type = interface.get("type")
            # vk.xml names a platform ("xcb"); its <platforms> table maps it to the guard macro.
            platform = interface.get("platform")
            if platform:
                self.featureExtraProtect = self.registry.tree.find(
                    f"platforms/platform[@name='{platform}']").get("protect")
            if interface.tag == "extension" and emit:
                target = (self.model.instance_extensions if self._extension_type == "instance"
                          else self.model.device_extensions)
                target.append(self.featureName)

        def genType(self, typeinfo, name, alias):
            super().genType(typeinfo, name, alias)
            elem = typeinfo.elem
            category = elem.get("category")
            if alias:
                self.model.type_alias[name] = alias
                return
            if category:
                self.model.type_category[name] = category
            if category == "handle":
                kind = elem.find("type")
                self.model.handle_types[name] = kind is not None and kind.text == "VK_DEFINE_HANDLE"
                if elem.get("objtypeenum"):
                    self.model.handle_object_type[name] = elem.get("objtypeenum")
            elif category == "bitmask":
                base = elem.find("type")
                self.model.bit_width[name] = 64 if base is not None and base.text == "VkFlags64" else 32
            elif category == "basetype":
                base = elem.find("type")
                if base is not None:
                    self.model.basetype_of[name] = base.text
            elif category in ("struct", "union"):
                members = [_parse_param(m) for m in elem.findall("member")]
                stype = next((m.values for m in members if m.name == "sType" and m.values), None)
                extends = [e for e in (elem.get("structextends") or "").split(",") if e]
                self.model.structs[name] = Struct(
                    name=name, category=category, members=members, extends=extends,
                    returned_only=elem.get("returnedonly") == "true", stype=stype,
                    protect=self.featureExtraProtect, origin=self.featureName)

        def genGroup(self, groupinfo, groupName, alias):
            super().genGroup(groupinfo, groupName, alias)
            if alias:
                self.model.type_alias[groupName] = alias
                return
            self.model.type_category[groupName] = "enum"
            self.model.bit_width[groupName] = int(groupinfo.elem.get("bitwidth") or 32)
            for enum in groupinfo.elem.findall("enum"):
                if (enum.get("value") or "").startswith("-") or enum.get("dir") == "-":
                    self.model.negative_enums.add(groupName)

        def genCmd(self, cmdinfo, name, alias):
            super().genCmd(cmdinfo, name, alias)
            if not self.emit:
                return
            proto = cmdinfo.elem.find("proto")
            params = [_parse_param(p) for p in cmdinfo.elem.findall("param")]
            self.model.commands.append(Command(
                name=name, return_type=proto.find("type").text, params=params,
                level=_command_level(name, params), origin=self.featureName,
                protect=self.featureExtraProtect, alias=alias,
                error_codes=[e for e in (cmdinfo.elem.get("errorcodes") or "").split(",") if e]))

    collector = Collector()
    options = generator.GeneratorOptions(
        conventions=vkconventions.VulkanConventions(),
        filename=None,
        apiname="vulkan",
        versions=allowlist.CORE_VERSIONS,
        emitversions=allowlist.CORE_VERSIONS,
        defaultExtensions=None,
        addExtensions=allowlist.extension_regex(),
        emitExtensions=allowlist.extension_regex(),
    )
    registry = reg.Registry(collector, options)
    registry.loadElementTree(etree.parse(os.path.join(registry_dir, "vk.xml")))
    registry.apiGen()

    missing = set(allowlist.INSTANCE_EXTENSIONS + allowlist.DEVICE_EXTENSIONS) - set(
        collector.model.instance_extensions + collector.model.device_extensions)
    if missing:
        raise SystemExit(f"allow-listed extensions not in vk.xml: {', '.join(sorted(missing))}")
    collector.model.commands.sort(key=lambda c: c.name)
    model = collector.model
    # A structure may name parents outside the selection in `structextends`: keep the selected ones.
    for struct in model.structs.values():
        struct.extends = [p for p in struct.extends if model.resolve(p) in model.structs]
    model.result_names = _result_names(registry.tree)
    for elem in registry.tree.findall("formats/format"):
        model.format_names.append(elem.get("name"))
        if elem.find("plane") is not None:
            continue  # multi-planar (YCbCr) formats: copied per plane, not supported by splitvk
        extent = tuple(int(v) for v in (elem.get("blockExtent") or "1,1,1").split(","))
        model.formats.append(Format(name=elem.get("name"), block_bytes=int(elem.get("blockSize")),
                                    block_extent=extent,
                                    components=[c.get("name") for c in elem.findall("component")],
                                    compressed=elem.get("compressed") is not None,
                                    ycbcr=elem.get("chroma") is not None))
    return model
