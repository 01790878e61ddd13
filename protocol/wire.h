#pragma once

// splitvk's wire format (docs/architecture.md §3): message framing, and the primitive encoding that every
// payload (handshake, generated Vulkan codec, metadata) is built from.
//
// Everything is little-endian on the wire, whatever the host. A message is a 16-byte header
// followed by `payload_length` bytes of payload:
//
//   offset  size  field
//        0     4  payload_length  bytes that follow the header (compressed size if compressed)
//        4     2  type            MessageType (ranges below)
//        6     2  flags           bit 0: payload is one zstd frame; every other bit must be zero
//        8     8  sequence        1, 2, 3, ... per direction; a gap or repeat is a protocol error
//
// Primitives inside payloads: fixed-size integers and IEEE floats little-endian, no padding, no
// alignment; arrays, strings and blobs are a u32 element count followed by the elements.
//
// Readers are defensive in the Venus style: every read is bounds-checked, every length is checked
// against a cap before anything is allocated, and the first error is sticky.

#include "result.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace splitvk::protocol {

inline constexpr size_t kHeaderSize = 16;
inline constexpr uint32_t kDefaultMaxPayload = 64u << 20; // 64 MiB

inline constexpr uint16_t kFlagCompressed = 0x0001;
inline constexpr uint16_t kKnownFlags = kFlagCompressed;

// Message types. The ranges are part of the protocol; values inside a range are assigned by the
// code that owns it. Type 0 is never valid.
enum class MessageType : uint16_t {
    // 0x0001-0x00FF: control (handshake.h). Hello must be the first message of a session.
    Hello = 0x0001,
    Welcome = 0x0002,
    Reject = 0x0003,
    Goodbye = 0x0004,
    Ping = 0x0005,
    Pong = 0x0006,

    // 0x0100-0x0FFF: forwarded Vulkan commands, assigned by the generated codec (codegen/).
    VulkanFirst = 0x0100,
    Commands = 0x0100, // a sequence of codec-encoded commands (vk_codec.h), replayed in order
    VulkanLast = 0x0FFF,

    // 0x1000-0xFFFF: metadata that is not a Vulkan call.
    MemoryData = 0x1000,         // contents of a range of device memory (client -> server)
    FrameBegin = 0x1001,         // acquire: a frame starts on a swapchain image
    FramePresent = 0x1002,       // present: the server renders and returns this frame's fovea
    Tiles = 0x1003,              // encoded fovea tiles of one frame (server -> client)
    SwapchainImages = 0x1004,    // a swapchain's images, which the server makes offscreen images
    SwapchainDestroyed = 0x1005, // the client destroyed a swapchain
    VerifyFrame = 0x1006,        // a whole presented frame read back by the server (SPLITVK_VERIFY)
    SplitConfig = 0x1007,        // the client's split settings: eyes, fovea, codec (client -> server)
    ImageLayouts = 0x1008,       // the client's VkSubresourceLayouts of a linear image (client -> server)
    SwapchainView = 0x1009,      // an OpenXR eye's field of view: where its fovea sits (client -> server)
    BufferAddress = 0x100A,      // a buffer's device address on the client (client -> server)
    PeripheryConfig = 0x100B,    // the swapped split's periphery scale and quality (client -> server)
};

enum class MessageClass { Invalid, Control, Vulkan, Metadata };

constexpr MessageClass message_class(uint16_t type) {
    if (type == 0) return MessageClass::Invalid;
    if (type <= 0x00FF) return MessageClass::Control;
    if (type <= 0x0FFF) return MessageClass::Vulkan;
    return MessageClass::Metadata;
}

constexpr uint16_t to_wire(MessageType type) {
    return static_cast<uint16_t>(type);
}

// The name of a named type ("Hello", "Tiles"), "Vulkan command" for the codec's range, or
// "unknown"; for log lines.
const char *message_type_name(uint16_t type);

