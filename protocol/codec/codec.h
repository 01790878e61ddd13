#pragma once

// The runtime of splitvk's generated Vulkan wire codec (docs/architecture.md §3): what the generated
// encoders (layer side) and decoders (agent side) in ${build}/generated/vk_codec*.{h,cpp} call.
//
//   Encoder      writes one or more commands into a WireWriter. Ids are the client's handle
//                values (Venus style: the client names every object), VK_NULL_HANDLE is id 0.
//   Decoder      reads them back, bounds-checked, with the first error sticky (WireReader's). Handles
//                are replaced through a HandleTable; pointer data lives in an Arena.
//   HandleTable  per session: client id -> (agent handle, VkObjectType, parent pool).
//   Arena        per message bump allocator, capped, zero-filled.
//
// Encoding rules: scalars little-endian; enums and 32-bit flags u32, 64-bit flags u64; VkBool32
// u32; size_t and VkDeviceSize u64; handles u64 ids; every pointer a u8 presence byte followed,
// when present, by its data (one structure, `len` elements, a string, or `len` bytes); unions as
// their raw 32-bit words; a pNext chain as (sType u32, structure) pairs ended by sType 0. Never
// encoded: VkAllocationCallbacks, function pointers, user-data pointers.

#include "wire.h"

#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace splitvk::codec {

// ---------------------------------------------------------------------------------------------
// Handles <-> 64-bit values. Dispatchable handles are pointers; non-dispatchable handles are
// pointers on 64-bit hosts and uint64_t elsewhere.

template <class H>
inline uint64_t handle_value(H handle) {
    if constexpr (std::is_pointer_v<H>)
        return static_cast<uint64_t>(reinterpret_cast<uintptr_t>(handle));
    else
        return static_cast<uint64_t>(handle);
}

template <class H>
inline H to_handle(uint64_t value) {
    if constexpr (std::is_pointer_v<H>)
        return reinterpret_cast<H>(static_cast<uintptr_t>(value));
    else
        return static_cast<H>(value);
}

// "VkBuffer" for VK_OBJECT_TYPE_BUFFER (generated from vk.xml), "VkObjectType(N)" if unknown.
const char *object_type_name(VkObjectType type);

// ---------------------------------------------------------------------------------------------

// Bump allocator for decoded data. Every allocation is zero-filled and aligned; nothing is freed
// until reset(). Allocations beyond the cap fail (nullptr) rather than grow without bound.
class Arena {
public:
    static constexpr size_t kDefaultCap = 256u << 20;

    explicit Arena(size_t cap = kDefaultCap) : cap_(cap) {}
    Arena(const Arena &) = delete;
    Arena &operator=(const Arena &) = delete;

    // nullptr when `bytes` would take the arena past its cap.
    void *allocate(size_t bytes, size_t align);
    template <class T>
    T *allocate_array(size_t count) {
        static_assert(std::is_trivially_destructible_v<T>, "arena memory is never destroyed");
        if (count > cap_ / sizeof(T)) return nullptr;
        return static_cast<T *>(allocate(count * sizeof(T), alignof(T)));
    }

    // Drops every allocation (keeps one block for the next message).
    void reset();
    size_t used() const { return used_; }
    size_t cap() const { return cap_; }
    void set_cap(size_t cap) { cap_ = cap; }

private:
    struct Block {
        std::unique_ptr<uint8_t[]> data;
        size_t size = 0;
    };
    static constexpr size_t kBlockSize = 64u << 10;
    std::vector<Block> blocks_;
    size_t offset_ = 0; // in the last block
    size_t used_ = 0;
    size_t cap_;
};

// ---------------------------------------------------------------------------------------------

// The agent's map from the client's ids to its own handles, one per session.
class HandleTable {
public:
    struct Entry {
        uint64_t handle = 0; // the agent's handle value
        VkObjectType type = VK_OBJECT_TYPE_UNKNOWN;
        uint64_t parent = 0; // id of the pool it was allocated from (0: none)
    };

