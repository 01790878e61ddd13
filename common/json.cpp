#include "json.h"

#include <cerrno>
#include <cstdlib>

namespace splitvk::json {

class Parser {
public:
    explicit Parser(std::string_view text) : text_(text) {}

    Result<Value> document() {
        Value value;
        skip_space();
        if (!parse_value(value, 0)) return Error{error_};
        skip_space();
        if (pos_ != text_.size()) return Error{at("unexpected text after the JSON value")};
        return value;
    }

private:
    std::string at(std::string_view what) const {
        return "JSON at byte " + std::to_string(pos_) + ": " + std::string(what);
    }
    bool fail(std::string_view what) {
        if (error_.empty()) error_ = at(what);
        return false;
    }
    void skip_space() {
        while (pos_ < text_.size() &&
               (text_[pos_] == ' ' || text_[pos_] == '\t' || text_[pos_] == '\n' || text_[pos_] == '\r'))
            ++pos_;
    }
    bool literal(std::string_view word) {
        if (text_.substr(pos_, word.size()) != word) return fail("unknown literal");
        pos_ += word.size();
        return true;
    }

    bool parse_value(Value &out, int depth) {
        if (depth > kMaxDepth) return fail("nested deeper than " + std::to_string(kMaxDepth));
        if (pos_ >= text_.size()) return fail("unexpected end of input");
        switch (text_[pos_]) {
        case '{':
            return parse_object(out, depth);
        case '[':
            return parse_array(out, depth);
        case '"':
            out.kind_ = Value::Kind::String;
            return parse_string(out.text_);
        case 't':
            out.kind_ = Value::Kind::Bool;
            out.bool_ = true;
            return literal("true");
        case 'f':
            out.kind_ = Value::Kind::Bool;
            return literal("false");
        case 'n':
            return literal("null");
        default:
            return parse_number(out);
        }
    }

    bool parse_object(Value &out, int depth) {
        out.kind_ = Value::Kind::Object;
        ++pos_;
        skip_space();
        if (pos_ < text_.size() && text_[pos_] == '}') {
            ++pos_;
            return true;
        }
        for (;;) {
            skip_space();
            if (pos_ >= text_.size() || text_[pos_] != '"') return fail("expected a member name");
            std::string key;
            if (!parse_string(key)) return false;
            skip_space();
            if (pos_ >= text_.size() || text_[pos_] != ':') return fail("expected ':'");
            ++pos_;
            skip_space();
            Value member;
            if (!parse_value(member, depth + 1)) return false;
            out.members_.emplace_back(std::move(key), std::move(member));
            skip_space();
            if (pos_ < text_.size() && text_[pos_] == ',') {
                ++pos_;
                continue;
            }
            if (pos_ < text_.size() && text_[pos_] == '}') {
                ++pos_;
                return true;
            }
            return fail("expected ',' or '}'");
        }
    }

    bool parse_array(Value &out, int depth) {
        out.kind_ = Value::Kind::Array;
        ++pos_;
        skip_space();
        if (pos_ < text_.size() && text_[pos_] == ']') {
            ++pos_;
            return true;
        }
        for (;;) {
            skip_space();
            Value item;
            if (!parse_value(item, depth + 1)) return false;
            out.items_.push_back(std::move(item));
            skip_space();
            if (pos_ < text_.size() && text_[pos_] == ',') {
                ++pos_;
                continue;
            }
            if (pos_ < text_.size() && text_[pos_] == ']') {
                ++pos_;
                return true;
            }
            return fail("expected ',' or ']'");
        }
    }

    static int hex_digit(char c) {
        if (c >= '0' && c <= '9') return c - '0';
        if (c >= 'a' && c <= 'f') return c - 'a' + 10;
        if (c >= 'A' && c <= 'F') return c - 'A' + 10;
        return -1;
    }

    bool parse_hex4(uint32_t &out) {
        if (pos_ + 4 > text_.size()) return fail("truncated \\u escape");
        out = 0;
        for (int i = 0; i < 4; ++i) {
            const int d = hex_digit(text_[pos_++]);
            if (d < 0) return fail("bad \\u escape");
            out = (out << 4) | static_cast<uint32_t>(d);
        }
        return true;
    }

    static void append_utf8(std::string &s, uint32_t cp) {
        if (cp < 0x80) {
            s += static_cast<char>(cp);
        } else if (cp < 0x800) {
            s += static_cast<char>(0xC0 | (cp >> 6));
            s += static_cast<char>(0x80 | (cp & 0x3F));
        } else if (cp < 0x10000) {
            s += static_cast<char>(0xE0 | (cp >> 12));
            s += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
            s += static_cast<char>(0x80 | (cp & 0x3F));
        } else {
            s += static_cast<char>(0xF0 | (cp >> 18));
            s += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
            s += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
            s += static_cast<char>(0x80 | (cp & 0x3F));
        }
    }

