"""Shared by every bench subcommand: the build tree, a private Xvfb, clean environments, running
splitvk-atrium and reading its `frame-time:` line."""
import contextlib
import os
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LAYER_NAME = "VK_LAYER_SPLITVK_split_render"
LAVAPIPE_ICD = "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json"

# `frame-time: median 12.34 ms, IQR 1.23 ms, 300 frames`
FRAME_TIME_RE = re.compile(
    r"^frame-time: median ([0-9.]+) ms, IQR ([0-9.]+) ms, ([0-9]+) frames\s*$", re.MULTILINE)


class BenchError(Exception):
    """Something failed to run."""


def ensure_packages():
    """Installs what scripts/common.sh's SPLITVK_PACKAGES lacks, as scripts/demo and scripts/test do
    (the bench imports and runs nothing outside that set). When it cannot (not root, no network)
    it says so and the bench goes on: what is missing is then reported where it is needed."""
    script = os.path.join(REPO, "scripts", "common.sh")
    r = subprocess.run(["bash", "-c", 'source "$1" && ensure_packages', "bash", script],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.stdout.strip():
        print(r.stdout.rstrip(), file=sys.stderr)
    if r.returncode != 0:
        print("bench: going on without the missing packages", file=sys.stderr)


class MissingBuild(Exception):
    """No usable build tree."""


class Build:
    def __init__(self, path):
        self.path = os.path.abspath(path)
        self.atrium = os.path.join(self.path, "bin", "splitvk-atrium")
        self.layer = os.path.join(self.path, "lib", "libVkLayer_splitvk.so")
        self.explicit_manifest_dir = os.path.join(self.path, "manifest", "explicit_layer.d")
        self.xr_manifest_dir = os.path.join(self.path, "manifest", "openxr")
        # Xvfb, the agent and screen grabs, as the e2e tests run them (tests/e2e/harness).
        self.harness = os.path.join(self.path, "bin", "splitvk-harness")

    def check(self):
        missing = [p for p in (self.atrium, self.layer, self.explicit_manifest_dir, self.harness)
                   if not os.path.exists(p)]
        if missing:
            raise MissingBuild(
                f"no splitvk build in {self.path} (missing {', '.join(missing)}); "
                "run scripts/test or scripts/demo first, or pass --build DIR")


def add_build_argument(parser):
    parser.add_argument("--build", default=os.path.join(REPO, "build"), metavar="DIR",
                        help="build tree to measure (default: %(default)s)")


def add_driver_argument(parser):
    parser.add_argument("--icd", default=LAVAPIPE_ICD, metavar="JSON|system",
                        help="Vulkan driver manifest to pin through VK_DRIVER_FILES, or 'system' for the "
                             "loader's own choice (default: lavapipe, %(default)s)")


def clean_env(icd):
    """The parent environment minus anything Vulkan- or splitvk-related that could change what is
    measured; the driver pinned unless icd == 'system'."""
    env = {}
    for k, v in os.environ.items():
        if k in ("VK_INSTANCE_LAYERS", "VK_DEVICE_LAYERS", "VK_ADD_LAYER_PATH", "VK_ICD_FILENAMES",
                 "VK_DRIVER_FILES", "VK_ADD_DRIVER_FILES"):
            continue
        if k.startswith(("VK_LAYER_", "VK_LOADER_", "SPLITVK_")):
            continue
        env[k] = v
    if icd != "system":
        env["VK_DRIVER_FILES"] = icd
    return env


def layer_env(env, build):
    """The layer from the build tree, forced to split (SPLITVK_SPLIT=always): a bench of the split
    measures the split, where the default would pass frames that it does not pay for through. Drop
    SPLITVK_SPLIT to measure what a user gets by default."""
    env = dict(env)
    env["VK_INSTANCE_LAYERS"] = LAYER_NAME
    env["VK_ADD_LAYER_PATH"] = build.explicit_manifest_dir
    env["SPLITVK_SPLIT"] = "always"
    return env


@contextlib.contextmanager
def harness_service(argv, env, what):
    """Runs a splitvk-harness service (`xvfb`, `agent`: tests/e2e/harness/harness_cli.cpp, the e2e
    tests' own code for it) while the block runs and yields its key=value report. It stops what it
    started when the block ends (SIGTERM), and on its own when this process dies."""
    proc = subprocess.Popen(argv, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        report = {}
        for line in proc.stdout:
            line = line.strip()
            if line == "ready":
                break
            key, _, value = line.partition("=")
            report[key] = value
        else:
            proc.wait()
            raise BenchError(f"{what} did not start:\n" + tail(proc.stderr.read()))
        yield report
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@contextlib.contextmanager
def display(build):
    """Yields the DISPLAY to use: the caller's, or a private Xvfb (splitvk-harness xvfb, which lets
    -displayfd pick a free display number) stopped afterwards."""
    if os.environ.get("DISPLAY"):
        yield os.environ["DISPLAY"]
        return
    if not shutil.which("Xvfb"):
        raise BenchError("DISPLAY is unset and Xvfb is not installed (apt-get install xvfb)")
    with tempfile.TemporaryDirectory(prefix="splitvk-bench-xvfb-") as logs, \
            harness_service([build.harness, "xvfb", "--out-dir", logs], os.environ, "Xvfb") as report:
        print(f"bench: started Xvfb on {report['display']}", file=sys.stderr)
        yield report["display"]


@contextlib.contextmanager
def started_agent(build, agent, env, out_dir, port=0, prefix=(), name="agent"):
    """Runs `prefix + agent --listen 127.0.0.1:port` (splitvk-harness agent: on a free port when 0, its
    log in out_dir/NAME.stderr, its TLS identity in agent_state_dir(out_dir), shared by every agent of
    the bench) while the block runs; yields the harness's report: address, pid, log."""
    argv = [build.harness, "agent", "--out-dir", out_dir, "--name", name, "--port", str(port)]
    for word in prefix:
        argv += ["--wrapper", word]
    argv += ["--", agent, "--state-dir", agent_state_dir(out_dir)]
    with harness_service(argv, env, "splitvk-agent") as report:
        yield report


def run_held(build, argv, env, frame, grab, width, height, out_dir, name, timeout_s):
    """Runs argv (an app with --hold) until it holds frame `frame`, grabs the top-left width x height
    of the screen into `grab` (a PNG), then ends it (splitvk-harness hold). Its output goes to
    out_dir/<name>.stdout and .stderr."""
    r = subprocess.run([build.harness, "hold", "--out-dir", out_dir, "--name", name, "--frame", str(frame),
                        "--grab", grab,
                        "--size", f"{width}x{height}", "--settle-ms", "500", "--timeout", str(timeout_s), "--"]
                       + argv, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       text=True)
    if r.returncode != 0:
        raise BenchError(f"{os.path.basename(argv[0])} --hold: " + tail(r.stderr))


class Run:
    def __init__(self, returncode, stdout, stderr, wall_s):
        self.returncode = returncode
        self.stdout = stdout
        self.stderr = stderr
        self.wall_s = wall_s

    def frame_time(self):
        """(median_ms, iqr_ms, frames) from the app's `frame-time:` line."""
        m = FRAME_TIME_RE.search(self.stdout)
        if not m:
            raise BenchError("no 'frame-time: median X ms, IQR Y ms, N frames' line in the output:\n"
                             + tail(self.stdout + self.stderr))
        return float(m.group(1)), float(m.group(2)), int(m.group(3))


def tail(text, lines=20):
    return "\n".join(text.splitlines()[-lines:])


def run(argv, env, timeout_s):
    """Runs argv to completion in its own process group; kills the group on timeout."""
    start = time.monotonic()
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            stdin=subprocess.DEVNULL, start_new_session=True, text=True)
    try:
        out, err = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        raise BenchError(f"{os.path.basename(argv[0])} ran past {timeout_s} s and was killed:\n" + tail(err))
    except BaseException:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        raise
    r = Run(proc.returncode, out, err, time.monotonic() - start)
    if r.returncode != 0:
        raise BenchError(f"{' '.join(argv)} exited with {r.returncode}:\n" + tail(out + err))
    return r


def agent_state_dir(out_dir):
    """Where a bench's splitvk-agent keeps its TLS identity (--state-dir): in the bench's own output
    folder, never the user's state directory."""
    return os.path.join(out_dir, "agent-state")


# `sha256:` and 64 hex digits, as splitvk-agent --print-fingerprint prints it
FINGERPRINT_RE = re.compile(r"\bsha256:[0-9a-f]{64}\b")


def tls_split_env(split_env, agent, out_dir, env):
    """split_env over TLS 1.3 (SPLITVK_TLS=on, also on loopback) to the agent whose identity is in
    agent_state_dir(out_dir), pinned by its fingerprint: a known_agents entry left by an earlier run
    at a reused port cannot refuse it. XDG_CONFIG_HOME points into out_dir so that the user's own
    ~/.config/splitvk/known_agents is neither read nor written."""
    state = agent_state_dir(out_dir)
    r = subprocess.run([agent, "--print-fingerprint", "--state-dir", state], env=env, stdin=subprocess.DEVNULL,
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=60)
    m = FINGERPRINT_RE.search(r.stdout)
    if r.returncode != 0 or not m:
        raise BenchError(f"{agent} --print-fingerprint --state-dir {state} failed:\n" + tail(r.stdout))
    return dict(split_env, SPLITVK_TLS="on", SPLITVK_AGENT_FINGERPRINT=m.group(0),
                XDG_CONFIG_HOME=os.path.join(out_dir, "tls-config"))


def check_tls_split(r):
    """Raises unless the run r (with tls_split_env) split over TLS 1.3."""
    if "running unsplit" in r.stderr or "[splitvk] split:" not in r.stderr or "TLS 1.3" not in r.stderr:
        raise BenchError("the TLS split run did not split over TLS 1.3:\n" + tail(r.stderr))


def layer_active_line(app_name):
    return f"[splitvk] info: {LAYER_NAME} active in '{app_name}'"


def quartiles(values):
    """(q1, median, q3) of a non-empty list."""
    values = sorted(values)
    if len(values) == 1:
        return values[0], values[0], values[0]
    q = statistics.quantiles(values, n=4, method="inclusive")
    return q[0], statistics.median(values), q[2]


def percentile(values, p):
    """The value at percentile p (0-100) of a non-empty list, interpolating between neighbours (as
    the layer's summary does)."""
    values = sorted(values)
    position = p / 100 * (len(values) - 1)
    below = int(position)
    above = min(below + 1, len(values) - 1)
    return values[below] + (values[above] - values[below]) * (position - below)
