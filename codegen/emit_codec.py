"""The Vulkan wire codec: for every forwarded (and manual) command an encoder for the layer and a
bounds-checked decoder with handle replacement for the agent (docs/architecture.md §3).

Outputs (in the build tree):
  vk_codec.h                public API: VkCommandId, kCodecFingerprint, encode_vk*, Decoded_vk*,
                            decode_vk*, apply_handle_changes, CommandVisitor, dispatch_decoded
  vk_codec_internal.h       structure codecs shared by the generated sources
  vk_codec_structs_N.cpp    structure encoders/decoders and pNext chains (split for a parallel build)
  vk_codec_commands_N.cpp   command encoders/decoders
  vk_codec_dispatch.cpp     names, dispatch, visitor, handle-table bookkeeping
  vk_codec_smoke_test.cpp   a GoogleTest per command: zero/null arguments encode, decode and re-encode
                            to the same bytes

The runtime it calls is hand-written in protocol/codec/ (codec.h: Encoder, Decoder, Arena,
HandleTable). Which commands: codec_policy.py. What vk.xml cannot say: codec_overrides.py.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

import allowlist
import codec_overrides as ov
import codec_policy
from cpp import HEADER, guarded

STRUCT_FILES = 4
COMMAND_FILES = 3
FIRST_COMMAND_ID = 0x0100

# C scalar types: (Encoder/Decoder method, wire bytes).
C_SCALARS = {
    "uint8_t": ("u8", 1), "uint16_t": ("u16", 2), "uint32_t": ("u32", 4), "uint64_t": ("u64", 8),
    "int32_t": ("i32", 4), "int64_t": ("i64", 8), "float": ("f32", 4), "double": ("f64", 8),
    "size_t": ("size", 8), "int": ("i32", 4),
}
# Bulk array helpers for element types that are exactly these C types.
BULK = {"uint32_t": "u32_array", "float": "f32_array", "uint64_t": "u64_array"}


DEVICE_ADDRESS_TYPES = {"VkDeviceAddress", "VkDeviceOrHostAddressKHR", "VkDeviceOrHostAddressConstKHR"}


class CodecError(SystemExit):
    pass


@dataclass
class Field:
    name: str
    type: str                  # canonical element type
    decl: str
    kind: str                  # see _classify
    elem: str = ""             # scalar | enum32 | handle | struct | union
    method: str = ""           # scalar Encoder/Decoder method
    wire: str = "0"            # C++ expression: minimum wire bytes of one element
    count: str | None = None   # C++ template for arrays: identifiers as {P}name
    optional: bool = False     # the pointer may be absent
    nullable: bool = False     # handles: id 0 allowed
    condition: str | None = None
    dims: list[str] = field(default_factory=list)
    negative: bool = False     # enum32 with negative values
    objtype: str = ""          # handles: VK_OBJECT_TYPE_*
    scalar_ctype: str = ""     # scalar: the C type the typedef resolves to
    parent_slot: bool = False  # codec_overrides.POOL_PARENTS: the decoder keeps this handle's id
    set_param: str = ""        # template data: the VkDescriptorSet parameter, if any

    def signature(self) -> str:
        """What the fingerprint hashes: everything that changes the bytes on the wire."""
        return (f"{self.name}:{self.kind}:{self.type}:{self.elem}:{self.method}:{self.count}:"
                f"{int(self.optional)}:{int(self.nullable)}:{self.condition}:{','.join(self.dims)}")


class Codec:
    """The classified model: which structures and commands, and how each member is encoded."""

    def __init__(self, model):
        self.model = model
        self.policy = codec_policy.classify(model)
        self.commands = sorted((c for c in model.commands if not c.alias and self.policy[c.name] != "local"),
                               key=lambda c: c.name)
        self.struct_order: list[str] = []
        self.struct_fields: dict[str, list[Field]] = {}
        self.extenders: dict[str, list[str]] = {}
        self.command_fields: dict[str, list[Field]] = {}
        self._seen: set[str] = set()
        self._used_overrides: set = set()
        for c in self.commands:
            self.command_fields[c.name] = self._command(c)
        self._check_overrides()
        for struct, member in ov.POOL_PARENTS.values():
            matches = [f for f in self.struct_fields.get(struct, []) if f.name == member and f.elem == "handle"]
            if len(matches) != 1:
                raise CodecError(f"codec_overrides.py: POOL_PARENTS names {struct}.{member}, not a handle member")
            matches[0].parent_slot = True

    # --- type helpers ------------------------------------------------------------------------

    def category(self, type_name: str) -> str:
        t = self.model.resolve(type_name)
        if t in C_SCALARS:
            return "c"
        return self.model.type_category.get(t, "c" if t in ("void", "char") else "unknown")

    def scalar(self, type_name: str):
        """(elem kind, method, wire bytes, C type) of a non-pointer value, or None for structs."""
        t = self.model.resolve(type_name)
        cat = self.category(t)
        if t in C_SCALARS:
            return ("scalar",) + C_SCALARS[t] + (t,)
        if cat == "basetype":
            base = self.model.basetype_of[t]
            return ("scalar",) + C_SCALARS[base] + (base,)
        if cat == "bitmask":
            return ("scalar", "u64", 8, "uint64_t") if self.model.bit_width[t] == 64 else ("scalar", "u32", 4, "uint32_t")
        if cat == "enum":
            if self.model.bit_width.get(t, 32) == 64:
                return ("scalar", "u64", 8, "uint64_t")
            return ("enum32", "enum32", 4, "")
        if cat == "handle":
            return ("handle", "handle", 8, "")
        return None

    def _objtype(self, t):
        ot = self.model.handle_object_type.get(t)
        if not ot:
            raise CodecError(f"codec: no VkObjectType for handle {t}")
        return ot

    # --- structures ----------------------------------------------------------------------------

    def visit_struct(self, name: str):
        name = self.model.resolve(name)
        if name in self._seen:
            return
        struct = self.model.structs.get(name)
        if struct is None:
            raise CodecError(f"codec: {name} is not a selected structure")
        if struct.protect:
            raise CodecError(f"codec: platform structure {name} ({struct.protect}) reached; not supported")
        self._seen.add(name)
        fields = [self._member(struct, m, i) for i, m in enumerate(struct.members)]
        self.struct_fields[name] = fields
        for f in fields:
            if f.elem in ("struct", "union") and f.kind != "skip":
                self.visit_struct(f.type)
        if any(f.kind == "pnext" for f in fields):
            ext = []
            for other in self.model.structs.values():
                if other.returned_only or other.name in ov.DROPPED_EXTENSIONS:
                    continue
                if name in [self.model.resolve(p) for p in other.extends]:
                    ext.append(other.name)
            self.extenders[name] = sorted(ext)
            for e in ext:
                self.visit_struct(e)
        self.struct_order.append(name)

    def _len_expr(self, owner_names: list[str], pointer_names: set[str], length: str, altlen: str | None,
                  where: str) -> str:
        """A C++ template ({P} = the owner prefix) counting the elements of an array."""
        expr = altlen if altlen else length
        if expr.startswith("latexmath"):
            raise CodecError(f"codec: {where}: LaTeX len without altlen")
        m = re.fullmatch(r"(\w+)->(\w+)", expr)
        if m:
            if m.group(1) not in owner_names:
                raise CodecError(f"codec: {where}: len {expr} names an unknown parameter")
            return f"({{P}}{m.group(1)} ? {{P}}{m.group(1)}->{m.group(2)} : 0)"

        def sub(match):
            word = match.group(0)
            if word in owner_names:
                if word in pointer_names:
                    return f"({{P}}{word} ? *{{P}}{word} : 0)"
                return "{P}" + word
            if word.isdigit():
                return word
            raise CodecError(f"codec: {where}: len {expr} names {word}, not a member")
        return re.sub(r"[A-Za-z_]\w*|\d+", sub, expr)

    def _check_order(self, members, index, length, where):
        """A length must be read before the array it counts: the decoder reads in order."""
        names = [m.name for m in members]
        for word in re.findall(r"[A-Za-z_]\w*", length):
            if word in names and names.index(word) >= index:
                raise CodecError(f"codec: {where}: length {word} comes after the array")

    def _member(self, struct, m, index) -> Field:
        where = f"{struct.name}.{m.name}"
        t = self.model.resolve(m.type)
        key = (struct.name, m.name)
        cond = None
        if key in ov.CONDITIONS:
            cond = ov.CONDITIONS[key][0]
            self._used_overrides.add(("cond",) + key)
        if key in ov.ALWAYS_VALID:
            self._used_overrides.add(("always",) + key)
        if m.noautovalidity and (m.pointer_depth or self.category(t) == "handle") and m.name != "pNext":
            if key not in ov.CONDITIONS and key not in ov.ALWAYS_VALID:
                raise CodecError(f"codec_overrides.py: {where} is noautovalidity: add a condition or ALWAYS_VALID")
        if m.name == "sType" and m.values:
            return Field(m.name, t, m.decl, "stype")
        if m.name == "pNext":
            return Field(m.name, t, m.decl, "pnext", wire="4")
        names = [x.name for x in struct.members]
        pointers = {x.name for x in struct.members if x.pointer_depth}
        return self._field(m, t, where, names, pointers, cond, struct.members, index, is_member=True)

    def _field(self, m, t, where, names, pointers, cond, members, index, is_member) -> Field:
        # A buffer device address is the client driver's number: replayed as it is, the agent's GPU
        # reads whatever lies there (server-agent/buffer_addresses.h). Nothing forwarded today has
        # one; an extension that brings one must translate it in the replayer or drop the structure.
        if DEVICE_ADDRESS_TYPES & {m.type, t}:
            raise CodecError(f"codec: {where} is a device address, which the agent must translate "
                             "(buffer_addresses.h) or never receive (codec_overrides.DROPPED_EXTENSIONS)")
        cat = self.category(t)
        opt0 = bool(m.optional_levels and m.optional_levels[0])
        opt1 = bool(len(m.optional_levels) > 1 and m.optional_levels[1])
        f = Field(m.name, t, m.decl, "", condition=cond)
        if t == "VkAllocationCallbacks" or cat == "funcpointer":
            f.kind = "skip"
            return f
        if m.pointer_depth == 0:
            s = self.scalar(t)
            f.kind = "value"
            f.dims = list(m.array_dims)
            if s:
                f.elem, f.method, wire, f.scalar_ctype = s
                f.wire = str(wire)
                if f.elem == "handle":
                    f.objtype = self._objtype(t)
                    f.nullable = opt0 or m.noautovalidity or cond is not None
                f.negative = t in self.model.negative_enums
            elif cat in ("struct", "union"):
                f.elem = cat
                f.wire = f"sizeof({t})" if cat == "union" else f"kWire_{t}"
            else:
                raise CodecError(f"codec: {where}: cannot encode type {t} ({cat})")
            if len(f.dims) > 1:
                raise CodecError(f"codec: {where}: multi-dimensional arrays are not supported")
            if f.dims:
                f.wire = f"({f.wire}) * {f.dims[0]}"
            return f

        lengths = m.lengths
        f.optional = opt0 or m.noautovalidity or cond is not None
        # Output pointers: non-const pointers.
        if not m.is_const:
            if t == "void":
                f.kind = "skip"        # void* user data, void** ppData
                return f
            if m.pointer_depth != 1:
                raise CodecError(f"codec: {where}: output with {m.pointer_depth} indirections")
            count = self._len_expr(names, pointers, lengths[0], m.altlen, where) if lengths else "1"
            if lengths:
                self._check_order(members, index, m.altlen or lengths[0], where)
            f.count = count
            f.wire = "1"
            s = self.scalar(t)
            if is_member:
                f.kind = "out_storage"     # the implementation writes it; decoded as zeroed storage
                f.elem = s[0] if s else self.category(t)
                return f
            if s and s[0] == "handle":
                f.kind = "out_handles"
                f.elem = "handle"
                f.objtype = self._objtype(t)
                f.optional = True
                return f
            if s and s[0] == "scalar" and not lengths:
                f.kind = "out_value"
                f.elem, f.method, _, f.scalar_ctype = s
                f.optional = True
                return f
            raise CodecError(f"codec: {where}: unsupported output {m.decl}")

        if t == "char" and lengths and lengths[-1] == "null-terminated":
            if m.pointer_depth == 1:
                f.kind = "string"
                f.wire = "1"
                return f
            if m.pointer_depth == 2 and len(lengths) == 2:
                self._check_order(members, index, lengths[0], where)
                f.kind = "string_array"
                f.count = self._len_expr(names, pointers, lengths[0], None, where)
                f.wire = "1"
                return f
            raise CodecError(f"codec: {where}: unsupported string {m.decl}")
        if m.pointer_depth != 1:
            raise CodecError(f"codec: {where}: unsupported pointer {m.decl}")
        if t == "void":
            if m.name == "pNext":
                return Field(m.name, t, m.decl, "pnext", wire="4")
            if not lengths:
                f.kind = "skip"
                return f
            self._check_order(members, index, m.altlen or lengths[0], where)
            f.kind = "blob"
            f.count = self._len_expr(names, pointers, lengths[0], m.altlen, where)
            f.wire = "1"
            return f
        s = self.scalar(t)
        if s:
            f.elem, f.method, wire, f.scalar_ctype = s
            f.wire = str(wire)
            if f.elem == "handle":
                f.objtype = self._objtype(t)
                f.nullable = opt1 or m.noautovalidity
            f.negative = t in self.model.negative_enums
        elif cat in ("struct", "union"):
            f.elem = cat
            f.wire = f"sizeof({t})" if cat == "union" else f"kWire_{t}"
        else:
            raise CodecError(f"codec: {where}: cannot encode pointer to {t} ({cat})")
        if lengths:
            self._check_order(members, index, m.altlen or lengths[0], where)
            f.kind = "array"
            f.count = self._len_expr(names, pointers, lengths[0], m.altlen, where)
        else:
            f.kind = "one"
        return f

    # --- commands ------------------------------------------------------------------------------

    def _command(self, c) -> list[Field]:
        names = [p.name for p in c.params]
        pointers = {p.name for p in c.params if p.pointer_depth}
        fields = []
        for i, p in enumerate(c.params):
            where = f"{c.name}({p.name})"
            t = self.model.resolve(p.type)
            if c.name in codec_policy.TEMPLATE_COMMANDS and p.name == "pData":
                sets = [q.name for q in c.params if self.model.resolve(q.type) == "VkDescriptorSet"]
                fields.append(Field(p.name, t, p.decl, "template_data", wire="4", set_param=sets[0] if sets else ""))
                self._used_overrides.add(("param", c.name, p.name))
                continue
            if p.noautovalidity and (p.pointer_depth or self.category(t) == "handle"):
                if (c.name, p.name) not in ov.ALWAYS_VALID_PARAMS:
                    raise CodecError(f"codec_overrides.py: {where} is noautovalidity: add it to ALWAYS_VALID_PARAMS")
                self._used_overrides.add(("param", c.name, p.name))
            f = self._field(p, t, where, names, pointers, None, c.params, i, is_member=False)
            if f.elem in ("struct", "union") and f.kind in ("value", "one", "array"):
                self.visit_struct(f.type)
            fields.append(f)
        return fields

    def _check_overrides(self):
        stale = []
        for key in ov.CONDITIONS:
            if ("cond",) + key not in self._used_overrides:
                stale.append(".".join(key))
        for key in ov.ALWAYS_VALID:
            if ("always",) + key not in self._used_overrides:
                stale.append(".".join(key))
        for key in ov.ALWAYS_VALID_PARAMS:
            if ("param",) + key not in self._used_overrides:
                stale.append(".".join(key))
        for name in list(ov.STRUCT_PROLOGUES) + list(ov.STRUCT_EPILOGUES):
            if name not in self.struct_fields:
                stale.append(name)
        for name in list(ov.COMMAND_PROLOGUES) + list(ov.COMMAND_EXTRA_ARGS) + list(ov.POOL_PARENTS) + \
                list(ov.PARAM_PARENTS) + list(ov.RESETS_CHILDREN):
            if name not in self.command_fields:
                stale.append(name)
        if stale:
            raise CodecError("codec_overrides.py: entries that match nothing in the codec: " + ", ".join(stale))

    # --- handle-table bookkeeping ----------------------------------------------------------------

    def destroyed_param(self, c) -> Field | None:
        """The handle (or handle array) a vkDestroy*/vkFree* command ends."""
        if not (c.name.startswith("vkDestroy") or c.name.startswith("vkFree")):
            return None
        handles = [f for f in self.command_fields[c.name]
                   if f.elem == "handle" and f.kind in ("value", "array")]
        if not handles:
            raise CodecError(f"codec: {c.name} destroys no handle")
        return handles[-1]

    def fingerprint(self) -> int:
        lines = []
        for i, c in enumerate(self.commands):
            lines.append(f"cmd {FIRST_COMMAND_ID + i:#06x} {c.name} {self.policy[c.name]}: " +
                         " ".join(f.signature() for f in self.command_fields[c.name]))
        for name in sorted(self.struct_fields):
            lines.append(f"struct {name} [{','.join(self.extenders.get(name, []))}]: " +
                         " ".join(f.signature() for f in self.struct_fields[name]))
        h = 0xcbf29ce484222325
        for byte in "\n".join(lines).encode():
            h ^= byte
            h = (h * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
        return h


# =============================================================================================
# C++ emission

def _count(f: Field, prefix: str) -> str:
    return f"static_cast<uint64_t>({f.count.replace('{P}', prefix)})"


def _field_name(f: Field) -> str:
    return f'"{f.name}"'


def _encode_elem(f: Field, expr: str) -> list[str]:
    """Encode one element `expr` (an lvalue) of field f."""
    if f.elem == "scalar":
        return [f"e.{f.method}({expr});"]
    if f.elem == "enum32":
        return [f"e.enum32({expr});"]
    if f.elem == "handle":
        return [f"e.handle({expr});"]
    if f.elem == "struct":
        return [f"encode_struct(e, {expr});"]
    if f.elem == "union":
        return [f"e.words(&{expr}, sizeof({f.type}) / 4);"]
    raise CodecError(f"codec: cannot encode element {f.elem}")


def _decode_elem(f: Field, target: str, nullable: bool) -> list[str]:
    """Decode one element into lvalue `target`."""
    name = _field_name(f)
    if f.elem == "scalar":
        return [f"{target} = d.{f.method}({name});"]
    if f.elem == "enum32":
        neg = ", true" if f.negative else ""
        return [f"{target} = d.enum32<{f.type}>({name}{neg});"]
    if f.elem == "handle":
        return [f"{target} = d.handle<{f.type}>({f.objtype}, {'true' if nullable else 'false'}, {name});"]
    if f.elem == "struct":
        return [f"decode_struct(d, {target});"]
    if f.elem == "union":
        return [f"d.words(&{target}, sizeof({f.type}) / 4, {name});"]
    raise CodecError(f"codec: cannot decode element {f.elem}")


def _indent(lines, n=1):
    pad = "    " * n
    return [pad + line if line else line for line in lines]


def encode_field(f: Field, acc: str, prefix: str) -> list[str]:
    """Encoder statements for field f; `acc` accesses it (e.g. "s.pViewports" or "pCreateInfo")."""
    k = f.kind
    cond = f.condition
    if k in ("stype", "skip"):
        return []
    if k == "pnext":
        raise CodecError("pNext handled by the structure")
    if k == "value":
        if f.dims:
            return [f"for (uint32_t i = 0; i < {f.dims[0]}; ++i) {{"] + _indent(_encode_elem(f, f"{acc}[i]")) + ["}"]
        if cond and f.elem == "handle":
            return [f"e.handle(({cond}) ? {acc} : {f.type}{{}});"]
        if cond:
            raise CodecError(f"codec: condition on non-handle value {f.name}")
        return _encode_elem(f, acc)
    ptr = f"(({cond}) ? {acc} : nullptr)" if cond else acc
    if k == "one":
        return [f"if (e.present({ptr})) {{"] + _indent(_encode_elem(f, f"*{acc}")) + ["}"]
    if k == "string":
        return [f"e.string({ptr});"]
    if k in ("array", "blob", "string_array", "out_handles"):
        n = _count(f, prefix)
        lines = ["{", f"    const uint64_t n = {n};", f"    const auto *p = n > 0 ? {ptr} : nullptr;", "    if (e.present(p)) {"]
        if k == "blob":
            body = ["e.bytes(p, static_cast<size_t>(n));"]
        elif k == "string_array":
            body = ["for (uint64_t i = 0; i < n; ++i)", "    e.string(p[i]);"]
        elif k == "out_handles":
            body = ["for (uint64_t i = 0; i < n; ++i)", "    e.handle(p[i]);"]
        elif f.elem == "scalar" and f.scalar_ctype in BULK:
            body = [f"e.{BULK[f.scalar_ctype]}(p, static_cast<size_t>(n));"]
        else:
            body = ["for (uint64_t i = 0; i < n; ++i) {"] + _indent(_encode_elem(f, "p[i]")) + ["}"]
        return lines + _indent(body, 2) + ["    }", "}"]
    if k == "out_value":
        return [f"if (e.present({acc})) e.{f.method}(*{acc});"]
    if k == "out_storage":
        n = _count(f, prefix)
        return [f"e.present({n} > 0 ? {acc} : nullptr);"]
    if k == "template_data":
        return [f"codec::encode_template_data(e, template_layout, {acc}, {f.set_param or 'VK_NULL_HANDLE'});"]
    raise CodecError(f"codec: cannot encode kind {k}")


def decode_field(f: Field, target: str, prefix: str, top_level: bool) -> list[str]:
    """Decoder statements for field f into `target` (an lvalue such as "s.pViewports")."""
    k = f.kind
    name = _field_name(f)
    if k in ("stype", "skip"):
        return []
    if k == "value":
        if f.dims:
            return [f"for (uint32_t i = 0; i < {f.dims[0]}; ++i) {{"] + \
                _indent(_decode_elem(f, f"{target}[i]", f.nullable)) + ["}"]
        if f.elem == "handle" and (top_level or f.parent_slot):
            nullable = "true" if f.nullable else "false"
            slot = f"&{target}_id" if top_level else "&d.parent_id()"
            return [f"{target} = d.handle<{f.type}>({f.objtype}, {nullable}, {name}, {slot});"]
        return _decode_elem(f, target, f.nullable)
    opt = "true" if f.optional else "false"
    if k == "one":
        return [f"if (d.present({name}, {opt})) {{",
                f"    auto *o = d.object<{f.type}>({name});",
                "    if (o) {"] + _indent(_decode_elem(f, "*o", f.nullable), 2) + [
                f"        {target} = o;", "    }", "}"]
    if k == "string":
        return [f"{target} = d.string({name}, {opt});"]
    if k in ("array", "blob", "string_array", "out_handles"):
        n = _count(f, prefix)
        absent_ok = "true" if f.optional else "n == 0"
        lines = ["{", f"    const uint64_t n = {n};", f"    if (d.present({name}, {absent_ok})) {{"]
        if k == "blob":
            body = [f"{target} = d.bytes(n, {name});"]
        elif k == "string_array":
            body = [f"auto *a = d.array<const char *>(n, 1, {name});",
                    "for (uint64_t i = 0; a && i < n && d.ok(); ++i)",
                    f"    a[i] = d.string({name}, false);",
                    f"{target} = a;"]
        elif k == "out_handles":
            body = [f"auto *ids = d.array<uint64_t>(n, 8, {name});",
                    "for (uint64_t i = 0; ids && i < n && d.ok(); ++i)",
                    f"    ids[i] = d.created_id({name});",
                    f"{target} = d.array<{f.type}>(n, 0, {name});",
                    f"{target}_ids = ids;",
                    f"{target}_count = static_cast<uint32_t>(n);"]
        else:
            body = [f"auto *a = d.array<{f.type}>(n, {f.wire}, {name});"]
            if f.elem == "scalar" and f.scalar_ctype in BULK:
                body += [f"d.{BULK[f.scalar_ctype]}(a, static_cast<size_t>(n), {name});"]
            elif f.elem == "handle" and top_level:
                nullable = "true" if f.nullable else "false"
                body += [f"auto *ids = d.array<uint64_t>(n, 0, {name});",
                         "for (uint64_t i = 0; a && ids && i < n && d.ok(); ++i)",
                         f"    a[i] = d.handle<{f.type}>({f.objtype}, {nullable}, {name}, &ids[i]);",
                         f"{target}_ids = ids;"]
            else:
                body += ["for (uint64_t i = 0; a && i < n && d.ok(); ++i) {"] + \
                    _indent(_decode_elem(f, "a[i]", f.nullable)) + ["}"]
            body += [f"{target} = a;"]
        return lines + _indent(body, 2) + ["    }", "}"]
    if k == "out_value":
        return [f"if (d.present({name}, true)) {{",
                f"    auto *o = d.object<{f.type}>({name});",
                f"    if (o) *o = d.{f.method}({name});",
                f"    {target} = o;", "}"]
    if k == "out_storage":
        n = _count(f, prefix)
        return [f"if (d.present({name}, true))",
                f"    {target} = d.array<{f.type}>({n}, 0, {name});"]
    if k == "template_data":
        return [f"codec::decode_template_data(d, {prefix}templateData);",
                f"{target} = {prefix}templateData.pData;"]
    raise CodecError(f"codec: cannot decode kind {k}")


# ---------------------------------------------------------------------------------------------

def _struct_functions(codec: Codec, name: str) -> list[str]:
    struct = codec.model.structs[name]
    fields = codec.struct_fields[name]
    has_chain = any(f.kind == "pnext" for f in fields)
    prologue = ov.STRUCT_PROLOGUES.get(name)
    epilogue = ov.STRUCT_EPILOGUES.get(name)
    out = []
    # Encoder.
    sig = f"void encode_struct(Encoder &e, const {name} &s{', bool chain' if has_chain else ''})"
    body = []
    if prologue:
        body += prologue.split("\n")
    if has_chain:
        body += [f"if (chain) encode_chain_{name}(e, s.pNext);"]
    for f in fields:
        if f.kind == "pnext":
            continue
        body += encode_field(f, f"s.{f.name}", "s.")
    if not body:
        body = ["static_cast<void>(e);", "static_cast<void>(s);"]
    out += [sig + " {"] + _indent(body) + ["}", ""]
    # Decoder.
    sig = f"bool decode_struct(Decoder &d, {name} &s{', bool chain' if has_chain else ''})"
    body = []
    if has_chain:
        body += [f'const DepthGuard guard(d, "{name}");', "if (!guard.ok()) return false;"]
    for f in fields:
        if f.kind == "stype":
            body += [f"s.sType = {struct.stype};"]
        elif f.kind == "pnext":
            chain_expr = f"decode_chain_{name}(d)"
            if not f.decl.startswith("const"):
                chain_expr = f"const_cast<void *>({chain_expr})"  # the arena's memory is mutable
            body += [f"if (chain) s.pNext = {chain_expr};"]
        else:
            body += decode_field(f, f"s.{f.name}", "s.", top_level=False)
    if epilogue:
        body += ["if (d.ok()) {"] + _indent(epilogue.split("\n")) + ["}"]
    body += ["return d.ok();"]
    out += [sig + " {"] + _indent(body) + ["}", ""]
    # pNext chain.
    if has_chain:
        exts = codec.extenders.get(name, [])
        dropped = sorted(o.name for o in codec.model.structs.values()
                         if o.name in ov.DROPPED_EXTENSIONS and name in [codec.model.resolve(p) for p in o.extends])
        out += [f"void encode_chain_{name}(Encoder &e, const void *next) {{",
                "    uint32_t length = 0;",
                "    for (auto *p = static_cast<const VkBaseInStructure *>(next); p; p = p->pNext) {",
                f'        if (!e.chain_step(length, "{name}")) break;',
                "        switch (p->sType) {"]
        for x in exts:
            xs = codec.model.structs[x]
            out += [f"        case {xs.stype}:",
                    f"            e.u32(static_cast<uint32_t>(p->sType));",
                    f"            encode_struct(e, *reinterpret_cast<const {x} *>(p), false);",
                    "            break;"]
        for x in dropped:
            out += [f"        case {codec.model.structs[x].stype}: // {ov.DROPPED_EXTENSIONS[x]}",
                    "            break;"]
        out += ["        default:",
                f'            e.skipped_structure(p->sType, "{name}");',
                "            break;",
                "        }", "    }", "    e.u32(0);", "}", ""]
        out += [f"const void *decode_chain_{name}(Decoder &d) {{",
                "    const void *head = nullptr;",
                "    VkBaseOutStructure *last = nullptr;",
                "    uint32_t length = 0;",
                "    while (d.ok()) {",
                '        const uint32_t stype = d.u32("sType");',
                "        if (!d.ok() || stype == 0) break;",
                f'        if (!d.chain_step(length, "{name}")) break;',
                "        VkBaseOutStructure *node = nullptr;",
                "        switch (stype) {"]
        for x in exts:
            xs = codec.model.structs[x]
            out += [f"        case {xs.stype}:",
                    f"            node = decode_chain_node<{x}>(d, {xs.stype});",
                    "            break;"]
        out += ["        default:",
                f'            d.unexpected_structure(stype, "{name}");',
                "            break;",
                "        }",
                "        if (!node) break;",
                "        if (last)",
                "            last->pNext = node;",
                "        else",
                "            head = node;",
                "        last = node;",
                "    }",
                "    return head;", "}", ""]
    return guarded(struct.protect, out)


def _wire_constants(codec: Codec) -> list[str]:
    lines = []
    emitted = set()

    def emit(name):
        if name in emitted:
            return
        for f in codec.struct_fields[name]:
            if f.kind == "value" and f.elem == "struct":
                emit(f.type)
        # A pointer member takes at least its presence byte; a value its element's bytes.
        parts = [f.wire if f.kind in ("value", "pnext") else "1"
                 for f in codec.struct_fields[name] if f.kind not in ("stype", "skip")]
        if codec.model.structs[name].category == "union":
            parts = [f"sizeof({name})"]
        lines.append(f"inline constexpr size_t kWire_{name} = {' + '.join(parts) or '0'};")
        emitted.add(name)

    for name in codec.struct_order:
        emit(name)
    return lines


def _encoder_params(c, fields) -> str:
    params = [f"Encoder &e"] + [p.decl for p in c.params]
    for t, n in ov.COMMAND_EXTRA_ARGS.get(c.name, []):
        params.append(f"{t} {n}")
    if c.name in codec_policy.TEMPLATE_COMMANDS:
        params.append("const DescriptorTemplateLayout &template_layout")
    return ", ".join(params)


def _decoded_members(c, fields) -> list[str]:
    lines = []
    for p, f in zip(c.params, fields):
        decl = p.decl
        if f.kind == "value" and f.dims:
            decl = decl[len("const "):] if decl.startswith("const ") else decl
            lines.append(f"    {decl}{{}};")
            continue
        if f.kind == "out_handles":
            lines.append(f"    {decl}{{}}; // storage for the created handles: pass to the driver")
            lines.append(f"    const uint64_t *{p.name}_ids{{}}; // the client's ids: register them after creation")
            lines.append(f"    uint32_t {p.name}_count{{}};")
            continue
        if f.kind == "template_data":
            lines.append(f"    {decl}{{}}; // laid out for the canonical template (descriptor_template.h)")
            lines.append("    DecodedTemplateData templateData{};")
            continue
        comment = ""
        if f.kind == "skip":
            comment = " // never sent: always null"
        lines.append(f"    {decl}{{}};{comment}")
        if f.elem == "handle" and f.kind == "value":
            lines.append(f"    uint64_t {p.name}_id{{}};")
        if f.elem == "handle" and f.kind == "array":
            lines.append(f"    const uint64_t *{p.name}_ids{{}};")
    if c.name in ov.POOL_PARENTS:
        lines.append("    uint64_t parent_id{}; // the pool the handles are allocated from")
    return lines


def _command_encoder(codec: Codec, c) -> list[str]:
    fields = codec.command_fields[c.name]
    body = []
    if c.name in ov.COMMAND_PROLOGUES:
        body += ov.COMMAND_PROLOGUES[c.name].split("\n")
    body.append(f"e.command(static_cast<uint16_t>(VkCommandId::{c.name}));")
    for p, f in zip(c.params, fields):
        if f.kind == "skip":
            body.append(f"static_cast<void>({p.name});")
        body += encode_field(f, p.name, "")
    return [f"void encode_{c.name}({_encoder_params(c, fields)}) {{"] + _indent(body) + ["}", ""]


def _command_decoder(codec: Codec, c) -> list[str]:
    fields = codec.command_fields[c.name]
    body = [f"out = {{}};", f'd.begin_command("{c.name}");']
    if c.name in ov.POOL_PARENTS:
        body.append("d.parent_id() = 0;")
    for f in fields:
        body += decode_field(f, f"out.{f.name}", "out.", top_level=True)
    if c.name in ov.POOL_PARENTS:
        body.append("out.parent_id = d.parent_id();")
    body.append("return d.end_command();")
    lines = [f"bool decode_args_{c.name}(Decoder &d, Decoded_{c.name} &out) {{"] + _indent(body) + ["}", ""]
    lines += [f"bool decode_{c.name}(Decoder &d, Decoded_{c.name} &out) {{",
              f'    d.begin_command("{c.name}");',
              f'    if (!d.expect_command(static_cast<uint16_t>(VkCommandId::{c.name}), "{c.name}")) return false;',
              f"    return decode_args_{c.name}(d, out);", "}", ""]
    return lines


def _handle_changes(codec: Codec, c) -> list[str] | None:
    fields = codec.command_fields[c.name]
    body = []
    outputs = [f for f in fields if f.kind == "out_handles"]
    for f in outputs:
        parent = "0"
        if c.name in ov.POOL_PARENTS:
            parent = "cmd.parent_id"
        elif c.name in ov.PARAM_PARENTS:
            parent = f"cmd.{ov.PARAM_PARENTS[c.name]}_id"
        body += [f"for (uint32_t i = 0; cmd.{f.name} && cmd.{f.name}_ids && i < cmd.{f.name}_count; ++i) {{",
                 f"    if (cmd.{f.name}_ids[i] == 0) continue; // a failed element of a batch",
                 f"    if (!table.insert(cmd.{f.name}_ids[i], {f.objtype}, cmd.{f.name}[i], {parent}, error)) return false;",
                 "}"]
    destroyed = codec.destroyed_param(c)
    if destroyed is not None:
        if destroyed.kind == "value":
            body += [f"table.remove(cmd.{destroyed.name}_id);"]
        else:
            n = _count(destroyed, "cmd.")
            body += [f"for (uint64_t i = 0; cmd.{destroyed.name}_ids && i < {n}; ++i)",
                     f"    table.remove(cmd.{destroyed.name}_ids[i]);"]
    if c.name in ov.RESETS_CHILDREN:
        body += [f"table.remove_children(cmd.{ov.RESETS_CHILDREN[c.name]}_id);"]
    if not body:
        return None
    return body


def emit(model) -> dict[str, str]:
    codec = Codec(model)
    fp = codec.fingerprint()
    out = {}

    # ---------------------------------------------------------------- vk_codec.h
    h = [HEADER.format(script="emit_codec.py"), "#pragma once", "",
         "// The generated Vulkan wire codec (see protocol/codec/codec.h for the encoding rules).", "//",
         "// Layer side:  encode_vkCmdDraw(encoder, ...the Vulkan arguments...) after the driver returned.",
         "// Agent side:  decode_vkCmdDraw(decoder, decoded) or dispatch_decoded(decoder, visitor); then the",
         "//              replayer calls the driver with the decoded arguments and apply_handle_changes().",
         "", '#include "codec.h"', '#include "descriptor_template.h"', "",
         "#include <vulkan/vulkan.h>", "", "#include <cstdint>", "#include <string>", "#include <string_view>", "",
         "namespace splitvk::codec {", "",
         "// A hash of every encoded command and structure layout: peers built from another vk.xml (or",
         "// another generator) disagree on it, and the handshake rejects them.",
         f"inline constexpr uint64_t kCodecFingerprint = 0x{fp:016x}ull;",
         f"inline constexpr uint32_t kCommandCount = {len(codec.commands)};",
         f"inline constexpr uint16_t kFirstCommandId = 0x{FIRST_COMMAND_ID:04x};",
         f"inline constexpr uint16_t kLastCommandId = 0x{FIRST_COMMAND_ID + len(codec.commands) - 1:04x};", "",
         "// Command ids: 0x0100 + the index of the command in name order (the MessageType range",
         "// 0x0100-0x0FFF). Aliases (vk*KHR of promoted commands) are encoded under the core name.",
         "enum class VkCommandId : uint16_t {"]
    for i, c in enumerate(codec.commands):
        h.append(f"    {c.name} = 0x{FIRST_COMMAND_ID + i:04x},")
    h += ["};", "",
          "enum class CommandPolicy : uint8_t {",
          "    Forward, // the layer encodes every call",
          "    Manual,  // hand-written semantics: the layer decides when to encode (codegen/codec_policy.py)",
          "};", "",
          "bool is_command_id(uint16_t id);",
          "// \"vkCmdDraw\", or \"unknown\".",
          "const char *command_name(VkCommandId id);",
          "CommandPolicy command_policy(VkCommandId id);", "",
          "// True for a device extension the layer forwards but the agent never enables: its commands are",
          "// the client's and its structures never cross the wire (codegen/allowlist.py CLIENT_ONLY_EXTENSIONS).",
          "bool client_only_device_extension(std::string_view name);", "",
          "// ---------------------------------------------------------------------------------------------",
          "// Encoders. Each writes the command id, then the arguments. Created handles (pBuffer, ...) are",
          "// read from the output arguments, so call after the driver returned. pAllocator is never sent.", ""]
    for c in codec.commands:
        h += guarded(c.protect, [f"void encode_{c.name}({_encoder_params(c, codec.command_fields[c.name])});"])
    h += ["", "// ---------------------------------------------------------------------------------------------",
          "// Decoded commands: the Vulkan arguments with the agent's handles (and the client's ids, *_id),",
          "// pointers into the decoder's arena. decode_* reads the command id first.", ""]
    for c in codec.commands:
        lines = [f"struct Decoded_{c.name} {{"] + _decoded_members(c, codec.command_fields[c.name]) + ["};",
                 f"bool decode_{c.name}(Decoder &d, Decoded_{c.name} &out);", ""]
        h += guarded(c.protect, lines)
    h += ["// ---------------------------------------------------------------------------------------------",
          "// Handle-table bookkeeping, to call after the driver call succeeded: registers created handles",
          "// (with their pool as parent), forgets destroyed and freed ones (and pool children).", ""]
    changes = {}
    for c in codec.commands:
        body = _handle_changes(codec, c)
        if body:
            changes[c.name] = body
            h += guarded(c.protect, [
                f"bool apply_handle_changes(HandleTable &table, const Decoded_{c.name} &cmd, std::string *error = nullptr);"])
    h += ["// True for the commands above.", "bool changes_handles(VkCommandId id);", "",
          "// ---------------------------------------------------------------------------------------------",
          "// The agent's view: one virtual per command. A method returns false to stop (a replay error).",
          "class CommandVisitor {", "public:", "    virtual ~CommandVisitor() = default;",
          "    // Called for commands the visitor does not override. The default refuses them.",
          "    virtual bool unhandled(VkCommandId id);"]
    for c in codec.commands:
        h += guarded(c.protect, [
            f"    virtual bool {c.name}(const Decoded_{c.name} &) {{ return unhandled(VkCommandId::{c.name}); }}"])
    h += ["};", "",
          "// Reads one command (id, then arguments) and calls the visitor. False on a decode error (then",
          "// d.error() says why) or when the visitor returned false (d.ok() is still true). An unknown id",
          "// is a decode error.",
          "bool dispatch_decoded(Decoder &d, CommandVisitor &visitor);",
          "// The same when the id was already read.",
          "bool dispatch_decoded(Decoder &d, VkCommandId id, CommandVisitor &visitor);", "",
          "} // namespace splitvk::codec", ""]
    out["vk_codec.h"] = "\n".join(h)

    # ---------------------------------------------------------------- vk_codec_internal.h
    ih = [HEADER.format(script="emit_codec.py"), "#pragma once", "",
          "// Structure codecs shared by the generated sources. Not for users of the codec.", "",
          '#include "descriptor_template.h"', '#include "rules.h"', '#include "vk_codec.h"', "",
          "namespace splitvk::codec {", "",
          "// Minimum bytes a structure takes on the wire (bounds array counts before allocation)."]
    ih += _wire_constants(codec)
    ih += [""]
    for name in codec.struct_order:
        struct = model.structs[name]
        if struct.category == "union":
            ih += [f"static_assert(sizeof({name}) % 4 == 0, \"unions are sent as 32-bit words\");"]
            continue
        has_chain = any(f.kind == "pnext" for f in codec.struct_fields[name])
        if has_chain:
            ih += guarded(struct.protect, [
                f"void encode_struct(Encoder &e, const {name} &s, bool chain = true);",
                f"bool decode_struct(Decoder &d, {name} &s, bool chain = true);",
                f"void encode_chain_{name}(Encoder &e, const void *next);",
                f"const void *decode_chain_{name}(Decoder &d);"])
        else:
            ih += guarded(struct.protect, [
                f"void encode_struct(Encoder &e, const {name} &s);",
                f"bool decode_struct(Decoder &d, {name} &s);"])
    ih += ["",
           "// One element of a pNext chain: allocated in the arena, its members decoded (not its chain).",
           "template <class T>", "VkBaseOutStructure *decode_chain_node(Decoder &d, VkStructureType stype) {",
           '    T *node = d.object<T>("pNext");', "    if (!node) return nullptr;", "    node->sType = stype;",
           "    if (!decode_struct(d, *node, false)) return nullptr;",
           "    return reinterpret_cast<VkBaseOutStructure *>(node);", "}", ""]
    for c in codec.commands:
        ih += guarded(c.protect, [f"bool decode_args_{c.name}(Decoder &d, Decoded_{c.name} &out);"])
    ih += ["", "} // namespace splitvk::codec", ""]
    out["vk_codec_internal.h"] = "\n".join(ih)

    # ---------------------------------------------------------------- structures
    struct_names = [n for n in codec.struct_order if model.structs[n].category != "union"]
    for i in range(STRUCT_FILES):
        src = [HEADER.format(script="emit_codec.py"), '#include "vk_codec_internal.h"', "",
               "namespace splitvk::codec {", ""]
        for name in struct_names[i::STRUCT_FILES]:
            src += _struct_functions(codec, name)
        src += ["} // namespace splitvk::codec", ""]
        out[f"vk_codec_structs_{i}.cpp"] = "\n".join(src)

    # ---------------------------------------------------------------- commands
    for i in range(COMMAND_FILES):
        src = [HEADER.format(script="emit_codec.py"), '#include "vk_codec_internal.h"', "",
               "namespace splitvk::codec {", ""]
        for c in codec.commands[i::COMMAND_FILES]:
            src += guarded(c.protect, _command_encoder(codec, c) + _command_decoder(codec, c))
        src += ["} // namespace splitvk::codec", ""]
        out[f"vk_codec_commands_{i}.cpp"] = "\n".join(src)

    # ---------------------------------------------------------------- dispatch
    src = [HEADER.format(script="emit_codec.py"), '#include "vk_codec_internal.h"', "",
           "#include <cstdio>", "", "namespace splitvk::codec {", "", "namespace {", "",
           "struct CommandInfo {", "    const char *name;", "    CommandPolicy policy;", "    bool changes_handles;",
           "    bool (*dispatch)(Decoder &, CommandVisitor &);", "};", ""]
    for c in codec.commands:
        src += guarded(c.protect, [
            f"bool dispatch_{c.name}(Decoder &d, CommandVisitor &visitor) {{",
            f"    Decoded_{c.name} cmd;",
            f"    if (!decode_args_{c.name}(d, cmd)) return false;",
            f"    return visitor.{c.name}(cmd);", "}", ""])
    src += [f"const CommandInfo kCommands[{len(codec.commands)}] = {{"]
    for c in codec.commands:
        pol = "CommandPolicy::Manual" if codec.policy[c.name] == "manual" else "CommandPolicy::Forward"
        ch = "true" if c.name in changes else "false"
        src += [f'    {{"{c.name}", {pol}, {ch}, &dispatch_{c.name}}},']
    src += ["};", "", "const CommandInfo *info(uint16_t id) {",
            "    if (id < kFirstCommandId || id > kLastCommandId) return nullptr;",
            "    return &kCommands[id - kFirstCommandId];", "}", "", "} // namespace", "",
            "bool is_command_id(uint16_t id) {", "    return info(id) != nullptr;", "}", "",
            "const char *command_name(VkCommandId id) {",
            "    const CommandInfo *i = info(static_cast<uint16_t>(id));",
            '    return i ? i->name : "unknown";', "}", "",
            "CommandPolicy command_policy(VkCommandId id) {",
            "    const CommandInfo *i = info(static_cast<uint16_t>(id));",
            "    return i ? i->policy : CommandPolicy::Manual;", "}", "",
            "bool client_only_device_extension(std::string_view name) {"] + [
            f'    if (name == "{n}") return true; // {why}' for n, why in sorted(allowlist.CLIENT_ONLY_EXTENSIONS.items())] + [
            "    return false;", "}", "",
            "bool changes_handles(VkCommandId id) {",
            "    const CommandInfo *i = info(static_cast<uint16_t>(id));",
            "    return i && i->changes_handles;", "}", "",
            "bool CommandVisitor::unhandled(VkCommandId) {", "    return false;", "}", "",
            "bool dispatch_decoded(Decoder &d, VkCommandId id, CommandVisitor &visitor) {",
            "    const CommandInfo *i = info(static_cast<uint16_t>(id));",
            "    if (!i) {", "        char text[64];",
            '        std::snprintf(text, sizeof(text), "unknown Vulkan command id 0x%04x", static_cast<unsigned>(id));',
            "        d.fail(text);", "        return false;", "    }",
            "    return i->dispatch(d, visitor);", "}", "",
            "bool dispatch_decoded(Decoder &d, CommandVisitor &visitor) {",
            '    const uint16_t id = d.u16("command");', "    if (!d.ok()) return false;",
            "    return dispatch_decoded(d, static_cast<VkCommandId>(id), visitor);", "}", ""]
    for c in codec.commands:
        if c.name in changes:
            src += guarded(c.protect, [
                f"bool apply_handle_changes(HandleTable &table, const Decoded_{c.name} &cmd, std::string *error) {{"] +
                _indent(changes[c.name]) + ["    static_cast<void>(error);", "    return true;", "}", ""])
    # Object type names for error lines.
    src += ["const char *object_type_name(VkObjectType type) {", "    switch (type) {"]
    for handle, ot in sorted(model.handle_object_type.items(), key=lambda kv: kv[1]):
        if handle in model.handle_types:
            src += [f"    case {ot}:", f'        return "{handle}";']
    src += ["    default:", "        break;", "    }",
            "    static thread_local char text[32];",
            '    std::snprintf(text, sizeof(text), "VkObjectType(%d)", static_cast<int>(type));',
            "    return text;", "}", "", "} // namespace splitvk::codec", ""]
    out["vk_codec_dispatch.cpp"] = "\n".join(src)

    out["vk_codec_smoke_test.cpp"] = _smoke_test(codec, changes)
    return out


# =============================================================================================
# The generated smoke test: every command with zero/null arguments (handles registered, required
# structures zero-filled with their sType) encodes, decodes without error, and re-encodes from the
# decoded arguments to the same bytes.

def _fill_functions(codec: Codec) -> list[str]:
    decls, defs = [], []
    for name in codec.struct_order:
        struct = codec.model.structs[name]
        if struct.category == "union":
            continue
        decls.append(f"void fill(Smoke &f, {name} &s);")
        body = ["static_cast<void>(f);"]
        for fld in codec.struct_fields[name]:
            if fld.kind == "stype":
                body.append(f"s.sType = {struct.stype};")
            elif fld.kind == "value" and fld.elem == "handle" and not fld.dims:
                body.append(f"s.{fld.name} = f.handle<{fld.type}>({fld.objtype});")
            elif fld.kind == "value" and fld.elem == "struct" and not fld.dims:
                body.append(f"fill(f, s.{fld.name});")
            elif fld.kind == "value" and fld.elem == "struct" and fld.dims:
                body.append(f"for (auto &x : s.{fld.name}) fill(f, x);")
            elif fld.kind == "one" and not fld.optional and fld.elem == "struct":
                body.append(f"s.{fld.name} = make_filled<{fld.type}>(f);")
            elif fld.kind == "one" and not fld.optional:
                body.append(f"s.{fld.name} = f.make<{fld.type}>();")
            elif fld.kind == "string" and not fld.optional:
                body.append(f's.{fld.name} = "";')
        if len(body) == 1:
            body.append("static_cast<void>(s);")
        defs += [f"void fill(Smoke &f, {name} &s) {{"] + _indent(body) + ["}", ""]
    return decls + ["", "template <class T>", "T *make_filled(Smoke &f) {", "    T *p = f.make<T>();",
                    "    fill(f, *p);", "    return p;", "}", ""] + defs


def _smoke_test(codec: Codec, changes) -> str:
    lines = [HEADER.format(script="emit_codec.py"),
             "// Every generated command codec with zero/null arguments: encode, decode (no error, all bytes",
             "// consumed), re-encode from the decoded arguments to the same bytes.", "",
             '#include "codec_test_util.h"', '#include "vk_codec_internal.h"', "",
             "#include <gtest/gtest.h>", "", "#include <string>", "",
             "namespace splitvk::codec {", "namespace {", "", "using test::Smoke;", ""]
    lines += _fill_functions(codec)
    names = []
    for c in codec.commands:
        if c.name in codec_policy.TEMPLATE_COMMANDS:
            continue  # hand-written encoders: tested in codec_template_test.cpp
        fields = codec.command_fields[c.name]
        body, args, re_args = [], [], []
        for p, f in zip(c.params, fields):
            var = f"a_{p.name}"
            if f.kind == "value" and f.dims:
                base = p.decl.split("[")[0].replace("const ", "").rsplit(" ", 1)[0]
                body.append(f"{base} {var}[{f.dims[0]}] = {{}};")
            elif f.kind == "value" and f.elem == "handle":
                body.append(f"const {f.type} {var} = f.handle<{f.type}>({f.objtype});")
            elif f.kind == "value":
                body.append(f"const {p.type} {var}{{}};")
            elif f.kind == "one" and f.elem == "struct":
                body.append(f"const {f.type} *{var} = make_filled<{f.type}>(f);")
            elif f.kind == "one":
                body.append(f"const {f.type} *{var} = f.make<{f.type}>();")
            elif f.kind == "out_handles" and f.count == "1":
                body.append(f"{f.type} {var}_storage = f.output<{f.type}>();")
                body.append(f"{f.type} *{var} = &{var}_storage;")
            elif f.kind == "out_value":
                body.append(f"{f.type} {var}_storage{{}};")
                body.append(f"{f.type} *{var} = &{var}_storage;")
            else:
                body.append(re.sub(rf"\b{p.name}\b", var, p.decl, count=1) + "{};")
            args.append(var)
            re_args.append(f"d.{p.name}")
        extra = [n for _, n in ov.COMMAND_EXTRA_ARGS.get(c.name, [])]
        extra_vals = ["{}" for _ in extra]
        body.append(f"encode_{c.name}({', '.join(['f.enc'] + args + extra_vals)});")
        body.append(f"Decoder dec(f.enc.data(), f.table, f.arena);")
        body.append(f"Decoded_{c.name} d;")
        body.append(f"if (!decode_{c.name}(dec, d)) return dec.error();")
        body.append('if (!dec.at_end()) return "bytes left after decoding";')
        for f in fields:
            if f.kind == "out_handles":
                body.append(f"for (uint32_t i = 0; i < d.{f.name}_count; ++i) d.{f.name}[i] = to_handle<{f.type}>(d.{f.name}_ids[i]);")
        body.append("Encoder again;")
        body.append(f"encode_{c.name}({', '.join(['again'] + re_args + extra_vals)});")
        body.append("return test::same_bytes(f.enc.data(), again.data());")
        lines += guarded(c.protect, [f"std::string smoke_{c.name}() {{", "    Smoke f;"] + _indent(body) + ["}", ""])
        names.append(c)
    struct_cases = []
    for name in codec.struct_order:
        struct = codec.model.structs[name]
        if struct.category == "union":
            continue
        lines += guarded(struct.protect, [
            f"std::string smoke_struct_{name}() {{", "    Smoke f;", f"    {name} s{{}};", "    fill(f, s);",
            "    encode_struct(f.enc, s);", "    Decoder dec(f.enc.data(), f.table, f.arena);",
            f"    {name} d{{}};", "    if (!decode_struct(dec, d)) return dec.error();",
            '    if (!dec.at_end()) return "bytes left after decoding";', "    Encoder again;",
            "    encode_struct(again, d);", "    return test::same_bytes(f.enc.data(), again.data());", "}", ""])
        struct_cases.append(struct)
    lines += ["struct SmokeCase {", "    const char *name;", "    std::string (*run)();", "};", "",
              "const SmokeCase kStructCases[] = {"]
    for struct in struct_cases:
        lines += guarded(struct.protect, [f'    {{"{struct.name}", &smoke_struct_{struct.name}}},'])
    lines += ["};", "", "class CodecStructSmoke : public ::testing::TestWithParam<SmokeCase> {};", "",
              "TEST_P(CodecStructSmoke, ZeroFilledRoundTrip) {",
              "    const std::string error = GetParam().run();",
              "    EXPECT_EQ(error, \"\") << GetParam().name;", "}", "",
              "INSTANTIATE_TEST_SUITE_P(Generated, CodecStructSmoke, ::testing::ValuesIn(kStructCases),",
              "                         [](const ::testing::TestParamInfo<SmokeCase> &p) { return std::string(p.param.name); });",
              ""]
    lines += ["const SmokeCase kCases[] = {"]
    for c in names:
        lines += guarded(c.protect, [f'    {{"{c.name}", &smoke_{c.name}}},'])
    lines += ["};", "", "class CodecSmoke : public ::testing::TestWithParam<SmokeCase> {};", "",
              "TEST_P(CodecSmoke, ZeroArgumentsRoundTrip) {",
              "    const std::string error = GetParam().run();",
              "    EXPECT_EQ(error, \"\") << GetParam().name;", "}", "",
              "INSTANTIATE_TEST_SUITE_P(Generated, CodecSmoke, ::testing::ValuesIn(kCases),",
              "                         [](const ::testing::TestParamInfo<SmokeCase> &p) { return std::string(p.param.name); });",
              "",
              "TEST(CodecSmokeCoverage, EveryGeneratedCommandHasACase) {",
              f"    EXPECT_EQ(std::size(kCases) + {len(codec_policy.TEMPLATE_COMMANDS & {c.name for c in codec.commands})}u, kCommandCount);",
              "}", "",
              "} // namespace", "} // namespace splitvk::codec", ""]
    return "\n".join(lines)