    // Registers an object the agent created for client id `id`. Fails (with one line in `error`)
    // for id 0 and for an id that still names a live object of another type or handle; inserting
    // the same (id, type, handle) again is accepted (vkGetDeviceQueue returns the same queue).
    bool insert(uint64_t id, VkObjectType type, uint64_t handle, uint64_t parent = 0,
                std::string *error = nullptr);
    template <class H>
    bool insert(uint64_t id, VkObjectType type, H handle, uint64_t parent = 0, std::string *error = nullptr) {
        return insert(id, type, handle_value(handle), parent, error);
    }
    // Forgets an object and every object allocated from it. False if the id was not live.
    bool remove(uint64_t id);
    // Forgets every object allocated from `parent` (vkResetDescriptorPool).
    void remove_children(uint64_t parent);

    const Entry *find(uint64_t id) const;
    size_t size() const { return entries_.size(); }
    bool empty() const { return entries_.empty(); }
    void clear();
    // Visits every live entry (for teardown at the end of a session).
    template <class F>
    void for_each(F &&f) const {
        for (const auto &[id, entry] : entries_)
            f(id, entry);
    }

private:
    std::unordered_map<uint64_t, Entry> entries_;
    std::unordered_map<uint64_t, std::unordered_set<uint64_t>> children_;
};

// ---------------------------------------------------------------------------------------------
// Encoding

// What the encoder asks of, and reports to, the layer. Every method has a safe default.
class EncodeHooks {
public:
    virtual ~EncodeHooks() = default;

    struct SubpassUse {
        bool color = true;         // the subpass writes at least one color attachment
        bool depth_stencil = true; // the subpass uses a depth/stencil attachment
    };
    // Which attachments subpass `subpass` of `render_pass` uses, for the pointers of
    // VkGraphicsPipelineCreateInfo the specification ignores otherwise. The default (both used)
    // reads pColorBlendState/pDepthStencilState whenever they are not null.
    virtual SubpassUse subpass_use(VkRenderPass render_pass, uint32_t subpass);
    // True if `binding` of the layout `set` was allocated with has immutable samplers: the sampler
    // member of VkDescriptorImageInfo is then ignored (and may be garbage). Default: false.
    virtual bool has_immutable_samplers(VkDescriptorSet set, uint32_t binding);
    // An extension structure the codec cannot forward was skipped in the pNext chain of `parent`
    // (the layer logs it once).
    virtual void skipped_structure(VkStructureType stype, const char *parent);
    // A pNext chain was longer than the limit (or looped) and was cut.
    virtual void chain_truncated(const char *parent);
};

// State an enclosing structure or command gives its members while they are encoded (see
// codegen/codec_overrides.py). Scopes (rules.h) set it and restore it.
struct EncodeContext {
    bool secondary_command_buffer = false; // vkBeginCommandBuffer's level
    bool render_pass_continue = false;     // VkCommandBufferBeginInfo::flags
    bool rendering_info_applies = true;    // VkPipelineRenderingCreateInfo & co. are read
    bool push_descriptor = false;          // vkCmdPushDescriptorSetKHR: dstSet is ignored
    VkDescriptorType descriptor_type = VK_DESCRIPTOR_TYPE_MAX_ENUM;
    bool immutable_samplers = false;
    bool pipeline_tessellation = true;
    bool pipeline_rasterization = true;
    bool pipeline_depth_stencil = true;
    bool pipeline_color = true;
    bool dynamic_viewport = false;
    bool dynamic_scissor = false;
    bool dynamic_vertex_input = false;            // VK_EXT_vertex_input_dynamic_state
    bool dynamic_color_blend_attachments = false; // EDS3 blend enable, equation and write mask
};

class Encoder {
public:
    // Same as DecodeLimits::max_chain_length: a chain the encoder cuts (a loop) still decodes.
    static constexpr uint32_t kMaxChainLength = 32;

    // Writes into a buffer of its own (take it with take()).
    Encoder() : out_(&own_) {}
    // Appends to `out`, which must outlive the encoder.
    explicit Encoder(protocol::WireWriter &out) : out_(&out) {}
    Encoder(const Encoder &) = delete;
    Encoder &operator=(const Encoder &) = delete;

    void set_hooks(EncodeHooks *hooks) { hooks_ = hooks; }
    EncodeHooks *hooks() const { return hooks_; }
    EncodeContext &context() { return context_; }

    protocol::WireWriter &writer() { return *out_; }
    std::span<const uint8_t> data() const { return out_->data(); }
    size_t size() const { return out_->size(); }
    std::vector<uint8_t> take() { return out_->take(); }
    bool ok() const { return out_->ok(); }

