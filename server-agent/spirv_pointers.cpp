#include "spirv_pointers.h"

#include <algorithm>
#include <memory>
#include <optional>
#include <unordered_map>

#include <spirv-tools/libspirv.h>
#include <spirv/unified1/spirv.hpp11>

namespace splitvk::agent {
namespace {

using spv::Op;
using spv::StorageClass;

// Arrays of addresses in a push-constant block: the limit is 128 bytes on most GPUs, 256 at most.
constexpr uint64_t kMaxPushArrayElements = 64;
constexpr int kMaxTypeDepth = 16;
constexpr uint32_t kMaxWalkSteps = 4096;

// One context for every module: it holds only SPIR-V's grammar tables, which spvBinaryParse reads
// (diagnostics go to a copy of it), so sessions may share it.
spv_const_context grammar() {
    static const std::unique_ptr<spv_context_t, decltype(&spvContextDestroy)> context(
        spvContextCreate(SPV_ENV_UNIVERSAL_1_6), spvContextDestroy);
    return context.get();
}

struct Type {
    Op op = Op::OpNop;
    uint32_t width = 0;                                 // OpTypeInt
    StorageClass storage_class = StorageClass::Generic; // OpTypePointer
    uint32_t pointee = 0;                               // OpTypePointer; element of OpTypeArray/OpTypeVector
    uint32_t length_id = 0;                             // OpTypeArray
    uint32_t components = 0;                            // OpTypeVector
    std::vector<uint32_t> members;
};

const char *storage_class_name(StorageClass storage_class) {
    switch (storage_class) {
    case StorageClass::Input:
        return "a shader input";
    case StorageClass::Uniform:
        return "a uniform or storage buffer";
    case StorageClass::StorageBuffer:
        return "a storage buffer";
    case StorageClass::Workgroup:
        return "workgroup memory";
    case StorageClass::PhysicalStorageBuffer:
        return "buffer memory through another address";
    default:
        return "memory";
    }
}

class Reader {
public:
    Reader(std::span<const uint32_t> words, ShaderAddresses &out) : words_(words), out_(out) {}

    bool run(std::string *error) {
        // A byte-swapped module is no module vkCreateShaderModule takes either.
        if (words_.size() < 5 || words_[0] != spv::MagicNumber) {
            *error = "not a SPIR-V module (no magic number)";
            return false;
        }
        if (!parse(error)) return false;
        for (const auto &[start, count] : kept_)
            instructions_.push_back(std::span<const uint32_t>(kept_words_).subspan(start, count));
        for (const auto &i : instructions_)
            declare(i);
        if (!out_.uses_addresses) return true;
        for (const auto &[variable, type] : push_constant_variables_)
            walk_push_type(pointee(type), 0, 0);
        for (const auto &i : instructions_)
            follow(i);
        std::sort(out_.push_constant_pointers.begin(), out_.push_constant_pointers.end());
        out_.push_constant_pointers.erase(
            std::unique(out_.push_constant_pointers.begin(), out_.push_constant_pointers.end()),
            out_.push_constant_pointers.end());
        return true;
    }

private:
    // SPIRV-Tools walks the module: every instruction's word count fits the module and its
    // operands (per SPIR-V's grammar) fit its words, or the module is refused as a whole. The
    // instructions are kept for the two passes below, as copies: the parser's words are only
    // valid during its callback.
    bool parse(std::string *error) {
        spv_diagnostic diagnostic = nullptr;
        const spv_result_t result = spvBinaryParse(grammar(), this, words_.data(), words_.size(), nullptr,
                                                   &Reader::keep_instruction, &diagnostic);
        if (result != SPV_SUCCESS) {
            *error = "malformed SPIR-V";
            if (diagnostic) {
                std::string why = diagnostic->error;
                std::replace(why.begin(), why.end(), '\n', ' ');
                *error += ": " + why; // names the instruction and its word
            }
        }
        spvDiagnosticDestroy(diagnostic);
        return result == SPV_SUCCESS;
    }
    static spv_result_t keep_instruction(void *user, const spv_parsed_instruction_t *parsed) {
        auto &reader = *static_cast<Reader *>(user);
        reader.kept_.emplace_back(reader.kept_words_.size(), parsed->num_words);
        reader.kept_words_.insert(reader.kept_words_.end(), parsed->words, parsed->words + parsed->num_words);
        return SPV_SUCCESS;
    }
    static Op opcode(std::span<const uint32_t> i) { return static_cast<Op>(i[0] & 0xffff); }
    static StorageClass storage_class(uint32_t word) { return static_cast<StorageClass>(word); }
    static uint32_t operand(std::span<const uint32_t> i, size_t n) { return n + 1 < i.size() ? i[n + 1] : 0; }

