#pragma once

// Buffer device addresses (VK_KHR_buffer_device_address, core 1.2's bufferDeviceAddress) on the
// agent. An address is a number the client's driver chose; the agent's driver places the same
// buffer elsewhere (another GPU, or lavapipe in another process), so a client address replayed
// as it is reads whatever lies there on the agent. Opaque capture addresses do not help: they
// are only portable between devices of one driver, and the agent's is in general not the client's.
//
// So the agent translates. The client sends what its vkGetBufferDeviceAddress returned
// (BufferAddress, after the buffer's bind); the agent asks its own driver for the same buffer's
// address and keeps, per buffer, client range [address, address + size) -> agent base. Both sides
// created the buffer from one VkBufferCreateInfo, so an offset inside it is the same on both.
//
// Where addresses travel typed, they are translated: 8-byte push-constant fields that the
// pipeline's SPIR-V reads as PhysicalStorageBuffer pointers (spirv_pointers.h). What the agent
// cannot translate, it does not guess at: an address the map does not know, or a pipeline that
// gets addresses from memory or computes them (spirv_pointers.h says which), marks the command
// buffer. It is never submitted (run, it would read or write wherever the client's number points
// on this GPU), and every frame from then on is flagged invalid, since later frames may read what
// it would have written (LimitGuard::untranslatable_address): the client shows the periphery
// there, never a fovea drawn from a wrong address.

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <unordered_map>

namespace splitvk::agent {

class BufferAddressMap {
public:
    // Buffer `buffer` (the agent's handle value) covers client addresses [client, client + size)
    // and starts at `agent` on this GPU. Replaces what the map had for `buffer`. A buffer whose
    // client range starts where another's does (aliases of one allocation on the client) replaces
    // that one: the newest buffer at an address wins, as the agent gives each its own memory.
    void insert(uint64_t buffer, uint64_t client, uint64_t size, uint64_t agent);
    // vkDestroyBuffer: its addresses name nothing any more.
    void erase(uint64_t buffer);

    // The agent address of client address `address`: inside a known buffer, at the same offset.
    std::optional<uint64_t> translate(uint64_t address) const;
    size_t size() const { return by_start_.size(); }

private:
    struct Range {
        uint64_t end = 0; // one past the last client address
        uint64_t agent = 0;
        uint64_t buffer = 0;
    };
    std::map<uint64_t, Range> by_start_;           // client start -> range
    std::unordered_map<uint64_t, uint64_t> start_; // buffer -> client start
};

// What translate_push_constants did to one vkCmdPushConstants.
struct PushTranslation {
    uint32_t translated = 0; // addresses rewritten to the agent's
    uint32_t unknown = 0;    // non-zero addresses inside no known buffer: left as they were
    uint32_t partial = 0;    // address fields the update covers only in part: left as they were
};

// Rewrites, in `bytes` (the push-constant bytes of an update at byte `offset` of the block), each
// 8-byte address whose block offset is in `pointer_offsets`, when the update covers it whole.
// Zero stays zero (a null reference is the same on both sides).
PushTranslation translate_push_constants(const BufferAddressMap &map,
                                         std::span<const uint32_t> pointer_offsets, uint32_t offset,
                                         std::span<uint8_t> bytes);

} // namespace splitvk::agent
