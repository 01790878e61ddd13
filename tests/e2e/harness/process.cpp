#include "process.h"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

namespace splitvk::e2e {

namespace {

double seconds_since(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

// In the sanitizer builds (scripts/test's build-asan/: -fsanitize=address,undefined, and
// build-tsan/: -fsanitize=thread, on everything this project builds, the harness included) the
// children need what the test binary cannot get from ctest's environment:
#if defined(__SANITIZE_ADDRESS__)
#define SPLITVK_E2E_ASAN 1
#elif defined(__SANITIZE_THREAD__)
#define SPLITVK_E2E_TSAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SPLITVK_E2E_ASAN 1
#elif __has_feature(thread_sanitizer)
#define SPLITVK_E2E_TSAN 1
#endif
#endif

#if defined(SPLITVK_E2E_ASAN) || defined(SPLITVK_E2E_TSAN)
#ifdef SPLITVK_E2E_ASAN
constexpr const char *kSanitizerRuntime = "/libasan.so";
#else
constexpr const char *kSanitizerRuntime = "/libtsan.so";
#endif

// The sanitizer runtime this binary runs with (from /proc/self/maps), so that a child preloads the
// same one.
std::string loaded_sanitizer_runtime() {
    static const std::string path = [] {
        for (const auto &line : split_lines(read_file("/proc/self/maps"))) {
            const auto slash = line.find('/');
            if (slash != std::string::npos && line.find(kSanitizerRuntime, slash) != std::string::npos)
                return line.substr(slash);
        }
        return std::string();
    }();
    return path;
}

// The build tree whose programs are linked with the sanitizer runtime already: this build's (the
// suites' SPLITVK_E2E_BUILD_DIR override included, as vk_env.h's build_dir()).
const std::filesystem::path &instrumented_build_dir() {
    static const std::filesystem::path dir = [] {
        const char *v = std::getenv("SPLITVK_E2E_BUILD_DIR");
        return std::filesystem::path(v && *v ? v : SPLITVK_BUILD_DIR);
    }();
    return dir;
}

// Only an executable file gets the runtime, not a script (scripts/xr-runtime): its interpreter,
// bash, crashes with TSan's runtime preloaded. An application such a script starts with a layer of
// this build must be this build's own (atrium).
bool is_elf(const std::string &program) {
    static constexpr char elf[4] = {'\x7f', 'E', 'L', 'F'};
    char magic[4] = {};
    std::ifstream in(program, std::ios::binary);
    return in.read(magic, sizeof magic) && std::memcmp(magic, elf, sizeof magic) == 0;
}

bool starts_with_path(const std::filesystem::path &p, const std::filesystem::path &dir) {
    std::error_code ec;
    const auto a = std::filesystem::weakly_canonical(p, ec).string();
    const auto b = std::filesystem::weakly_canonical(dir, ec).string();
    return !b.empty() && a.rfind(b + "/", 0) == 0;
}
#endif

void adapt_env_to_sanitizers([[maybe_unused]] const std::string &program, [[maybe_unused]] Env &env) {
#ifdef SPLITVK_E2E_ASAN
    // 1. No leak checking in children. LeakSanitizer's report at exit would be about code that is
    //    not ours: lavapipe (and LLVM's JIT under it), the Vulkan loader, the validation layer and
    //    Xlib/xcb keep allocations until exit, and the driver's are made by a module the loader has
    //    dlclose()d by then, so they can be neither symbolized nor suppressed by a suppressions
    //    file. splitvk's own code keeps leak checking in the unit tests (run with detect_leaks=1),
    //    and the soak watches the real processes' memory over 10,000 frames. ASan's other checks and
    //    UBSan stay on in every child (ctest's ASAN_OPTIONS / UBSAN_OPTIONS are passed on; a later
    //    flag wins, so this is appended).
    auto &asan = env["ASAN_OPTIONS"];
    asan += (asan.empty() ? "" : ":") + std::string("detect_leaks=0");
#endif
#if defined(SPLITVK_E2E_ASAN) || defined(SPLITVK_E2E_TSAN)
    // 2. An uninstrumented program (vkcube, vkcubepp, gfxrecon-replay) that loads one of this
    //    build's instrumented layers (splitvk, or the test hold layer) must have the sanitizer
    //    runtime in its initial library list: ASan aborts at dlopen with "ASan runtime does not
    //    come first in initial library list", and TSan's runtime cannot be loaded by dlopen at
    //    all. Programs of this build are linked with it already; others are left alone when no
    //    splitvk layer can load (Xvfb, ffmpeg). TSAN_OPTIONS (scripts/test's) is passed on as is.
    const auto layers = env.find("VK_INSTANCE_LAYERS");
    const bool loads_ours = (layers != env.end() && layers->second.find("SPLITVK") != std::string::npos) ||
                            env.count("SPLITVK_ENABLE") != 0;
    if (loads_ours && !starts_with_path(program, instrumented_build_dir()) && is_elf(program) &&
        !loaded_sanitizer_runtime().empty()) {
        auto &preload = env["LD_PRELOAD"];
        preload = preload.empty() ? loaded_sanitizer_runtime() : loaded_sanitizer_runtime() + ":" + preload;
    }
#endif
}

} // namespace

std::string read_file(const std::filesystem::path &path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return {};
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

std::vector<std::string> split_lines(const std::string &text) {
    std::vector<std::string> lines;
    std::string::size_type start = 0;
    while (start < text.size()) {
        auto end = text.find('\n', start);
        if (end == std::string::npos) end = text.size();
        std::string line = text.substr(start, end - start);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        lines.push_back(std::move(line));
        start = end + 1;
    }
    return lines;
}

std::vector<std::string> grep(const std::string &text, const std::string &needle) {
    std::vector<std::string> hits;
    for (auto &line : split_lines(text))
        if (line.find(needle) != std::string::npos) hits.push_back(line);
    return hits;
}

std::optional<std::string> find_program(const std::string &name, const Env &env) {
    if (name.find('/') != std::string::npos) {
        if (::access(name.c_str(), X_OK) == 0) return name;
        return std::nullopt;
    }
    auto it = env.find("PATH");
    std::string path = it != env.end() ? it->second : "/usr/local/bin:/usr/bin:/bin";
    std::stringstream ss(path);
    std::string dir;
    while (std::getline(ss, dir, ':')) {
        if (dir.empty()) continue;
        std::string candidate = dir + "/" + name;
        struct stat st {};
        if (::stat(candidate.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
            ::access(candidate.c_str(), X_OK) == 0)
            return candidate;
    }
    return std::nullopt;
}

std::string ProcessResult::out() const {
    return read_file(stdout_path);
}
std::string ProcessResult::err() const {
    return read_file(stderr_path);
}

std::string ProcessResult::describe() const {
    std::ostringstream ss;
    if (!started)
        ss << "did not start: " << start_error;
    else if (timed_out)
        ss << "TIMED OUT after " << wall_s << " s (process group killed)";
    else if (exited)
        ss << "exited with code " << exit_code << " after " << wall_s << " s";
    else
        ss << "killed by signal " << term_signal << " (" << strsignal(term_signal) << ") after " << wall_s
           << " s";
    ss << "; stdout: " << stdout_path.string() << "; stderr: " << stderr_path.string();
    return ss.str();
}

Process::Process(ProcessSpec spec) : spec_(std::move(spec)) {
    if (spec_.name.empty() && !spec_.argv.empty())
        spec_.name = std::filesystem::path(spec_.argv[0]).filename().string();
    result_.stdout_path = spec_.out_dir / (spec_.name + ".stdout");
    result_.stderr_path = spec_.out_dir / (spec_.name + ".stderr");
}

Process::~Process() {
    if (pid_ > 0 && !reaped_) {
        kill_group(SIGKILL);
        try_reap(true);
    }
}

bool Process::start() {
    if (spec_.argv.empty()) {
        result_.start_error = error_ = "empty argv";
        return false;
    }
    auto program = find_program(spec_.argv[0], spec_.env);
    if (!program) {
        result_.start_error = error_ = "program not found: " + spec_.argv[0];
        return false;
    }
    std::error_code ec;
    std::filesystem::create_directories(spec_.out_dir, ec);
    const std::filesystem::path cwd = spec_.cwd.empty() ? spec_.out_dir : spec_.cwd;

    // Everything the child needs is prepared before fork: between fork and exec only
    // async-signal-safe calls are allowed (the test binary may have threads).
    Env env = spec_.env;
    adapt_env_to_sanitizers(*program, env);
    std::vector<std::string> env_strings;
    for (auto &[k, v] : env)
        env_strings.push_back(k + "=" + v);
    std::vector<char *> envp;
    for (auto &s : env_strings)
        envp.push_back(s.data());
    envp.push_back(nullptr);
    std::vector<std::string> args = spec_.argv;
    std::vector<char *> argv;
    for (auto &s : args)
        argv.push_back(s.data());
    argv.push_back(nullptr);
    const std::string out_path = result_.stdout_path.string();
    const std::string err_path = result_.stderr_path.string();
    const std::string cwd_str = cwd.string();
    const std::vector<int> keep = spec_.keep_fds;
    const int death_signal = spec_.parent_death_signal;
    const pid_t parent = ::getpid();

    int out_fd = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    int err_fd = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    int null_fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
    // exec failure is reported through a close-on-exec pipe: EOF means exec succeeded.
    int status_pipe[2];
    if (out_fd < 0 || err_fd < 0 || null_fd < 0 || ::pipe2(status_pipe, O_CLOEXEC) != 0) {
        result_.start_error = error_ = std::string("cannot open output files in ") + spec_.out_dir.string() +
                                       ": " + std::strerror(errno);
        for (int fd : {out_fd, err_fd, null_fd})
            if (fd >= 0) ::close(fd);
        return false;
    }

    started_at_ = Clock::now();
    pid_t pid = ::fork();
    if (pid < 0) {
        result_.start_error = error_ = std::string("fork: ") + std::strerror(errno);
        for (int fd : {out_fd, err_fd, null_fd, status_pipe[0], status_pipe[1]})
            ::close(fd);
        return false;
    }
    if (pid == 0) {
        ::setpgid(0, 0); // own process group, so a timeout kills the app and all its children
        // If the test binary itself is killed (ctest's TIMEOUT), the app and Xvfb must not outlive it.
        ::prctl(PR_SET_PDEATHSIG, death_signal);
        if (::getppid() != parent) ::_exit(127);
        ::dup2(null_fd, STDIN_FILENO);
        ::dup2(out_fd, STDOUT_FILENO);
        ::dup2(err_fd, STDERR_FILENO);
        // Default signal dispositions and an empty mask for the child.
        sigset_t none;
        sigemptyset(&none);
        ::sigprocmask(SIG_SETMASK, &none, nullptr);
        ::signal(SIGPIPE, SIG_DFL);
        for (int fd : keep)
            ::fcntl(fd, F_SETFD, 0);
        int err = 0;
        if (::chdir(cwd_str.c_str()) != 0) {
            err = errno;
        } else {
            ::execve(program->c_str(), argv.data(), envp.data());
            err = errno;
        }
        ssize_t ignored = ::write(status_pipe[1], &err, sizeof err);
        (void)ignored;
        ::_exit(127);
    }
    pid_ = pid;
    ::setpgid(pid, pid); // also from the parent, so kill_group works even before the child runs
    for (int fd : {out_fd, err_fd, null_fd, status_pipe[1]})
        ::close(fd);
    int child_errno = 0;
    ssize_t n;
    do {
        n = ::read(status_pipe[0], &child_errno, sizeof child_errno);
    } while (n < 0 && errno == EINTR);
    ::close(status_pipe[0]);
    if (n == static_cast<ssize_t>(sizeof child_errno)) {
        result_.start_error = error_ = "exec " + *program + ": " + std::strerror(child_errno);
        try_reap(true);
        return false;
    }
    result_.started = true;
    return true;
}

void Process::kill_group(int sig) {
    if (pid_ > 0 && !reaped_) ::kill(-pid_, sig);
}

bool Process::try_reap(bool block) {
    if (pid_ <= 0) return true;
    if (reaped_) return true;
    int status = 0;
    pid_t r;
    do {
        r = ::waitpid(pid_, &status, block ? 0 : WNOHANG);
    } while (r < 0 && errno == EINTR);
    if (r == 0) return false;
    reaped_ = true;
    result_.wall_s = seconds_since(started_at_);
    if (r < 0) return true;
    if (WIFEXITED(status)) {
        result_.exited = true;
        result_.exit_code = WEXITSTATUS(status);
    } else if (WIFSIGNALED(status)) {
        result_.exited = false;
        result_.term_signal = WTERMSIG(status);
    }
    // Whatever the app left behind in its group (helpers, grandchildren) goes too.
    ::kill(-pid_, SIGKILL);
    return true;
}

bool Process::running() {
    return pid_ > 0 && !try_reap(false);
}

bool Process::wait_for_line(const std::string &line, std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    for (;;) {
        // The stdout file is re-read whole: apps print little, and this needs no pipe draining.
        for (auto &l : split_lines(read_file(result_.stdout_path)))
            if (l == line) return true;
        if (!running()) {
            // It may have printed the line just before exiting.
            for (auto &l : split_lines(read_file(result_.stdout_path)))
                if (l == line) return true;
            return false;
        }
        if (Clock::now() >= deadline) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
}

ProcessResult Process::wait(std::chrono::milliseconds timeout) {
    if (pid_ <= 0) return result_;
    const auto deadline = Clock::now() + timeout;
    while (!try_reap(false)) {
        if (Clock::now() >= deadline) {
            result_.timed_out = true;
            kill_group(SIGKILL);
            try_reap(true);
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return result_;
}

ProcessResult Process::terminate(std::chrono::milliseconds grace) {
    if (pid_ <= 0 || reaped_) return result_;
    kill_group(SIGTERM);
    return wait(grace);
}

ProcessResult run_process(ProcessSpec spec, std::chrono::milliseconds timeout) {
    Process p(std::move(spec));
    if (!p.start()) {
        ProcessResult r = p.result();
        r.start_error = p.error();
        return r;
    }
    return p.wait(timeout);
}

} // namespace splitvk::e2e
