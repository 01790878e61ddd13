#include "wire.h"

#include "compression.h"

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <limits>
#include <new>

namespace splitvk::protocol {
namespace {

std::string hex16(uint16_t v) {
    char text[8];
    std::snprintf(text, sizeof(text), "0x%04x", v);
    return text;
}

// Payload memory is reserved in steps as bytes arrive, so a header claiming a large payload does
// not allocate it up front.
constexpr size_t kPayloadReserveStep = 1u << 20;

} // namespace

const char *message_type_name(uint16_t type) {
    switch (static_cast<MessageType>(type)) {
    case MessageType::Hello:
        return "Hello";
    case MessageType::Welcome:
        return "Welcome";
    case MessageType::Reject:
        return "Reject";
    case MessageType::Goodbye:
        return "Goodbye";
    case MessageType::Ping:
        return "Ping";
    case MessageType::Pong:
        return "Pong";
    case MessageType::MemoryData:
        return "MemoryData";
    case MessageType::FrameBegin:
        return "FrameBegin";
    case MessageType::FramePresent:
        return "FramePresent";
    case MessageType::Tiles:
        return "Tiles";
    case MessageType::SwapchainImages:
        return "SwapchainImages";
    case MessageType::SwapchainDestroyed:
        return "SwapchainDestroyed";
    case MessageType::SplitConfig:
        return "SplitConfig";
    case MessageType::VerifyFrame:
        return "VerifyFrame";
    case MessageType::ImageLayouts:
        return "ImageLayouts";
    case MessageType::SwapchainView:
        return "SwapchainView";
    case MessageType::BufferAddress:
        return "BufferAddress";
    case MessageType::PeripheryConfig:
        return "PeripheryConfig";
    default:
        break;
    }
    return message_class(type) == MessageClass::Vulkan ? "Vulkan command" : "unknown";
}

bool is_defined_type(uint16_t type) {
    switch (message_class(type)) {
    case MessageClass::Vulkan:
        return true;
    case MessageClass::Invalid:
        return false;
    case MessageClass::Control:
        return type >= to_wire(MessageType::Hello) && type <= to_wire(MessageType::Pong);
    case MessageClass::Metadata:
        return type >= to_wire(MessageType::MemoryData) && type <= to_wire(MessageType::PeripheryConfig);
    }
    return false;
}

std::array<uint8_t, kHeaderSize> encode_header(const MessageHeader &header) {
    std::array<uint8_t, kHeaderSize> bytes{};
    store_le32(bytes.data() + 0, header.payload_length);
    store_le16(bytes.data() + 4, header.type);
    store_le16(bytes.data() + 6, header.flags);
    store_le64(bytes.data() + 8, header.sequence);
    return bytes;
}

MessageHeader decode_header(std::span<const uint8_t, kHeaderSize> bytes) {
    MessageHeader header;
    header.payload_length = load_le32(bytes.data() + 0);
    header.type = load_le16(bytes.data() + 4);
    header.flags = load_le16(bytes.data() + 6);
    header.sequence = load_le64(bytes.data() + 8);
    return header;
}

std::vector<uint8_t> encode_frame(uint16_t type, uint64_t sequence, std::span<const uint8_t> payload,
                                  uint16_t flags) {
    MessageHeader header;
    header.payload_length = static_cast<uint32_t>(std::min<size_t>(payload.size(), UINT32_MAX));
    header.type = type;
    header.flags = flags;
    header.sequence = sequence;
    const auto head = encode_header(header);
    std::vector<uint8_t> frame(kHeaderSize + header.payload_length);
    std::memcpy(frame.data(), head.data(), kHeaderSize);
    if (header.payload_length > 0)
        std::memcpy(frame.data() + kHeaderSize, payload.data(), header.payload_length);
    return frame;
}

HeaderVerdict check_header(const MessageHeader &header, uint64_t expected_sequence,
                           const ReceivePolicy &policy, std::string &error) {
    // Error lines are built only on the error paths: this runs for every message received.
    const auto what = [&] {
        return "message " + std::to_string(header.sequence) + " (type " + hex16(header.type) + ")";
    };
    if ((header.flags & ~kKnownFlags) != 0) {
        error = what() + ": unknown flags " + hex16(header.flags);
        return HeaderVerdict::Reject;
    }
    if (header.sequence != expected_sequence) {
        error = "sequence " + std::to_string(header.sequence) + " where " +
                std::to_string(expected_sequence) + " was expected (type " + hex16(header.type) + ")";
        return HeaderVerdict::Reject;
    }
    if (header.type == 0) {
        error = what() + ": type 0 is not a valid message type";
        return HeaderVerdict::Reject;
    }
    if (header.payload_length > policy.max_payload) {
        error = what() + ": payload length " + std::to_string(header.payload_length) + " exceeds the limit " +
                std::to_string(policy.max_payload);
        if (!policy.max_payload_name.empty()) error += " (" + policy.max_payload_name + ")";
        return HeaderVerdict::Reject;
    }
    const bool known =
        policy.is_known_type ? policy.is_known_type(header.type) : is_defined_type(header.type);
    if (!known) {
        if (policy.unknown_types == UnknownTypePolicy::Skip) return HeaderVerdict::Skip;
        error = what() + ": unknown message type";
        return HeaderVerdict::Reject;
    }
    return HeaderVerdict::Accept;
}

// ---------------------------------------------------------------------------------------------

FrameDecoder::FrameDecoder(ReceivePolicy policy) : policy_(std::move(policy)) {}

FrameDecoder::~FrameDecoder() = default;

void FrameDecoder::set_error(std::string error) {
    if (error_.empty()) error_ = std::move(error);
    payload_ = {};
}

bool FrameDecoder::feed(std::span<const uint8_t> data, std::vector<Message> &out) {
    while (ok() && !data.empty()) {
        switch (state_) {
        case State::Header: {
            const size_t n = std::min(kHeaderSize - header_fill_, data.size());
            std::copy_n(data.begin(), n, header_bytes_.begin() + static_cast<ptrdiff_t>(header_fill_));
            header_fill_ += n;
            offset_ += n;
            data = data.subspan(n);
            if (header_fill_ < kHeaderSize) break;

            header_fill_ = 0;
            header_ = decode_header(std::span<const uint8_t, kHeaderSize>(header_bytes_));
            message_offset_ = offset_ - kHeaderSize;
            std::string error;
            const HeaderVerdict verdict = check_header(header_, expected_sequence_, policy_, error);
            if (verdict == HeaderVerdict::Reject) {
                set_error(error + " at stream offset " + std::to_string(message_offset_));
                break;
            }
            ++expected_sequence_;
            remaining_ = header_.payload_length;
            if (verdict == HeaderVerdict::Skip) {
                ++skipped_;
                state_ = State::Skip;
            } else {
                payload_.clear();
                try {
                    payload_.reserve(std::min(remaining_, kPayloadReserveStep));
                } catch (const std::bad_alloc &) {
                    set_error("out of memory for a message payload");
                    break;
                }
                state_ = State::Payload;
            }
            if (remaining_ == 0) {
                if (state_ == State::Skip)
                    state_ = State::Header;
                else
                    finish_message(out);
            }
            break;
        }
        case State::Payload: {
            const size_t n = std::min(remaining_, data.size());
            try {
                if (payload_.capacity() < payload_.size() + n)
                    payload_.reserve(std::min<size_t>(
                        header_.payload_length, std::max(payload_.size() + n, payload_.capacity() * 2)));
                payload_.insert(payload_.end(), data.begin(), data.begin() + static_cast<ptrdiff_t>(n));
            } catch (const std::bad_alloc &) {
                set_error("out of memory for a message payload");
                break;
            }
            remaining_ -= n;
            offset_ += n;
            data = data.subspan(n);
            if (remaining_ == 0) finish_message(out);
            break;
        }
        case State::Skip: {
            const size_t n = std::min(remaining_, data.size());
            remaining_ -= n;
            offset_ += n;
            data = data.subspan(n);
            if (remaining_ == 0) state_ = State::Header;
            break;
        }
        }
    }
    return ok();
}

bool FrameDecoder::finish_message(std::vector<Message> &out) {
    state_ = State::Header;
    Message message;
    message.type = header_.type;
    message.sequence = header_.sequence;
    message.was_compressed = header_.compressed();
    message.wire_payload_bytes = header_.payload_length;
    if (header_.compressed()) {
        if (!decompressor_) decompressor_ = std::make_unique<Decompressor>();
        auto result = decompressor_->decompress(payload_, policy_.max_payload);
        if (!result) {
            set_error("message " + std::to_string(header_.sequence) + " (type " + hex16(header_.type) +
                      "): " + result.error() + " at stream offset " + std::to_string(message_offset_) +
                      (policy_.max_payload_name.empty() ? "" : " (limit: " + policy_.max_payload_name + ")"));
            return false;
        }
        message.payload = std::move(result).value();
        payload_ = {};
    } else {
        message.payload = std::move(payload_);
        payload_ = {};
    }
    ++messages_;
    out.push_back(std::move(message));
    return true;
}

// ---------------------------------------------------------------------------------------------

const uint8_t *WireReader::take(size_t count, const char *type, const char *field) {
    if (!ok()) return nullptr;
    const size_t left = data_.size() - offset_;
    if (count > left) {
        std::string line = "truncated: ";
        line += type;
        if (field) {
            line += " '";
            line += field;
            line += "'";
        }
        line += " at offset " + std::to_string(offset_) + " needs " + std::to_string(count) + " bytes, " +
                std::to_string(left) + " left";
        error_ = std::move(line);
        return nullptr;
    }
    const uint8_t *p = data_.data() + offset_;
    offset_ += count;
    return p;
}

void WireReader::fail(std::string_view what) {
    if (!ok()) return;
    error_ = std::string(what.empty() ? "error" : what) + " at offset " + std::to_string(offset_);
}

bool WireReader::expect_end(const char *what) {
    if (!ok()) return false;
    if (offset_ != data_.size()) {
        error_ = std::to_string(data_.size() - offset_) + " unexpected bytes after the " + what +
                 " at offset " + std::to_string(offset_);
        return false;
    }
    return true;
}

uint8_t WireReader::u8(const char *field) {
    const uint8_t *p = take(1, "u8", field);
    return p ? p[0] : 0;
}
uint16_t WireReader::u16(const char *field) {
    const uint8_t *p = take(2, "u16", field);
    return p ? load_le16(p) : 0;
}
uint32_t WireReader::u32(const char *field) {
    const uint8_t *p = take(4, "u32", field);
    return p ? load_le32(p) : 0;
}
uint64_t WireReader::u64(const char *field) {
    const uint8_t *p = take(8, "u64", field);
    return p ? load_le64(p) : 0;
}
int32_t WireReader::i32(const char *field) {
    const uint8_t *p = take(4, "i32", field);
    return p ? static_cast<int32_t>(load_le32(p)) : 0;
}
int64_t WireReader::i64(const char *field) {
    const uint8_t *p = take(8, "i64", field);
    return p ? static_cast<int64_t>(load_le64(p)) : 0;
}
float WireReader::f32(const char *field) {
    const uint8_t *p = take(4, "f32", field);
    if (!p) return 0.0f;
    const uint32_t bits = load_le32(p);
    float v;
    std::memcpy(&v, &bits, sizeof(v));
    return v;
}
double WireReader::f64(const char *field) {
    const uint8_t *p = take(8, "f64", field);
    if (!p) return 0.0;
    const uint64_t bits = load_le64(p);
    double v;
    std::memcpy(&v, &bits, sizeof(v));
    return v;
}

std::span<const uint8_t> WireReader::bytes(size_t count, const char *field) {
    const uint8_t *p = take(count, "bytes", field);
    return p ? std::span<const uint8_t>(p, count) : std::span<const uint8_t>();
}

uint32_t WireReader::count(uint32_t max_count, size_t min_element_bytes, const char *field) {
    const size_t at = offset_;
    const uint32_t n = u32(field ? field : "count");
    if (!ok()) return 0;
    const char *name = field ? field : "array";
    if (n > max_count) {
        error_ = std::string(name) + " count " + std::to_string(n) + " at offset " + std::to_string(at) +
                 " exceeds the limit " + std::to_string(max_count);
        return 0;
    }
    const size_t left = data_.size() - offset_;
    if (min_element_bytes > 0 && n > left / min_element_bytes) {
        error_ = "truncated: " + std::string(name) + " of " + std::to_string(n) + " elements at offset " +
                 std::to_string(at) + " needs at least " +
                 std::to_string(static_cast<uint64_t>(n) * min_element_bytes) + " bytes, " +
                 std::to_string(left) + " left";
        return 0;
    }
    return n;
}

std::span<const uint8_t> WireReader::blob(uint32_t max_bytes, const char *field) {
    const uint32_t n = count(max_bytes, 1, field ? field : "blob");
    if (!ok()) return {};
    return bytes(n, field);
}

std::string WireReader::string(uint32_t max_bytes, const char *field) {
    const uint32_t n = count(max_bytes, 1, field ? field : "string");
    if (!ok()) return {};
    const auto view = bytes(n, field);
    return std::string(view.begin(), view.end());
}

// ---------------------------------------------------------------------------------------------

uint8_t *WireWriter::grow(size_t count) {
    const size_t at = buffer_.size();
    buffer_.resize(at + count);
    return buffer_.data() + at;
}

uint32_t WireWriter::length(size_t count) {
    if (count > std::numeric_limits<uint32_t>::max()) {
        ok_ = false;
        return 0;
    }
    return static_cast<uint32_t>(count);
}

void WireWriter::f32(float v) {
    uint32_t bits;
    std::memcpy(&bits, &v, sizeof(bits));
    u32(bits);
}

void WireWriter::f64(double v) {
    uint64_t bits;
    std::memcpy(&bits, &v, sizeof(bits));
    u64(bits);
}

void WireWriter::bytes(std::span<const uint8_t> data) {
    buffer_.insert(buffer_.end(), data.begin(), data.end());
}

void WireWriter::blob(std::span<const uint8_t> data) {
    const uint32_t n = length(data.size());
    u32(n);
    if (n == data.size()) bytes(data);
}

void WireWriter::string(std::string_view text) {
    blob(std::span<const uint8_t>(reinterpret_cast<const uint8_t *>(text.data()), text.size()));
}

void WireWriter::patch_u32(size_t offset, uint32_t v) {
    if (offset > buffer_.size() || buffer_.size() - offset < 4) {
        ok_ = false;
        return;
    }
    store_le32(buffer_.data() + offset, v);
}

} // namespace splitvk::protocol
