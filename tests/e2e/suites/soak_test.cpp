// Soak: 10,000 frames of splitvk-atrium split with a real splitvk-agent on loopback, in a
// small window (320x144 stereo) with a small model (--model: a floor and a box, 12 triangles) so
// that it stays affordable on two cores: lavapipe's cost is atrium's 300,000 triangles, not the
// pixels (86 ms a frame at 320x144 with the atrium scene, 4 ms with the box, client and agent
// both on one machine). The layer's and agent's per-frame work is the same whatever is drawn. It proves what
// a short run cannot:
//  - no frame is lost: atrium's frame-time line counts 10,000 frames, the layer's split summary
//    says 10,000 frames composited (none late), and the agent's session closed after 10,000 frames;
//  - nothing grows per frame: the resident memory (VmRSS) of the app and of the agent's session
//    process grows less than 5 % from warm-up to the end, and their open descriptors stay the same.
// Memory and descriptors are sampled from /proc every 200 ms while the app runs. Warm-up is the
// sample at 10 % of the frame loop's wall time (about frame 1,000: atrium renders at a steady
// rate), the end is taken while the app holds its last frame (--hold), before anything is torn down.
//
// Label `soak`: scripts/test runs it with everything else; `ctest -L e2e -LE soak` skips it.
#include "agent.h"
#include "e2e_test.h"

#include <algorithm>
#include <regex>
#include <thread>

#include <dirent.h>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

constexpr int kFrames = 10000;
constexpr double kMaxRssGrowth = 0.05;

struct Sample {
    double t = 0;      // seconds since the app started
    long rss_kib = -1; // VmRSS; -1 when the process is gone
    int fds = -1;
};

long vm_rss_kib(int pid) {
    for (const auto &line : split_lines(read_file("/proc/" + std::to_string(pid) + "/status")))
        if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
    return -1;
}

int open_fds(int pid) {
    DIR *dir = ::opendir(("/proc/" + std::to_string(pid) + "/fd").c_str());
    if (!dir) return -1;
    int n = 0;
    while (const dirent *entry = ::readdir(dir))
        if (entry->d_name[0] != '.') ++n;
    ::closedir(dir);
    return n;
}

Sample sample(int pid, double t) {
    return {t, vm_rss_kib(pid), open_fds(pid)};
}

// The first sample at or after time t (the last one if none).
Sample at(const std::vector<Sample> &samples, double t) {
    for (const Sample &s : samples)
        if (s.t >= t && s.rss_kib > 0) return s;
    return samples.empty() ? Sample{} : samples.back();
}

// "session 1 (pid 1234) started" in the agent's log: the session's process.
int session_pid(const std::string &agent_log) {
    static const std::regex started(R"(session \d+ \(pid (\d+)\) started)");
    std::smatch m;
    if (std::regex_search(agent_log, m, started)) return std::stoi(m[1]);
    return -1;
}

class Soak : public XTest {};

