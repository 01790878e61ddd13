"""vk_format_info.h: what vk.xml's <formats> says of each single-plane VkFormat, for the layer's
snapshot of image contents (how many bytes a copy of a region takes, which aspect to copy)."""
from cpp import HEADER


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
             "};", "",
             "constexpr FormatInfo format_info(VkFormat format) {",
             "    switch (format) {"]
    for f in model.formats:
        depth = "true" if "D" in f.components else "false"
        stencil = "true" if "S" in f.components else "false"
        lines.append(f"    case {f.name}: return {{{f.block_bytes}, {f.block_extent[0]}, {f.block_extent[1]}, "
                     f"{depth}, {stencil}}};")
    lines += ["    default: return {};", "    }", "}", "", "} // namespace splitvk", ""]
    return {"vk_format_info.h": "\n".join(lines)}
