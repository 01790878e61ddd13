// splitvk-harness: the e2e harness's process handling (process.h, xvfb.h, agent_process.h,
// screen_grab.h) for the scripts, so that scripts/bench, scripts/fuzz, scripts/device-check and
// the gtest suites start Xvfb and the agent, wait for them, hold an app and grab the screen one
// way. Reports go to stdout as key=value lines; problems to stderr as one "error:" line.
//
//   splitvk-harness xvfb --out-dir DIR
//   splitvk-harness agent --out-dir DIR [--name NAME] [--port N] [--wrapper ARG]... -- AGENT [ARGS...]
//       Services: start, print their key=value lines and a last line "ready", then run until
//       SIGTERM, SIGINT or SIGHUP (or until whoever started this exits), and stop what they started.
//   splitvk-harness hold --out-dir DIR [--name NAME] --frame N --grab FILE --size WxH [--at X,Y]
//                        [--grab-frames K] [--framerate R] [--pix-fmt F] [--settle-ms MS]
//                        [--timeout S] -- APP [ARGS...]
//       Runs APP until it prints "holding frame N", grabs the screen, ends APP with SIGTERM.
//
// Everything runs with this program's environment (DISPLAY included); the agent in --out-dir, the
// app of `hold` in the current directory. Nothing is left running when it exits, whatever the way.
#include "agent_process.h"
#include "process.h"
#include "screen_grab.h"
#include "xvfb.h"

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <sys/prctl.h>
#include <unistd.h>

extern char **environ;

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

volatile std::sig_atomic_t g_stop = 0;

void on_stop_signal(int) {
    g_stop = 1;
}

// Services end on a signal, and with their caller: a script that dies leaves nothing running.
void watch_signals() {
    struct sigaction action {};
    action.sa_handler = on_stop_signal;
    sigemptyset(&action.sa_mask);
    for (int sig : {SIGTERM, SIGINT, SIGHUP})
        ::sigaction(sig, &action, nullptr);
    const pid_t parent = ::getppid();
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) g_stop = 1; // the caller went before the line above
}

Env current_env() {
    Env env;
    for (char **e = environ; e && *e; ++e) {
        const std::string kv(*e);
        const auto eq = kv.find('=');
        if (eq != std::string::npos) env[kv.substr(0, eq)] = kv.substr(eq + 1);
    }
    return env;
}

int fail(const std::string &message) {
    std::fprintf(stderr, "splitvk-harness: error: %s\n", message.c_str());
    return 1;
}

void report(const std::string &key, const std::string &value) {
    std::printf("%s=%s\n", key.c_str(), value.c_str());
}

void ready() {
    std::printf("ready\n");
    std::fflush(stdout);
}

struct Args {
    std::string out_dir;
    std::string name;
    std::vector<std::string> wrapper;
    uint16_t port = 0;
    int frame = -1;
    std::string grab;
    uint32_t width = 0, height = 0;
    int x = 0, y = 0;
    int grab_frames = 1;
    int framerate = 0;
    std::string pix_fmt;
    int settle_ms = 0;
    int timeout_s = 600;
    std::vector<std::string> command; // after "--"
};

bool parse_int(const std::string &text, long min, long max, long *out) {
    char *end = nullptr;
    errno = 0;
    const long v = std::strtol(text.c_str(), &end, 10);
    if (text.empty() || *end || errno || v < min || v > max) return false;
    *out = v;
    return true;
}

// Parses the options after the subcommand; false with *error on the first bad one.
bool parse(int argc, char **argv, Args *a, std::string *error) {
    for (int i = 2; i < argc; ++i) {
        const std::string opt = argv[i];
        if (opt == "--") {
            a->command.assign(argv + i + 1, argv + argc);
            // Children run in --out-dir (the agent) or here (hold): a path is made absolute now.
            if (!a->command.empty() && a->command[0].find('/') != std::string::npos)
                a->command[0] = std::filesystem::absolute(a->command[0]).string();
            return true;
        }
        if (i + 1 >= argc) {
            *error = opt + " needs a value (or is unknown)";
            return false;
        }
        const std::string value = argv[++i];
        long n = 0;
        if (opt == "--out-dir") {
            a->out_dir = value;
        } else if (opt == "--name") {
            a->name = value;
        } else if (opt == "--wrapper") {
            a->wrapper.push_back(value);
        } else if (opt == "--port" && parse_int(value, 0, 65535, &n)) {
            a->port = static_cast<uint16_t>(n);
        } else if (opt == "--frame" && parse_int(value, 0, 1L << 30, &n)) {
            a->frame = static_cast<int>(n);
        } else if (opt == "--grab") {
            a->grab = value;
        } else if (opt == "--size" && std::sscanf(value.c_str(), "%ux%u", &a->width, &a->height) == 2 &&
                   a->width && a->height) {
        } else if (opt == "--at" && std::sscanf(value.c_str(), "%d,%d", &a->x, &a->y) == 2) {
        } else if (opt == "--grab-frames" && parse_int(value, 1, 1000, &n)) {
            a->grab_frames = static_cast<int>(n);
        } else if (opt == "--framerate" && parse_int(value, 1, 1000, &n)) {
            a->framerate = static_cast<int>(n);
        } else if (opt == "--pix-fmt") {
            a->pix_fmt = value;
        } else if (opt == "--settle-ms" && parse_int(value, 0, 60000, &n)) {
            a->settle_ms = static_cast<int>(n);
        } else if (opt == "--timeout" && parse_int(value, 1, 86400, &n)) {
            a->timeout_s = static_cast<int>(n);
        } else {
            *error = "bad option " + opt + " " + value;
            return false;
        }
    }
    return true;
}

