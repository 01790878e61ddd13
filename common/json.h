#pragma once

// A small JSON reader for the files splitvk reads: Khronos Vulkan profiles (the agent's
// --emulate-limits, the built-in baseline of protocol/device_envelope.h). Strict RFC 8259: one
// value, no comments, no trailing commas; nesting is capped so that a hostile file cannot exhaust
// the stack. Numbers keep their text as well, so that 64-bit limits survive exactly.

#include "result.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace splitvk::json {

using protocol::Error;
using protocol::Result;

inline constexpr int kMaxDepth = 64;

class Value {
public:
    enum class Kind { Null, Bool, Number, String, Array, Object };

    Kind kind() const { return kind_; }
    bool is_object() const { return kind_ == Kind::Object; }
    bool is_array() const { return kind_ == Kind::Array; }
    bool is_number() const { return kind_ == Kind::Number; }
    bool is_bool() const { return kind_ == Kind::Bool; }

    bool as_bool() const { return bool_; }
    double as_double() const { return number_; }
    // The number as an exact integer, if its text is one that fits.
    std::optional<uint64_t> as_u64() const;
    std::optional<int64_t> as_i64() const;
    const std::string &as_string() const { return text_; }
    const std::vector<Value> &items() const { return items_; }
    const std::vector<std::pair<std::string, Value>> &members() const { return members_; }
    // The member named `key` of an object; nullptr when absent or not an object.
    const Value *find(std::string_view key) const;

    static const char *kind_name(Kind kind);

private:
    friend class Parser;
    Kind kind_ = Kind::Null;
    bool bool_ = false;
    double number_ = 0;
    std::string text_; // a string's contents, or a number's source text
    std::vector<Value> items_;
    std::vector<std::pair<std::string, Value>> members_;
};

// Parses a whole document. Errors are one line with the byte offset.
Result<Value> parse(std::string_view text);

} // namespace splitvk::json