// True for the named control and metadata types and for the whole Vulkan command range (the
// generated decoder rejects command numbers it does not know). This is the default notion of a
// known type; a receiver can pass a stricter predicate in ReceivePolicy. (Keep it in step with the
// enum: named values are contiguous within their range.)
bool is_defined_type(uint16_t type);

// ---------------------------------------------------------------------------------------------
// Little-endian loads and stores: byte arithmetic, so they are correct on any host and never
// read or write through a misaligned pointer.

inline void store_le16(uint8_t *p, uint16_t v) {
    p[0] = static_cast<uint8_t>(v);
    p[1] = static_cast<uint8_t>(v >> 8);
}
inline void store_le32(uint8_t *p, uint32_t v) {
    for (int i = 0; i < 4; ++i)
        p[i] = static_cast<uint8_t>(v >> (8 * i));
}
inline void store_le64(uint8_t *p, uint64_t v) {
    for (int i = 0; i < 8; ++i)
        p[i] = static_cast<uint8_t>(v >> (8 * i));
}
inline uint16_t load_le16(const uint8_t *p) {
    return static_cast<uint16_t>(p[0] | (p[1] << 8));
}
inline uint32_t load_le32(const uint8_t *p) {
    uint32_t v = 0;
    for (int i = 3; i >= 0; --i)
        v = (v << 8) | p[i];
    return v;
}
inline uint64_t load_le64(const uint8_t *p) {
    uint64_t v = 0;
    for (int i = 7; i >= 0; --i)
        v = (v << 8) | p[i];
    return v;
}

// ---------------------------------------------------------------------------------------------
// Header

struct MessageHeader {
    uint32_t payload_length = 0;
    uint16_t type = 0;
    uint16_t flags = 0;
    uint64_t sequence = 0;

    bool compressed() const { return (flags & kFlagCompressed) != 0; }
    friend bool operator==(const MessageHeader &, const MessageHeader &) = default;
};

std::array<uint8_t, kHeaderSize> encode_header(const MessageHeader &header);
MessageHeader decode_header(std::span<const uint8_t, kHeaderSize> bytes);

// How far a reader skips to get past a message whose header it has read: the payload length.
// (The header is already consumed.) This is the whole "skip an unknown type" mechanism: lengths
// are explicit, so a reader never needs to understand a payload to step over it.
inline size_t bytes_to_skip(const MessageHeader &header) {
    return header.payload_length;
}

// A complete framed message (header + payload) as bytes; for tests and for tools that write raw
// streams. `payload` must already be compressed if flags says so.
std::vector<uint8_t> encode_frame(uint16_t type, uint64_t sequence, std::span<const uint8_t> payload,
                                  uint16_t flags = 0);

// What a receiver does with a message whose type it does not know.
enum class UnknownTypePolicy {
    Reject, // a protocol error: the session ends (the agent: an unknown type ends the session)
    Skip,   // step over its payload (without allocating it) and go on; counted in skipped()
};

struct ReceivePolicy {
    // Cap on payload_length and, for compressed payloads, on the decompressed size. Checked on
    // the header, before any payload byte is read or allocated.
    uint32_t max_payload = kDefaultMaxPayload;
    UnknownTypePolicy unknown_types = UnknownTypePolicy::Reject;
    // Which types this receiver knows. Empty: is_defined_type().
    std::function<bool(uint16_t)> is_known_type;
    // What sets max_payload, named in the error line ("--max-message-bytes"); empty: nothing.
    std::string max_payload_name;
};

enum class HeaderVerdict { Accept, Skip, Reject };

// Validates a header against the policy and the sequence number the receiver expects next:
// flags, type 0, length cap, sequence, unknown type. On Reject, `error` gets one line.
HeaderVerdict check_header(const MessageHeader &header, uint64_t expected_sequence,
                           const ReceivePolicy &policy, std::string &error);

// A received message. The payload is always the decompressed one.
struct Message {
    uint16_t type = 0;
    uint64_t sequence = 0;
    bool was_compressed = false;
    uint32_t wire_payload_bytes = 0; // payload bytes on the wire (compressed size if it was)
    std::vector<uint8_t> payload;
};