// Sleeps until a stop signal, or until `alive` says the service is gone (false).
template <class Alive>
bool run_until_stopped(Alive alive) {
    while (!g_stop) {
        if (!alive()) return false;
        std::this_thread::sleep_for(100ms);
    }
    return true;
}

int xvfb(const Args &a) {
    Xvfb server;
    if (!server.start(a.out_dir, current_env())) return fail(server.error());
    report("display", server.display());
    ready();
    if (!run_until_stopped([&server] { return server.alive(); })) return fail("Xvfb ended on its own");
    server.stop();
    return 0;
}

int agent(const Args &a) {
    if (a.command.empty()) return fail("agent: no agent program after --");
    AgentProcess agent(a.command[0]);
    agent.set_host("127.0.0.1", a.wrapper);
    const std::vector<std::string> extra(a.command.begin() + 1, a.command.end());
    if (!agent.start(current_env(), a.out_dir, extra, a.port, a.name.empty() ? "splitvk-agent" : a.name))
        return fail(agent.error());
    report("address", agent.address());
    report("pid", std::to_string(agent.pid()));
    report("log", agent.log_path().string());
    ready();
    const bool stopped = run_until_stopped([&agent] { return agent.running(); });
    const ProcessResult r = agent.stop(30s);
    if (!stopped) return fail("splitvk-agent ended on its own: " + r.describe());
    return 0;
}

int hold(const Args &a) {
    if (a.command.empty()) return fail("hold: no program after --");
    if (a.frame < 0 || a.grab.empty() || !a.width) return fail("hold needs --frame, --grab and --size");
    const char *display = std::getenv("DISPLAY");
    if (!display || !*display) return fail("hold: DISPLAY is not set");
    ProcessSpec spec;
    spec.argv = a.command;
    spec.env = current_env();
    spec.out_dir = a.out_dir;
    spec.name = a.name;
    spec.cwd = std::filesystem::current_path(); // the caller's, as if it ran the app itself
    Process app(spec);
    if (!app.start()) return fail(app.error());
    const std::string line = "holding frame " + std::to_string(a.frame);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(a.timeout_s);
    bool held = false;
    while (!held && !g_stop && std::chrono::steady_clock::now() < deadline) {
        held = app.wait_for_line(line, 200ms);
        if (!held && !app.running())
            return fail("the app ended before '" + line + "': " + app.result().describe());
    }
    if (!held) {
        const auto r = app.terminate(5s);
        return fail(g_stop ? "stopped"
                           : "the app did not print '" + line + "' in " + std::to_string(a.timeout_s) +
                                 " s: " + r.describe());
    }
    // The X server may still be taking the last present when the app reports it.
    std::this_thread::sleep_for(std::chrono::milliseconds(a.settle_ms));
    ScreenGrab grab;
    grab.display = display;
    grab.x = a.x;
    grab.y = a.y;
    grab.width = a.width;
    grab.height = a.height;
    grab.frames = a.grab_frames;
    grab.framerate = a.framerate;
    grab.pix_fmt = a.pix_fmt;
    grab.output = a.grab;
    grab.log_dir = a.out_dir;
    std::string error;
    const bool grabbed = grab_to_file(grab, spec.env, &error);
    const ProcessResult r = app.terminate(30s);
    if (!grabbed) return fail(error);
    report("grab", a.grab);
    report("stdout", r.stdout_path.string());
    report("stderr", r.stderr_path.string());
    if (!r.ok()) return fail("the app did not end cleanly on SIGTERM: " + r.describe());
    std::fflush(stdout);
    return 0;
}

int usage() {
    std::fprintf(
        stderr,
        "usage: splitvk-harness xvfb --out-dir DIR\n"
        "       splitvk-harness agent --out-dir DIR [--name NAME] [--port N] [--wrapper ARG]... -- AGENT "
        "[ARGS...]\n"
        "       splitvk-harness hold --out-dir DIR [--name NAME] --frame N --grab FILE --size WxH [--at "
        "X,Y]\n"
        "                            [--grab-frames K] [--framerate R] [--pix-fmt F] [--settle-ms MS] "
        "[--timeout S]\n"
        "                            -- APP [ARGS...]\n");
    return 2;
}

} // namespace
} // namespace splitvk::e2e

int main(int argc, char **argv) {
    using namespace splitvk::e2e;
    if (argc < 2) return usage();
    const std::string command = argv[1];
    Args args;
    std::string error;
    if (!parse(argc, argv, &args, &error)) {
        fail(error);
        return usage();
    }
    if (args.out_dir.empty()) return fail(command + " needs --out-dir");
    watch_signals();
    if (command == "xvfb") return xvfb(args);
    if (command == "agent") return agent(args);
    if (command == "hold") return hold(args);
    return usage();
}