    // Types, constants, decorations and the push-constant variables: everything declared before
    // the functions, in any order (forward pointers name structs declared later).
    void declare(std::span<const uint32_t> i) {
        switch (opcode(i)) {
        case Op::OpCapability:
            if (static_cast<spv::Capability>(operand(i, 0)) ==
                spv::Capability::PhysicalStorageBufferAddresses)
                out_.uses_addresses = true;
            break;
        case Op::OpTypeInt: {
            Type t;
            t.op = Op::OpTypeInt;
            t.width = operand(i, 1);
            types_[operand(i, 0)] = t;
        } break;
        case Op::OpTypeVector: {
            Type t;
            t.op = Op::OpTypeVector;
            t.pointee = operand(i, 1);
            t.components = operand(i, 2);
            types_[operand(i, 0)] = t;
            break;
        }
        case Op::OpTypeArray: {
            Type t;
            t.op = Op::OpTypeArray;
            t.pointee = operand(i, 1);
            t.length_id = operand(i, 2);
            types_[operand(i, 0)] = t;
            break;
        }
        case Op::OpTypeStruct: {
            Type t;
            t.op = Op::OpTypeStruct;
            if (i.size() > 2) t.members.assign(i.begin() + 2, i.end());
            types_[operand(i, 0)] = t;
            break;
        }
        case Op::OpTypePointer: {
            Type t;
            t.op = Op::OpTypePointer;
            t.storage_class = storage_class(operand(i, 1));
            t.pointee = operand(i, 2);
            types_[operand(i, 0)] = t;
            break;
        }
        case Op::OpConstant:
            if (i.size() >= 4)
                constants_[operand(i, 1)] = operand(i, 2); // the low word is enough for indices
            break;
        case Op::OpDecorate:
            if (static_cast<spv::Decoration>(operand(i, 1)) == spv::Decoration::ArrayStride)
                array_strides_[operand(i, 0)] = operand(i, 2);
            break;
        case Op::OpMemberDecorate:
            if (static_cast<spv::Decoration>(operand(i, 2)) == spv::Decoration::Offset)
                member_offsets_[key(operand(i, 0), operand(i, 1))] = operand(i, 3);
            break;
        case Op::OpVariable:
            types_of_[operand(i, 1)] = operand(i, 0);
            if (storage_class(operand(i, 2)) == StorageClass::PushConstant)
                push_constant_variables_.emplace_back(operand(i, 1), operand(i, 0));
            break;
        default:
            break;
        }
    }

    static uint64_t key(uint32_t a, uint32_t b) { return (uint64_t{a} << 32) | b; }
    const Type *type(uint32_t id) const {
        const auto it = types_.find(id);
        return it == types_.end() ? nullptr : &it->second;
    }
    uint32_t pointee(uint32_t pointer_type) const {
        const Type *t = type(pointer_type);
        return t && t->op == Op::OpTypePointer ? t->pointee : 0;
    }
    bool is_address(uint32_t type_id) const {
        const Type *t = type(type_id);
        return t && t->op == Op::OpTypePointer && t->storage_class == StorageClass::PhysicalStorageBuffer;
    }
    bool is_int64(uint32_t type_id) const {
        const Type *t = type(type_id);
        return t && t->op == Op::OpTypeInt && t->width == 64;
    }
    // Memoised: a module may share one struct type among many members at every level.
    bool holds_address(uint32_t type_id, int depth = 0) {
        if (const auto known = holds_address_.find(type_id); known != holds_address_.end())
            return known->second;
        const Type *t = type(type_id);
        if (!t || depth > kMaxTypeDepth) return false;
        bool holds = false;
        if (t->op == Op::OpTypePointer)
            holds = t->storage_class == StorageClass::PhysicalStorageBuffer;
        else if (t->op == Op::OpTypeArray)
            holds = holds_address(t->pointee, depth + 1);
        else if (t->op == Op::OpTypeStruct)
            holds = std::any_of(t->members.begin(), t->members.end(),
                                [&](uint32_t m) { return holds_address(m, depth + 1); });
        holds_address_[type_id] = holds;
        return holds;
    }
    std::optional<uint32_t> member_offset(uint32_t struct_id, uint32_t member) const {
        const auto it = member_offsets_.find(key(struct_id, member));
        if (it == member_offsets_.end()) return std::nullopt;
        return it->second;
    }

