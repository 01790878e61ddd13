"""splitvk-link for benchmarks: an emulated LAN link between the layer and splitvk-agent.

build/bin/splitvk-link is a TCP proxy that gives each direction of each connection a serialising
link, a rate and a one-way delay (docs/measuring.md). This module starts it for the length of a
`with` block, between a free loopback port and the agent's, and reads back its per-connection log:

    from . import common, link

    with link.Link(build, agent_port=port, profile="wifi5") as net:
        env = dict(layered, SPLITVK_SERVER=net.address)   # the layer dials the link, not the agent
        r = common.run(argv, env, timeout_s)
    for c in net.connections():                        # after the block: complete
        print(c["id"], c["up_bytes"], c["down_bytes"], c["seconds"])

Profiles: gige (940 Mbit/s, 0.2 ms), wifi5 (400 Mbit/s, 2 ms; the paper's client link), wifi6
(800 Mbit/s, 1.5 ms), none (forwarding only: measures the proxy itself). Instead of a profile,
rate="400M" and/or delay="2ms" (both directions), as the command line takes them. cpus="1" runs
the proxy under `taskset -c 1`: give it the agent's cores, since a real network costs the weak
client nothing but its own socket calls.

Not a subcommand itself: `scripts/bench paper` (to come) uses it. A subcommand that wants a
`--link` option calls add_argument(parser) in its register() and wraps its runs in
`with link.Link(build, agent_port, profile=args.link)`; "direct" there means no proxy at all
(link.maybe(...) returns a context that yields None for it).
"""
import contextlib
import os
import re
import select
import signal
import subprocess
import threading
import time

from . import common

PROFILES = ("gige", "wifi5", "wifi6", "none")

LISTENING_RE = re.compile(r"listening on 127\.0\.0\.1:(\d+)")
# `[splitvk-link] info: connection 2: closed after 1.234 s: 10 bytes up, 20 bytes down (up closed, down closed)`
CLOSED_RE = re.compile(r"connection (\d+): closed after ([\d.]+) s: (\d+) bytes up, (\d+) bytes down "
                       r"\(up (\w+), down (\w+)\)")


def add_argument(parser, default="wifi5"):
    """Adds --link PROFILE|direct to a bench subcommand's parser."""
    parser.add_argument("--link", choices=PROFILES + ("direct",), default=default,
                        help="emulated network between the layer and the agent (splitvk-link profile), or "
                             "'direct' for plain loopback (default: %(default)s)")


class Link:
    """splitvk-link running between 127.0.0.1:<a free port> and agent_host:agent_port."""

    def __init__(self, build, agent_port, profile=None, rate=None, delay=None, agent_host="127.0.0.1",
                 cpus=None, env=None):
        if profile is None and rate is None and delay is None:
            raise ValueError("Link needs a profile, or a rate and/or a delay")
        if profile is not None and profile not in PROFILES:
            raise ValueError(f"unknown link profile {profile!r}; expected one of {', '.join(PROFILES)}")
        path = build.path if isinstance(build, common.Build) else os.path.abspath(build)
        self.binary = os.path.join(path, "bin", "splitvk-link")
        self.argv = [self.binary, "--listen", "127.0.0.1:0", "--connect", f"{agent_host}:{agent_port}"]
        if profile is not None:
            self.argv += ["--profile", profile]
        if rate is not None:
            self.argv += ["--rate", str(rate)]
        if delay is not None:
            self.argv += ["--delay", str(delay)]
        if cpus is not None:
            self.argv = ["taskset", "-c", str(cpus)] + self.argv
        self.env = env
        self.port = None
        self._proc = None
        self._lines = []
        self._reader = None

    @property
    def address(self):
        """What SPLITVK_SERVER should be."""
        return f"127.0.0.1:{self.port}"

    @property
    def log(self):
        return "".join(self._lines)

    def connections(self):
        """One dict per connection closed so far: id, seconds, up_bytes, down_bytes, up_end, down_end."""
        found = []
        for m in CLOSED_RE.finditer(self.log):
            found.append({"id": int(m.group(1)), "seconds": float(m.group(2)), "up_bytes": int(m.group(3)),
                          "down_bytes": int(m.group(4)), "up_end": m.group(5), "down_end": m.group(6)})
        return found

    def __enter__(self):
        if not os.path.exists(self.binary):
            raise common.MissingBuild(f"{self.binary} is missing; build the tree first (target splitvk-link)")
        self._proc = subprocess.Popen(self.argv, env=self.env, stdin=subprocess.DEVNULL,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                      start_new_session=True)
        try:
            deadline = time.monotonic() + 10
            while self.port is None:
                left = deadline - time.monotonic()
                ready, _, _ = select.select([self._proc.stderr], [], [], max(0.0, left))
                line = self._proc.stderr.readline() if ready else ""
                if not line:
                    raise common.BenchError("splitvk-link did not start:\n" + self.log)
                self._lines.append(line)
                m = LISTENING_RE.search(line)
                if m:
                    self.port = int(m.group(1))
        except BaseException:
            self._stop()
            raise
        # Drain its log for the rest of the run, so a long run cannot fill the pipe and stall it.
        self._reader = threading.Thread(target=self._drain, daemon=True)
        self._reader.start()
        return self

    def __exit__(self, *exc):
        self._stop()
        return False

    def _drain(self):
        for line in self._proc.stderr:
            self._lines.append(line)

    def _stop(self):
        if self._proc is None or self._proc.poll() is not None:
            return
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self._proc.pid, signal.SIGTERM)
        try:
            self._proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(self._proc.pid, signal.SIGKILL)
            self._proc.wait()
        if self._reader is not None:
            self._reader.join(timeout=5)


def maybe(build, agent_port, link, **kwargs):
    """A Link for a --link value, or, for 'direct', a context that yields None (dial the agent)."""
    if link == "direct":
        return contextlib.nullcontext(None)
    return Link(build, agent_port, profile=link, **kwargs)
