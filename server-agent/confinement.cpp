#include "confinement.h"

#include "log.h"

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <ctime>

#include <dirent.h>
#include <fcntl.h>
#include <grp.h>
#include <linux/landlock.h>
#include <pwd.h>
#include <sys/file.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

// Debian 12's headers describe Landlock ABI 2; the later rights are defined here with the values
// of the kernel's uapi, and used only where the running kernel's ABI has them.
#ifndef LANDLOCK_ACCESS_FS_TRUNCATE
#define LANDLOCK_ACCESS_FS_TRUNCATE (1ULL << 14) // ABI 3
#endif
#ifndef LANDLOCK_ACCESS_FS_IOCTL_DEV
#define LANDLOCK_ACCESS_FS_IOCTL_DEV (1ULL << 15) // ABI 5
#endif
#ifndef LANDLOCK_ACCESS_NET_BIND_TCP
#define LANDLOCK_ACCESS_NET_BIND_TCP (1ULL << 0) // ABI 4
#define LANDLOCK_ACCESS_NET_CONNECT_TCP (1ULL << 1)
#endif
#ifndef LANDLOCK_SCOPE_ABSTRACT_UNIX_SOCKET
#define LANDLOCK_SCOPE_ABSTRACT_UNIX_SOCKET (1ULL << 0) // ABI 6
#define LANDLOCK_SCOPE_SIGNAL (1ULL << 1)
#endif