    // Every member of pointer type in the push-constant block, at its byte offset.
    void walk_push_type(uint32_t type_id, uint64_t base, int depth) {
        const Type *t = type(type_id);
        // A push-constant block is 256 bytes at most: more address fields than that name no block a
        // driver accepts, and nested arrays must not make this walk exponential.
        if (!t || depth > kMaxTypeDepth || ++walk_steps_ > kMaxWalkSteps || !holds_address(type_id)) return;
        if (is_address(type_id)) {
            if (base <= UINT32_MAX) out_.push_constant_pointers.push_back(static_cast<uint32_t>(base));
        } else if (t->op == Op::OpTypeStruct) {
            for (uint32_t m = 0; m < t->members.size(); ++m)
                if (const auto offset = member_offset(type_id, m))
                    walk_push_type(t->members[m], base + *offset, depth + 1);
        } else if (t->op == Op::OpTypeArray) {
            const auto stride = array_strides_.find(type_id);
            const auto length = constants_.find(t->length_id);
            if (stride == array_strides_.end() || length == constants_.end()) return;
            for (uint64_t e = 0; e < std::min<uint64_t>(length->second, kMaxPushArrayElements); ++e)
                walk_push_type(t->pointee, base + e * stride->second, depth + 1);
        }
    }

    // The byte offset in the push-constant block that an access chain with constant indices
    // reaches from a push-constant variable (or from such a chain).
    std::optional<uint64_t> chain_offset(std::span<const uint32_t> i) const {
        const uint32_t base = operand(i, 2);
        uint64_t offset = 0;
        uint32_t current = 0;
        if (const auto it = push_chains_.find(base); it != push_chains_.end()) {
            offset = it->second.first;
            current = it->second.second;
        } else if (std::any_of(push_constant_variables_.begin(), push_constant_variables_.end(),
                               [&](const auto &v) { return v.first == base; })) {
            current = pointee(types_of_.at(base));
        } else {
            return std::nullopt;
        }
        for (size_t n = 3; n + 1 < i.size(); ++n) {
            const auto index = constants_.find(operand(i, n));
            const Type *t = type(current);
            if (index == constants_.end() || !t) return std::nullopt;
            if (t->op == Op::OpTypeStruct) {
                const auto member = member_offset(current, index->second);
                if (!member || index->second >= t->members.size()) return std::nullopt;
                offset += *member;
                current = t->members[index->second];
            } else if (t->op == Op::OpTypeArray) {
                const auto stride = array_strides_.find(current);
                if (stride == array_strides_.end()) return std::nullopt;
                offset += uint64_t{index->second} * stride->second;
                current = t->pointee;
            } else if (t->op == Op::OpTypeVector) {
                const Type *component = type(t->pointee);
                if (!component || component->op != Op::OpTypeInt) return std::nullopt;
                offset += uint64_t{index->second} * (component->width / 8);
                current = t->pointee;
            } else {
                return std::nullopt;
            }
        }
        return offset;
    }

    void untranslatable(const std::string &why) {
        if (out_.untranslatable.empty()) out_.untranslatable = why;
    }