TEST_F(Soak, TenThousandSplitFramesLoseNothingAndLeakNothing) {
    ASSERT_TRUE(built(explicit_layer_dir()));
    ASSERT_TRUE(built(atrium_path()));
    ASSERT_TRUE(built(agent_path()));
    // No --validate and no validation layer here: 10,000 frames under validation would cost many
    // minutes, and the short split suites run every split path under it already.
    Agent agent;
    ASSERT_TRUE(agent.start(env(), out_)) << agent.error();

    Env e = env();
    use_explicit_layers(e, {kLayerName});
    e["SPLITVK_SERVER"] = agent.address();
    e["SPLITVK_TILE_WAIT"] = "60000"; // a busy CI machine must not turn frames late: none may be
    e["SPLITVK_LOG_LEVEL"] = "info";
    // A floor and a box: a few draws per eye, each with its own texture.
    const auto model = source_dir() / "tests" / "data" / "floor_and_box.obj";
    ProcessSpec spec;
    spec.argv = {atrium_path().string(),
                 "--width",
                 "320",
                 "--height",
                 "144",
                 "--eyes",
                 "2",
                 "--frames",
                 std::to_string(kFrames),
                 "--present-mode",
                 "immediate",
                 "--model",
                 model.string(),
                 "--hold"};
    spec.env = e;
    spec.out_dir = out_;
    spec.name = "soak";
    Process app(spec);
    ASSERT_TRUE(app.start()) << app.error();
    const auto started = Clock::now();
    const auto since = [&] { return std::chrono::duration<double>(Clock::now() - started).count(); };

    // Sample both processes until the app holds its last frame.
    const std::string holding = "holding frame " + std::to_string(kFrames - 1);
    std::vector<Sample> app_samples, session_samples;
    double loop_start = -1; // when atrium's frame loop began
    int session = -1;
    const auto deadline = Clock::now() + 500s;
    bool held = false;
    while (Clock::now() < deadline && app.running()) {
        const double t = since();
        // atrium prints its "atrium: T triangles" line right before its frame loop.
        if (loop_start < 0 && read_file(out_ / "soak.stdout").find("atrium: ") != std::string::npos)
            loop_start = t;
        if (session < 0) session = session_pid(agent.log());
        app_samples.push_back(sample(app.pid(), t));
        if (session > 0) session_samples.push_back(sample(session, t));
        if (!grep(read_file(out_ / "soak.stdout"), holding).empty()) {
            held = true;
            break;
        }
        std::this_thread::sleep_for(200ms);
    }
    const double loop_end = since();
    // The end: the app holds its last frame, the session waits for the next; both at rest.
    std::this_thread::sleep_for(500ms);
    const Sample app_end = sample(app.pid(), since());
    const Sample session_end = sample(session, since());
    const ProcessResult r = app.terminate(30s);
    ASSERT_TRUE(held) << "the app did not reach frame " << kFrames - 1 << ": " << r.describe() << "\n"
                      << tail(r.err(), 30);
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err(), 30);
    ASSERT_GE(loop_start, 0) << "atrium never started its frame loop:\n" << tail(r.out(), 30);
    ASSERT_GT(session, 0) << "no session in the agent's log:\n" << tail(agent.log(), 30);

    // No frame lost, by three independent counts.
    const std::string out = r.out();
    const std::string err = r.err();
    const std::regex frame_time(R"(frame-time: median .* ms, IQR .* ms, (\d+) frames)");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(out, m, frame_time)) << "no frame-time line from atrium:\n" << out;
    EXPECT_EQ(std::stoull(m[1]), static_cast<unsigned long long>(kFrames)) << m[0];
    const std::regex summary(R"(\[splitvk\] split: (\d+) frames, .* (\d+) late)");
    ASSERT_TRUE(std::regex_search(err, m, summary)) << "no split summary line:\n" << tail(err, 30);
    EXPECT_EQ(std::stoull(m[1]), static_cast<unsigned long long>(kFrames)) << m[0];
    EXPECT_EQ(std::stoull(m[2]), 0ull) << m[0];
    EXPECT_TRUE(grep(err, "went away").empty()) << tail(err, 30);
    std::string agent_log = agent.log();
    const std::regex closed(R"(closed after \d+ messages, \d+ commands, \d+ submits, (\d+) frames)");
    const auto agent_deadline = Clock::now() + 30s;
    while (!std::regex_search(agent_log, m, closed) && Clock::now() < agent_deadline) {
        std::this_thread::sleep_for(100ms);
        agent_log = agent.log();
    }
    ASSERT_TRUE(std::regex_search(agent_log, m, closed)) << "the session did not close cleanly:\n"
                                                         << tail(agent_log, 30);
    EXPECT_EQ(std::stoull(m[1]), static_cast<unsigned long long>(kFrames)) << m[0];
    EXPECT_TRUE(grep(agent_log, "error:").empty()) << tail(agent_log, 30);

    // Nothing grows per frame.
    const double warm_t = loop_start + 0.1 * (loop_end - loop_start);
    const Sample app_warm = at(app_samples, warm_t);
    const Sample session_warm = at(session_samples, warm_t);
    const auto report = [](const char *who, const Sample &warm, const Sample &end) {
        std::cout << "  " << who << ": VmRSS " << warm.rss_kib << " KiB at warm-up (" << warm.t << " s), "
                  << end.rss_kib << " KiB at the end (" << end.t << " s), "
                  << 100.0 * double(end.rss_kib - warm.rss_kib) / double(warm.rss_kib) << " %; fds "
                  << warm.fds << " -> " << end.fds << "\n";
    };
    std::cout << "  " << kFrames << " frames in " << loop_end - loop_start << " s ("
              << 1000.0 * (loop_end - loop_start) / kFrames << " ms a frame), " << app_samples.size()
              << " samples\n";
    report("app", app_warm, app_end);
    report("agent session", session_warm, session_end);
    // Halfway, for the reader: a leak grows steadily, a warm-up effect levels off.
    const double mid_t = loop_start + 0.55 * (loop_end - loop_start);
    std::cout << "  halfway (" << mid_t << " s): app " << at(app_samples, mid_t).rss_kib
              << " KiB, agent session " << at(session_samples, mid_t).rss_kib << " KiB\n";
    RecordProperty("soak_s", std::to_string(loop_end - loop_start));
    RecordProperty("app_rss_warm_kib", std::to_string(app_warm.rss_kib));
    RecordProperty("app_rss_end_kib", std::to_string(app_end.rss_kib));
    RecordProperty("session_rss_warm_kib", std::to_string(session_warm.rss_kib));
    RecordProperty("session_rss_end_kib", std::to_string(session_end.rss_kib));
    for (const auto &[who, warm, end] :
         {std::tuple{"app", app_warm, app_end}, std::tuple{"agent session", session_warm, session_end}}) {
        ASSERT_GT(warm.rss_kib, 0) << who << " was not sampled at warm-up";
        ASSERT_GT(end.rss_kib, 0) << who << " was not sampled at the end";
        EXPECT_LT(double(end.rss_kib), double(warm.rss_kib) * (1 + kMaxRssGrowth))
            << who << "'s resident memory grew from " << warm.rss_kib << " KiB to " << end.rss_kib
            << " KiB between frame ~" << kFrames / 10 << " and frame " << kFrames;
        EXPECT_EQ(end.fds, warm.fds) << who << " has " << end.fds << " open descriptors at the end, "
                                     << warm.fds << " at warm-up";
    }
}

} // namespace
} // namespace splitvk::e2e
