// The session process's confinement (server-agent/confinement.h): the real confine_session() in a
// forked child, which then tries what a compromised session would.

#include "confinement.h"

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iterator>
#include <map>
#include <string>

#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/filter.h>
#include <linux/seccomp.h>
#include <netinet/in.h>
#include <pwd.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

namespace splitvk::agent {
namespace {

std::string make_dir(const char *name, mode_t mode) {
    std::string path = std::string("/tmp/splitvk-confinement-") + name + "-XXXXXX";
    if (!mkdtemp(path.data())) return {};
    chmod(path.c_str(), mode);
    return path;
}

void write_file(const std::string &path, const std::string &text) {
    std::ofstream(path) << text;
    chmod(path.c_str(), 0666);
}

// "ok" or the errno's name for one attempt.
std::string outcome(int rc) {
    if (rc >= 0) return "ok";
    return errno == EACCES ? "EACCES" : errno == EPERM ? "EPERM" : std::strerror(errno);
}

std::string try_open(const std::string &path, int flags) {
    const int fd = open(path.c_str(), flags | O_CLOEXEC, 0644);
    const std::string r = outcome(fd);
    if (fd >= 0) close(fd);
    return r;
}

// Runs `child` in a forked process that reports key=value lines; returns them.
template <class Child>
std::map<std::string, std::string> in_child(Child child) {
    int fds[2];
    if (pipe(fds) != 0) return {};
    const pid_t pid = fork();
    if (pid == 0) {
        close(fds[0]);
        std::string report;
        child([&](const std::string &key, const std::string &value) { report += key + "=" + value + "\n"; });
        (void)!write(fds[1], report.data(), report.size());
        _exit(0);
    }
    close(fds[1]);
    std::string text;
    char buffer[4096];
    ssize_t n;
    while ((n = read(fds[0], buffer, sizeof(buffer))) > 0)
        text.append(buffer, static_cast<size_t>(n));
    close(fds[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    std::map<std::string, std::string> result;
    size_t at = 0;
    while (at < text.size()) {
        const size_t eol = text.find('\n', at);
        const std::string line = text.substr(at, eol - at);
        const size_t eq = line.find('=');
        if (eq != std::string::npos) result[line.substr(0, eq)] = line.substr(eq + 1);
        at = eol == std::string::npos ? text.size() : eol + 1;
    }
    return result;
}

TEST(Confinement, SessionProcessCannotOpenOutsideTheAllowedSet) {
    // Files any user may read and write, so that only Landlock can refuse them: one outside the
    // allowed set, one in a folder the Vulkan loader is pointed at (read-only).
    const std::string outside = make_dir("outside", 0777);
    const std::string manifests = make_dir("manifests", 0755);
    ASSERT_FALSE(outside.empty() || manifests.empty());
    write_file(outside + "/secret", "not for sessions");
    write_file(manifests + "/layer.json", "{}");
    const int listener = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(bind(listener, reinterpret_cast<sockaddr *>(&addr), sizeof(addr)), 0);
    ASSERT_EQ(listen(listener, 4), 0);
    socklen_t len = sizeof(addr);
    getsockname(listener, reinterpret_cast<sockaddr *>(&addr), &len);

    setenv("VK_ADD_LAYER_PATH", manifests.c_str(), 1);
    std::string error;
    const auto plan = plan_confinement(AgentOptions{}, &error);
    ASSERT_TRUE(plan) << error;
    SessionDirectories dirs;
    ASSERT_TRUE(dirs.open(*plan, &error)) << error;
    const std::string session_dir = dirs.create(1, &error);
    ASSERT_FALSE(session_dir.empty()) << error;

    const auto r = in_child([&](auto report) {
        std::string why;
        if (!confine_session(*plan, session_dir, &why)) return report("confine", why);
        report("confine", "ok");
        report("no_new_privs", std::to_string(prctl(PR_GET_NO_NEW_PRIVS, 0, 0, 0, 0)));
        report("uid", std::to_string(getuid()));
        report("regain_root", getuid() == 0 ? "still root" : outcome(setuid(0)));
        report("tmpdir", std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "");
        report("outside_read", try_open(outside + "/secret", O_RDONLY));
        report("outside_create", try_open(outside + "/planted", O_WRONLY | O_CREAT));
        report("outside_mkdir", outcome(mkdir((outside + "/dir").c_str(), 0700)));
        report("private_create", try_open(session_dir + "/scratch", O_RDWR | O_CREAT));
        report("system_read", try_open("/etc/passwd", O_RDONLY));
        report("manifest_read", try_open(manifests + "/layer.json", O_RDONLY));
        report("manifest_write", try_open(manifests + "/layer.json", O_WRONLY));
        const int s = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
        report("tcp_connect", outcome(connect(s, reinterpret_cast<const sockaddr *>(&addr), sizeof(addr))));
        close(s);
    });
    unsetenv("VK_ADD_LAYER_PATH");
    close(listener);
    const bool planted = access((outside + "/planted").c_str(), F_OK) == 0;
    remove_tree(outside);
    remove_tree(manifests);
    dirs.release(1, session_dir);

    ASSERT_EQ(r.count("confine"), 1u) << "the child reported nothing";
    ASSERT_EQ(r.at("confine"), "ok");
    EXPECT_EQ(r.at("no_new_privs"), "1");
    if (geteuid() == 0) {
        const passwd *nobody = getpwnam("nobody");
        ASSERT_NE(nobody, nullptr);
        EXPECT_EQ(r.at("uid"), std::to_string(nobody->pw_uid));
        EXPECT_EQ(r.at("regain_root"), "EPERM");
    }
    EXPECT_EQ(r.at("tmpdir"), session_dir);
    // What a Vulkan driver needs stays open.
    EXPECT_EQ(r.at("private_create"), "ok");
    EXPECT_EQ(r.at("system_read"), "ok");
    EXPECT_EQ(r.at("manifest_read"), "ok");
    if (plan->landlock_abi == 0) {
        EXPECT_EQ(r.at("outside_read"), "ok"); // nothing else refuses it: the test's files are 0666
        GTEST_SKIP() << "this kernel has no Landlock (landlock_create_ruleset: no ABI version): no_new_privs "
                        "and the user drop were tested, the filesystem restriction was not";
    }
    EXPECT_EQ(r.at("outside_read"), "EACCES");
    EXPECT_EQ(r.at("outside_create"), "EACCES");
    EXPECT_EQ(r.at("outside_mkdir"), "EACCES");
    EXPECT_FALSE(planted);
    EXPECT_EQ(r.at("manifest_write"), "EACCES");
    if (plan->landlock_abi >= 4) {
        EXPECT_EQ(r.at("tcp_connect"), "EACCES");
    }
}

// A kernel without Landlock, as the agent sees one: landlock_create_ruleset fails with ENOSYS
// (a seccomp filter in the child says so). The listener says it once, and sessions go on with
// no_new_privs and the user drop.
TEST(Confinement, KernelWithoutLandlockIsSaidOnceAndSessionsGoOn) {
    const std::string outside = make_dir("nolandlock", 0777);
    ASSERT_FALSE(outside.empty());
    write_file(outside + "/file", "readable");
    const std::string log = outside + "/agent.log";
    // The session's directory, made by this process as a listener would (the child is dropped to
    // nobody and could not remove it from /tmp).
    std::string error;
    const auto listener_plan = plan_confinement(AgentOptions{}, &error);
    ASSERT_TRUE(listener_plan) << error;
    SessionDirectories dirs;
    ASSERT_TRUE(dirs.open(*listener_plan, &error)) << error;
    const std::string session_dir = dirs.create(1, &error);
    ASSERT_FALSE(session_dir.empty()) << error;
    const auto r = in_child([&](auto report) {
        sock_filter filter[] = {
            BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(seccomp_data, nr)),
            BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, SYS_landlock_create_ruleset, 0, 1),
            BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ERRNO | ENOSYS),
            BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ALLOW),
        };
        sock_fprog program{static_cast<unsigned short>(sizeof(filter) / sizeof(filter[0])), filter};
        if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 ||
            prctl(PR_SET_SECCOMP, SECCOMP_MODE_FILTER, &program) != 0)
            return report("seccomp", std::strerror(errno));
        if (!std::freopen(log.c_str(), "w", stderr)) return report("log", std::strerror(errno));
        std::string why;
        const auto plan = plan_confinement(AgentOptions{}, &why);
        std::fflush(stderr);
        if (!plan) return report("plan", why);
        report("abi", std::to_string(plan->landlock_abi));
        report("confine", confine_session(*plan, session_dir, &why) ? "ok" : why);
        report("no_new_privs", std::to_string(prctl(PR_GET_NO_NEW_PRIVS, 0, 0, 0, 0)));
        report("uid", std::to_string(getuid()));
        report("outside_read", try_open(outside + "/file", O_RDONLY));
    });
    std::ifstream in(log);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    remove_tree(outside);
    dirs.release(1, session_dir);
    ASSERT_EQ(r.count("abi"), 1u) << (r.empty() ? "the child reported nothing" : r.begin()->second);
    EXPECT_EQ(r.at("abi"), "0");
    EXPECT_EQ(r.at("confine"), "ok");
    EXPECT_EQ(r.at("no_new_privs"), "1");
    if (geteuid() == 0) {
        EXPECT_NE(r.at("uid"), "0");
    }
    EXPECT_EQ(r.at("outside_read"), "ok");
    const std::string line = "this kernel has no Landlock";
    ASSERT_NE(text.find(line), std::string::npos) << text;
    EXPECT_EQ(text.find(line, text.find(line) + 1), std::string::npos) << text;
    EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << text;
}

