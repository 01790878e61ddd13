// Shared helpers for the end-to-end suites.
#pragma once

#include "image.h"
#include "process.h"
#include "vk_env.h"
#include "x11grab.h"
#include "xvfb.h"

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk::e2e {

// A test that needs the X server: SetUp starts (or reuses) this binary's Xvfb and a fresh output dir.
class XTest : public ::testing::Test {
protected:
    void SetUp() override {
        out_ = test_output_dir();
        xvfb_ = shared_xvfb();
        ASSERT_NE(xvfb_, nullptr) << "cannot start Xvfb: " << shared_xvfb_error();
    }
    std::string display() const { return xvfb_->display(); }
    Env env() const { return app_env(display()); }

    std::filesystem::path out_;
    Xvfb *xvfb_ = nullptr;
};

// Runs argv to completion under `env` with stdout/stderr in out_dir/<name>.{stdout,stderr}.
inline ProcessResult run_app(const std::vector<std::string> &argv, const Env &env,
                             const std::filesystem::path &out_dir, const std::string &name,
                             std::chrono::seconds timeout) {
    ProcessSpec spec;
    spec.argv = argv;
    spec.env = env;
    spec.out_dir = out_dir;
    spec.name = name;
    return run_process(spec, timeout);
}

// Fails the test unless the build produced what the e2e tests run.
inline ::testing::AssertionResult built(const std::filesystem::path &p) {
    if (std::filesystem::exists(p)) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure()
           << p.string() << " does not exist: build the tree first (cmake --build)";
}

// The first message of a validation log (its first line and the indented lines under it) and how
// many messages the log holds; a message starts at a line that is not indented.
inline std::string first_message(const std::string &log) {
    auto lines = split_lines(log);
    std::string first;
    size_t messages = 0;
    for (auto &l : lines) {
        if (l.empty()) continue;
        const bool indented = l[0] == ' ' || l[0] == '\t';
        if (!indented) ++messages;
        if (messages == 1) first += l + "\n";
    }
    return first + "(" + std::to_string(messages) + " message(s) in all)";
}

// The files in `dir` whose names `name` matches whole, each with the numbers its groups match (all
// decimal): for image(\d+)-(\d+)\.pam, image3-00012.pam gives {3, 12}.
inline std::vector<std::pair<std::vector<int>, std::filesystem::path>>
numbered_files(const std::filesystem::path &dir, const std::regex &name) {
    std::vector<std::pair<std::vector<int>, std::filesystem::path>> files;
    std::error_code ec;
    for (const auto &entry : std::filesystem::directory_iterator(dir, ec)) {
        std::smatch m;
        const std::string file = entry.path().filename().string();
        if (!std::regex_match(file, m, name)) continue;
        std::vector<int> numbers;
        for (size_t i = 1; i < m.size(); ++i)
            numbers.push_back(std::stoi(m[i]));
        files.emplace_back(std::move(numbers), entry.path());
    }
    return files;
}

// A CSV of SPLITVK_STATS as rows of named fields, as written.
inline std::vector<std::map<std::string, std::string>> stats_text_rows(const std::string &text) {
    std::vector<std::map<std::string, std::string>> rows;
    const auto lines = split_lines(text);
    if (lines.empty()) return rows;
    std::vector<std::string> names;
    std::stringstream header(lines[0]);
    for (std::string field; std::getline(header, field, ',');)
        names.push_back(field);
    for (size_t i = 1; i < lines.size(); ++i) {
        std::map<std::string, std::string> row;
        std::stringstream fields(lines[i]);
        size_t column = 0;
        for (std::string field; std::getline(fields, field, ',') && column < names.size(); ++column)
            row[names[column]] = field;
        // getline drops a trailing empty field: the last columns are then empty.
        for (; column < names.size(); ++column)
            row[names[column]] = "";
        rows.push_back(std::move(row));
    }
    return rows;
}

// The same as rows of named numbers. An empty field is a value the layer did not measure
// (periphery_psnr_db), and a field that is not a number names something (agent): both are left out.
inline std::vector<std::map<std::string, double>> stats_rows(const std::string &text) {
    std::vector<std::map<std::string, double>> rows;
    for (const auto &text_row : stats_text_rows(text)) {
        std::map<std::string, double> row;
        for (const auto &[name, field] : text_row) {
            char *end = nullptr;
            const double value = std::strtod(field.c_str(), &end);
            if (!field.empty() && end == field.c_str() + field.size()) row[name] = value;
        }
        rows.push_back(std::move(row));
    }
    return rows;
}

// The last lines of a text, for failure messages.
inline std::string tail(const std::string &text, size_t n = 15) {
    auto lines = split_lines(text);
    std::string s;
    for (size_t i = lines.size() > n ? lines.size() - n : 0; i < lines.size(); ++i)
        s += lines[i] + "\n";
    return s;
}

inline std::string joined(const std::vector<std::string> &lines) {
    std::string s;
    for (auto &l : lines)
        s += "\n  " + l;
    return s;
}

} // namespace splitvk::e2e
