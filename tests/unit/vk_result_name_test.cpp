// vk_result_name() (generated from vk.xml by codegen/emit_results.py) against the VkResult enum of
// the vulkan_core.h the project builds with: every enumerant is named, an alias by the enumerant
// it aliases, and a value no header defines is said to be unknown.
#include "vk_result_name.h"

#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace splitvk {
namespace {

// name -> its value or, for an alias, the name it aliases, as vulkan_core.h writes them.
std::map<std::string, std::string> header_results() {
    std::ifstream in(SPLITVK_VULKAN_CORE_H);
    std::stringstream text;
    text << in.rdbuf();
    const std::string header = text.str();
    const size_t begin = header.find("typedef enum VkResult {");
    const size_t end = header.find("} VkResult;", begin);
    std::map<std::string, std::string> results;
    if (begin == std::string::npos || end == std::string::npos) return results;
    const std::string body = header.substr(begin, end - begin);
    const std::regex enumerant(R"((VK_\w+) = (-?\w+),?)");
    for (auto it = std::sregex_iterator(body.begin(), body.end(), enumerant); it != std::sregex_iterator();
         ++it)
        if ((*it)[1] != "VK_RESULT_MAX_ENUM") results[(*it)[1]] = (*it)[2];
    return results;
}

TEST(VkResultName, NamesEveryVkResultOfVulkanCoreH) {
    const auto results = header_results();
    ASSERT_GT(results.size(), 40u) << "no VkResult enum in " << SPLITVK_VULKAN_CORE_H;
    for (const auto &[name, value] : results) {
        std::string canonical = name, number = value;
        for (int hops = 0; hops < 4 && results.count(number); ++hops) { // an alias, maybe of an alias
            canonical = number;
            number = results.at(number);
        }
        ASSERT_TRUE(std::regex_match(number, std::regex("-?[0-9]+"))) << name << " = " << value;
        const auto result = static_cast<VkResult>(std::stoll(number));
        EXPECT_STREQ(vk_result_name(result), canonical.c_str()) << name << " = " << value;
    }
}

TEST(VkResultName, AValueNoHeaderDefinesIsUnknown) {
    EXPECT_STREQ(vk_result_name(static_cast<VkResult>(-12345)), "an unknown VkResult");
    EXPECT_STREQ(vk_result_name(VK_SUCCESS), "VK_SUCCESS");
    EXPECT_STREQ(vk_result_name(VK_ERROR_OUT_OF_POOL_MEMORY_KHR), "VK_ERROR_OUT_OF_POOL_MEMORY");
}

} // namespace
} // namespace splitvk
