// The strict JSON reader behind Khronos profiles (common/json.h).
#include "json.h"

#include <string>

#include <gtest/gtest.h>

namespace splitvk::json {
namespace {

TEST(Json, ReadsEveryKindOfValue) {
    auto v = parse(
        R"( {"a": [1, -2.5e1, true, false, null], "b": {"c": "x\"\\\/\b\f\n\r\t\u00e9\ud83d\ude00"}} )");
    ASSERT_TRUE(v.ok()) << v.error();
    const Value *a = v->find("a");
    ASSERT_TRUE(a && a->is_array());
    ASSERT_EQ(a->items().size(), 5u);
    EXPECT_EQ(a->items()[0].as_u64(), 1u);
    EXPECT_DOUBLE_EQ(a->items()[1].as_double(), -25.0);
    EXPECT_FALSE(a->items()[1].as_u64());
    EXPECT_TRUE(a->items()[2].as_bool());
    EXPECT_EQ(a->items()[4].kind(), Value::Kind::Null);
    EXPECT_EQ(v->find("b")->find("c")->as_string(), "x\"\\/\b\f\n\r\t\xc3\xa9\xf0\x9f\x98\x80");
    EXPECT_EQ(v->find("missing"), nullptr);
}

TEST(Json, KeepsSixtyFourBitIntegersExact) {
    auto v = parse("[18446744073709551615, 9007199254740993, -9223372036854775808, 18446744073709551616]");
    ASSERT_TRUE(v.ok()) << v.error();
    EXPECT_EQ(v->items()[0].as_u64(), UINT64_MAX);
    EXPECT_EQ(v->items()[1].as_u64(), 9007199254740993ull) << "above 2^53: a double would round it";
    EXPECT_EQ(v->items()[2].as_i64(), INT64_MIN);
    EXPECT_FALSE(v->items()[3].as_u64()) << "out of range is not a value";
}

TEST(Json, RejectsWhatRfc8259Rejects) {
    for (const char *bad : {"", "{", "[1,]", "{\"a\":1,}", "{'a':1}", "01", "1.", "-", "tru", "[1] 2",
                            "\"\\x\"", "\"\\ud800\"", "\"\x01\"", "// comment\n1", "{\"a\" 1}", "[1 2]"}) {
        auto v = parse(bad);
        EXPECT_FALSE(v.ok()) << "accepted: " << bad;
        if (!v.ok()) {
            EXPECT_EQ(v.error().rfind("JSON at byte ", 0), 0u) << v.error();
        }
    }
}

TEST(Json, CapsNesting) {
    std::string deep(kMaxDepth + 2, '[');
    deep += std::string(kMaxDepth + 2, ']');
    auto v = parse(deep);
    ASSERT_FALSE(v.ok());
    EXPECT_NE(v.error().find("nested deeper"), std::string::npos) << v.error();
    std::string fine(kMaxDepth, '[');
    fine += std::string(kMaxDepth, ']');
    EXPECT_TRUE(parse(fine).ok());
}

} // namespace
} // namespace splitvk::json
