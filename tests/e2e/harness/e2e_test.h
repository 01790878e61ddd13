// Shared helpers for the end-to-end suites.
#pragma once

#include "image.h"
#include "process.h"
#include "vk_env.h"
#include "x11grab.h"
#include "xvfb.h"

#include <chrono>
#include <filesystem>
#include <map>
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

// A CSV of SPLITVK_STATS as rows of named numbers.
inline std::vector<std::map<std::string, double>> stats_rows(const std::string &text) {
    std::vector<std::map<std::string, double>> rows;
    const auto lines = split_lines(text);
    if (lines.empty()) return rows;
    std::vector<std::string> names;
    std::stringstream header(lines[0]);
    for (std::string field; std::getline(header, field, ',');)
        names.push_back(field);
    for (size_t i = 1; i < lines.size(); ++i) {
        std::map<std::string, double> row;
        std::stringstream fields(lines[i]);
        size_t column = 0;
        for (std::string field; std::getline(fields, field, ',') && column < names.size(); ++column)
            row[names[column]] = std::stod(field);
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
