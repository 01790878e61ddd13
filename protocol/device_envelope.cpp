#include "device_envelope.h"

#include "json.h"
#include "vk_envelope_tables.h"
#include "wire.h"

#include <algorithm>
#include <cstring>
#include <iterator>

// protocol/agent_baseline.json, embedded by protocol/CMakeLists.txt.
extern "C" const char splitvk_agent_baseline_json[];

namespace splitvk::protocol {
namespace {

using envelope::Combine;
using envelope::kEnvelopeFormats;
using envelope::kFeatureFields;
using envelope::kLimitFields;
using envelope::LimitField;
using envelope::Scalar;

constexpr size_t kLimitCount = std::size(kLimitFields);
constexpr size_t kFeatureCount = std::size(kFeatureFields);
constexpr size_t kFormatCount = std::size(kEnvelopeFormats);
static_assert(sizeof(size_t) == 8, "limits of type size_t travel as 8 bytes");

size_t scalar_size(Scalar scalar) {
    switch (scalar) {
    case Scalar::U64:
    case Scalar::SizeT:
        return 8;
    default:
        return 4;
    }
}

// One element of one limit (maxComputeWorkGroupSize has three), read and written in place.
struct Element {
    const LimitField &field;
    uint32_t index;

    const uint8_t *at(const VkPhysicalDeviceLimits &limits) const {
        return reinterpret_cast<const uint8_t *>(&limits) + field.offset + index * scalar_size(field.scalar);
    }
    uint8_t *at(VkPhysicalDeviceLimits &limits) const {
        return reinterpret_cast<uint8_t *>(&limits) + field.offset + index * scalar_size(field.scalar);
    }
    // long double holds every u64, i32 and float exactly, so comparisons are exact.
    long double value(const VkPhysicalDeviceLimits &limits) const {
        const uint8_t *p = at(limits);
        switch (field.scalar) {
        case Scalar::U32: {
            uint32_t v;
            std::memcpy(&v, p, 4);
            return v;
        }
        case Scalar::I32: {
            int32_t v;
            std::memcpy(&v, p, 4);
            return v;
        }
        case Scalar::F32: {
            float v;
            std::memcpy(&v, p, 4);
            return v;
        }
        case Scalar::U64:
        case Scalar::SizeT: {
            uint64_t v;
            std::memcpy(&v, p, 8);
            return static_cast<long double>(v);
        }
        }
        return 0;
    }
    uint64_t bits(const VkPhysicalDeviceLimits &limits) const {
        uint64_t v = 0;
        std::memcpy(&v, at(limits), scalar_size(field.scalar));
        return v;
    }
    void copy(VkPhysicalDeviceLimits &to, const VkPhysicalDeviceLimits &from) const {
        std::memcpy(at(to), at(from), scalar_size(field.scalar));
    }
    std::string name() const {
        return field.count > 1 ? std::string(field.name) + "[" + std::to_string(index) + "]" : field.name;
    }
    std::string text(const VkPhysicalDeviceLimits &limits) const {
        if (field.scalar == Scalar::F32) {
            char buffer[32];
            std::snprintf(buffer, sizeof(buffer), "%g", static_cast<double>(value(limits)));
            return buffer;
        }
        if (field.scalar == Scalar::I32) return std::to_string(static_cast<int64_t>(value(limits)));
        if (field.combine == Combine::Bitmask && field.scalar == Scalar::U32 &&
            std::strstr(field.name, "SampleCounts")) {
            char buffer[16];
            std::snprintf(buffer, sizeof(buffer), "0x%llx", static_cast<unsigned long long>(bits(limits)));
            return buffer;
        }
        return std::to_string(bits(limits));
    }
};

template <class F>
void for_each_element(F &&f) {
    for (const LimitField &field : kLimitFields)
        for (uint32_t i = 0; i < field.count; ++i)
            f(Element{field, i});
}

// The value of `a` and `b` that both honour, as bytes of one of them.
void narrow(const Element &e, VkPhysicalDeviceLimits &into, const VkPhysicalDeviceLimits &other) {
    const long double mine = e.value(into);
    const long double theirs = e.value(other);
    switch (e.field.combine) {
    case Combine::Max:
    case Combine::Bits:
        if (theirs < mine) e.copy(into, other);
        return;
    case Combine::Min:
        if (theirs > mine) e.copy(into, other);
        return;
    case Combine::Bitmask: {
        const uint64_t both = e.bits(into) & e.bits(other);
        std::memcpy(e.at(into), &both, scalar_size(e.field.scalar));
        return;
    }
    case Combine::Range:
        // [min, max]: the envelope is the intersection of the ranges.
        if (e.index == 0 ? theirs > mine : theirs < mine) e.copy(into, other);
        return;
    case Combine::ClientLocal:
        return;
    }
}

// Whether a device whose value is `device` can honour `told`.
bool honours(const Element &e, const VkPhysicalDeviceLimits &device, const VkPhysicalDeviceLimits &told) {
    const long double have = e.value(device);
    const long double need = e.value(told);
    switch (e.field.combine) {
    case Combine::Max:
    case Combine::Bits:
        return have >= need;
    case Combine::Min:
        if (have > need) return false;
        // A power-of-two alignment the app was told is a multiple of every smaller one.
        return !e.field.power_of_two || have == 0 || (e.bits(told) % e.bits(device)) == 0;
    case Combine::Bitmask:
        return (e.bits(device) & e.bits(told)) == e.bits(told);
    case Combine::Range:
        return e.index == 0 ? have <= need : have >= need;
    case Combine::ClientLocal:
        return true;
    }
    return true;
}

// One forwarded extension's feature structure as a device answered it; empty where the device
// does not offer the extension (its features then read as unsupported).
using ExtensionFeatures = std::vector<std::vector<uint8_t>>;

ExtensionFeatures extension_features(VkPhysicalDevice device, const DeviceQueries &queries,
                                     uint32_t api_version) {
    ExtensionFeatures out(std::size(envelope::kExtensionFeatureStructs));
    // Extension structures are read through vkGetPhysicalDeviceFeatures2 (Vulkan 1.1).
    if (!queries.get_features2 || !queries.enumerate_extensions || api_version < VK_API_VERSION_1_1)
        return out;
    uint32_t count = 0;
    if (queries.enumerate_extensions(device, nullptr, &count, nullptr) != VK_SUCCESS) return out;
    std::vector<VkExtensionProperties> offered(count);
    if (queries.enumerate_extensions(device, nullptr, &count, offered.data()) < 0) return out;
    offered.resize(count);
    for (size_t i = 0; i < out.size(); ++i) {
        const auto &known = envelope::kExtensionFeatureStructs[i];
        const bool has = std::any_of(offered.begin(), offered.end(), [&](const VkExtensionProperties &e) {
            return std::string_view(e.extensionName) == known.extension;
        });
        if (!has) continue;
        // Queried one at a time: a structure of an extension the device lacks never reaches it.
        out[i].assign(known.size, 0);
        auto *node = reinterpret_cast<VkBaseOutStructure *>(out[i].data());
        node->sType = known.stype;
        VkPhysicalDeviceFeatures2 features2{};
        features2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
        features2.pNext = node;
        queries.get_features2(device, &features2);
        node->pNext = nullptr;
    }
    return out;
}

const VkBool32 *feature_in(const envelope::FeatureField &field, const VkPhysicalDeviceFeatures &core,
                           const VkPhysicalDeviceVulkan11Features &v11,
                           const VkPhysicalDeviceVulkan12Features &v12,
                           const VkPhysicalDeviceVulkan13Features &v13, const ExtensionFeatures &extensions) {
    static constexpr VkBool32 kUnsupported = VK_FALSE;
    const uint8_t *base = nullptr;
    switch (field.source) {
    case envelope::FeatureStruct::Extension:
        if (extensions[field.extension].empty()) return &kUnsupported;
        base = extensions[field.extension].data();
        break;
    case envelope::FeatureStruct::Core:
        base = reinterpret_cast<const uint8_t *>(&core);
        break;
    case envelope::FeatureStruct::Vulkan11:
        base = reinterpret_cast<const uint8_t *>(&v11);
        break;
    case envelope::FeatureStruct::Vulkan12:
        base = reinterpret_cast<const uint8_t *>(&v12);
        break;
    case envelope::FeatureStruct::Vulkan13:
        base = reinterpret_cast<const uint8_t *>(&v13);
        break;
    }
    return reinterpret_cast<const VkBool32 *>(base + field.offset);
}

int feature_index(std::string_view name) {
    for (size_t i = 0; i < kFeatureCount; ++i)
        if (name == kFeatureFields[i].name) return static_cast<int>(i);
    return -1;
}

const LimitField *limit_field(std::string_view name) {
    for (const LimitField &field : kLimitFields)
        if (name == field.name) return &field;
    return nullptr;
}

// A profile's value for one limit element into `limits`; one line on error.
bool read_limit_value(const json::Value &value, const Element &e, VkPhysicalDeviceLimits &limits,
                      std::string *error) {
    const std::string where = "limit " + e.name();
    uint8_t *p = e.at(limits);
    if (e.field.combine == Combine::Bitmask && value.is_array()) {
        // VkSampleCountFlags as the profiles write them: ["VK_SAMPLE_COUNT_1_BIT", ...].
        uint32_t mask = 0;
        for (const auto &item : value.items()) {
            unsigned count = 0;
            if (item.kind() != json::Value::Kind::String ||
                std::sscanf(item.as_string().c_str(), "VK_SAMPLE_COUNT_%u_BIT", &count) != 1 || count == 0 ||
                (count & (count - 1)) != 0 || count > 64) {
                *error = where + ": expected VK_SAMPLE_COUNT_<n>_BIT names";
                return false;
            }
            mask |= count;
        }
        std::memcpy(p, &mask, 4);
        return true;
    }
    if (value.is_bool()) {
        if (e.field.scalar != Scalar::U32 || e.field.combine != Combine::Bitmask) {
            *error = where + ": a boolean where a number is expected";
            return false;
        }
        const uint32_t v = value.as_bool() ? VK_TRUE : VK_FALSE;
        std::memcpy(p, &v, 4);
        return true;
    }
    if (!value.is_number()) {
        *error = where + ": expected a number, found " + json::Value::kind_name(value.kind());
        return false;
    }
    switch (e.field.scalar) {
    case Scalar::F32: {
        const auto v = static_cast<float>(value.as_double());
        std::memcpy(p, &v, 4);
        return true;
    }
    case Scalar::I32: {
        const auto v = value.as_i64();
        if (!v || *v < INT32_MIN || *v > INT32_MAX) {
            *error = where + ": expected a 32-bit integer";
            return false;
        }
        const auto narrow_v = static_cast<int32_t>(*v);
        std::memcpy(p, &narrow_v, 4);
        return true;
    }
    case Scalar::U32: {
        const auto v = value.as_u64();
        if (!v || *v > UINT32_MAX) {
            *error = where + ": expected an unsigned 32-bit integer";
            return false;
        }
        const auto narrow_v = static_cast<uint32_t>(*v);
        std::memcpy(p, &narrow_v, 4);
        return true;
    }
    case Scalar::U64:
    case Scalar::SizeT: {
        const auto v = value.as_u64();
        if (!v) {
            *error = where + ": expected an unsigned integer";
            return false;
        }
        std::memcpy(p, &*v, 8);
        return true;
    }
    }
    return true;
}

bool read_profile_limits(const json::Value &limits_json, DeviceProfile &profile, std::string *error) {
    if (!limits_json.is_object()) {
        *error = "VkPhysicalDeviceProperties.limits must be an object";
        return false;
    }
    for (const auto &[name, value] : limits_json.members()) {
        const LimitField *field = limit_field(name);
        if (!field) {
            *error = "unknown limit '" + name + "'";
            return false;
        }
        const size_t index = static_cast<size_t>(field - kLimitFields);
        VkPhysicalDeviceLimits read{};
        if (field->count > 1) {
            if (!value.is_array() || value.items().size() != field->count) {
                *error = "limit " + name + ": expected an array of " + std::to_string(field->count);
                return false;
            }
            for (uint32_t i = 0; i < field->count; ++i)
                if (!read_limit_value(value.items()[i], Element{*field, i}, read, error)) return false;
        } else if (!read_limit_value(value, Element{*field, 0}, read, error)) {
            return false;
        }
        for (uint32_t i = 0; i < field->count; ++i) {
            const Element e{*field, i};
            // Two capability blocks naming one limit: the profile asks for the stricter.
            if (profile.limit_named[index])
                narrow(e, profile.limits, read);
            else
                e.copy(profile.limits, read);
        }
        profile.limit_named[index] = 1;
    }
    return true;
}

bool read_profile_features(const json::Value &features_json, DeviceProfile &profile, std::string *error) {
    if (!features_json.is_object()) {
        *error = "features must be an object";
        return false;
    }
    for (const auto &[structure, members] : features_json.members()) {
        // The aggregates must name only features the envelope knows. Extension structures may
        // repeat promoted features under the same names, which count, as do the features of the
        // extensions splitvk forwards; other extensions' members are outside the envelope.
        const bool aggregate = structure == "VkPhysicalDeviceFeatures" ||
                               structure == "VkPhysicalDeviceVulkan11Features" ||
                               structure == "VkPhysicalDeviceVulkan12Features" ||
                               structure == "VkPhysicalDeviceVulkan13Features";
        if (!members.is_object()) {
            *error = structure + " must be an object";
            return false;
        }
        for (const auto &[name, value] : members.members()) {
            const int index = feature_index(name);
            if (index < 0 && !aggregate) continue;
            if (index < 0 || !value.is_bool()) {
                *error =
                    structure + "." + name + (index < 0 ? ": unknown feature" : ": expected true or false");
                return false;
            }
            int8_t &slot = profile.features[static_cast<size_t>(index)];
            slot = slot == 0 ? int8_t{0} : static_cast<int8_t>(value.as_bool());
        }
    }
    return true;
}

} // namespace

DeviceDescription describe(VkPhysicalDevice device, const DeviceQueries &queries) {
    DeviceDescription out;
    VkPhysicalDeviceProperties properties{};
    queries.get_properties(device, &properties);
    out.name = properties.deviceName;
    out.limits = properties.limits;

    VkPhysicalDeviceFeatures core{};
    VkPhysicalDeviceVulkan11Features v11{};
    v11.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES;
    VkPhysicalDeviceVulkan12Features v12{};
    v12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
    VkPhysicalDeviceVulkan13Features v13{};
    v13.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES;
    // The 1.1-1.3 aggregates exist from the device version that introduced them (1.2, 1.3).
    if (queries.get_features2 && properties.apiVersion >= VK_API_VERSION_1_2) {
        VkPhysicalDeviceFeatures2 features2{};
        features2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
        features2.pNext = &v11;
        v11.pNext = &v12;
        if (properties.apiVersion >= VK_API_VERSION_1_3) v12.pNext = &v13;
        queries.get_features2(device, &features2);
        core = features2.features;
        v11.pNext = v12.pNext = nullptr;
    } else {
        queries.get_features(device, &core);
    }
    const ExtensionFeatures extensions = extension_features(device, queries, properties.apiVersion);
    out.features.resize(kFeatureCount);
    for (size_t i = 0; i < kFeatureCount; ++i)
        out.features[i] = *feature_in(kFeatureFields[i], core, v11, v12, v13, extensions) ? 1 : 0;

    out.formats.resize(kFormatCount);
    for (size_t i = 0; i < kFormatCount; ++i)
        queries.get_format_properties(device, kEnvelopeFormats[i], &out.formats[i]);
    return out;
}

void combine(DeviceDescription &into, const DeviceDescription &other) {
    for_each_element([&](const Element &e) { narrow(e, into.limits, other.limits); });
    for (size_t i = 0; i < into.features.size() && i < other.features.size(); ++i)
        into.features[i] &= other.features[i];
    for (size_t i = 0; i < into.formats.size() && i < other.formats.size(); ++i) {
        into.formats[i].linearTilingFeatures &= other.formats[i].linearTilingFeatures;
        into.formats[i].optimalTilingFeatures &= other.formats[i].optimalTilingFeatures;
        into.formats[i].bufferFeatures &= other.formats[i].bufferFeatures;
    }
}

void apply(DeviceDescription &into, const DeviceProfile &profile) {
    for (size_t i = 0; i < kLimitCount; ++i) {
        if (!profile.limit_named[i]) continue;
        for (uint32_t j = 0; j < kLimitFields[i].count; ++j)
            narrow(Element{kLimitFields[i], j}, into.limits, profile.limits);
    }
    for (size_t i = 0; i < into.features.size() && i < profile.features.size(); ++i)
        if (profile.features[i] == 0) into.features[i] = 0;
}

std::vector<LimitChange> limit_changes(const DeviceDescription &device, const DeviceDescription &envelope) {
    std::vector<LimitChange> changes;
    for_each_element([&](const Element &e) {
        if (e.bits(device.limits) != e.bits(envelope.limits))
            changes.push_back({e.name(), e.text(device.limits), e.text(envelope.limits)});
    });
    return changes;
}

std::vector<std::string> features_hidden(const DeviceDescription &device, const DeviceDescription &envelope) {
    std::vector<std::string> hidden;
    for (size_t i = 0; i < device.features.size() && i < envelope.features.size(); ++i)
        if (device.features[i] && !envelope.features[i]) hidden.emplace_back(kFeatureFields[i].name);
    return hidden;
}

size_t formats_narrowed(const DeviceDescription &device, const DeviceDescription &envelope) {
    size_t narrowed = 0;
    for (size_t i = 0; i < device.formats.size() && i < envelope.formats.size(); ++i) {
        const auto &a = device.formats[i];
        const auto &b = envelope.formats[i];
        if (a.linearTilingFeatures != b.linearTilingFeatures ||
            a.optimalTilingFeatures != b.optimalTilingFeatures || a.bufferFeatures != b.bufferFeatures)
            ++narrowed;
    }
    return narrowed;
}

std::vector<std::string> violations(const DeviceDescription &device, const DeviceDescription &envelope) {
    std::vector<std::string> out;
    for_each_element([&](const Element &e) {
        if (!honours(e, device.limits, envelope.limits))
            out.push_back(e.name() + ": told " + e.text(envelope.limits) + ", this device " +
                          e.text(device.limits));
    });
    for (size_t i = 0; i < device.features.size() && i < envelope.features.size(); ++i)
        if (envelope.features[i] && !device.features[i])
            out.push_back(std::string("feature ") + kFeatureFields[i].name + " is not supported");
    return out;
}

std::string refusal(const DeviceDescription &device, const DeviceDescription &envelope) {
    constexpr size_t kMost = 4;
    const auto problems = violations(device, envelope);
    std::string why;
    for (size_t i = 0; i < problems.size() && i < kMost; ++i)
        why += (i ? "; " : "") + problems[i];
    if (problems.size() > kMost) why += "; and " + std::to_string(problems.size() - kMost) + " more";
    return why;
}

std::vector<VkFormat> format_gaps(const DeviceDescription &device, const DeviceDescription &envelope) {
    std::vector<VkFormat> out;
    for (size_t i = 0; i < device.formats.size() && i < envelope.formats.size(); ++i) {
        const auto &have = device.formats[i];
        const auto &told = envelope.formats[i];
        if ((have.linearTilingFeatures & told.linearTilingFeatures) != told.linearTilingFeatures ||
            (have.optimalTilingFeatures & told.optimalTilingFeatures) != told.optimalTilingFeatures ||
            (have.bufferFeatures & told.bufferFeatures) != told.bufferFeatures)
            out.push_back(kEnvelopeFormats[i]);
    }
    return out;
}

Result<DeviceProfile> parse_profile(std::string_view json_text, std::string_view name) {
    auto document = json::parse(json_text);
    if (!document) return Error{document.error()};
    DeviceProfile profile;
    profile.name = name;
    profile.limit_named.assign(kLimitCount, 0);
    profile.features.assign(kFeatureCount, -1);
    const json::Value *capabilities = document->find("capabilities");
    if (!capabilities || !capabilities->is_object())
        return Error{"not a Vulkan profile: no \"capabilities\" object"};
    // A profile lists the capability blocks it requires; blocks it lists nowhere (optionals) do
    // not constrain. A file without a "profiles" section is read whole.
    std::vector<std::string> required;
    if (const json::Value *profiles = document->find("profiles"); profiles && profiles->is_object()) {
        for (const auto &[profile_name, entry] : profiles->members()) {
            const json::Value *list = entry.find("capabilities");
            if (!list || !list->is_array()) continue;
            for (const auto &item : list->items()) {
                // An array item lists alternatives; the first one is what this reading requires.
                const json::Value *first =
                    item.is_array() && !item.items().empty() ? &item.items()[0] : &item;
                if (first->kind() == json::Value::Kind::String) required.push_back(first->as_string());
            }
        }
    }
    std::string error;
    for (const auto &[block_name, block] : capabilities->members()) {
        if (!required.empty() && std::find(required.begin(), required.end(), block_name) == required.end())
            continue;
        if (const json::Value *properties = block.find("properties")) {
            const json::Value *device = properties->find("VkPhysicalDeviceProperties");
            const json::Value *limits = device ? device->find("limits") : nullptr;
            if (limits && !read_profile_limits(*limits, profile, &error))
                return Error{"capability " + block_name + ": " + error};
        }
        if (const json::Value *features = block.find("features")) {
            if (!read_profile_features(*features, profile, &error))
                return Error{"capability " + block_name + ": " + error};
        }
    }
    return profile;
}

const DeviceProfile &agent_baseline() {
    // The built-in file is part of the build: a parse error is a build defect, caught by the unit
    // test that parses it, so a failure here leaves an empty (unconstraining) profile.
    static const DeviceProfile baseline = [] {
        auto parsed = parse_profile(splitvk_agent_baseline_json, "the agent baseline");
        if (parsed) return std::move(parsed.value());
        DeviceProfile empty;
        empty.name = "the agent baseline (unreadable: " + parsed.error() + ")";
        empty.limit_named.assign(kLimitCount, 0);
        empty.features.assign(kFeatureCount, -1);
        return empty;
    }();
    return baseline;
}

std::vector<uint8_t> encode(const DeviceDescription &description) {
    WireWriter w(4096);
    w.string(description.name.substr(0, 256));
    w.u32(static_cast<uint32_t>(kLimitCount));
    for_each_element([&](const Element &e) {
        if (scalar_size(e.field.scalar) == 8)
            w.u64(e.bits(description.limits));
        else
            w.u32(static_cast<uint32_t>(e.bits(description.limits)));
    });
    w.u32(static_cast<uint32_t>(description.features.size()));
    for (uint8_t f : description.features)
        w.u8(f);
    w.u32(static_cast<uint32_t>(description.formats.size()));
    for (const auto &f : description.formats) {
        w.u32(f.linearTilingFeatures);
        w.u32(f.optimalTilingFeatures);
        w.u32(f.bufferFeatures);
    }
    return w.take();
}

Result<DeviceDescription> decode_device_description(std::span<const uint8_t> payload) {
    WireReader r(payload);
    DeviceDescription d;
    d.name = r.string(256, "device name");
    const uint32_t limits = r.u32("limit count");
    if (r.ok() && limits != kLimitCount)
        return Error{"device description with " + std::to_string(limits) + " limits, this side knows " +
                     std::to_string(kLimitCount) + " (built from another vk.xml)"};
    for_each_element([&](const Element &e) {
        if (scalar_size(e.field.scalar) == 8) {
            const uint64_t v = r.u64(e.field.name);
            std::memcpy(e.at(d.limits), &v, 8);
        } else {
            const uint32_t v = r.u32(e.field.name);
            std::memcpy(e.at(d.limits), &v, 4);
        }
    });
    const uint32_t features = r.u32("feature count");
    if (r.ok() && features != kFeatureCount)
        return Error{"device description with " + std::to_string(features) + " features, this side knows " +
                     std::to_string(kFeatureCount)};
    d.features.resize(kFeatureCount);
    for (auto &f : d.features) {
        f = r.u8("feature");
        if (r.ok() && f > 1) r.fail("a feature is neither 0 nor 1");
    }
    const uint32_t formats = r.u32("format count");
    if (r.ok() && formats != kFormatCount)
        return Error{"device description with " + std::to_string(formats) + " formats, this side knows " +
                     std::to_string(kFormatCount)};
    d.formats.resize(kFormatCount);
    for (auto &f : d.formats) {
        f.linearTilingFeatures = r.u32("linear features");
        f.optimalTilingFeatures = r.u32("optimal features");
        f.bufferFeatures = r.u32("buffer features");
    }
    if (!r.ok() || !r.expect_end("device description"))
        return Error{"malformed device description: " + r.error()};
    return d;
}

} // namespace splitvk::protocol
