#include "codec.h"

#include <algorithm>
#include <cstdio>
#include <limits>

namespace splitvk::codec {

namespace {

std::string hex(uint64_t v) {
    char text[24];
    std::snprintf(text, sizeof(text), "0x%llx", static_cast<unsigned long long>(v));
    return text;
}

std::string field_name(const char *field) {
    return field ? std::string("'") + field + "'" : std::string("a value");
}

} // namespace

// ---------------------------------------------------------------------------------------------

void *Arena::allocate(size_t bytes, size_t align) {
    if (bytes == 0) bytes = 1;
    if (align == 0 || (align & (align - 1)) != 0 || align > alignof(std::max_align_t)) return nullptr;
    if (bytes > cap_ || used_ > cap_ - bytes) return nullptr;
    if (!blocks_.empty()) {
        Block &block = blocks_.back();
        const size_t start = (offset_ + align - 1) & ~(align - 1);
        if (start <= block.size && bytes <= block.size - start) {
            offset_ = start + bytes;
            used_ += bytes;
            uint8_t *p = block.data.get() + start;
            std::memset(p, 0, bytes);
            return p;
        }
    }
    const size_t size = std::max(kBlockSize, bytes);
    Block block;
    block.data.reset(new (std::nothrow) uint8_t[size]);
    if (!block.data) return nullptr;
    block.size = size;
    blocks_.push_back(std::move(block));
    offset_ = bytes;
    used_ += bytes;
    std::memset(blocks_.back().data.get(), 0, bytes);
    return blocks_.back().data.get();
}

void Arena::reset() {
    if (blocks_.size() > 1) {
        // Keep the largest block: the next message is likely to be alike.
        auto largest = std::max_element(blocks_.begin(), blocks_.end(),
                                        [](const Block &a, const Block &b) { return a.size < b.size; });
        Block keep = std::move(*largest);
        blocks_.clear();
        blocks_.push_back(std::move(keep));
    }
    offset_ = 0;
    used_ = 0;
}

// ---------------------------------------------------------------------------------------------

bool HandleTable::insert(uint64_t id, VkObjectType type, uint64_t handle, uint64_t parent,
                         std::string *error) {
    if (id == 0) {
        if (error) *error = std::string("created ") + object_type_name(type) + " has id 0";
        return false;
    }
    auto [it, inserted] = entries_.try_emplace(id, Entry{handle, type, parent});
    if (!inserted) {
        const Entry &old = it->second;
        if (old.type == type && old.handle == handle && old.parent == parent) return true;
        if (error)
            *error = "id " + hex(id) + " of a new " + object_type_name(type) + " still names a live " +
                     object_type_name(old.type);
        return false;
    }
    if (parent != 0) children_[parent].insert(id);
    return true;
}

bool HandleTable::remove(uint64_t id) {
    auto it = entries_.find(id);
    if (it == entries_.end()) return false;
    const uint64_t parent = it->second.parent;
    entries_.erase(it);
    if (parent != 0) {
        auto p = children_.find(parent);
        if (p != children_.end()) {
            p->second.erase(id);
            if (p->second.empty()) children_.erase(p);
        }
    }
    remove_children(id);
    return true;
}

void HandleTable::remove_children(uint64_t parent) {
    auto p = children_.find(parent);
    if (p == children_.end()) return;
    const std::unordered_set<uint64_t> children = std::move(p->second);
    children_.erase(p);
    for (const uint64_t child : children) {
        auto it = entries_.find(child);
        if (it != entries_.end() && it->second.parent == parent) {
            entries_.erase(it);
            remove_children(child); // pools of pools do not exist, but stay correct
        }
    }
}

const HandleTable::Entry *HandleTable::find(uint64_t id) const {
    auto it = entries_.find(id);
    return it == entries_.end() ? nullptr : &it->second;
}

void HandleTable::clear() {
    entries_.clear();
    children_.clear();
}

// ---------------------------------------------------------------------------------------------

EncodeHooks::SubpassUse EncodeHooks::subpass_use(VkRenderPass, uint32_t) {
    return {};
}
bool EncodeHooks::has_immutable_samplers(VkDescriptorSet, uint32_t) {
    return false;
}
void EncodeHooks::skipped_structure(VkStructureType, const char *) {}
void EncodeHooks::chain_truncated(const char *) {}

void Encoder::string(const char *s) {
    if (!present(s)) return;
    out_->string(std::string_view(s));
}

void Encoder::bytes(const void *p, size_t count) {
    if (count == 0) return;
    out_->bytes(std::span<const uint8_t>(static_cast<const uint8_t *>(p), count));
}

namespace {

// Converts to little-endian in chunks, so large arrays (shader code) are appended in few steps.
template <class T, size_t N, class Store>
void append_le(protocol::WireWriter &out, const T *p, size_t count, Store store) {
    uint8_t chunk[256 * sizeof(T)];
    while (count > 0) {
        const size_t n = std::min<size_t>(count, 256);
        for (size_t i = 0; i < n; ++i) {
            T v;
            std::memcpy(&v, p + i, sizeof(T));
            store(chunk + i * N, v);
        }
        out.bytes(std::span<const uint8_t>(chunk, n * N));
        p += n;
        count -= n;
    }
}

} // namespace

void Encoder::u32_array(const uint32_t *p, size_t count) {
    append_le<uint32_t, 4>(*out_, p, count, [](uint8_t *d, uint32_t v) { protocol::store_le32(d, v); });
}

void Encoder::f32_array(const float *p, size_t count) {
    append_le<float, 4>(*out_, p, count, [](uint8_t *d, float v) {
        uint32_t bits;
        std::memcpy(&bits, &v, 4);
        protocol::store_le32(d, bits);
    });
}

void Encoder::u64_array(const uint64_t *p, size_t count) {
    append_le<uint64_t, 8>(*out_, p, count, [](uint8_t *d, uint64_t v) { protocol::store_le64(d, v); });
}

void Encoder::words(const void *p, size_t count) {
    const auto *bytes = static_cast<const uint8_t *>(p);
    for (size_t i = 0; i < count; ++i) {
        uint32_t v;
        std::memcpy(&v, bytes + 4 * i, 4);
        out_->u32(v);
    }
}

bool Encoder::chain_step(uint32_t &length, const char *parent) {
    if (++length <= kMaxChainLength) return true;
    ++truncated_chains_;
    if (hooks_) hooks_->chain_truncated(parent);
    return false;
}

void Encoder::skipped_structure(VkStructureType stype, const char *parent) {
    ++skipped_structures_;
    if (hooks_) hooks_->skipped_structure(stype, parent);
}

// ---------------------------------------------------------------------------------------------

std::string Decoder::error() const {
    if (ok()) return {};
    if (command_) return std::string(command_) + ": " + reader_.error();
    return reader_.error();
}

bool Decoder::expect_command(uint16_t expected, const char *name) {
    const uint16_t id = reader_.u16("command");
    if (!ok()) return false;
    if (id != expected) {
        char text[96];
        std::snprintf(text, sizeof(text), "command id 0x%04x where %s (0x%04x) was expected", id, name,
                      expected);
        fail(text);
        return false;
    }
    return true;
}

size_t Decoder::size(const char *field) {
    const uint64_t v = reader_.u64(field);
    if (v > std::numeric_limits<size_t>::max()) {
        fail("size " + field_name(field) + " does not fit size_t");
        return 0;
    }
    return static_cast<size_t>(v);
}

uint64_t Decoder::lookup(VkObjectType type, bool nullable, const char *field, uint64_t *id_out) {
    const uint64_t id = reader_.u64(field);
    if (id_out) *id_out = ok() ? id : 0;
    if (!ok()) return 0;
    if (id == 0) {
        if (!nullable) fail(std::string("null ") + object_type_name(type) + " for " + field_name(field));
        return 0;
    }
    const HandleTable::Entry *entry = table_->find(id);
    if (!entry) {
        fail(std::string("unknown ") + object_type_name(type) + " id " + hex(id) + " in " +
             field_name(field));
        return 0;
    }
    if (entry->type != type) {
        fail("id " + hex(id) + " is a " + object_type_name(entry->type) + ", expected " +
             object_type_name(type) + " in " + field_name(field));
        return 0;
    }
    return entry->handle;
}

bool Decoder::present(const char *field, bool optional) {
    const uint8_t v = reader_.u8(field);
    if (!ok()) return false;
    if (v > 1) {
        fail("presence byte " + std::to_string(v) + " of " + field_name(field));
        return false;
    }
    if (v == 0 && !optional) {
        fail("missing " + field_name(field));
        return false;
    }
    return v == 1;
}

bool Decoder::check_count(uint64_t count, size_t min_wire_bytes, const char *field) {
    if (!ok()) return false;
    if (count > limits_.max_array_count) {
        fail(field_name(field) + " count " + std::to_string(count) + " exceeds the limit " +
             std::to_string(limits_.max_array_count));
        return false;
    }
    if (min_wire_bytes > 0 && count > reader_.remaining() / min_wire_bytes) {
        fail("truncated: " + field_name(field) + " of " + std::to_string(count) +
             " elements needs at least " + std::to_string(count * min_wire_bytes) + " bytes, " +
             std::to_string(reader_.remaining()) + " left");
        return false;
    }
    return true;
}

void Decoder::out_of_memory(const char *field) {
    fail("decoded data for " + field_name(field) + " exceeds the arena limit of " +
         std::to_string(arena_->cap()) + " bytes");
}

void Decoder::invalid_enum(const char *field, int32_t value) {
    fail("invalid enum value " + std::to_string(value) + " for " + field_name(field));
}

const char *Decoder::string(const char *field, bool optional) {
    if (!present(field, optional)) return nullptr;
    const uint32_t n = reader_.count(limits_.max_string_bytes, 1, field);
    if (!ok()) return nullptr;
    const auto view = reader_.bytes(n, field);
    if (!ok()) return nullptr;
    char *p = static_cast<char *>(arena_->allocate(size_t{n} + 1, 1));
    if (!p) {
        out_of_memory(field);
        return nullptr;
    }
    if (n > 0) std::memcpy(p, view.data(), n);
    return p;
}

const void *Decoder::bytes(uint64_t count, const char *field) {
    if (!ok()) return nullptr;
    if (count > reader_.remaining()) {
        fail("truncated: " + field_name(field) + " of " + std::to_string(count) + " bytes, " +
             std::to_string(reader_.remaining()) + " left");
        return nullptr;
    }
    if (count == 0) return nullptr;
    const auto view = reader_.bytes(static_cast<size_t>(count), field);
    if (!ok()) return nullptr;
    const size_t padded = (view.size() + 7) & ~size_t{7};
    void *p = arena_->allocate(padded, 8);
    if (!p) {
        out_of_memory(field);
        return nullptr;
    }
    std::memcpy(p, view.data(), view.size());
    return p;
}

void Decoder::u32_array(uint32_t *dst, size_t count, const char *field) {
    const auto view = reader_.bytes(count * 4, field);
    if (!ok() || !dst) return;
    for (size_t i = 0; i < count; ++i)
        dst[i] = protocol::load_le32(view.data() + 4 * i);
}

void Decoder::f32_array(float *dst, size_t count, const char *field) {
    const auto view = reader_.bytes(count * 4, field);
    if (!ok() || !dst) return;
    for (size_t i = 0; i < count; ++i) {
        const uint32_t bits = protocol::load_le32(view.data() + 4 * i);
        std::memcpy(dst + i, &bits, 4);
    }
}

void Decoder::u64_array(uint64_t *dst, size_t count, const char *field) {
    const auto view = reader_.bytes(count * 8, field);
    if (!ok() || !dst) return;
    for (size_t i = 0; i < count; ++i)
        dst[i] = protocol::load_le64(view.data() + 8 * i);
}

void Decoder::words(void *dst, size_t count, const char *field) {
    const auto view = reader_.bytes(count * 4, field);
    if (!ok()) return;
    auto *out = static_cast<uint8_t *>(dst);
    for (size_t i = 0; i < count; ++i) {
        const uint32_t v = protocol::load_le32(view.data() + 4 * i);
        std::memcpy(out + 4 * i, &v, 4);
    }
}

bool Decoder::enter(const char *what) {
    if (!ok()) return false;
    if (depth_ >= limits_.max_depth) {
        fail(std::string("structures nested deeper than ") + std::to_string(limits_.max_depth) + " at " +
             (what ? what : "?"));
        return false;
    }
    ++depth_;
    return true;
}

bool Decoder::chain_step(uint32_t &length, const char *parent) {
    if (!ok()) return false;
    if (++length > limits_.max_chain_length) {
        fail(std::string("pNext chain of ") + parent + " longer than " +
             std::to_string(limits_.max_chain_length));
        return false;
    }
    return true;
}

void Decoder::unexpected_structure(uint32_t stype, const char *parent) {
    fail("VkStructureType " + std::to_string(stype) + " cannot extend " + parent);
}

} // namespace splitvk::codec
