#!/usr/bin/env python3
"""splitvk's code generator: reads vk.xml through Khronos' reg.py and writes C++ into the build tree.

Usage: generate.py --registry /usr/share/vulkan/registry --out DIR TARGET...
Targets: dispatch (instance/device dispatch tables), layer (layer entry points and lookup),
formats (vk_format_info.h: block sizes of single-plane formats), envelope (vk_envelope_tables.h:
how device limits, features and formats combine), results (vk_result_name.h: every VkResult's name),
codec (the Vulkan wire codec: encoders, decoders, dispatch, smoke test). All consume the same
model from vkregistry.py.
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import emit_codec  # noqa: E402
import emit_dispatch  # noqa: E402
import emit_envelope  # noqa: E402
import emit_formats  # noqa: E402
import emit_layer  # noqa: E402
import emit_replay  # noqa: E402
import emit_results  # noqa: E402
import vkregistry  # noqa: E402

EMITTERS = {
    "dispatch": emit_dispatch.emit,
    "layer": emit_layer.emit,
    "codec": emit_codec.emit,
    "replay": emit_replay.emit,
    "formats": emit_formats.emit,
    "envelope": emit_envelope.emit,
    "results": emit_results.emit,
}


def write_if_changed(path: str, text: str) -> None:
    """Keep timestamps of unchanged outputs so a re-run does not rebuild the layer."""
    if os.path.exists(path) and open(path, encoding="utf-8").read() == text:
        return
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8", newline="\n") as f:
        f.write(text)
    os.replace(tmp, path)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--registry", required=True, help="directory holding vk.xml and reg.py")
    parser.add_argument("--out", required=True, help="output directory (in the build tree)")
    parser.add_argument("targets", nargs="+", choices=sorted(EMITTERS))
    args = parser.parse_args()

    model = vkregistry.load(args.registry)
    os.makedirs(args.out, exist_ok=True)
    for target in args.targets:
        for filename, text in EMITTERS[target](model).items():
            write_if_changed(os.path.join(args.out, filename), text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