    bool parse_string(std::string &out) {
        ++pos_; // the opening quote
        for (;;) {
            if (pos_ >= text_.size()) return fail("unterminated string");
            const char c = text_[pos_++];
            if (c == '"') return true;
            if (static_cast<unsigned char>(c) < 0x20) return fail("control character in a string");
            if (c != '\\') {
                out += c;
                continue;
            }
            if (pos_ >= text_.size()) return fail("unterminated escape");
            const char e = text_[pos_++];
            switch (e) {
            case '"':
            case '\\':
            case '/':
                out += e;
                break;
            case 'b':
                out += '\b';
                break;
            case 'f':
                out += '\f';
                break;
            case 'n':
                out += '\n';
                break;
            case 'r':
                out += '\r';
                break;
            case 't':
                out += '\t';
                break;
            case 'u': {
                uint32_t cp = 0;
                if (!parse_hex4(cp)) return false;
                if (cp >= 0xD800 && cp <= 0xDBFF) {
                    uint32_t low = 0;
                    if (text_.substr(pos_, 2) != "\\u") return fail("unpaired surrogate");
                    pos_ += 2;
                    if (!parse_hex4(low)) return false;
                    if (low < 0xDC00 || low > 0xDFFF) return fail("unpaired surrogate");
                    cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00);
                } else if (cp >= 0xDC00 && cp <= 0xDFFF) {
                    return fail("unpaired surrogate");
                }
                append_utf8(out, cp);
                break;
            }
            default:
                return fail("unknown escape");
            }
        }
    }

    bool parse_number(Value &out) {
        const size_t start = pos_;
        auto digits = [&] {
            const size_t from = pos_;
            while (pos_ < text_.size() && text_[pos_] >= '0' && text_[pos_] <= '9')
                ++pos_;
            return pos_ > from;
        };
        if (pos_ < text_.size() && text_[pos_] == '-') ++pos_;
        if (pos_ < text_.size() && text_[pos_] == '0') {
            ++pos_;
        } else if (!digits()) {
            return fail("expected a value");
        }
        if (pos_ < text_.size() && text_[pos_] == '.') {
            ++pos_;
            if (!digits()) return fail("expected digits after '.'");
        }
        if (pos_ < text_.size() && (text_[pos_] == 'e' || text_[pos_] == 'E')) {
            ++pos_;
            if (pos_ < text_.size() && (text_[pos_] == '+' || text_[pos_] == '-')) ++pos_;
            if (!digits()) return fail("expected digits in the exponent");
        }
        out.kind_ = Value::Kind::Number;
        out.text_ = std::string(text_.substr(start, pos_ - start));
        out.number_ = std::strtod(out.text_.c_str(), nullptr);
        return true;
    }

    std::string_view text_;
    size_t pos_ = 0;
    std::string error_;
};

std::optional<uint64_t> Value::as_u64() const {
    if (kind_ != Kind::Number || text_.empty() || text_[0] == '-' ||
        text_.find_first_of(".eE") != std::string::npos)
        return std::nullopt;
    errno = 0;
    const unsigned long long v = std::strtoull(text_.c_str(), nullptr, 10);
    if (errno == ERANGE) return std::nullopt;
    return static_cast<uint64_t>(v);
}

std::optional<int64_t> Value::as_i64() const {
    if (kind_ != Kind::Number || text_.find_first_of(".eE") != std::string::npos) return std::nullopt;
    errno = 0;
    const long long v = std::strtoll(text_.c_str(), nullptr, 10);
    if (errno == ERANGE) return std::nullopt;
    return static_cast<int64_t>(v);
}

const Value *Value::find(std::string_view key) const {
    if (kind_ != Kind::Object) return nullptr;
    for (const auto &[name, value] : members_)
        if (name == key) return &value;
    return nullptr;
}

const char *Value::kind_name(Kind kind) {
    switch (kind) {
    case Kind::Null:
        return "null";
    case Kind::Bool:
        return "a boolean";
    case Kind::Number:
        return "a number";
    case Kind::String:
        return "a string";
    case Kind::Array:
        return "an array";
    case Kind::Object:
        return "an object";
    }
    return "?";
}

Result<Value> parse(std::string_view text) {
    return Parser(text).document();
}

} // namespace splitvk::json
