#pragma once

// The session process's confinement (docs/security.md, "The session process"). A session decodes
// untrusted input and hands it to the GPU driver, so before it reads its first message it:
//   1. sets no_new_privs (and stays non-dumpable, so sessions of the same user cannot ptrace or
//      read one another);
//   2. drops from root to --user (default nobody), with the groups of the GPU device files;
//   3. restricts its filesystem to what a Vulkan driver needs with Landlock: system paths and the
//      Vulkan loader's manifests read-only, the GPU device files read-write, and a private
//      directory of its own (TMPDIR and the shader caches) read-write; where the kernel's Landlock
//      ABI has them, no TCP bind/connect and no signals or abstract sockets outside the session.
// The listener plans this once (and says once if the kernel has no Landlock); each forked session
// applies it.

#include "agent_options.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <sys/types.h>

namespace splitvk::agent {

struct SessionUser {
    std::string name;
    uid_t uid = 0;
    gid_t gid = 0;
    std::vector<gid_t> groups; // supplementary: the user's own and the GPU device files' groups
};

struct ConfinementPlan {
    bool enabled = true;             // false: --no-confine
    std::optional<SessionUser> user; // set when the agent runs as root
    int landlock_abi = 0;            // 0: the kernel has no Landlock
    std::string corpus_dir;          // --record-corpus: copied out of each session's directory
};

// The kernel's Landlock ABI version, 0 when it has none (or it is disabled).
int landlock_abi_version();

// Resolves --user (only when running as root) and probes Landlock; logs one line that says how
// sessions will run. nullopt with `error` set when --user cannot be used.
std::optional<ConfinementPlan> plan_confinement(const AgentOptions &options, std::string *error);

// In the forked session process, before it reads anything from its client: sets the cache
// variables to `session_dir`, then no_new_privs, the user, Landlock. Any step failing (but
// Landlock missing from the kernel, which the plan knows) returns false with `error` set: the
// session must not go on.
bool confine_session(const ConfinementPlan &plan, const std::string &session_dir, std::string *error);

// The paths Landlock lets a session read (only), for the docs and the tests: system paths,
// /sys, parts of /proc, and the directories the Vulkan loader's variables name.
std::vector<std::string> read_only_paths();

// Per-session private directories under one directory of the listener's (mode 0711: sessions reach
// their own, and list none). Each is created before the fork, owned by the session's user, and
// removed by the listener once the session's process is gone, whatever it left there. The
// listener's directory goes when it exits; one that a killed listener left behind, the next
// listener to start removes.
class SessionDirectories {
public:
    SessionDirectories() = default;
    SessionDirectories(const SessionDirectories &) = delete;
    SessionDirectories &operator=(const SessionDirectories &) = delete;
    ~SessionDirectories();

    bool open(const ConfinementPlan &plan, std::string *error);
    const std::string &base() const { return base_; }
    // "" with `error` set on failure.
    std::string create(uint64_t session_id, std::string *error);
    // Copies the --record-corpus files out (when the plan records) and removes the directory.
    void release(uint64_t session_id, const std::string &dir);
    // In a forked session: lets go of the listener's directory without touching it.
    void close_in_session();

private:
    const ConfinementPlan *plan_ = nullptr;
    std::string base_;
    int lock_ = -1; // flock held on base_ while the listener lives
};

// Removes `path` and everything under it without following a symbolic link anywhere (a session's
// user owns what is inside). False if something could not be removed.
bool remove_tree(const std::string &path);

} // namespace splitvk::agent
