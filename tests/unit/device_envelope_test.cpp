// The device envelope (protocol/device_envelope.h): how limits, features and formats combine into
// what both sides honour, how a device is checked against it, Khronos profile reading, and the
// wire form. Hand-built descriptions, so every rule is pinned to a value.
#include "device_envelope.h"
#include "vk_envelope_tables.h"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

namespace splitvk::protocol {
namespace {

DeviceDescription device(const char *name) {
    DeviceDescription d;
    d.name = name;
    d.features.assign(std::size(envelope::kFeatureFields), 1);
    d.formats.assign(std::size(envelope::kEnvelopeFormats), VkFormatProperties{0xFF, 0xFFFF, 0xF});
    VkPhysicalDeviceLimits &l = d.limits;
    l.maxImageDimension2D = 16384;
    l.maxUniformBufferRange = 65536;
    l.minUniformBufferOffsetAlignment = 16;
    l.minStorageBufferOffsetAlignment = 16;
    l.minMemoryMapAlignment = 64;
    l.framebufferColorSampleCounts = VK_SAMPLE_COUNT_1_BIT | VK_SAMPLE_COUNT_4_BIT;
    l.viewportBoundsRange[0] = -32768;
    l.viewportBoundsRange[1] = 32768;
    l.minTexelOffset = -32;
    l.maxComputeWorkGroupSize[0] = 1024;
    l.subPixelPrecisionBits = 8;
    return d;
}

size_t feature(const char *name) {
    for (size_t i = 0; i < std::size(envelope::kFeatureFields); ++i)
        if (std::string(envelope::kFeatureFields[i].name) == name) return i;
    ADD_FAILURE() << "no feature " << name;
    return 0;
}

TEST(DeviceEnvelope, TablesFollowVkXmlLimittype) {
    auto field = [](const char *name) {
        return *std::find_if(std::begin(envelope::kLimitFields), std::end(envelope::kLimitFields),
                             [&](const auto &f) { return std::string(f.name) == name; });
    };
    EXPECT_EQ(field("minUniformBufferOffsetAlignment").combine, envelope::Combine::Min);
    EXPECT_TRUE(field("minUniformBufferOffsetAlignment").power_of_two);
    EXPECT_EQ(field("maxImageDimension2D").combine, envelope::Combine::Max);
    EXPECT_EQ(field("viewportBoundsRange").combine, envelope::Combine::Range);
    EXPECT_EQ(field("viewportBoundsRange").count, 2);
    EXPECT_EQ(field("framebufferColorSampleCounts").combine, envelope::Combine::Bitmask);
    EXPECT_EQ(field("minMemoryMapAlignment").combine, envelope::Combine::ClientLocal);
    EXPECT_EQ(field("subPixelPrecisionBits").combine, envelope::Combine::Bits);
    EXPECT_EQ(std::size(envelope::kLimitFields), 106u)
        << "VkPhysicalDeviceLimits has 106 members in Vulkan 1.3";
}

TEST(DeviceEnvelope, CombineTakesWhatBothHonour) {
    DeviceDescription client = device("client");
    DeviceDescription agent = device("agent");
    agent.limits.maxImageDimension2D = 32768;
    agent.limits.minUniformBufferOffsetAlignment = 64;
    agent.limits.minStorageBufferOffsetAlignment = 8;
    agent.limits.minMemoryMapAlignment = 4096;
    agent.limits.framebufferColorSampleCounts = VK_SAMPLE_COUNT_1_BIT | VK_SAMPLE_COUNT_8_BIT;
    agent.limits.viewportBoundsRange[0] = -16384;
    agent.limits.viewportBoundsRange[1] = 65536;
    agent.limits.minTexelOffset = -8;
    agent.limits.maxComputeWorkGroupSize[0] = 256;
    agent.limits.subPixelPrecisionBits = 4;
    agent.features[feature("geometryShader")] = 0;
    agent.formats[3].optimalTilingFeatures = 0x0F0F;

    DeviceDescription envelope = client;
    combine(envelope, agent);
    const VkPhysicalDeviceLimits &l = envelope.limits;
    EXPECT_EQ(l.maxImageDimension2D, 16384u);          // the smaller maximum
    EXPECT_EQ(l.minUniformBufferOffsetAlignment, 64u); // the larger alignment
    EXPECT_EQ(l.minStorageBufferOffsetAlignment, 16u); // the larger alignment
    EXPECT_EQ(l.minMemoryMapAlignment, 64u);           // the client's own memory
    EXPECT_EQ(l.framebufferColorSampleCounts, VkSampleCountFlags{VK_SAMPLE_COUNT_1_BIT}); // both support
    EXPECT_EQ(l.viewportBoundsRange[0], -16384.0f); // the narrower range
    EXPECT_EQ(l.viewportBoundsRange[1], 32768.0f);
    EXPECT_EQ(l.minTexelOffset, -8); // "min": the less capable, larger value
    EXPECT_EQ(l.maxComputeWorkGroupSize[0], 256u);
    EXPECT_EQ(l.subPixelPrecisionBits, 4u);
    EXPECT_EQ(envelope.features[feature("geometryShader")], 0);
    EXPECT_EQ(envelope.features[feature("multiview")], 1);
    EXPECT_EQ(envelope.formats[3].optimalTilingFeatures, 0x0F0Fu);

    EXPECT_TRUE(violations(agent, envelope).empty()) << violations(agent, envelope).front();
    EXPECT_TRUE(violations(client, envelope).empty()) << violations(client, envelope).front();
    EXPECT_TRUE(format_gaps(agent, envelope).empty());

    const auto changes = limit_changes(client, envelope);
    const bool named = std::any_of(changes.begin(), changes.end(), [](const LimitChange &c) {
        return c.name == "minUniformBufferOffsetAlignment" && c.from == "16" && c.to == "64";
    });
    EXPECT_TRUE(named);
    EXPECT_EQ(features_hidden(client, envelope), std::vector<std::string>{"geometryShader"});
    EXPECT_EQ(formats_narrowed(client, envelope), 1u);
}

// The forwarded extensions' own features are in the envelope like the core ones: an
// agent without transform feedback hides it from the application, and a later one without it is
// refused. The EDS3 features the layer always clears are not in it at all.
TEST(DeviceEnvelope, ForwardedExtensionFeaturesAreInTheEnvelope) {
    for (const char *name : {"transformFeedback", "geometryStreams", "conditionalRendering"}) {
        EXPECT_TRUE(std::any_of(std::begin(envelope::kFeatureFields), std::end(envelope::kFeatureFields),
                                [&](const auto &f) { return std::string(f.name) == name; }))
            << name;
    }
    for (const auto &withheld : envelope::kWithheldFeatures) {
        EXPECT_TRUE(std::none_of(std::begin(envelope::kFeatureFields), std::end(envelope::kFeatureFields),
                                 [&](const auto &f) { return std::string(f.name) == withheld.name; }))
            << withheld.name << " is cleared by the layer and must not be in the envelope";
    }
    const size_t xfb = feature("transformFeedback");
    EXPECT_EQ(envelope::kFeatureFields[xfb].source, envelope::FeatureStruct::Extension);
    EXPECT_STREQ(envelope::kExtensionFeatureStructs[envelope::kFeatureFields[xfb].extension].extension,
                 "VK_EXT_transform_feedback");
    EXPECT_EQ(envelope::kFeatureFields[feature("extendedDynamicState3PolygonMode")].source,
              envelope::FeatureStruct::Extension);

    const DeviceDescription client = device("client");
    DeviceDescription agent = device("agent");
    agent.features[xfb] = 0;
    DeviceDescription envelope = client;
    combine(envelope, agent);
    EXPECT_EQ(envelope.features[xfb], 0);
    const auto hidden = features_hidden(client, envelope);
    EXPECT_NE(std::find(hidden.begin(), hidden.end(), "transformFeedback"), hidden.end());
    const auto refused = violations(agent, client);
    EXPECT_NE(std::find(refused.begin(), refused.end(), "feature transformFeedback is not supported"),
              refused.end());
}

TEST(DeviceEnvelope, ViolationsNameWhatTheDeviceCannotHonour) {
    DeviceDescription told = device("client");
    DeviceDescription gpu = device("NVIDIA");
    gpu.limits.minUniformBufferOffsetAlignment =
        64; // the alignment an agent's GPU needed that the client's did not
    gpu.limits.maxImageDimension2D = 8192;
    gpu.limits.viewportBoundsRange[1] = 32767;
    gpu.limits.framebufferColorSampleCounts = VK_SAMPLE_COUNT_1_BIT;
    gpu.features[feature("multiview")] = 0;
    gpu.formats[0].bufferFeatures = 0;
    const auto v = violations(gpu, told);
    const auto has = [&](const std::string &text) {
        return std::any_of(v.begin(), v.end(),
                           [&](const std::string &s) { return s.find(text) != std::string::npos; });
    };
    EXPECT_TRUE(has("minUniformBufferOffsetAlignment: told 16, this device 64"));
    EXPECT_TRUE(has("maxImageDimension2D: told 16384, this device 8192"));
    EXPECT_TRUE(has("viewportBoundsRange[1]"));
    EXPECT_TRUE(has("framebufferColorSampleCounts"));
    EXPECT_TRUE(has("feature multiview"));
    EXPECT_EQ(v.size(), 5u);
    const std::string line = refusal(gpu, told);
    EXPECT_EQ(line.rfind("maxImageDimension2D: told 16384, this device 8192", 0), 0u) << line;
    EXPECT_NE(line.find("; and 1 more"), std::string::npos) << line;
    EXPECT_TRUE(refusal(told, told).empty());
    EXPECT_EQ(format_gaps(gpu, told).size(), 1u) << "formats are reported, not refused";
    // Client-local limits are never the agent's to honour.
    gpu = device("NVIDIA");
    gpu.limits.minMemoryMapAlignment = 4096;
    EXPECT_TRUE(violations(gpu, told).empty());
}

TEST(DeviceEnvelope, ProfileNamesOnlySomeLimits) {
    const std::string json = R"({
      "capabilities": {
        "a": {"properties": {"VkPhysicalDeviceProperties": {"limits": {
              "minUniformBufferOffsetAlignment": 256, "maxComputeWorkGroupSize": [128, 128, 64],
              "framebufferColorSampleCounts": ["VK_SAMPLE_COUNT_1_BIT"], "strictLines": false,
              "viewportBoundsRange": [-8192, 8191]}}},
              "features": {"VkPhysicalDeviceFeatures": {"geometryShader": false, "depthClamp": true},
                           "VkPhysicalDeviceMultiviewFeatures": {"multiview": false, "somethingElse": true}}},
        "b": {"properties": {"VkPhysicalDeviceProperties": {"limits": {"minUniformBufferOffsetAlignment": 64}}}}
      }})";
    auto profile = parse_profile(json, "test");
    ASSERT_TRUE(profile.ok()) << profile.error();
    DeviceDescription d = device("client");
    apply(d, *profile);
    EXPECT_EQ(d.limits.minUniformBufferOffsetAlignment, 256u) << "two blocks: the stricter";
    EXPECT_EQ(d.limits.maxComputeWorkGroupSize[0], 128u);
    EXPECT_EQ(d.limits.framebufferColorSampleCounts, VkSampleCountFlags{VK_SAMPLE_COUNT_1_BIT});
    EXPECT_EQ(d.limits.viewportBoundsRange[0], -8192.0f);
    EXPECT_EQ(d.limits.maxImageDimension2D, 16384u) << "a limit the profile does not name stays";
    EXPECT_EQ(d.features[feature("geometryShader")], 0);
    EXPECT_EQ(d.features[feature("depthClamp")], 1);
    EXPECT_EQ(d.features[feature("multiview")], 0) << "promoted names count in extension structures";
}