namespace splitvk::agent {
namespace {

// struct landlock_ruleset_attr as of ABI 6. The kernel takes a larger struct than it knows as long
// as the fields it does not know are zero, so this one works on every ABI.
struct RulesetAttr {
    uint64_t handled_access_fs = 0;
    uint64_t handled_access_net = 0;
    uint64_t scoped = 0;
};

constexpr uint64_t kRead = LANDLOCK_ACCESS_FS_READ_FILE | LANDLOCK_ACCESS_FS_READ_DIR;
// The session's own directory: files and directories made, written, renamed and removed; no
// devices, sockets or fifos, nothing executed.
constexpr uint64_t kPrivate = kRead | LANDLOCK_ACCESS_FS_WRITE_FILE | LANDLOCK_ACCESS_FS_REMOVE_DIR |
                              LANDLOCK_ACCESS_FS_REMOVE_FILE | LANDLOCK_ACCESS_FS_MAKE_DIR |
                              LANDLOCK_ACCESS_FS_MAKE_REG | LANDLOCK_ACCESS_FS_MAKE_SYM |
                              LANDLOCK_ACCESS_FS_REFER | LANDLOCK_ACCESS_FS_TRUNCATE;
// GPU device files: opened read-write and driven by ioctl.
constexpr uint64_t kDevice = kRead | LANDLOCK_ACCESS_FS_WRITE_FILE | LANDLOCK_ACCESS_FS_IOCTL_DEV;
// The rights that mean something on a file (the kernel refuses the others on a file's rule).
constexpr uint64_t kFileRights = LANDLOCK_ACCESS_FS_EXECUTE | LANDLOCK_ACCESS_FS_WRITE_FILE |
                                 LANDLOCK_ACCESS_FS_READ_FILE | LANDLOCK_ACCESS_FS_TRUNCATE |
                                 LANDLOCK_ACCESS_FS_IOCTL_DEV;

uint64_t handled_fs(int abi) {
    uint64_t rights = (LANDLOCK_ACCESS_FS_MAKE_SYM << 1) - 1; // ABI 1: EXECUTE .. MAKE_SYM
    if (abi >= 2) rights |= LANDLOCK_ACCESS_FS_REFER;
    if (abi >= 3) rights |= LANDLOCK_ACCESS_FS_TRUNCATE;
    if (abi >= 5) rights |= LANDLOCK_ACCESS_FS_IOCTL_DEV;
    return rights;
}

std::string errno_text(const std::string &what) {
    return what + ": " + std::strerror(errno);
}

// The GPU device files a session opens: DRM render nodes (Mesa), NVIDIA's /dev/nvidia*.
std::vector<std::string> gpu_device_paths() {
    std::vector<std::string> paths;
    if (DIR *dir = opendir("/dev")) {
        while (const dirent *e = readdir(dir)) {
            if (std::strncmp(e->d_name, "nvidia", 6) == 0) paths.push_back(std::string("/dev/") + e->d_name);
        }
        closedir(dir);
    }
    std::sort(paths.begin(), paths.end());
    paths.insert(paths.begin(), "/dev/dri");
    return paths;
}

// The groups that own the GPU device files, root's excepted: a render node is typically
// root:render 0660, and the session's user needs that group to reach the GPU at all. Of /dev/dri
// only the render nodes count: the card nodes (display, mode setting) need no more than rendering.
std::vector<gid_t> gpu_device_groups() {
    std::vector<std::string> nodes = gpu_device_paths();
    nodes.erase(nodes.begin()); // /dev/dri
    if (DIR *dir = opendir("/dev/dri")) {
        while (const dirent *e = readdir(dir)) {
            if (std::strncmp(e->d_name, "renderD", 7) == 0)
                nodes.push_back(std::string("/dev/dri/") + e->d_name);
        }
        closedir(dir);
    }
    std::vector<gid_t> groups;
    for (const auto &node : nodes) {
        struct stat st {};
        if (stat(node.c_str(), &st) == 0 && S_ISCHR(st.st_mode) && st.st_gid != 0 &&
            std::find(groups.begin(), groups.end(), st.st_gid) == groups.end())
            groups.push_back(st.st_gid);
    }
    return groups;
}

std::optional<SessionUser> resolve_user(const std::string &name, std::string *error) {
    std::vector<char> buffer(16384);
    passwd pw{};
    passwd *found = nullptr;
    const int rc = getpwnam_r(name.c_str(), &pw, buffer.data(), buffer.size(), &found);
    if (rc != 0 || !found) {
        *error =
            "--user " + name + ": no such user" + (rc ? std::string(" (") + std::strerror(rc) + ")" : "");
        return std::nullopt;
    }
    if (pw.pw_uid == 0) {
        *error = "--user " + name + " has uid 0: sessions must run as an unprivileged user";
        return std::nullopt;
    }
    SessionUser user;
    user.name = name;
    user.uid = pw.pw_uid;
    user.gid = pw.pw_gid;
    int count = 64;
    user.groups.resize(static_cast<size_t>(count));
    if (getgrouplist(name.c_str(), pw.pw_gid, user.groups.data(), &count) < 0) {
        user.groups.resize(static_cast<size_t>(count));
        getgrouplist(name.c_str(), pw.pw_gid, user.groups.data(), &count);
    }
    user.groups.resize(static_cast<size_t>(std::max(count, 0)));
    for (gid_t g : gpu_device_groups())
        if (std::find(user.groups.begin(), user.groups.end(), g) == user.groups.end())
            user.groups.push_back(g);
    // Never root's group, whatever the group database says.
    user.groups.erase(std::remove(user.groups.begin(), user.groups.end(), gid_t{0}), user.groups.end());
    if (user.gid == 0) {
        *error = "--user " + name + " has group 0: sessions must run as an unprivileged user";
        return std::nullopt;
    }
    return user;
}

void add_env_paths(const char *variable, const char *suffix, std::vector<std::string> &paths) {
    const char *value = std::getenv(variable);
    if (!value) return;
    std::string list = value;
    size_t start = 0;
    while (start <= list.size()) {
        const size_t end = std::min(list.find(':', start), list.size());
        const std::string entry = list.substr(start, end - start);
        start = end + 1;
        if (entry.empty() || entry[0] != '/') continue;
        paths.push_back(entry + suffix);
        // A manifest's library_path is usually relative to the manifest's folder.
        struct stat st {};
        if (!*suffix && stat(entry.c_str(), &st) == 0 && !S_ISDIR(st.st_mode))
            paths.push_back(entry.substr(0, entry.rfind('/')));
    }
}

// One rule. A path that does not exist is skipped (the lists name what a system may have), and so
// is one the session's user cannot reach anyway.
bool add_rule(int ruleset, const std::string &path, uint64_t access, uint64_t handled, std::string *error) {
    const int fd = open(path.c_str(), O_PATH | O_CLOEXEC);
    if (fd < 0) return errno == ENOENT || errno == ENOTDIR || errno == EACCES;
    struct stat st {};
    if (fstat(fd, &st) != 0) {
        close(fd);
        return true;
    }
    landlock_path_beneath_attr rule{};
    rule.allowed_access = access & handled & (S_ISDIR(st.st_mode) ? ~uint64_t{0} : kFileRights);
    rule.parent_fd = fd;
    const long rc = syscall(SYS_landlock_add_rule, ruleset, LANDLOCK_RULE_PATH_BENEATH, &rule, 0);
    const int saved = errno;
    close(fd);
    if (rc != 0) {
        errno = saved;
        *error = errno_text("landlock_add_rule " + path);
        return false;
    }
    return true;
}

bool restrict_filesystem(int abi, const std::string &session_dir, std::string *error) {
    RulesetAttr attr;
    attr.handled_access_fs = handled_fs(abi);
    // No rule allows a TCP bind or connect: the session talks only over the socket it inherited.
    if (abi >= 4) attr.handled_access_net = LANDLOCK_ACCESS_NET_BIND_TCP | LANDLOCK_ACCESS_NET_CONNECT_TCP;
    if (abi >= 6) attr.scoped = LANDLOCK_SCOPE_ABSTRACT_UNIX_SOCKET | LANDLOCK_SCOPE_SIGNAL;
    const int ruleset = static_cast<int>(syscall(SYS_landlock_create_ruleset, &attr, sizeof(attr), 0));
    if (ruleset < 0) {
        *error = errno_text("landlock_create_ruleset");
        return false;
    }
    bool ok = true;
    for (const auto &path : read_only_paths())
        ok = ok && add_rule(ruleset, path, kRead, attr.handled_access_fs, error);
    for (const auto &path : gpu_device_paths())
        ok = ok && add_rule(ruleset, path, kDevice, attr.handled_access_fs, error);
    for (const char *path : {"/dev/null", "/dev/zero", "/dev/full"})
        ok = ok &&
             add_rule(ruleset, path, kRead | LANDLOCK_ACCESS_FS_WRITE_FILE, attr.handled_access_fs, error);
    for (const char *path : {"/dev/urandom", "/dev/random"})
        ok = ok && add_rule(ruleset, path, kRead, attr.handled_access_fs, error);
    ok = ok && add_rule(ruleset, session_dir, kPrivate, attr.handled_access_fs, error);
    if (ok && syscall(SYS_landlock_restrict_self, ruleset, 0) != 0) {
        *error = errno_text("landlock_restrict_self");
        ok = false;
    }
    close(ruleset);
    return ok;
}

bool drop_user(const SessionUser &user, std::string *error) {
    // Groups first, while still root: after setuid the process could no longer change them.
    if (setgroups(user.groups.size(), user.groups.data()) != 0)
        return *error = errno_text("setgroups"), false;
    if (setresgid(user.gid, user.gid, user.gid) != 0) return *error = errno_text("setresgid"), false;
    if (setresuid(user.uid, user.uid, user.uid) != 0) return *error = errno_text("setresuid"), false;
    uid_t ru, eu, su;
    gid_t rg, eg, sg;
    if (getresuid(&ru, &eu, &su) != 0 || getresgid(&rg, &eg, &sg) != 0 || ru != user.uid || eu != user.uid ||
        su != user.uid || rg != user.gid || eg != user.gid || sg != user.gid) {
        *error = "the user and group did not change to " + user.name;
        return false;
    }
    if (setuid(0) == 0 || setgid(0) == 0) {
        *error = "root could be regained after dropping to " + user.name;
        return false;
    }
    return true;
}

// Directory entries of `dir_fd`, "." and ".." left out. getdents64 into a buffer on the stack
// rather than opendir's heap buffer: the listener runs this for every session it cleans up after.
std::vector<std::string> entries(int dir_fd) {
    std::vector<std::string> names;
    alignas(dirent64) char buffer[8192];
    ssize_t n;
    while ((n = getdents64(dir_fd, buffer, sizeof(buffer))) > 0) {
        for (ssize_t at = 0; at < n;) {
            const auto *e = reinterpret_cast<const dirent64 *>(buffer + at);
            at += e->d_reclen;
            if (std::strcmp(e->d_name, ".") != 0 && std::strcmp(e->d_name, "..") != 0)
                names.emplace_back(e->d_name);
        }
    }
    return names;
}

bool remove_at(int parent, const std::string &name, int depth) {
    const int fd = openat(parent, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) {
        if (errno == ENOENT) return true;
        // A file, a symbolic link (ELOOP), a device: unlinked, never followed.
        if (errno == ENOTDIR || errno == ELOOP)
            return unlinkat(parent, name.c_str(), 0) == 0 || errno == ENOENT;
        return false;
    }
    bool ok = depth < 64;
    if (ok) {
        for (const auto &entry : entries(fd))
            ok = remove_at(fd, entry, depth + 1) && ok;
    }
    close(fd);
    return ok && (unlinkat(parent, name.c_str(), AT_REMOVEDIR) == 0 || errno == ENOENT);
}

// --record-corpus files a session wrote into its directory (s<session>-*), copied into `to` by the
// listener: regular files only, of the recorder's sizes, never through a link.
void copy_corpus(const std::string &dir, uint64_t session_id, const std::string &to) {
    const int from = open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (from < 0) return;
    std::string prefix = std::to_string(session_id);
    prefix.insert(0, 1, 's');
    prefix += '-';
    size_t copied = 0;
    for (const auto &name : entries(from)) {
        if (name.rfind(prefix, 0) != 0 || copied >= 1024) continue;
        const int in = openat(from, name.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
        if (in < 0) continue;
        struct stat st {};
        if (fstat(in, &st) == 0 && S_ISREG(st.st_mode) && st.st_nlink == 1 && st.st_size <= (16 << 20)) {
            const std::string target = to + "/" + name;
            const int out = open(target.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0644);
            if (out >= 0) {
                char buffer[65536];
                ssize_t n;
                bool ok = true;
                while (ok && (n = read(in, buffer, sizeof(buffer))) > 0)
                    ok = write(out, buffer, static_cast<size_t>(n)) == n;
                close(out);
                if (!ok) SPLITVK_WARN("--record-corpus: cannot write %s", target.c_str());
                ++copied;
            } else {
                SPLITVK_WARN("--record-corpus: cannot write %s: %s", target.c_str(), std::strerror(errno));
            }
        }
        close(in);
    }
    close(from);
}

} // namespace

int landlock_abi_version() {
    const long abi = syscall(SYS_landlock_create_ruleset, nullptr, 0, LANDLOCK_CREATE_RULESET_VERSION);
    return abi > 0 ? static_cast<int>(abi) : 0;
}

std::vector<std::string> read_only_paths() {
    // The loader, the drivers and their libraries, the dynamic linker's cache, drirc and the
    // loader's system manifests (/etc/vulkan, /usr/share/vulkan); /sys for device enumeration
    // (libdrm, the loader's PCI sorting); of /proc what drivers and the C library read about this
    // process and the machine, not other processes.
    std::vector<std::string> paths = {"/usr",          "/etc",          "/lib",          "/lib32",
                                      "/lib64",        "/libx32",       "/opt",          "/sys",
                                      "/proc/self",    "/proc/cpuinfo", "/proc/meminfo", "/proc/stat",
                                      "/proc/devices", "/proc/sys",     "/proc/driver"};
    // What the loader is pointed at instead of, or besides, the system manifests (VK_DRIVER_FILES
    // and VK_ICD_FILENAMES name manifest files or folders, the layer variables folders,
    // VK_LAYER_SETTINGS_PATH vk_layer_settings.txt or its folder).
    for (const char *variable :
         {"VK_DRIVER_FILES", "VK_ICD_FILENAMES", "VK_ADD_DRIVER_FILES", "VK_LAYER_PATH", "VK_ADD_LAYER_PATH",
          "VK_IMPLICIT_LAYER_PATH", "VK_ADD_IMPLICIT_LAYER_PATH", "VK_LAYER_SETTINGS_PATH"})
        add_env_paths(variable, "", paths);
    for (const char *variable : {"XDG_DATA_DIRS", "XDG_CONFIG_DIRS"})
        add_env_paths(variable, "/vulkan", paths);
    // A driver the loader opens after the confinement is searched for along LD_LIBRARY_PATH as
    // well: an agent run from a bundle outside /usr (scripts/device-check) keeps its libraries
    // there, a manifest's relative library_path included.
    add_env_paths("LD_LIBRARY_PATH", "", paths);
    return paths;
}

std::optional<ConfinementPlan> plan_confinement(const AgentOptions &options, std::string *error) {
    ConfinementPlan plan;
    plan.enabled = options.confine;
    plan.corpus_dir = options.record_corpus;
    const bool root = geteuid() == 0;
    if (!plan.enabled) {
        SPLITVK_WARN("--no-confine: sessions run with the agent's rights (%s), without no_new_privs or "
                     "Landlock; for debugging only",
                     root ? "root" : "its user");
        return plan;
    }
    if (root) {
        plan.user = resolve_user(options.user, error);
        if (!plan.user) return std::nullopt;
    } else if (options.user_given) {
        passwd *self = getpwuid(geteuid());
        if (!self || options.user != self->pw_name) {
            *error = "--user " + options.user + ": the agent runs as " +
                     (self ? self->pw_name : "another user") +
                     ", and only root can switch sessions to another user";
            return std::nullopt;
        }
    }
    plan.landlock_abi = landlock_abi_version();
    std::string who = plan.user ? "user " + plan.user->name + " (uid " + std::to_string(plan.user->uid) + ")"
                                : "the agent's user";
    if (plan.landlock_abi > 0) {
        SPLITVK_INFO("sessions run confined: no_new_privs, %s, Landlock ABI %d", who.c_str(),
                     plan.landlock_abi);
    } else {
        SPLITVK_WARN("this kernel has no Landlock (or it is disabled): sessions run with no_new_privs as %s, "
                     "but their filesystem access is not restricted",
                     who.c_str());
    }
    return plan;
}

bool confine_session(const ConfinementPlan &plan, const std::string &session_dir, std::string *error) {
    if (!plan.enabled) return true;
    // The drivers' caches and temporary files go to the private directory, which dies with the
    // session: no cache shared between sessions, so none can plant a compiled shader for another.
    const std::string cache = session_dir + "/cache";
    setenv("TMPDIR", session_dir.c_str(), 1);
    setenv("XDG_CACHE_HOME", cache.c_str(), 1);
    setenv("MESA_SHADER_CACHE_DIR", (cache + "/mesa").c_str(), 1);
    setenv("__GL_SHADER_DISK_CACHE_PATH", (cache + "/nvidia").c_str(), 1);
    if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 || prctl(PR_GET_NO_NEW_PRIVS, 0, 0, 0, 0) != 1)
        return *error = errno_text("prctl(PR_SET_NO_NEW_PRIVS)"), false;
    if (plan.user && !drop_user(*plan.user, error)) return false;
    // Made as the session's user; the drivers make only the last part of a cache path.
    if (mkdir(cache.c_str(), 0700) != 0 && errno != EEXIST)
        return *error = errno_text("mkdir " + cache), false;
    // Not dumpable: another session of the same user can neither ptrace this one nor read its
    // memory through /proc, with or without Landlock (which also forbids it across sessions).
    if (prctl(PR_SET_DUMPABLE, 0, 0, 0, 0) != 0) return *error = errno_text("prctl(PR_SET_DUMPABLE)"), false;
    if (plan.landlock_abi > 0 && !restrict_filesystem(plan.landlock_abi, session_dir, error)) return false;
    return true;
}

namespace {

constexpr char kBasePrefix[] = "splitvk-agent-";

// Removes the directories of listeners that died without cleaning up (SIGKILL, a crash): a live
// listener holds an flock on its directory, which the kernel drops with the process, whichever
// way it ends. A directory younger than a minute is left alone: its listener may not have locked
// it yet.
void sweep_stale(const std::string &tmp) {
    const int dir = ::open(tmp.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dir < 0) return;
    const time_t now = time(nullptr);
    for (const auto &name : entries(dir)) {
        if (name.rfind(kBasePrefix, 0) != 0 || name.size() != sizeof(kBasePrefix) - 1 + 6) continue;
        const int fd = openat(dir, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
        if (fd < 0) continue;
        struct stat st {};
        if (fstat(fd, &st) == 0 && st.st_uid == geteuid() && (st.st_mode & 07777) == 0711 &&
            st.st_mtime < now - 60 && flock(fd, LOCK_EX | LOCK_NB) == 0)
            remove_at(dir, name, 0);
        close(fd);
    }
    close(dir);
}

} // namespace

SessionDirectories::~SessionDirectories() {
    if (!base_.empty()) remove_tree(base_);
    if (lock_ >= 0) close(lock_);
}

bool SessionDirectories::open(const ConfinementPlan &plan, std::string *error) {
    plan_ = &plan;
    const char *tmp_env = std::getenv("TMPDIR");
    const std::string tmp = tmp_env && *tmp_env == '/' ? tmp_env : "/tmp";
    sweep_stale(tmp);
    std::string pattern = tmp + "/" + kBasePrefix + "XXXXXX";
    if (!mkdtemp(pattern.data())) return *error = errno_text("cannot create " + pattern), false;
    base_ = pattern;
    // Sessions of another user must pass through to their own directory, and list nothing.
    if (chmod(base_.c_str(), 0711) != 0) return *error = errno_text("chmod " + base_), false;
    lock_ = ::open(base_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (lock_ < 0 || flock(lock_, LOCK_EX | LOCK_NB) != 0)
        return *error = errno_text("flock " + base_), false;
    return true;
}

void SessionDirectories::close_in_session() {
    // The session must neither remove the listener's directory at exit nor be able to unlock it.
    if (lock_ >= 0) close(lock_);
    lock_ = -1;
    base_.clear();
}

std::string SessionDirectories::create(uint64_t session_id, std::string *error) {
    const std::string dir = base_ + "/s" + std::to_string(session_id);
    if (mkdir(dir.c_str(), 0700) != 0) return *error = errno_text("cannot create " + dir), "";
    if (plan_->user && chown(dir.c_str(), plan_->user->uid, plan_->user->gid) != 0) {
        *error = errno_text("chown " + dir);
        rmdir(dir.c_str());
        return "";
    }
    return dir;
}

void SessionDirectories::release(uint64_t session_id, const std::string &dir) {
    if (dir.empty()) return;
    if (!plan_->corpus_dir.empty()) copy_corpus(dir, session_id, plan_->corpus_dir);
    if (!remove_tree(dir))
        SPLITVK_WARN("session %llu: cannot remove %s entirely", (unsigned long long)session_id, dir.c_str());
}

bool remove_tree(const std::string &path) {
    const size_t slash = path.rfind('/');
    if (slash == std::string::npos || slash + 1 == path.size()) return false;
    const std::string parent = slash == 0 ? "/" : path.substr(0, slash);
    const int fd = open(parent.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return errno == ENOENT;
    const bool ok = remove_at(fd, path.substr(slash + 1), 0);
    close(fd);
    return ok;
}

} // namespace splitvk::agent
