"""vk_result_name.h: the name of every VkResult vk.xml defines (its own enumerants and those its
core versions and extensions add), for log lines on both sides. An alias has the value of the
enumerant it names, so it is answered by that name."""
from cpp import HEADER


def emit(model):
    lines = [HEADER.format(script="emit_results.py"), "#pragma once", "",
             "#include <vulkan/vulkan.h>", "",
             "namespace splitvk {", "",
             "// The enumerant's name (\"VK_ERROR_DEVICE_LOST\"); \"an unknown VkResult\" for a value vk.xml",
             "// does not list.",
             "constexpr const char *vk_result_name(VkResult result) {",
             "    switch (result) {"]
    lines += [f"    case {name}: return \"{name}\";" for name in model.result_names]
    lines += ["    default: return \"an unknown VkResult\";", "    }", "}", "",
              "} // namespace splitvk", ""]
    return {"vk_result_name.h": "\n".join(lines)}