TEST(Confinement, NoConfineLeavesTheProcessAsItIs) {
    AgentOptions options;
    options.confine = false;
    std::string error;
    const auto plan = plan_confinement(options, &error);
    ASSERT_TRUE(plan) << error;
    const auto r = in_child([&](auto report) {
        std::string why;
        report("confine", confine_session(*plan, "/nonexistent", &why) ? "ok" : why);
        report("no_new_privs", std::to_string(prctl(PR_GET_NO_NEW_PRIVS, 0, 0, 0, 0)));
        report("uid", std::to_string(getuid()));
    });
    EXPECT_EQ(r.at("confine"), "ok");
    EXPECT_EQ(r.at("no_new_privs"), std::to_string(prctl(PR_GET_NO_NEW_PRIVS, 0, 0, 0, 0)));
    EXPECT_EQ(r.at("uid"), std::to_string(getuid()));
}

TEST(Confinement, UnknownUserIsOneLine) {
    if (geteuid() != 0) GTEST_SKIP() << "--user is resolved only when the agent runs as root";
    AgentOptions options;
    options.user = "splitvk-no-such-user";
    std::string error;
    EXPECT_FALSE(plan_confinement(options, &error));
    EXPECT_NE(error.find("--user splitvk-no-such-user: no such user"), std::string::npos) << error;
    EXPECT_EQ(error.find('\n'), std::string::npos);
}

