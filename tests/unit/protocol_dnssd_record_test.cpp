#include "dnssd_record.h"
#include "handshake.h"

#include <algorithm>

#include <gtest/gtest.h>

namespace splitvk::protocol {
namespace {

AgentRecord sample() {
    AgentRecord record;
    record.session = session_text(0x0123456789abcdefull);
    record.certificate = "sha256:" + std::string(64, 'a');
    record.gpu_name = "llvmpipe (LLVM 15.0.6, 256 bits)";
    record.gpu_uuid = std::string(32, '0');
    record.tls = true;
    record.free_slots = 3;
    record.max_slots = 4;
    return record;
}

TEST(DnssdRecord, RoundTripsInAnyOrder) {
    std::vector<std::string> txt = encode_txt(sample());
    ASSERT_EQ(txt.size(), dnssd_key_table().size());
    std::reverse(txt.begin(), txt.end());
    txt.push_back("future=whatever"); // a key a later agent adds is ignored
    auto decoded = decode_txt(txt);
    ASSERT_TRUE(decoded) << decoded.error();
    EXPECT_EQ(*decoded, sample());
}

TEST(DnssdRecord, NoCertificateIsNone) {
    AgentRecord record = sample();
    record.certificate.clear();
    record.tls = false;
    const std::vector<std::string> txt = encode_txt(record);
    EXPECT_NE(std::find(txt.begin(), txt.end(), "cert=none"), txt.end());
    auto decoded = decode_txt(txt);
    ASSERT_TRUE(decoded) << decoded.error();
    EXPECT_EQ(*decoded, record);
}

TEST(DnssdRecord, SessionTextIsTheHandshakesFingerprint) {
    const std::string text = session_text(42);
    char hex[17];
    std::snprintf(hex, sizeof(hex), "%016llx", static_cast<unsigned long long>(session_fingerprint(42)));
    EXPECT_EQ(text, std::to_string(kProtocolMajor) + "-" + hex);
    EXPECT_NE(session_text(43), text);
}

TEST(DnssdRecord, AMissingOrMalformedKeyIsNamed) {
    std::vector<std::string> txt = encode_txt(sample());
    txt.erase(txt.begin() + 5); // slots
    auto missing = decode_txt(txt);
    ASSERT_FALSE(missing);
    EXPECT_NE(missing.error().find("'slots'"), std::string::npos) << missing.error();
    txt = encode_txt(sample());
    txt[5] = "slots=many";
    EXPECT_NE(decode_txt(txt).error().find("'slots' is 'many'"), std::string::npos);
    txt = encode_txt(sample());
    txt[1] = "cert=md5:00";
    EXPECT_FALSE(decode_txt(txt));
}

} // namespace
} // namespace splitvk::protocol
