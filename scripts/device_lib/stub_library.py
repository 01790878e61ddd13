#!/usr/bin/env python3
"""Writes a stand-in for a shared library that splitvk never calls into but that a library it
does use names as DT_NEEDED: FFmpeg's libavcodec links every codec Debian enables (x265, AV1,
codec2, ...) and libLLVM links libxml2 and z3, while splitvk needs only the H.264 decoder and
lavapipe's code generator. The stand-in has the real library's SONAME and defines every dynamic
symbol it exports, under the same symbol versions: zero-filled objects of the real sizes, and
functions that end the process with one line naming themselves if they are ever called. The
exception are the queries FFmpeg's codec registration makes of every codec library it links
(aom_codec_version, vpx_codec_vp9_cx, x265_api_get, ...): they return 0, which FFmpeg reads as a
codec without capabilities. So the dynamic loader binds libavcodec (linked with BIND_NOW) and
libLLVM as before, and a device bundle leaves out tens of MiB.

Usage: stub_library.py REAL_LIBRARY OUT_DIRECTORY   (writes OUT_DIRECTORY/<SONAME>)
"""
import os
import re
import subprocess
import sys
import tempfile


def soname(path):
    out = subprocess.check_output(["readelf", "-d", "-W", path], text=True)
    m = re.search(r"\(SONAME\)\s+Library soname: \[(.+?)\]", out)
    return m.group(1) if m else os.path.basename(path)


def exported_symbols(path):
    """(name, version or None, is_default_version, type, size) of every defined dynamic symbol."""
    out = subprocess.check_output(["readelf", "--dyn-syms", "-W", path], text=True)
    symbols = []
    for line in out.splitlines():
        f = line.split()
        # Num: Value Size Type Bind Vis Ndx Name
        # ABS symbols are the version definitions themselves, not code or data.
        if len(f) < 8 or not f[0].endswith(":") or f[6] in ("UND", "Ndx", "ABS"):
            continue
        kind, bind, full = f[3], f[4], f[7]
        if bind not in ("GLOBAL", "WEAK") or kind not in ("FUNC", "IFUNC", "OBJECT", "TLS", "NOTYPE"):
            continue
        size = int(f[2], 16) if f[2].startswith("0x") else int(f[2])
        if "@@" in full:
            name, version = full.split("@@", 1)
            default = True
        elif "@" in full:
            name, version = full.split("@", 1)
            default = False
        else:
            name, version, default = full, None, True
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
            continue
        symbols.append((name, version, default, kind, size))
    return symbols


# What codec registration asks of a library: its version, capabilities and interfaces.
QUERY = re.compile(r"(version|caps|_cx$|_dx$|api_get|_iface)")


def main():
    real, out_dir = sys.argv[1], sys.argv[2]
    name = soname(real)
    symbols = exported_symbols(real)
    c = ["/* A stand-in for " + name + ", written by scripts/device_lib/stub_library.py. */",
         "extern long write(int, const void *, unsigned long);",
         "extern void _exit(int);",
         "static void called(const char *what, unsigned long length) {",
         f'    static const char prefix[] = "splitvk device bundle: {name} is a stand-in, and ";',
         "    write(2, prefix, sizeof prefix - 1);",
         "    write(2, what, length);",
         '    write(2, " was called\\n", 12);',
         "    _exit(70);",
         "}"]
    versions = {}
    for index, (sym, version, default, kind, size) in enumerate(symbols):
        ident = sym if default else f"splitvk_stub_{index}"
        if kind in ("OBJECT", "TLS"):
            storage = "__thread " if kind == "TLS" else ""
            c.append(f"{storage}__attribute__((aligned(16))) char {ident}[{max(size, 1)}];")
        elif QUERY.search(sym):
            c.append(f"long {ident}(void) {{ return 0; }}")
        else:
            c.append(f'void {ident}(void) {{ called("{sym}", {len(sym)}); }}')
        if version:
            versions.setdefault(version, [])
            if default:
                versions[version].append(sym)
            else:
                c.append(f'__asm__(".symver {ident},{sym}@{version}");')
    script = []
    for version, names in versions.items():
        script.append(f"{version} {{ global: " + "".join(f"{n}; " for n in names) + "};")
    with tempfile.TemporaryDirectory() as tmp:
        source = os.path.join(tmp, "stub.c")
        with open(source, "w") as f:
            f.write("\n".join(c) + "\n")
        args = ["cc", "-shared", "-fPIC", "-O0", "-w", "-fno-builtin", "-o", os.path.join(out_dir, name), source,
                f"-Wl,-soname,{name}"]
        if script:
            vs = os.path.join(tmp, "versions.map")
            with open(vs, "w") as f:
                f.write("\n".join(script) + "\n")
            args.append(f"-Wl,--version-script={vs}")
        subprocess.check_call(args)
    print(f"{name}: {len(symbols)} symbols")


if __name__ == "__main__":
    main()