TEST(Confinement, SessionDirectoriesArePrivateAndGoAway) {
    std::string error;
    const auto plan = plan_confinement(AgentOptions{}, &error);
    ASSERT_TRUE(plan) << error;
    std::string base;
    {
        SessionDirectories dirs;
        ASSERT_TRUE(dirs.open(*plan, &error)) << error;
        base = dirs.base();
        struct stat st {};
        ASSERT_EQ(stat(base.c_str(), &st), 0);
        EXPECT_EQ(st.st_mode & 07777, 0711u);
        const std::string dir = dirs.create(7, &error);
        ASSERT_FALSE(dir.empty()) << error;
        ASSERT_EQ(stat(dir.c_str(), &st), 0);
        EXPECT_EQ(st.st_mode & 07777, 0700u);
        if (plan->user) {
            EXPECT_EQ(st.st_uid, plan->user->uid);
        }
        write_file(dir + "/left-behind", "x");
        dirs.release(7, dir);
        EXPECT_NE(access(dir.c_str(), F_OK), 0);
        EXPECT_FALSE(dirs.create(8, &error).empty()) << error; // left for the destructor
    }
    EXPECT_NE(access(base.c_str(), F_OK), 0);
}

// A listener killed with SIGKILL cannot clean up; the next one to start removes what it left, and
// leaves alone the directory of a listener that still runs, however old.
TEST(Confinement, ADirectoryLeftByAKilledListenerIsRemovedByTheNext) {
    std::string error;
    const auto plan = plan_confinement(AgentOptions{}, &error);
    ASSERT_TRUE(plan) << error;
    int fds[2];
    ASSERT_EQ(pipe(fds), 0);
    const pid_t pid = fork();
    if (pid == 0) {
        SessionDirectories dirs;
        std::string why;
        if (dirs.open(*plan, &why) && !dirs.create(1, &why).empty())
            (void)!write(fds[1], dirs.base().data(), dirs.base().size());
        raise(SIGKILL);
    }
    close(fds[1]);
    char buffer[4096];
    const ssize_t n = read(fds[0], buffer, sizeof(buffer));
    close(fds[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status));
    ASSERT_GT(n, 0);
    const std::string killed(buffer, static_cast<size_t>(n));
    ASSERT_EQ(access((killed + "/s1").c_str(), F_OK), 0) << killed;

    SessionDirectories live;
    ASSERT_TRUE(live.open(*plan, &error)) << error;
    // Both over a minute old: younger, a directory may still be waiting for its listener's lock.
    const timespec old[2] = {{time(nullptr) - 120, 0}, {time(nullptr) - 120, 0}};
    ASSERT_EQ(utimensat(AT_FDCWD, killed.c_str(), old, 0), 0);
    ASSERT_EQ(utimensat(AT_FDCWD, live.base().c_str(), old, 0), 0);
    {
        SessionDirectories next;
        ASSERT_TRUE(next.open(*plan, &error)) << error;
    }
    EXPECT_NE(access(killed.c_str(), F_OK), 0) << killed << " is still there";
    EXPECT_EQ(access(live.base().c_str(), F_OK), 0) << "the live listener's directory was removed";
}

TEST(Confinement, RemoveTreeNeverFollowsALink) {
    // What a session leaves in its directory is its user's to shape: links out of it must be
    // removed, not followed, by the listener that cleans up after it.
    const std::string outside = make_dir("kept", 0755);
    const std::string tree = make_dir("tree", 0755);
    ASSERT_FALSE(outside.empty() || tree.empty());
    write_file(outside + "/precious", "keep me");
    ASSERT_EQ(mkdir((tree + "/sub").c_str(), 0700), 0);
    write_file(tree + "/sub/file", "x");
    ASSERT_EQ(symlink(outside.c_str(), (tree + "/link-to-dir").c_str()), 0);
    ASSERT_EQ(symlink((outside + "/precious").c_str(), (tree + "/sub/link-to-file").c_str()), 0);
    EXPECT_TRUE(remove_tree(tree));
    EXPECT_NE(access(tree.c_str(), F_OK), 0);
    EXPECT_EQ(access((outside + "/precious").c_str(), F_OK), 0);
    EXPECT_TRUE(remove_tree(outside));
    EXPECT_TRUE(remove_tree(tree)); // already gone: nothing to do
}

} // namespace
} // namespace splitvk::agent
