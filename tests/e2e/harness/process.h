// Child processes for end-to-end tests: fork/exec with an explicit environment, stdout and stderr
// captured to files, a hard timeout that kills the whole process group, waiting for a line on
// stdout, SIGTERM and reap. A hung application must fail its test, never hang ctest.
#pragma once

#include <chrono>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <sys/types.h>

namespace splitvk::e2e {

using Env = std::map<std::string, std::string>;
using Clock = std::chrono::steady_clock;

struct ProcessSpec {
    std::vector<std::string> argv; // argv[0] is the program: an absolute path or a name in PATH
    Env env;                       // the child's whole environment (nothing is inherited)
    std::filesystem::path out_dir; // <out_dir>/<name>.stdout and <name>.stderr
    std::string name;              // file stem for the captured output; defaults to argv[0]'s stem
    std::filesystem::path cwd;     // working directory; empty = out_dir
    std::vector<int> keep_fds;     // descriptors the child inherits (others are close-on-exec)
    int parent_death_signal = 9;   // sent to the child if the test binary dies (ctest timeout)
};

struct ProcessResult {
    bool started = false;    // exec succeeded
    std::string start_error; // why not, when !started
    bool timed_out = false;  // killed by us after the deadline
    bool exited = false;     // ended through exit() (exit_code valid)
    int exit_code = -1;
    int term_signal = 0; // the signal that ended it when !exited
    double wall_s = 0.0;
    std::filesystem::path stdout_path;
    std::filesystem::path stderr_path;

    bool ok() const { return started && !timed_out && exited && exit_code == 0; }
    std::string out() const; // whole captured stdout
    std::string err() const; // whole captured stderr
    // One line for assertion messages: how it ended and where its output is.
    std::string describe() const;
};

class Process {
public:
    explicit Process(ProcessSpec spec);
    ~Process(); // kills the process group if it is still running, then reaps
    Process(const Process &) = delete;
    Process &operator=(const Process &) = delete;

    // Forks and execs. False (with a message in error()) when fork or exec failed.
    bool start();
    pid_t pid() const { return pid_; }
    bool running();

    // Waits until a whole line equal to `line` appears on the child's stdout. False on timeout or
    // when the child ended first (the result then says how).
    bool wait_for_line(const std::string &line, std::chrono::milliseconds timeout);

    // Waits for the child to end on its own; after `timeout` kills the process group (SIGKILL)
    // and marks the result timed_out.
    ProcessResult wait(std::chrono::milliseconds timeout);

    // SIGTERM to the process group, then waits up to `grace` before SIGKILL (then timed_out).
    ProcessResult terminate(std::chrono::milliseconds grace);

    const ProcessResult &result() const { return result_; }
    const std::string &error() const { return error_; }

private:
    bool try_reap(bool block);
    void kill_group(int sig);

    ProcessSpec spec_;
    pid_t pid_ = -1;
    bool reaped_ = false;
    Clock::time_point started_at_{};
    ProcessResult result_;
    std::string error_;
};

// Runs to completion with a hard timeout.
ProcessResult run_process(ProcessSpec spec, std::chrono::milliseconds timeout);

std::string read_file(const std::filesystem::path &path);
std::vector<std::string> split_lines(const std::string &text);
// The lines of `text` that contain `needle`.
std::vector<std::string> grep(const std::string &text, const std::string &needle);
std::optional<std::string> find_program(const std::string &name, const Env &env);

} // namespace splitvk::e2e
