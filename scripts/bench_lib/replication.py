"""bench replication: what forwarding the command stream costs, on the wire and on the client.

Starts splitvk-agent on a free loopback port and runs splitvk-atrium with the layer in two modes,
alternating, in one invocation:
  pass-through  the layer loaded but no agent at its address ("running unsplit")
  replicating   the layer forwarding everything to the agent

Bytes on the wire per frame in steady state come from the layer's session summary line of a short
and a long run: (bytes(long) - bytes(short)) / (frames(long) - frames(short)), so scene loading
cancels out. The client's capture cost (memory comparison and encoding, on the app's threads and
the layer's I/O thread) is the app's CPU time per frame replicating minus pass-through, as a
fraction of the pass-through frame time. CPU time rather than wall time, because the agent replays
on the same machine and competes for its cores; on separate machines wall time would follow."""
import argparse
import os
import re
import resource
import socket
import tempfile

from . import common

APP_NAME = "splitvk-atrium"
SESSION_RE = re.compile(r"session to \S+: (\d+) presents, ([\d.]+) ms comparing memory, (\d+) messages, "
                        r"(\d+) payload bytes, (\d+) bytes on the wire")


def register(subparsers):
    p = subparsers.add_parser(
        "replication", help="wire bytes per frame and the client's capture cost (splitvk-atrium)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--frames", type=int, default=60, help="frames of the long runs (default: %(default)s)")
    p.add_argument("--short-frames", type=int, default=20, help="frames of the short run (default: %(default)s)")
    p.add_argument("--rounds", type=int, default=3, help="pass-through/replicating pairs (default: %(default)s)")
    p.add_argument("--width", type=int, default=2400, help="window width (default: %(default)s)")
    p.add_argument("--height", type=int, default=1080, help="window height (default: %(default)s)")
    p.add_argument("--eyes", type=int, choices=(1, 2), default=2, help="default: %(default)s")
    common.add_build_argument(p)
    common.add_driver_argument(p)


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def timed_run(argv, env, timeout_s):
    """common.run plus the CPU seconds (user + system) the app used."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = common.run(argv, env, timeout_s)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return r, cpu


def session_summary(r):
    m = SESSION_RE.search(r.stderr)
    if not m:
        raise common.BenchError("the layer printed no session summary (did it reach the agent?):\n"
                                + common.tail(r.stderr))
    return {"frames": int(m.group(1)), "compare_ms": float(m.group(2)), "messages": int(m.group(3)),
            "payload_bytes": int(m.group(4)), "wire_bytes": int(m.group(5))}


def run(args):
    if min(args.frames, args.short_frames, args.rounds, args.width, args.height) < 1 or \
            args.short_frames >= args.frames:
        raise common.BenchError("need positive sizes and --short-frames < --frames")
    build = common.Build(args.build)
    build.check()
    agent = os.path.join(build.path, "bin", "splitvk-agent")
    if not os.path.exists(agent):
        raise common.MissingBuild(f"{agent} is missing; build the tree first")

    def argv(frames):
        return [build.atrium, "--width", str(args.width), "--height", str(args.height), "--eyes", str(args.eyes),
                "--frames", str(frames), "--present-mode", "immediate"]

    timeout_s = 120 + 4 * args.frames
    port, dead_port = free_port(), free_port()
    print(f"replication: {APP_NAME} {args.width}x{args.height}, {args.eyes} eye(s), {args.frames} frames "
          f"(short run {args.short_frames}), {args.rounds} rounds, agent on 127.0.0.1:{port}", flush=True)

    with common.display(build) as disp:
        base = common.clean_env(args.icd)
        base["DISPLAY"] = disp
        base["SPLITVK_LOG_LEVEL"] = "info"
        layered = common.layer_env(base, build)
        passthrough_env = dict(layered, SPLITVK_SERVER=f"127.0.0.1:{dead_port}")
        replicating_env = dict(layered, SPLITVK_SERVER=f"127.0.0.1:{port}")
        # The agent's log and TLS identity in a folder of their own: this bench keeps no files.
        with tempfile.TemporaryDirectory(prefix="splitvk-bench-replication-") as agent_dir, \
                common.started_agent(build, agent, base, agent_dir, port):
            short, _ = timed_run(argv(args.short_frames), replicating_env, timeout_s)
            short_summary = session_summary(short)
            rows = []
            for i in range(args.rounds):
                order = ("pass-through", "replicating") if i % 2 == 0 else ("replicating", "pass-through")
                row = {}
                for mode in order:
                    r, cpu = timed_run(argv(args.frames), passthrough_env if mode == "pass-through"
                                       else replicating_env, timeout_s)
                    if mode == "pass-through" and "running unsplit" not in r.stderr:
                        raise common.BenchError("the pass-through run found an agent:\n" + common.tail(r.stderr))
                    median, _, frames = r.frame_time()
                    row[mode] = {"median_ms": median, "cpu_ms_per_frame": 1000 * cpu / frames}
                    if mode == "replicating":
                        row["summary"] = session_summary(r)
                rows.append(row)
                print(f"  round {i + 1}/{args.rounds}: pass-through {row['pass-through']['median_ms']:7.2f} ms/frame "
                      f"({row['pass-through']['cpu_ms_per_frame']:.2f} ms CPU)   replicating "
                      f"{row['replicating']['median_ms']:7.2f} ms/frame ({row['replicating']['cpu_ms_per_frame']:.2f} "
                      f"ms CPU)", flush=True)

    long_summary = rows[-1]["summary"]
    extra_frames = long_summary["frames"] - short_summary["frames"]
    wire_per_frame = (long_summary["wire_bytes"] - short_summary["wire_bytes"]) / extra_frames
    payload_per_frame = (long_summary["payload_bytes"] - short_summary["payload_bytes"]) / extra_frames
    raw_frame = args.width * args.height * 4
    _, pass_ms, _ = common.quartiles([r["pass-through"]["median_ms"] for r in rows])
    _, cpu_delta, _ = common.quartiles([r["replicating"]["cpu_ms_per_frame"] - r["pass-through"]["cpu_ms_per_frame"]
                                        for r in rows])
    load_ms = long_summary["compare_ms"]
    print(f"bytes on the wire per frame (steady state): {wire_per_frame / 1024:.1f} KiB "
          f"({payload_per_frame / 1024:.1f} KiB before compression) against a raw "
          f"{args.width}x{args.height} frame of {raw_frame / 1024:.0f} KiB: {wire_per_frame / raw_frame:.5f} of it")
    print(f"whole run of {long_summary['frames']} frames: {long_summary['wire_bytes'] / 2**20:.1f} MiB on the wire "
          f"(scene upload included), {long_summary['messages']} messages, {load_ms:.1f} ms comparing memory")
    print(f"client capture cost: {cpu_delta:+.2f} ms CPU per frame, {cpu_delta / pass_ms:+.4f} of the "
          f"pass-through frame time ({pass_ms:.2f} ms; median over {len(rows)} rounds; amortised over "
          f"{args.frames} frames, the scene upload included)")
    return 0