    // Counters of what was left out (the layer logs them).
    uint64_t skipped_structures() const { return skipped_structures_; }
    uint64_t truncated_chains() const { return truncated_chains_; }

    // --- used by generated code ---
    void command(uint16_t id) { out_->u16(id); }
    void u8(uint8_t v) { out_->u8(v); }
    void u16(uint16_t v) { out_->u16(v); }
    void u32(uint32_t v) { out_->u32(v); }
    void u64(uint64_t v) { out_->u64(v); }
    void i32(int32_t v) { out_->i32(v); }
    void i64(int64_t v) { out_->i64(v); }
    void f32(float v) { out_->f32(v); }
    void f64(double v) { out_->f64(v); }
    void size(size_t v) { out_->u64(static_cast<uint64_t>(v)); }
    // Reads the bits, never the enum value: members the specification ignores may hold values
    // outside the enum's range, and loading those is undefined behaviour.
    template <class E>
    void enum32(const E &v) {
        static_assert(sizeof(E) == 4, "32-bit enums");
        uint32_t bits;
        std::memcpy(&bits, &v, sizeof(bits));
        out_->u32(bits);
    }
    template <class H>
    void handle(H h) {
        out_->u64(handle_value(h));
    }
    // Presence byte of a pointer; returns whether the pointee follows.
    bool present(const void *p) {
        out_->u8(p != nullptr ? 1 : 0);
        return p != nullptr;
    }
    // A null-terminated string: presence, then u32 length + bytes.
    void string(const char *s);
    // `count` bytes, no length (the length is another member). For void* data with a len.
    void bytes(const void *p, size_t count);
    // Arrays of fixed-size scalars, little-endian.
    void u32_array(const uint32_t *p, size_t count);
    void f32_array(const float *p, size_t count);
    void u64_array(const uint64_t *p, size_t count);
    // A union, as its raw 32-bit words (every Vulkan union forwarded is made of 4-byte members).
    void words(const void *p, size_t count);

    // pNext bookkeeping: returns false (and reports) when the chain exceeds kMaxChainLength.
    bool chain_step(uint32_t &length, const char *parent);
    void skipped_structure(VkStructureType stype, const char *parent);

private:
    protocol::WireWriter own_;
    protocol::WireWriter *out_;
    EncodeHooks *hooks_ = nullptr;
    EncodeContext context_;
    uint64_t skipped_structures_ = 0;
    uint64_t truncated_chains_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Decoding

struct DecodeLimits {
    uint32_t max_array_count = 1u << 20;  // elements in one array
    uint32_t max_string_bytes = 1u << 16; // one string
    uint32_t max_chain_length = 32;       // structures in one pNext chain
    uint32_t max_depth = 32;              // nesting of structures through pointers
};

class Decoder {
public:
    // Decodes from `payload` (which must outlive the decoder); handles through `table`, pointer
    // data into `arena` (decoded data stays valid until the arena is reset).
    Decoder(std::span<const uint8_t> payload, const HandleTable &table, Arena &arena,
            DecodeLimits limits = {})
        : reader_(payload), table_(&table), arena_(&arena), limits_(limits) {}
    Decoder(const Decoder &) = delete;
    Decoder &operator=(const Decoder &) = delete;

    bool ok() const { return reader_.ok(); }
    // One line: "vkCreateBuffer: unknown VkBuffer id 0x10 at offset 12". Empty while ok().
    std::string error() const;
    bool at_end() const { return reader_.at_end(); }
    size_t offset() const { return reader_.offset(); }
    size_t remaining() const { return reader_.remaining(); }
    protocol::WireReader &reader() { return reader_; }
    Arena &arena() { return *arena_; }
    const DecodeLimits &limits() const { return limits_; }
    // Records a semantic error (sticky; ignored after the first).
    void fail(std::string_view what) { reader_.fail(what); }

    // --- used by generated code ---
    // Names the command being decoded in error lines. end_command() returns ok().
    void begin_command(const char *name) {
        if (ok()) command_ = name;
    }
    bool end_command() { return ok(); }
    // Reads a command id; false (error) unless it is `expected`.
    bool expect_command(uint16_t expected, const char *name);