class Decompressor;

// Incremental decoder of an inbound byte stream: feed it whatever the socket returned (any split,
// one byte at a time if need be) and it emits complete, validated, decompressed messages. The
// header is validated before any payload byte is buffered; payload memory then grows with the
// bytes actually received (a header claiming 64 MiB reserves at most 1 MiB until more arrives), and
// the payload of a skipped message is never buffered at all. The first error is sticky: every later
// feed() returns false at once.
class FrameDecoder {
public:
    explicit FrameDecoder(ReceivePolicy policy = {});
    ~FrameDecoder();
    FrameDecoder(const FrameDecoder &) = delete;
    FrameDecoder &operator=(const FrameDecoder &) = delete;

    // Appends every message completed by `data` to `out` (those completed before an error too).
    // Returns false once the stream is in error.
    bool feed(std::span<const uint8_t> data, std::vector<Message> &out);

    bool ok() const { return error_.empty(); }
    const std::string &error() const { return error_; }
    uint64_t messages() const { return messages_; }
    uint64_t skipped() const { return skipped_; }
    uint64_t stream_offset() const { return offset_; } // bytes consumed so far
    // True when no partial message is buffered (a clean place for the stream to end).
    bool at_message_boundary() const { return state_ == State::Header && header_fill_ == 0; }

private:
    enum class State { Header, Payload, Skip };
    bool finish_message(std::vector<Message> &out);
    void set_error(std::string error);

    ReceivePolicy policy_;
    std::unique_ptr<Decompressor> decompressor_; // created on the first compressed message
    State state_ = State::Header;
    std::array<uint8_t, kHeaderSize> header_bytes_{};
    size_t header_fill_ = 0;
    MessageHeader header_;
    std::vector<uint8_t> payload_;
    size_t remaining_ = 0; // payload (or skip) bytes still to come
    uint64_t expected_sequence_ = 1;
    uint64_t messages_ = 0;
    uint64_t skipped_ = 0;
    uint64_t offset_ = 0;
    uint64_t message_offset_ = 0; // stream offset of the current message's header
    std::string error_;
};

// ---------------------------------------------------------------------------------------------
// Payload primitives

// Reads primitives from a byte span. Every read is bounds-checked; the first failure is sticky:
// afterwards every read returns zero / empty, ok() stays false and error() keeps describing the
// first failure in one line ("truncated: u32 'capabilities' at offset 8 needs 4 bytes, 2 left").
// The optional `field` names what is being read in that line. Never allocates more than the
// bytes actually present justify.
class WireReader {
public:
    explicit WireReader(std::span<const uint8_t> data) : data_(data) {}

    uint8_t u8(const char *field = nullptr);
    uint16_t u16(const char *field = nullptr);
    uint32_t u32(const char *field = nullptr);
    uint64_t u64(const char *field = nullptr);
    int32_t i32(const char *field = nullptr);
    int64_t i64(const char *field = nullptr);
    float f32(const char *field = nullptr);
    double f64(const char *field = nullptr);

    // `count` raw bytes, a view into the input (empty on error).
    std::span<const uint8_t> bytes(size_t count, const char *field = nullptr);
    // u32 length + that many bytes; a length over max_bytes is an error. A view into the input.
    std::span<const uint8_t> blob(uint32_t max_bytes, const char *field = nullptr);
    // u32 length + that many bytes as a string; a length over max_bytes is an error.
    std::string string(uint32_t max_bytes, const char *field = nullptr);
    // u32 element count of an array whose elements take at least min_element_bytes each. Fails
    // if the count is over max_count or if the bytes left cannot hold that many elements, so a
    // caller can size a container from it.
    uint32_t count(uint32_t max_count, size_t min_element_bytes, const char *field = nullptr);
    // u32 count + that many elements of an arithmetic type.
    template <class T>
    std::vector<T> array(uint32_t max_count, const char *field = nullptr);

