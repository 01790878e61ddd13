// VkPhysicalDevice: the device envelope the application is told (physical_device.h), by the edits
// of the generated property, feature and format queries (their KHR aliases share them).

#include "core/physical_device.h"

#include "core/instance.h"
#include "core/layer_settings.h"
#include "core/vk_util.h"
#include "layer_entry_points.h"
#include "log.h"
#include "vk_envelope_tables.h"

#include <algorithm>
#include <cstring>
#include <iterator>
#include <string>

namespace splitvk {
namespace {

std::string join(const std::vector<std::string> &items, size_t most) {
    std::string out;
    for (size_t i = 0; i < items.size() && i < most; ++i)
        out += (i ? ", " : "") + items[i];
    if (items.size() > most) out += ", ... (" + std::to_string(items.size() - most) + " more)";
    return out;
}

void log_envelope(const PhysicalDeviceState &state, const std::string &sources) {
    std::vector<std::string> limits;
    for (const auto &change : protocol::limit_changes(state.client, *state.envelope))
        limits.push_back(change.name + " " + change.from + " -> " + change.to);
    const auto hidden = protocol::features_hidden(state.client, *state.envelope);
    const size_t formats = protocol::formats_narrowed(state.client, *state.envelope);
    SPLITVK_INFO("device envelope of '%s' (%s): limits changed: %s", state.client.name.c_str(),
                 sources.c_str(), limits.empty() ? "none" : join(limits, limits.size()).c_str());
    SPLITVK_INFO("device envelope of '%s': %zu features hidden%s%s; %zu formats with fewer features",
                 state.client.name.c_str(), hidden.size(), hidden.empty() ? "" : ": ",
                 join(hidden, 12).c_str(), formats);
}

// Features whose promise the agent cannot keep on another driver, whatever its GPU supports:
// opaque capture addresses are portable only within one driver, and the agent replays on one
// device. Buffer device addresses themselves are translated (server-agent/buffer_addresses.h).
constexpr const char *kUnreplayableFeatures[] = {"bufferDeviceAddressCaptureReplay",
                                                 "bufferDeviceAddressMultiDevice"};

void withhold_unreplayable_features(protocol::DeviceDescription &envelope) {
    for (size_t f = 0; f < std::size(envelope::kFeatureFields); ++f)
        for (const char *name : kUnreplayableFeatures)
            if (std::strcmp(envelope::kFeatureFields[f].name, name) == 0) envelope.features[f] = 0;
}

std::unique_ptr<PhysicalDeviceState> make_state(InstanceState &instance, VkPhysicalDevice physical_device) {
    auto state = std::make_unique<PhysicalDeviceState>();
    protocol::DeviceQueries queries;
    queries.get_properties = instance.dispatch.GetPhysicalDeviceProperties;
    queries.get_features = instance.dispatch.GetPhysicalDeviceFeatures;
    // Asking for the 1.1-1.3 features is only valid on an instance of 1.1 or later; on an older
    // one the application cannot ask for them either, and the envelope leaves them alone below.
    if (instance.api_version >= VK_API_VERSION_1_1)
        queries.get_features2 = instance.dispatch.GetPhysicalDeviceFeatures2;
    queries.get_format_properties = instance.dispatch.GetPhysicalDeviceFormatProperties;
    queries.enumerate_extensions = instance.dispatch.EnumerateDeviceExtensionProperties;
    state->client = protocol::describe(physical_device, queries);

    const LoadedSettings &loaded = layer_settings();
    if (!loaded.valid() || !loaded.settings.envelope) {
        if (loaded.valid())
            SPLITVK_INFO("SPLITVK_ENVELOPE=client: '%s' reports its own limits, which no agent checks",
                         state->client.name.c_str());
        return state;
    }
    protocol::DeviceDescription envelope = state->client;
    protocol::apply(envelope, protocol::agent_baseline());
    withhold_unreplayable_features(envelope);
    std::string sources = "the client, the agent baseline";
    if (instance.early_agent) {
        if (const auto &agent = instance.early_agent->agent_device()) {
            protocol::combine(envelope, *agent);
            state->agent_included = true;
            sources += ", the agent's '" + agent->name + "'";
        }
    }
    envelope.name = state->client.name;
    state->envelope = std::move(envelope);
    state->envelope_wire = protocol::encode(*state->envelope);
    log_envelope(*state, sources);
    return state;
}

// Whether the envelope hides feature `f`: the client has it and another source does not. A feature
// the client could not be asked for (a 1.0 instance) is never hidden: the driver's answer stands.
bool hidden(const PhysicalDeviceState &state, size_t f) {
    return state.client.features[f] && !state.envelope->features[f];
}

// Clears every feature of a VkPhysicalDeviceFeatures2 chain that the envelope hides, by name:
// the Vulkan 1.1-1.3 aggregates and every extension structure that repeats a promoted feature.
void mask_feature_chain(void *next, const PhysicalDeviceState &state) {
    for (auto *s = static_cast<VkBaseOutStructure *>(next); s; s = s->pNext) {
        for (const auto &chained : envelope::kFeatureChainStructs) {
            if (chained.stype != s->sType) continue;
            for (uint32_t m = 0; m < chained.count; ++m) {
                const auto &member = chained.members[m];
                for (size_t f = 0; f < std::size(envelope::kFeatureFields); ++f) {
                    if (!hidden(state, f) || std::strcmp(envelope::kFeatureFields[f].name, member.name) != 0)
                        continue;
                    *reinterpret_cast<VkBool32 *>(reinterpret_cast<uint8_t *>(s) + member.offset) = VK_FALSE;
                }
            }
        }
    }
}

void mask_core_features(VkPhysicalDeviceFeatures &features, const PhysicalDeviceState &state) {
    for (size_t f = 0; f < std::size(envelope::kFeatureFields); ++f) {
        const auto &field = envelope::kFeatureFields[f];
        if (field.source != envelope::FeatureStruct::Core || !hidden(state, f)) continue;
        *reinterpret_cast<VkBool32 *>(reinterpret_cast<uint8_t *>(&features) + field.offset) = VK_FALSE;
    }
}

const VkFormatProperties *envelope_format(const protocol::DeviceDescription &envelope, VkFormat format) {
    for (size_t i = 0; i < std::size(envelope::kEnvelopeFormats); ++i)
        if (envelope::kEnvelopeFormats[i] == format) return &envelope.formats[i];
    return nullptr;
}

const protocol::DeviceDescription *envelope_of(VkPhysicalDevice physical_device) {
    const PhysicalDeviceState *state = physical_device_state(physical_device);
    return state && state->envelope ? &*state->envelope : nullptr;
}

const PhysicalDeviceState *enveloped(VkPhysicalDevice physical_device) {
    const PhysicalDeviceState *state = physical_device_state(physical_device);
    return state && state->envelope ? state : nullptr;
}

// Clears the features of forwarded extensions whose state splitvk does not forward
// (codegen/allowlist.py WITHHELD_FEATURES), whatever the envelope: no agent could replay them.
void clear_withheld_features(void *next) {
    for (auto *s = static_cast<VkBaseOutStructure *>(next); s; s = s->pNext)
        for (const auto &withheld : envelope::kWithheldFeatures)
            if (withheld.stype == s->sType)
                *reinterpret_cast<VkBool32 *>(reinterpret_cast<uint8_t *>(s) + withheld.offset) = VK_FALSE;
}

void narrow_features2(VkPhysicalDevice physical_device, VkPhysicalDeviceFeatures2 *features) {
    clear_withheld_features(features->pNext);
    if (const auto *state = enveloped(physical_device)) {
        mask_core_features(features->features, *state);
        mask_feature_chain(features->pNext, *state);
    }
}

} // namespace

const PhysicalDeviceState *physical_device_state(VkPhysicalDevice physical_device) {
    InstanceState *instance = find_instance(dispatch_key(physical_device));
    if (!instance) return nullptr;
    std::lock_guard lock(instance->physical_devices_mutex);
    auto &slot = instance->physical_devices[physical_device];
    if (!slot) slot = make_state(*instance, physical_device);
    return slot.get();
}

namespace {

void narrow_format_properties2(VkPhysicalDevice physicalDevice, VkFormat format,
                               VkFormatProperties2 *properties) {
    const auto *envelope = envelope_of(physicalDevice);
    const VkFormatProperties *narrowed = envelope ? envelope_format(*envelope, format) : nullptr;
    if (!narrowed) return;
    properties->formatProperties = *narrowed;
    // VkFormatProperties3 repeats the 32 legacy bits in its 64-bit flags; the bits above are
    // features only the 2-flags know, outside the envelope.
    if (auto *p3 =
            find_in_chain<VkFormatProperties3>(properties->pNext, VK_STRUCTURE_TYPE_FORMAT_PROPERTIES_3)) {
        constexpr VkFormatFeatureFlags2 kHigh = ~VkFormatFeatureFlags2{0xFFFFFFFFu};
        p3->linearTilingFeatures &= kHigh | narrowed->linearTilingFeatures;
        p3->optimalTilingFeatures &= kHigh | narrowed->optimalTilingFeatures;
        p3->bufferFeatures &= kHigh | narrowed->bufferFeatures;
    }
}

} // namespace

namespace edit {

void GetPhysicalDeviceProperties(VkPhysicalDevice physicalDevice, VkPhysicalDeviceProperties *pProperties) {
    if (const auto *envelope = envelope_of(physicalDevice)) pProperties->limits = envelope->limits;
}

void GetPhysicalDeviceProperties2(VkPhysicalDevice physicalDevice, VkPhysicalDeviceProperties2 *pProperties) {
    if (const auto *envelope = envelope_of(physicalDevice)) pProperties->properties.limits = envelope->limits;
}

void GetPhysicalDeviceFeatures(VkPhysicalDevice physicalDevice, VkPhysicalDeviceFeatures *pFeatures) {
    if (const auto *state = enveloped(physicalDevice)) mask_core_features(*pFeatures, *state);
}

void GetPhysicalDeviceFeatures2(VkPhysicalDevice physicalDevice, VkPhysicalDeviceFeatures2 *pFeatures) {
    narrow_features2(physicalDevice, pFeatures);
}

void GetPhysicalDeviceFormatProperties(VkPhysicalDevice physicalDevice, VkFormat format,
                                       VkFormatProperties *pFormatProperties) {
    if (const auto *envelope = envelope_of(physicalDevice))
        if (const VkFormatProperties *narrowed = envelope_format(*envelope, format))
            *pFormatProperties = *narrowed;
}

void GetPhysicalDeviceFormatProperties2(VkPhysicalDevice physicalDevice, VkFormat format,
                                        VkFormatProperties2 *pFormatProperties) {
    narrow_format_properties2(physicalDevice, format, pFormatProperties);
}

} // namespace edit
} // namespace splitvk
