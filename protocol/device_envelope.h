#pragma once

// The device envelope: what the layer tells the application about its GPU, chosen so
// that the client's GPU and any agent GPU that may serve it can both honour it. An application
// sizes and aligns by what it is told (uniform slots by minUniformBufferOffsetAlignment, textures
// by maxImageDimension2D, ...); the agent replays those very numbers on its own GPU, so a value
// only the client honours draws garbage on the agent.
//
//   limits   the strictest of all sources: for every alignment and granularity the largest, for
//            every maximum the smallest (vk.xml's limittype, codegen/emit_envelope.py); a few
//            limits describe only the client's own driver and keep its value (CLIENT_LOCAL there)
//   features those every source supports (VkPhysicalDeviceFeatures, Vulkan 1.1-1.3 aggregates, and
//            the feature structures of the extensions splitvk forwards)
//   formats  the format features every source supports (linear, optimal, buffer)
//
// The sources: the client's device, the agent baseline (a Khronos-profile JSON built in:
// agent_baseline.json), and the agent's own device when one answers while the instance is
// created. A later agent checks the envelope it is sent against its own device (honours()) and
// refuses a session it cannot serve.
//
// A *profile* is partial: a Khronos Vulkan profile (schema profiles-0.8) names only some limits
// and features. apply() combines the ones it names and leaves the rest.

#include "result.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace splitvk::protocol {

// A whole device: every limit, every feature of the envelope tables, every format.
struct DeviceDescription {
    std::string name; // for messages: the GPU, or what the envelope was made of
    VkPhysicalDeviceLimits limits{};
    std::vector<uint8_t> features;           // 0/1, one per envelope::kFeatureFields
    std::vector<VkFormatProperties> formats; // one per envelope::kEnvelopeFormats
};

// Some limits and features, as a Khronos profile names them.
struct DeviceProfile {
    std::string name;
    VkPhysicalDeviceLimits limits{};
    std::vector<uint8_t> limit_named; // one per envelope::kLimitFields: 1 where the profile names it
    std::vector<int8_t> features;     // one per envelope::kFeatureFields: -1 unnamed, else 0/1
};

// The queries describe() needs; GetPhysicalDeviceFeatures2 may be null (a 1.0 instance), and the
// Vulkan 1.1-1.3 features then read as unsupported.
struct DeviceQueries {
    PFN_vkGetPhysicalDeviceProperties get_properties = nullptr;
    PFN_vkGetPhysicalDeviceFeatures get_features = nullptr;
    PFN_vkGetPhysicalDeviceFeatures2 get_features2 = nullptr;
    PFN_vkGetPhysicalDeviceFormatProperties get_format_properties = nullptr;
    // The forwarded extensions' own features are read where the device offers the extension; null:
    // they read as unsupported.
    PFN_vkEnumerateDeviceExtensionProperties enumerate_extensions = nullptr;
};
DeviceDescription describe(VkPhysicalDevice device, const DeviceQueries &queries);

// One limit the envelope made stricter than a device: "minUniformBufferOffsetAlignment 16 -> 256".
struct LimitChange {
    std::string name;
    std::string from;
    std::string to;
};

// `into` narrowed to what `other` also honours. Client-local limits keep `into`'s value.
void combine(DeviceDescription &into, const DeviceDescription &other);
// `into` narrowed by what a profile names.
void apply(DeviceDescription &into, const DeviceProfile &profile);

// What `envelope` changed of `device`: limits, then feature and format counts.
std::vector<LimitChange> limit_changes(const DeviceDescription &device, const DeviceDescription &envelope);
std::vector<std::string> features_hidden(const DeviceDescription &device, const DeviceDescription &envelope);
size_t formats_narrowed(const DeviceDescription &device, const DeviceDescription &envelope);

// Every limit and feature by which `device` fails to honour `envelope` (what the application was
// told), one short phrase each, "minUniformBufferOffsetAlignment: told 16, this device 256"; empty
// when it honours them. A session is refused for these.
std::vector<std::string> violations(const DeviceDescription &device, const DeviceDescription &envelope);
// violations() as one line for a refusal, the first few and how many more; empty when `device`
// honours `envelope`. What the agent's Reject and the layer's own check of an early agent say.
std::string refusal(const DeviceDescription &device, const DeviceDescription &envelope);
// The formats whose features the application was told but `device` lacks. Not a refusal: GPUs
// differ in dozens of formats no application uses; the agent flags the images that use one.
std::vector<VkFormat> format_gaps(const DeviceDescription &device, const DeviceDescription &envelope);

// Reads a Khronos profile JSON: every capability block's properties → VkPhysicalDeviceProperties →
// limits, and features → VkPhysicalDeviceFeatures / VkPhysicalDeviceVulkan1{1,2,3}Features, all
// combined into one (the strictest). Unknown limit or feature names are errors, so that a typo
// cannot pass as "no constraint".
Result<DeviceProfile> parse_profile(std::string_view json_text, std::string_view name);
// The agent baseline built into splitvk: what every supported agent GPU honours (its sources are
// in protocol/agent_baseline.json's description and docs/user-guide.md).
const DeviceProfile &agent_baseline();

// The wire form (Hello carries the envelope, Welcome the agent's device). Both sides are built
// from one vk.xml (the handshake checks the codec fingerprint), so the tables' sizes must match.
std::vector<uint8_t> encode(const DeviceDescription &description);
Result<DeviceDescription> decode_device_description(std::span<const uint8_t> payload);

// Caps for the handshake's blobs.
inline constexpr uint32_t kMaxDeviceDescriptionBytes = 64 * 1024;

} // namespace splitvk::protocol
