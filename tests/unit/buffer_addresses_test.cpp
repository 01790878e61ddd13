// The agent's buffer device address translation (server-agent/buffer_addresses.h) and the SPIR-V
// reading that says which push-constant bytes are addresses (server-agent/spirv_pointers.h).

#include "address_test_spirv.h"
#include "buffer_addresses.h"
#include "spirv_pointers.h"

#include <cstring>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk::agent {
namespace {

TEST(BufferAddressMap, TranslatesEveryOffsetInsideABufferAndNothingOutside) {
    BufferAddressMap map;
    map.insert(/*buffer=*/1, /*client=*/0x1000, /*size=*/0x100, /*agent=*/0xa000'0000);
    map.insert(2, 0x1100, 0x40, 0xb000'0000); // right after buffer 1 on the client
    EXPECT_EQ(map.translate(0x1000), 0xa000'0000u);
    EXPECT_EQ(map.translate(0x1010), 0xa000'0010u);
    EXPECT_EQ(map.translate(0x10ff), 0xa000'00ffu);
    EXPECT_EQ(map.translate(0x1100), 0xb000'0000u); // one past buffer 1 is buffer 2's start
    EXPECT_EQ(map.translate(0x113f), 0xb000'003fu);
    EXPECT_FALSE(map.translate(0x1140)); // past buffer 2
    EXPECT_FALSE(map.translate(0x0fff)); // before buffer 1
    EXPECT_FALSE(map.translate(0));
    EXPECT_EQ(map.size(), 2u);
}

TEST(BufferAddressMap, DestroyedBufferNamesNothingAndItsRangeCanBeReused) {
    BufferAddressMap map;
    map.insert(1, 0x1000, 0x100, 0xa000);
    map.erase(1);
    EXPECT_FALSE(map.translate(0x1000));
    EXPECT_EQ(map.size(), 0u);
    map.erase(1); // twice: nothing
    // The client's driver hands the range to a new buffer (with a reused handle value, too).
    map.insert(1, 0x1000, 0x80, 0xc000);
    EXPECT_EQ(map.translate(0x1008), 0xc008u);
    EXPECT_FALSE(map.translate(0x1080)); // the old, larger range is gone
    // The same buffer sent again (a snapshot replayed) replaces its entry.
    map.insert(1, 0x2000, 0x80, 0xd000);
    EXPECT_FALSE(map.translate(0x1000));
    EXPECT_EQ(map.translate(0x2010), 0xd010u);
    EXPECT_EQ(map.size(), 1u);
}

TEST(BufferAddressMap, AliasAtTheSameAddressReplacesTheOlderBuffer) {
    BufferAddressMap map;
    map.insert(1, 0x1000, 0x100, 0xa000);
    map.insert(2, 0x1000, 0x100, 0xb000); // both bound at one offset of one allocation on the client
    EXPECT_EQ(map.translate(0x1004), 0xb004u);
    map.erase(1); // the older one's destroy leaves the newer one alone
    EXPECT_EQ(map.translate(0x1004), 0xb004u);
    map.erase(2);
    EXPECT_FALSE(map.translate(0x1004));
}

TEST(BufferAddressMap, EmptyOrWrappingRangesNameNothing) {
    BufferAddressMap map;
    map.insert(1, 0x1000, 0, 0xa000);
    map.insert(2, UINT64_MAX - 4, 0x10, 0xb000);
    EXPECT_FALSE(map.translate(0x1000));
    EXPECT_FALSE(map.translate(UINT64_MAX - 2));
    EXPECT_EQ(map.size(), 0u);
}

std::vector<uint8_t> push_bytes(std::initializer_list<uint64_t> values) {
    std::vector<uint8_t> bytes(values.size() * 8);
    size_t at = 0;
    for (uint64_t v : values) {
        std::memcpy(bytes.data() + at, &v, 8);
        at += 8;
    }
    return bytes;
}
uint64_t word(const std::vector<uint8_t> &bytes, size_t at) {
    uint64_t v;
    std::memcpy(&v, bytes.data() + at, 8);
    return v;
}

TEST(BufferAddressMap, PushConstantsTranslateOnlyReflectedFieldsTheUpdateCoversWhole) {
    BufferAddressMap map;
    map.insert(1, 0x1000, 0x100, 0xa000);
    const std::vector<uint32_t> pointers = {16, 24, 32, 40};
    // Bytes 8..48 of the block: [8] not an address, [16] one, [24] null, [32] unknown, [40] half.
    auto bytes = push_bytes({0x1010, 0x1020, 0, 0x9999, 0x1030});
    bytes.resize(bytes.size() - 4);
    const PushTranslation t = translate_push_constants(map, pointers, 8, bytes);
    EXPECT_EQ(word(bytes, 0), 0x1010u) << "offset 8 is no address field";
    EXPECT_EQ(word(bytes, 8), 0xa020u);
    EXPECT_EQ(word(bytes, 16), 0u);
    EXPECT_EQ(word(bytes, 24), 0x9999u);
    EXPECT_EQ(t.translated, 1u);
    EXPECT_EQ(t.unknown, 1u);
    EXPECT_EQ(t.partial, 1u);
    // An update that starts inside a field covers it in part.
    auto tail = push_bytes({0x1010});
    const PushTranslation u = translate_push_constants(map, pointers, 20, tail);
    EXPECT_EQ(u.partial, 2u); // 16..24 and 24..32
    EXPECT_EQ(word(tail, 0), 0x1010u);
}

template <size_t N>
ShaderAddresses reflect(const uint32_t (&words)[N]) {
    ShaderAddresses out;
    std::string error;
    EXPECT_TRUE(reflect_shader_addresses(std::span<const uint32_t>(words, N), &out, &error)) << error;
    return out;
}

TEST(SpirvAddresses, PointerMembersOfThePushConstantBlockAreFoundWithTheirOffsets) {
    const ShaderAddresses a = reflect(test_spirv::address_push_pointers_vert);
    EXPECT_TRUE(a.uses_addresses);
    EXPECT_EQ(a.push_constant_pointers, (std::vector<uint32_t>{16, 24, 32}));
    EXPECT_EQ(a.untranslatable, "");
}

TEST(SpirvAddresses, IntegerMemberThatBecomesAnAddressIsFound) {
    const ShaderAddresses a = reflect(test_spirv::address_push_integer_comp);
    EXPECT_TRUE(a.uses_addresses);
    EXPECT_EQ(a.push_constant_pointers, (std::vector<uint32_t>{8}));
    EXPECT_EQ(a.untranslatable, "");
}

TEST(SpirvAddresses, AddressesFromMemoryOrUntracedIntegersAreUntranslatable) {
    const ShaderAddresses uniform = reflect(test_spirv::address_from_uniform_frag);
    EXPECT_EQ(uniform.untranslatable, "an address read from a uniform or storage buffer");
    const ShaderAddresses list = reflect(test_spirv::address_from_memory_comp);
    EXPECT_EQ(list.push_constant_pointers, (std::vector<uint32_t>{0})); // the head is translatable
    EXPECT_EQ(list.untranslatable, "an address read from buffer memory through another address");
    const ShaderAddresses halves = reflect(test_spirv::address_from_uvec2_comp);
    EXPECT_EQ(halves.untranslatable, "an address bitcast from integers the agent cannot trace");
}

TEST(SpirvAddresses, ShaderWithoutAddressesHasNone) {
    const ShaderAddresses a = reflect(test_spirv::no_addresses_frag);
    EXPECT_FALSE(a.uses_addresses);
    EXPECT_TRUE(a.push_constant_pointers.empty());
    EXPECT_EQ(a.untranslatable, "");
}

// A client's module is untrusted: nested arrays of addresses (64 of 64 of ... ten deep) must not
// make the walk over the push-constant block exponential.
TEST(SpirvAddresses, HostileTypesAreReadInBoundedTime) {
    auto op = [](uint32_t opcode, std::initializer_list<uint32_t> operands) {
        std::vector<uint32_t> words = {uint32_t(operands.size() + 1) << 16 | opcode};
        words.insert(words.end(), operands);
        return words;
    };
    std::vector<uint32_t> module = {0x07230203, 0x00010500, 0, 1000, 0};
    auto add = [&](const std::vector<uint32_t> &words) {
        module.insert(module.end(), words.begin(), words.end());
    };
    add(op(17, {5347}));        // OpCapability PhysicalStorageBufferAddresses
    add(op(21, {1, 64, 0}));    // %1 = OpTypeInt 64
    add(op(43, {1, 2, 64, 0})); // %2 = OpConstant %1 64
    add(op(32, {3, 5349, 1}));  // %3 = OpTypePointer PhysicalStorageBuffer %1
    uint32_t element = 3, stride = 8;
    for (uint32_t level = 0; level < 10; ++level, stride *= 64) {
        const uint32_t array = 10 + level;
        add(op(28, {array, element, 2})); // OpTypeArray element [64]
        add(op(71, {array, 6, stride}));  // OpDecorate ArrayStride
        element = array;
    }
    add(op(30, {50, element}));  // %50 = OpTypeStruct
    add(op(72, {50, 0, 35, 0})); // OpMemberDecorate %50 0 Offset 0
    add(op(30, {60}));           // %60 = OpTypeStruct with no members
    add(op(32, {51, 9, 50}));    // %51 = OpTypePointer PushConstant %50
    add(op(59, {51, 52, 9}));    // %52 = OpVariable %51 PushConstant
    ShaderAddresses out;
    std::string error;
    ASSERT_TRUE(reflect_shader_addresses(module, &out, &error)) << error;
    EXPECT_TRUE(out.uses_addresses);
    EXPECT_FALSE(out.push_constant_pointers.empty());
    EXPECT_LE(out.push_constant_pointers.size(), 4096u);
    EXPECT_EQ(out.push_constant_pointers.front(), 0u);
}

TEST(SpirvAddresses, MalformedModulesAreOneLineErrors) {
    ShaderAddresses out;
    std::string error;
    const uint32_t not_spirv[] = {1, 2, 3, 4, 5, 6};
    EXPECT_FALSE(reflect_shader_addresses(not_spirv, &out, &error));
    EXPECT_EQ(error, "not a SPIR-V module (no magic number)");
    EXPECT_FALSE(reflect_shader_addresses({}, &out, &error));
}

// Whatever is wrong with a module, the whole of it is refused with one line saying where, and
// nothing read from it before the fault is reported as found.
TEST(SpirvAddresses, TruncatedOrMalformedModulesAreRejectedWhole) {
    const std::vector<uint32_t> good(std::begin(test_spirv::address_push_pointers_vert),
                                     std::end(test_spirv::address_push_pointers_vert));
    auto expect_rejected = [](const std::vector<uint32_t> &module, const char *what) {
        ShaderAddresses out;
        out.push_constant_pointers = {1234};
        std::string error;
        EXPECT_FALSE(reflect_shader_addresses(module, &out, &error)) << what;
        EXPECT_EQ(error.rfind("malformed SPIR-V: ", 0), 0u) << what << ": " << error;
        EXPECT_EQ(error.find('\n'), std::string::npos) << what << ": " << error;
        EXPECT_FALSE(out.uses_addresses) << what;
        EXPECT_TRUE(out.push_constant_pointers.empty()) << what;
    };
    {
        std::vector<uint32_t> module = good;
        module[5] = (0xffffu << 16) | (module[5] & 0xffff); // the first instruction claims 65535 words
        expect_rejected(module, "instruction longer than the module");
    }
    {
        std::vector<uint32_t> module = good;
        module[5] &= 0xffff; // the first instruction claims no words at all
        expect_rejected(module, "instruction of zero words");
    }
    {
        // Cut inside the first instruction: the header is well formed.
        ASSERT_GT(good[5] >> 16, 1u);
        const std::vector<uint32_t> module(good.begin(), good.begin() + 6);
        expect_rejected(module, "module cut short");
    }
    {
        std::vector<uint32_t> module = good;
        module.push_back(1u << 16 | 30); // OpTypeStruct without its result id
        expect_rejected(module, "instruction shorter than its operands");
    }
    {
        std::vector<uint32_t> module = good;
        module.push_back(1u << 16 | 0xfff0); // no opcode SPIR-V defines
        expect_rejected(module, "unknown opcode");
    }
}

// A module the reader refuses (here: an opcode newer than its grammar) still replays untouched when
// its capabilities, which SPIR-V puts first, declare no addresses; otherwise, or when even those
// cannot be read, its addresses count as untranslatable.
TEST(SpirvAddresses, RefusedModulesMayUseAddressesOnlyIfTheyDeclareThem) {
    constexpr uint32_t kOpCapability = 2u << 16 | 17, kShader = 1, kPhysicalStorageBufferAddresses = 5347;
    constexpr uint32_t kUnknownOpcode = 1u << 16 | 0xfff0;
    constexpr uint32_t kOpMemoryModel = 3u << 16 | 14, kLogical = 0, kGlsl450 = 1;
    const uint32_t header[] = {0x07230203, 0x00010500, 0, 16, 0};
    auto module = [&](std::initializer_list<uint32_t> body) {
        std::vector<uint32_t> words(std::begin(header), std::end(header));
        words.insert(words.end(), body);
        return words;
    };
    const auto shader_only =
        module({kOpCapability, kShader, kOpMemoryModel, kLogical, kGlsl450, kUnknownOpcode});
    const auto with_addresses =
        module({kOpCapability, kShader, kOpCapability, kPhysicalStorageBufferAddresses, kUnknownOpcode});
    ShaderAddresses out;
    std::string error;
    ASSERT_FALSE(reflect_shader_addresses(shader_only, &out, &error));
    ASSERT_FALSE(reflect_shader_addresses(with_addresses, &out, &error));
    EXPECT_FALSE(may_use_addresses(shader_only));
    EXPECT_TRUE(may_use_addresses(with_addresses));
    EXPECT_TRUE(may_use_addresses(module({kOpCapability & 0xffff})));        // a capability of zero words
    EXPECT_TRUE(may_use_addresses(std::vector<uint32_t>{1, 2, 3, 4, 5, 6})); // not SPIR-V at all
}

} // namespace
} // namespace splitvk::agent