TEST(DeviceEnvelope, KhronosRoadmapProfileReadsItsRequiredBlocksOnly) {
    std::ifstream in("/usr/share/vulkan/registry/profiles/VP_KHR_roadmap_2022.json");
    if (!in) GTEST_SKIP() << "libvulkan-dev's profiles are not installed";
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    auto profile = parse_profile(text, "roadmap");
    ASSERT_TRUE(profile.ok()) << profile.error();
    DeviceDescription d = device("client");
    d.limits.pointSizeGranularity = 1.0f;
    d.limits.maxColorAttachments = 8;
    apply(d, *profile);
    EXPECT_EQ(d.limits.maxColorAttachments, 7u);
    EXPECT_EQ(d.limits.maxImageDimension2D, 8192u);
    EXPECT_EQ(d.limits.pointSizeGranularity, 1.0f) << "an optional block does not constrain";
}

TEST(DeviceEnvelope, BadProfilesSayWhatIsWrong) {
    const std::pair<const char *, const char *> cases[] = {
        {"{", "JSON at byte"},
        {"{}", "no \"capabilities\""},
        {R"({"capabilities":{"a":{"properties":{"VkPhysicalDeviceProperties":{"limits":{"maxImageDimensoin2D":1}}}}}})",
         "unknown limit 'maxImageDimensoin2D'"},
        {R"({"capabilities":{"a":{"properties":{"VkPhysicalDeviceProperties":{"limits":{"maxImageDimension2D":-1}}}}}})",
         "unsigned 32-bit"},
        {R"({"capabilities":{"a":{"properties":{"VkPhysicalDeviceProperties":{"limits":{"maxComputeWorkGroupSize":[1,2]}}}}}})",
         "an array of 3"},
        {R"({"capabilities":{"a":{"properties":{"VkPhysicalDeviceProperties":{"limits":{"framebufferColorSampleCounts":["VK_SAMPLE_COUNT_3_BIT"]}}}}}})",
         "VK_SAMPLE_COUNT_<n>_BIT"},
        {R"({"capabilities":{"a":{"features":{"VkPhysicalDeviceFeatures":{"warpDrive":true}}}}})",
         "unknown feature"},
        {R"({"capabilities":{"a":{"features":{"VkPhysicalDeviceFeatures":{"geometryShader":1}}}}})",
         "expected true or false"},
    };
    for (const auto &[json, expected] : cases) {
        auto profile = parse_profile(json, "bad");
        ASSERT_FALSE(profile.ok()) << json;
        EXPECT_NE(profile.error().find(expected), std::string::npos) << profile.error();
        EXPECT_EQ(profile.error().find('\n'), std::string::npos);
    }
}

