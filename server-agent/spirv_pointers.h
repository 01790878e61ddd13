#pragma once

// Where a shader gets its buffer device addresses from (buffer_addresses.h), read from its SPIR-V,
// as GFXReconstruct's address replacement does: push constants and memory contents are untyped
// bytes on the wire, and only the shader says which of them are addresses.
//
// Translatable: 8-byte push-constant fields that hold an address, which are
//   - members (of the block, of nested structs, of arrays) of PhysicalStorageBuffer pointer type;
//   - 64-bit integer members whose loaded value reaches OpConvertUToPtr directly or through
//     integer additions and subtractions (an address plus an offset stays inside the same buffer,
//     which has the same layout on both sides).
// Untranslatable (the module's `untranslatable` says which it met first):
//   - an address read from memory: a PhysicalStorageBuffer pointer, or a struct holding one,
//     loaded from a uniform or storage buffer, from PhysicalStorageBuffer memory (addresses a
//     shader or the host wrote there), from a vertex input or from workgroup memory;
//   - an address built from any other integer (OpConvertUToPtr of a value that is not a
//     push-constant field as above, OpBitcast of a uvec2 or of a 64-bit integer to a pointer).
// Values kept in function or private variables were judged where they were made, so loads from
// those are neither. What the analysis does not follow (a push-constant integer spilled through a
// local variable before OpConvertUToPtr) errs on the untranslatable side, never on a guess.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace splitvk::agent {

struct ShaderAddresses {
    bool uses_addresses = false;                  // declares PhysicalStorageBufferAddresses
    std::vector<uint32_t> push_constant_pointers; // byte offsets in the push-constant block, sorted, unique
    std::string untranslatable;                   // empty, or why (one phrase)
};

// Reads a SPIR-V module (words as vkCreateShaderModule takes them). False with one line in
// `error` when the words are not a well-formed module as far as this reader goes.
bool reflect_shader_addresses(std::span<const uint32_t> words, ShaderAddresses *out, std::string *error);

// Whether a module declares PhysicalStorageBufferAddresses, read from its capabilities alone
// (SPIR-V puts them first). For a module reflect_shader_addresses refuses, such as one with an
// instruction newer than this SPIRV-Tools' grammar: one that declares no addresses cannot use
// any, and its pipelines replay as they are. True when even the capabilities cannot be read.
bool may_use_addresses(std::span<const uint32_t> words);

} // namespace splitvk::agent
