#include "spirv_pointers.h"

#include <algorithm>
#include <optional>
#include <unordered_map>

namespace splitvk::agent {
namespace {

// The SPIR-V numbers this reader needs (SPIR-V 1.6 specification, section 3).
constexpr uint32_t kMagic = 0x07230203;
enum Op : uint32_t {
    OpCapability = 17,
    OpTypeInt = 21,
    OpTypeVector = 23,
    OpTypeArray = 28,
    OpTypeStruct = 30,
    OpTypePointer = 32,
    OpConstant = 43,
    OpFunctionParameter = 55,
    OpVariable = 59,
    OpLoad = 61,
    OpAccessChain = 65,
    OpInBoundsAccessChain = 66,
    OpPtrAccessChain = 67,
    OpInBoundsPtrAccessChain = 70,
    OpDecorate = 71,
    OpMemberDecorate = 72,
    OpCopyObject = 83,
    OpConvertUToPtr = 120,
    OpBitcast = 124,
    OpIAdd = 128,
    OpISub = 130,
};
constexpr uint32_t kCapabilityPhysicalStorageBufferAddresses = 5347;
constexpr uint32_t kDecorationArrayStride = 6;
constexpr uint32_t kDecorationOffset = 35;
enum StorageClass : uint32_t {
    Input = 1,
    Uniform = 2,
    Workgroup = 4,
    Private = 6,
    Function = 7,
    PushConstant = 9,
    StorageBuffer = 12,
    PhysicalStorageBuffer = 5349,
};
// Arrays of addresses in a push-constant block: the limit is 128 bytes on most GPUs, 256 at most.
constexpr uint64_t kMaxPushArrayElements = 64;
constexpr int kMaxTypeDepth = 16;
constexpr uint32_t kMaxWalkSteps = 4096;

struct Type {
    uint32_t op = 0;
    uint32_t width = 0;         // OpTypeInt
    uint32_t storage_class = 0; // OpTypePointer
    uint32_t pointee = 0;       // OpTypePointer; element of OpTypeArray/OpTypeVector
    uint32_t length_id = 0;     // OpTypeArray
    uint32_t components = 0;    // OpTypeVector
    std::vector<uint32_t> members;
};

const char *storage_class_name(uint32_t storage_class) {
    switch (storage_class) {
    case Input:
        return "a shader input";
    case Uniform:
        return "a uniform or storage buffer";
    case StorageBuffer:
        return "a storage buffer";
    case Workgroup:
        return "workgroup memory";
    case PhysicalStorageBuffer:
        return "buffer memory through another address";
    default:
        return "memory";
    }
}

class Reader {
public:
    Reader(std::span<const uint32_t> words, ShaderAddresses &out) : words_(words), out_(out) {}

