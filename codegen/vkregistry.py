"""A model of the Vulkan API that splitvk forwards, read from Khronos' vk.xml through reg.py.

Every generator in this folder consumes the model built here rather than walking the XML
itself, so the question "which commands, with which parameters, from which extension" is
answered in exactly one place. The selection is core Vulkan 1.0-1.3 plus the extensions on the
allow-list in allowlist.py.
"""
from __future__ import annotations

import os
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


@dataclass
class Command:
    name: str                 # "vkCmdDraw"
    return_type: str          # "void", "VkResult", ...
    params: list[Param]
    level: str                # "global", "instance", "physical_device" or "device"
    origin: str               # "VK_VERSION_1_0" or the extension that introduced it
    protect: str | None       # platform macro guarding it, e.g. "VK_USE_PLATFORM_XCB_KHR"
    alias: str | None         # the command this one aliases, if any

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
class ApiModel:
    commands: list[Command] = field(default_factory=list)
    handle_types: dict[str, bool] = field(default_factory=dict)  # handle name -> dispatchable
    instance_extensions: list[str] = field(default_factory=list)
    device_extensions: list[str] = field(default_factory=list)

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
    decl = " ".join("".join(elem.itertext()).split())
    type_name = elem.find("type").text
    name = elem.find("name").text
    tail = "".join(elem.itertext()).split(name)[0]
    return Param(type=type_name, name=name, decl=decl, is_pointer="*" in tail or "[" in decl,
                 is_const=decl.startswith("const"), length=elem.get("len"),
                 optional=elem.get("optional", "false").startswith("true"))


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
            if typeinfo.elem.get("category") == "handle" and not alias:
                kind = typeinfo.elem.find("type")
                self.model.handle_types[name] = kind is not None and kind.text == "VK_DEFINE_HANDLE"

        def genCmd(self, cmdinfo, name, alias):
            super().genCmd(cmdinfo, name, alias)
            if not self.emit:
                return
            proto = cmdinfo.elem.find("proto")
            params = [_parse_param(p) for p in cmdinfo.elem.findall("param")]
            self.model.commands.append(Command(
                name=name, return_type=proto.find("type").text, params=params,
                level=_command_level(name, params), origin=self.featureName,
                protect=self.featureExtraProtect, alias=alias))

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
    return collector.model