    // The functions' instructions, in order: where addresses come from.
    void follow(std::span<const uint32_t> i) {
        const Op op = opcode(i);
        switch (op) {
        case Op::OpFunctionParameter:
        case Op::OpVariable:
            types_of_[operand(i, 1)] = operand(i, 0);
            break;
        case Op::OpAccessChain:
        case Op::OpInBoundsAccessChain:
        case Op::OpPtrAccessChain:
        case Op::OpInBoundsPtrAccessChain: {
            const uint32_t result = operand(i, 1);
            types_of_[result] = operand(i, 0);
            if (op == Op::OpAccessChain || op == Op::OpInBoundsAccessChain)
                if (const auto offset = chain_offset(i))
                    push_chains_[result] = {*offset, pointee(operand(i, 0))};
            break;
        }
        case Op::OpLoad: {
            const uint32_t result_type = operand(i, 0), result = operand(i, 1), pointer = operand(i, 2);
            types_of_[result] = result_type;
            if (const auto chain = push_chains_.find(pointer); chain != push_chains_.end()) {
                if (is_int64(result_type)) push_integers_[result] = chain->second.first;
                break;
            }
            if (!holds_address(result_type)) break;
            const auto pointer_type = types_of_.find(pointer);
            const Type *t = pointer_type == types_of_.end() ? nullptr : type(pointer_type->second);
            const StorageClass source =
                t && t->op == Op::OpTypePointer ? t->storage_class : StorageClass::Generic;
            if (source == StorageClass::Function || source == StorageClass::Private ||
                source == StorageClass::PushConstant)
                break;
            untranslatable(std::string("an address read from ") + storage_class_name(source));
            break;
        }
        case Op::OpCopyObject:
            types_of_[operand(i, 1)] = operand(i, 0);
            if (const auto it = push_integers_.find(operand(i, 2)); it != push_integers_.end())
                push_integers_[operand(i, 1)] = it->second;
            break;
        case Op::OpIAdd:
        case Op::OpISub: {
            if (!is_int64(operand(i, 0))) break;
            const auto a = push_integers_.find(operand(i, 2));
            const auto b = push_integers_.find(operand(i, 3));
            // Address plus offset; an offset minus an address is no address of this buffer.
            if (a != push_integers_.end() && b == push_integers_.end())
                push_integers_[operand(i, 1)] = a->second;
            else if (op == Op::OpIAdd && b != push_integers_.end() && a == push_integers_.end())
                push_integers_[operand(i, 1)] = b->second;
            break;
        }
        case Op::OpConvertUToPtr:
        case Op::OpBitcast: {
            if (!is_address(operand(i, 0))) break;
            const auto source = push_integers_.find(operand(i, 2));
            if (source != push_integers_.end() && source->second <= UINT32_MAX) {
                out_.push_constant_pointers.push_back(static_cast<uint32_t>(source->second));
                break;
            }
            if (is_address(types_of_.count(operand(i, 2)) ? types_of_[operand(i, 2)] : 0))
                break; // a pointer cast to another pointer type: judged where it was made
            untranslatable(op == Op::OpBitcast ? "an address bitcast from integers the agent cannot trace"
                                               : "an address made from an integer the agent cannot trace");
            break;
        }
        default:
            break;
        }
    }

    std::span<const uint32_t> words_;
    ShaderAddresses &out_;
    std::vector<uint32_t> kept_words_;
    std::vector<std::pair<size_t, uint16_t>> kept_; // (start in kept_words_, word count)
    std::vector<std::span<const uint32_t>> instructions_;
    std::unordered_map<uint32_t, Type> types_;
    std::unordered_map<uint32_t, uint32_t> constants_;
    std::unordered_map<uint32_t, uint32_t> array_strides_;
    std::unordered_map<uint64_t, uint32_t> member_offsets_;
    std::vector<std::pair<uint32_t, uint32_t>> push_constant_variables_;      // (variable, pointer type)
    std::unordered_map<uint32_t, uint32_t> types_of_;                         // id -> its type
    std::unordered_map<uint32_t, std::pair<uint64_t, uint32_t>> push_chains_; // id -> (offset, pointee)
    std::unordered_map<uint32_t, uint64_t> push_integers_; // 64-bit values loaded from push constants
    std::unordered_map<uint32_t, bool> holds_address_;
    uint32_t walk_steps_ = 0;
};

} // namespace

bool may_use_addresses(std::span<const uint32_t> words) {
    struct Capabilities {
        bool addresses = false;
        static spv_result_t next(void *user, const spv_parsed_instruction_t *parsed) {
            if (parsed->opcode != static_cast<uint16_t>(Op::OpCapability)) return SPV_REQUESTED_TERMINATION;
            if (parsed->num_words > 1 && static_cast<spv::Capability>(parsed->words[1]) ==
                                             spv::Capability::PhysicalStorageBufferAddresses)
                static_cast<Capabilities *>(user)->addresses = true;
            return SPV_SUCCESS;
        }
    } found;
    if (words.size() < 5 || words[0] != spv::MagicNumber) return true;
    const spv_result_t result =
        spvBinaryParse(grammar(), &found, words.data(), words.size(), nullptr, &Capabilities::next, nullptr);
    return found.addresses || (result != SPV_SUCCESS && result != SPV_REQUESTED_TERMINATION);
}

bool reflect_shader_addresses(std::span<const uint32_t> words, ShaderAddresses *out, std::string *error) {
    *out = {};
    Reader reader(words, *out);
    return reader.run(error);
}

} // namespace splitvk::agent