    // Records a semantic error found by the caller (an unknown enum value, an id of the wrong
    // kind). Sticky like the others; ignored if an error is already recorded.
    void fail(std::string_view what);
    // Fails if bytes remain; call after the last field of a fixed layout.
    bool expect_end(const char *what = "message");

    bool ok() const { return error_.empty(); }
    const std::string &error() const { return error_; }
    size_t offset() const { return offset_; }
    size_t remaining() const { return ok() ? data_.size() - offset_ : 0; }
    bool at_end() const { return remaining() == 0; }

private:
    const uint8_t *take(size_t count, const char *type, const char *field);

    std::span<const uint8_t> data_;
    size_t offset_ = 0;
    std::string error_;
};

// Appends primitives to a growable buffer. Lengths that do not fit a u32 make ok() false (a
// programming error: payloads are capped far below 4 GiB) and write a zero length instead.
class WireWriter {
public:
    WireWriter() = default;
    explicit WireWriter(size_t reserve) { buffer_.reserve(reserve); }

    void u8(uint8_t v) { buffer_.push_back(v); }
    void u16(uint16_t v) { store_le16(grow(2), v); }
    void u32(uint32_t v) { store_le32(grow(4), v); }
    void u64(uint64_t v) { store_le64(grow(8), v); }
    void i32(int32_t v) { u32(static_cast<uint32_t>(v)); }
    void i64(int64_t v) { u64(static_cast<uint64_t>(v)); }
    void f32(float v);
    void f64(double v);

    void bytes(std::span<const uint8_t> data);
    void blob(std::span<const uint8_t> data);
    void string(std::string_view text);
    template <class T>
    void array(std::span<const T> values);

    // Overwrites a u32 written earlier (a count known only after its elements).
    void patch_u32(size_t offset, uint32_t v);

    size_t size() const { return buffer_.size(); }
    std::span<const uint8_t> data() const { return buffer_; }
    std::vector<uint8_t> take() { return std::move(buffer_); }
    bool ok() const { return ok_; }

private:
    uint8_t *grow(size_t count);
    uint32_t length(size_t count);

    std::vector<uint8_t> buffer_;
    bool ok_ = true;
};

// ---------------------------------------------------------------------------------------------

template <class T>
std::vector<T> WireReader::array(uint32_t max_count, const char *field) {
    static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool> && !std::is_same_v<T, long double>,
                  "WireReader::array reads fixed-size integers and floats");
    const uint32_t n = count(max_count, sizeof(T), field);
    std::vector<T> values;
    if (!ok()) return values;
    values.reserve(n);
    for (uint32_t i = 0; i < n; ++i) {
        if constexpr (std::is_floating_point_v<T>) {
            values.push_back(sizeof(T) == 4 ? static_cast<T>(f32(field)) : static_cast<T>(f64(field)));
        } else if constexpr (sizeof(T) == 1) {
            values.push_back(static_cast<T>(u8(field)));
        } else if constexpr (sizeof(T) == 2) {
            values.push_back(static_cast<T>(u16(field)));
        } else if constexpr (sizeof(T) == 4) {
            values.push_back(static_cast<T>(u32(field)));
        } else {
            static_assert(sizeof(T) == 8);
            values.push_back(static_cast<T>(u64(field)));
        }
    }
    return values;
}

template <class T>
void WireWriter::array(std::span<const T> values) {
    static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool> && !std::is_same_v<T, long double>,
                  "WireWriter::array writes fixed-size integers and floats");
    u32(length(values.size()));
    for (const T v : values) {
        if constexpr (std::is_floating_point_v<T>) {
            if constexpr (sizeof(T) == 4)
                f32(v);
            else
                f64(static_cast<double>(v));
        } else if constexpr (sizeof(T) == 1) {
            u8(static_cast<uint8_t>(v));
        } else if constexpr (sizeof(T) == 2) {
            u16(static_cast<uint16_t>(v));
        } else if constexpr (sizeof(T) == 4) {
            u32(static_cast<uint32_t>(v));
        } else {
            u64(static_cast<uint64_t>(v));
        }
    }
}

} // namespace splitvk::protocol