    uint8_t u8(const char *field) { return reader_.u8(field); }
    uint16_t u16(const char *field) { return reader_.u16(field); }
    uint32_t u32(const char *field) { return reader_.u32(field); }
    uint64_t u64(const char *field) { return reader_.u64(field); }
    int32_t i32(const char *field) { return reader_.i32(field); }
    int64_t i64(const char *field) { return reader_.i64(field); }
    float f32(const char *field) { return reader_.f32(field); }
    double f64(const char *field) { return reader_.f64(field); }
    size_t size(const char *field);
    // A 32-bit enum. Vulkan enums without negative enumerators span [0, 2^31): a value outside is
    // rejected (it could not even be held in the enum type).
    template <class E>
    E enum32(const char *field, bool may_be_negative = false) {
        const int32_t v = reader_.i32(field);
        if (v < 0 && !may_be_negative) invalid_enum(field, v);
        return ok() ? static_cast<E>(v) : E{};
    }

    // A handle: id 0 -> VK_NULL_HANDLE if `nullable`, else an error; an unknown id or one of
    // another type -> an error. The id is stored in *id when id is not null.
    template <class H>
    H handle(VkObjectType type, bool nullable, const char *field, uint64_t *id = nullptr) {
        return to_handle<H>(lookup(type, nullable, field, id));
    }
    // The id of a handle the command creates (0 allowed: a failed element of a batch).
    uint64_t created_id(const char *field) { return reader_.u64(field); }

    // A presence byte (0 or 1). A pointer that is not `optional` must be present.
    bool present(const char *field, bool optional = true);
    // Room for `count` elements after checking count against the limits and against the bytes
    // left (each element takes at least `min_wire_bytes` on the wire). nullptr for count 0 and on
    // error (then ok() is false).
    template <class T>
    T *array(uint64_t count, size_t min_wire_bytes, const char *field) {
        if (!check_count(count, min_wire_bytes, field)) return nullptr;
        if (count == 0) return nullptr;
        T *p = arena_->allocate_array<T>(static_cast<size_t>(count));
        if (!p) out_of_memory(field);
        return p;
    }
    template <class T>
    T *object(const char *field) {
        T *p = arena_->allocate_array<T>(1);
        if (!p) out_of_memory(field);
        return p;
    }
    // A string (presence, u32 length, bytes) copied into the arena with its terminator. nullptr
    // when absent; absence of a required string is an error.
    const char *string(const char *field, bool optional);
    // `count` raw bytes copied into the arena (8-byte aligned, zero-padded to a multiple of 8).
    const void *bytes(uint64_t count, const char *field);
    void u32_array(uint32_t *dst, size_t count, const char *field);
    void f32_array(float *dst, size_t count, const char *field);
    void u64_array(uint64_t *dst, size_t count, const char *field);
    void words(void *dst, size_t count, const char *field);

    // Nesting guard: false (error) past limits().max_depth. Pair with leave().
    bool enter(const char *what);
    void leave() { --depth_; }
    // pNext: false (error) when the chain is longer than limits().max_chain_length.
    bool chain_step(uint32_t &length, const char *parent);
    void unexpected_structure(uint32_t stype, const char *parent);

    // Pool bookkeeping (codec_overrides.POOL_PARENTS): the id of the pool a command allocates from.
    uint64_t &parent_id() { return parent_id_; }

    uint64_t lookup(VkObjectType type, bool nullable, const char *field, uint64_t *id);

private:
    bool check_count(uint64_t count, size_t min_wire_bytes, const char *field);
    void out_of_memory(const char *field);
    void invalid_enum(const char *field, int32_t value);

    protocol::WireReader reader_;
    const HandleTable *table_;
    Arena *arena_;
    DecodeLimits limits_;
    const char *command_ = nullptr;
    uint32_t depth_ = 0;
    uint64_t parent_id_ = 0;
};

// RAII nesting guard for generated code.
class DepthGuard {
public:
    DepthGuard(Decoder &d, const char *what) : d_(d), entered_(d.enter(what)) {}
    ~DepthGuard() {
        if (entered_) d_.leave();
    }
    DepthGuard(const DepthGuard &) = delete;
    DepthGuard &operator=(const DepthGuard &) = delete;
    bool ok() const { return entered_; }

private:
    Decoder &d_;
    bool entered_;
};

} // namespace splitvk::codec
