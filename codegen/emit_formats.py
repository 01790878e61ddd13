"""vk_format_info.h: what vk.xml's <formats> says of each single-plane VkFormat, for the layer's
snapshot of image contents (how many bytes a copy of a region takes, which aspect to copy) and for
the texel size of tiles (tiles/tile_format.h), and the name of every VkFormat it lists, for log
lines."""
from cpp import HEADER


def _bool(value: bool) -> str:
    return "true" if value else "false"


def emit(model):
    lines = [HEADER.format(script="emit_formats.py"), "#pragma once", "",
             "#include <vulkan/vulkan.h>", "", "#include <cstdint>", "",
             "namespace splitvk {", "",
             "struct FormatInfo {",
             "    uint32_t block_bytes = 0; // 0: a format vk.xml does not describe as single-plane",
             "    uint32_t block_width = 1;",
             "    uint32_t block_height = 1;",
             "    bool depth = false;",
             "    bool stencil = false;",
             "    bool compressed = false; // block-compressed: BC, ETC2, EAC, ASTC, PVRTC",
             "    bool ycbcr = false;      // Y'CbCr (vk.xml's chroma): sampled only through a conversion",
             "};", "",
             "constexpr FormatInfo format_info(VkFormat format) {",
             "    switch (format) {"]
    for f in model.formats:
        depth = _bool("D" in f.components)
        stencil = _bool("S" in f.components)
        lines.append(f"    case {f.name}: return {{{f.block_bytes}, {f.block_extent[0]}, {f.block_extent[1]}, "
                     f"{depth}, {stencil}, {_bool(f.compressed)}, {_bool(f.ycbcr)}}};")
    lines += ["    default: return {};", "    }", "}", ""]

    # Every format vk.xml describes, multi-planar ones included, for tests that cover them all.
    lines += ["inline constexpr VkFormat kFormats[] = {"]
    lines += [f"    {name}," for name in model.format_names]
    lines += ["};", ""]

    lines += ["// The enumerant's name (\"VK_FORMAT_R16G16B16A16_UNORM\"); \"VK_FORMAT_UNDEFINED\" for 0 and",
              "// \"an unknown VkFormat\" for a value vk.xml does not list.",
              "constexpr const char *format_name(VkFormat format) {",
              "    switch (format) {",
              "    case VK_FORMAT_UNDEFINED: return \"VK_FORMAT_UNDEFINED\";"]
    lines += [f"    case {name}: return \"{name}\";" for name in model.format_names]
    lines += ["    default: return \"an unknown VkFormat\";", "    }", "}", "",
              "} // namespace splitvk", ""]
    return {"vk_format_info.h": "\n".join(lines)}