    bool run(std::string *error) {
        if (words_.size() < 5 || words_[0] != kMagic) {
            *error = "not a SPIR-V module (no magic number)";
            return false;
        }
        for (size_t at = 5; at < words_.size();) {
            const uint32_t count = words_[at] >> 16;
            if (count == 0 || at + count > words_.size()) {
                *error = "SPIR-V instruction at word " + std::to_string(at) + " runs past the module";
                return false;
            }
            instructions_.push_back(words_.subspan(at, count));
            at += count;
        }
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
    static uint32_t opcode(std::span<const uint32_t> i) { return i[0] & 0xffff; }
    static uint32_t operand(std::span<const uint32_t> i, size_t n) { return n + 1 < i.size() ? i[n + 1] : 0; }

    // Types, constants, decorations and the push-constant variables: everything declared before
    // the functions, in any order (forward pointers name structs declared later).
    void declare(std::span<const uint32_t> i) {
        switch (opcode(i)) {
        case OpCapability:
            if (operand(i, 0) == kCapabilityPhysicalStorageBufferAddresses) out_.uses_addresses = true;
            break;
        case OpTypeInt: {
            Type t;
            t.op = OpTypeInt;
            t.width = operand(i, 1);
            types_[operand(i, 0)] = t;
        } break;
        case OpTypeVector: {
            Type t;
            t.op = OpTypeVector;
            t.pointee = operand(i, 1);
            t.components = operand(i, 2);
            types_[operand(i, 0)] = t;
            break;
        }
        case OpTypeArray: {
            Type t;
            t.op = OpTypeArray;
            t.pointee = operand(i, 1);
            t.length_id = operand(i, 2);
            types_[operand(i, 0)] = t;
            break;
        }
        case OpTypeStruct: {
            Type t;
            t.op = OpTypeStruct;
            if (i.size() > 2) t.members.assign(i.begin() + 2, i.end());
            types_[operand(i, 0)] = t;
            break;
        }
        case OpTypePointer: {
            Type t;
            t.op = OpTypePointer;
            t.storage_class = operand(i, 1);
            t.pointee = operand(i, 2);
            types_[operand(i, 0)] = t;
            break;
        }
        case OpConstant:
            if (i.size() >= 4)
                constants_[operand(i, 1)] = operand(i, 2); // the low word is enough for indices
            break;
        case OpDecorate:
            if (operand(i, 1) == kDecorationArrayStride) array_strides_[operand(i, 0)] = operand(i, 2);
            break;
        case OpMemberDecorate:
            if (operand(i, 2) == kDecorationOffset)
                member_offsets_[key(operand(i, 0), operand(i, 1))] = operand(i, 3);
            break;
        case OpVariable:
            types_of_[operand(i, 1)] = operand(i, 0);
            if (operand(i, 2) == PushConstant)
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
        return t && t->op == OpTypePointer ? t->pointee : 0;
    }
    bool is_address(uint32_t type_id) const {
        const Type *t = type(type_id);
        return t && t->op == OpTypePointer && t->storage_class == PhysicalStorageBuffer;
    }
    bool is_int64(uint32_t type_id) const {
        const Type *t = type(type_id);
        return t && t->op == OpTypeInt && t->width == 64;
    }
    // Memoised: a module may share one struct type among many members at every level.
    bool holds_address(uint32_t type_id, int depth = 0) {
        if (const auto known = holds_address_.find(type_id); known != holds_address_.end())
            return known->second;
        const Type *t = type(type_id);
        if (!t || depth > kMaxTypeDepth) return false;
        bool holds = false;
        if (t->op == OpTypePointer)
            holds = t->storage_class == PhysicalStorageBuffer;
        else if (t->op == OpTypeArray)
            holds = holds_address(t->pointee, depth + 1);
        else if (t->op == OpTypeStruct)
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
        } else if (t->op == OpTypeStruct) {
            for (uint32_t m = 0; m < t->members.size(); ++m)
                if (const auto offset = member_offset(type_id, m))
                    walk_push_type(t->members[m], base + *offset, depth + 1);
        } else if (t->op == OpTypeArray) {
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
            if (t->op == OpTypeStruct) {
                const auto member = member_offset(current, index->second);
                if (!member || index->second >= t->members.size()) return std::nullopt;
                offset += *member;
                current = t->members[index->second];
            } else if (t->op == OpTypeArray) {
                const auto stride = array_strides_.find(current);
                if (stride == array_strides_.end()) return std::nullopt;
                offset += uint64_t{index->second} * stride->second;
                current = t->pointee;
            } else if (t->op == OpTypeVector) {
                const Type *component = type(t->pointee);
                if (!component || component->op != OpTypeInt) return std::nullopt;
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
        const uint32_t op = opcode(i);
        switch (op) {
        case OpFunctionParameter:
        case OpVariable:
            types_of_[operand(i, 1)] = operand(i, 0);
            break;
        case OpAccessChain:
        case OpInBoundsAccessChain:
        case OpPtrAccessChain:
        case OpInBoundsPtrAccessChain: {
            const uint32_t result = operand(i, 1);
            types_of_[result] = operand(i, 0);
            if (op == OpAccessChain || op == OpInBoundsAccessChain)
                if (const auto offset = chain_offset(i))
                    push_chains_[result] = {*offset, pointee(operand(i, 0))};
            break;
        }
        case OpLoad: {
            const uint32_t result_type = operand(i, 0), result = operand(i, 1), pointer = operand(i, 2);
            types_of_[result] = result_type;
            if (const auto chain = push_chains_.find(pointer); chain != push_chains_.end()) {
                if (is_int64(result_type)) push_integers_[result] = chain->second.first;
                break;
            }
            if (!holds_address(result_type)) break;
            const auto pointer_type = types_of_.find(pointer);
            const Type *t = pointer_type == types_of_.end() ? nullptr : type(pointer_type->second);
            const uint32_t storage_class = t && t->op == OpTypePointer ? t->storage_class : 0;
            if (storage_class == Function || storage_class == Private || storage_class == PushConstant) break;
            untranslatable(std::string("an address read from ") + storage_class_name(storage_class));
            break;
        }
        case OpCopyObject:
            types_of_[operand(i, 1)] = operand(i, 0);
            if (const auto it = push_integers_.find(operand(i, 2)); it != push_integers_.end())
                push_integers_[operand(i, 1)] = it->second;
            break;
        case OpIAdd:
        case OpISub: {
            if (!is_int64(operand(i, 0))) break;
            const auto a = push_integers_.find(operand(i, 2));
            const auto b = push_integers_.find(operand(i, 3));
            // Address plus offset; an offset minus an address is no address of this buffer.
            if (a != push_integers_.end() && b == push_integers_.end())
                push_integers_[operand(i, 1)] = a->second;
            else if (op == OpIAdd && b != push_integers_.end() && a == push_integers_.end())
                push_integers_[operand(i, 1)] = b->second;
            break;
        }
        case OpConvertUToPtr:
        case OpBitcast: {
            if (!is_address(operand(i, 0))) break;
            const auto source = push_integers_.find(operand(i, 2));
            if (source != push_integers_.end() && source->second <= UINT32_MAX) {
                out_.push_constant_pointers.push_back(static_cast<uint32_t>(source->second));
                break;
            }
            if (is_address(types_of_.count(operand(i, 2)) ? types_of_[operand(i, 2)] : 0))
                break; // a pointer cast to another pointer type: judged where it was made
            untranslatable(op == OpBitcast ? "an address bitcast from integers the agent cannot trace"
                                           : "an address made from an integer the agent cannot trace");
            break;
        }
        default:
            break;
        }
    }

    std::span<const uint32_t> words_;
    ShaderAddresses &out_;
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

bool reflect_shader_addresses(std::span<const uint32_t> words, ShaderAddresses *out, std::string *error) {
    *out = {};
    Reader reader(words, *out);
    return reader.run(error);
}

} // namespace splitvk::agent