TEST(DeviceEnvelope, AgentBaselineIsBuiltIn) {
    const DeviceProfile &baseline = agent_baseline();
    EXPECT_EQ(baseline.name, "the agent baseline");
    DeviceDescription d = device("lavapipe");
    apply(d, baseline);
    EXPECT_EQ(d.limits.minUniformBufferOffsetAlignment, 256u);
    EXPECT_EQ(d.limits.minStorageBufferOffsetAlignment, 256u);
    EXPECT_EQ(d.limits.maxImageDimension2D, 8192u);
    EXPECT_EQ(d.limits.minTexelOffset, -8);
    EXPECT_EQ(d.limits.minMemoryMapAlignment, 64u);
}

TEST(DeviceEnvelope, WireRoundTripAndMalformedInput) {
    DeviceDescription d = device("llvmpipe");
    d.features[feature("shaderFloat64")] = 0;
    d.formats[7] = {1, 2, 3};
    const auto bytes = encode(d);
    auto back = decode_device_description(bytes);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->name, "llvmpipe");
    EXPECT_EQ(std::memcmp(&back->limits, &d.limits, sizeof(d.limits)), 0);
    EXPECT_EQ(back->features, d.features);
    EXPECT_EQ(back->formats[7].optimalTilingFeatures, 2u);
    for (size_t cut = 0; cut < bytes.size(); cut += 7)
        EXPECT_FALSE(decode_device_description(std::span(bytes).first(cut)).ok()) << cut;
    auto longer = bytes;
    longer.push_back(0);
    EXPECT_FALSE(decode_device_description(longer).ok());
    // A feature is 0 or 1: the first feature byte follows the name, the limits and the count.
    size_t limit_bytes = 0;
    for (const auto &f : envelope::kLimitFields)
        limit_bytes +=
            f.count * (f.scalar == envelope::Scalar::U64 || f.scalar == envelope::Scalar::SizeT ? 8 : 4);
    auto bad = bytes;
    const size_t first_feature = 4 + d.name.size() + 4 + limit_bytes + 4;
    ASSERT_LT(first_feature, bad.size());
    ASSERT_EQ(bad[first_feature], 1);
    bad[first_feature] = 2;
    auto rejected = decode_device_description(bad);
    ASSERT_FALSE(rejected.ok());
    EXPECT_NE(rejected.error().find("neither 0 nor 1"), std::string::npos) << rejected.error();
}

} // namespace
} // namespace splitvk::protocol
