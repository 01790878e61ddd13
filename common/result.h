#pragma once

// A value or a one-line error, for protocol code that must not throw across the layer boundary.
// (std::expected is C++23; this is the small part of it splitvk needs.)

#include <optional>
#include <string>
#include <utility>

namespace splitvk::protocol {

// The failure half of a Result: `return Error{"what went wrong"};`
struct Error {
    std::string message;
};

template <class T>
class [[nodiscard]] Result {
public:
    Result(T value) : value_(std::move(value)) {}
    Result(Error error) : error_(std::move(error.message)) {
        if (error_.empty()) error_ = "unknown error";
    }

    bool ok() const { return value_.has_value(); }
    explicit operator bool() const { return ok(); }

    // Only valid when ok().
    T &value() & { return *value_; }
    const T &value() const & { return *value_; }
    T &&value() && { return std::move(*value_); }
    T *operator->() { return &*value_; }
    const T *operator->() const { return &*value_; }
    T &operator*() & { return *value_; }
    const T &operator*() const & { return *value_; }

    // Empty when ok().
    const std::string &error() const { return error_; }

private:
    std::optional<T> value_;
    std::string error_;
};

} // namespace splitvk::protocol
