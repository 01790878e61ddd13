"""bench payoff: what the defaults cost a small application, where the split does not pay.

Small frames are slower split than native: the agent's path alone outlasts the whole native frame.
By default (SPLITVK_SPLIT=auto) the layer measures both ways and passes frames through where the
split loses. This bench runs splitvk-atrium four ways in every round (the order alternating),
against one agent on one X server:
  native   without the layer
  unsplit  the layer with no agent at its address: native frames, timed by the layer's clock
  split    the layer forced to split (SPLITVK_SPLIT=always)
  default  the layer with the defaults, as a new user runs it
and reports each run's median frame time (atrium's own, present to present). The default run is
measured over its frames after the verdict (--settled-after, past both measurement windows and the
switch), so its ratio tells what the application runs at once the layer has decided; the split's
later probes fall inside that and are counted. The latency of a frame (SPLITVK_STATS'
frame_latency_ms: the application's acquire returning to the driver's present returning) is compared
on the same clock: the default run's frames passed through against the unsplit run's frames.

By default the scene is a cube (--scene cube: a model of 12 triangles written into --out-dir), whose
frames take a few milliseconds here; --scene atrium draws atrium's own 300,000-triangle scene, where
the split pays on a weak client and the default must stay split; --scene vkcube runs vkcube (one eye)
instead of atrium. vkcube times no frames of its own, so its runs are timed by the layer
(SPLITVK_STATS' frame_ms, present to present) and the unsplit run stands for native (no native run). --fovea sets SPLITVK_FOVEA for the
split and default runs (auto: the fovea that sizes itself, whose first measurement waits for its
sizing). Ends with lines for tools, nothing after them:
  split/native: R            the forced split's median frame time over native's
  default/native: R          the default's, after its verdict, over native's
  latency-default/native: R  median latency of the default's frames passed through over the unsplit
                             run's frames (`none` when no frame passed through)
  passed-through/native: R   median frame time (SPLITVK_STATS' frame_ms) of the default's frames
                             passed through over the unsplit run's frames, on the layer's clock:
                             what a frame passed through costs, the split's probes left out
Timings never pass or fail."""
import argparse
import csv
import os
import statistics

from . import common, paper, split

APP_NAME = "splitvk-atrium"

CUBE_OBJ = """# a cube, 12 triangles (scripts/bench payoff)
v -1 -1 -1
v 1 -1 -1
v 1 1 -1
v -1 1 -1
v -1 -1 1
v 1 -1 1
v 1 1 1
v -1 1 1
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 4 7 3
f 4 8 7
f 1 5 8
f 1 8 4
f 2 3 7
f 2 7 6
"""


def register(subparsers):
    p = subparsers.add_parser(
        "payoff", help="native, the forced split and the defaults on small frames: do the defaults pass them through",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", choices=("cube", "atrium", "vkcube"), default="cube", help="default: %(default)s")
    p.add_argument("--frames", type=int, default=600, help="frames per run (default: %(default)s)")
    p.add_argument("--settled-after", type=int, default=120,
                   help="frames of the default run left out of its medians (default: %(default)s: both "
                        "measurement windows and the switch; with --fovea auto, 240 covers the split's "
                        "first hold too)")
    p.add_argument("--fovea", help="SPLITVK_FOVEA of the split and default runs (default: the layer's)")
    p.add_argument("--rounds", type=int, default=3, help="default: %(default)s")
    p.add_argument("--width", type=int, default=480, help="window width (default: %(default)s)")
    p.add_argument("--height", type=int, default=270, help="window height (default: %(default)s)")
    client_cpus, agent_cpus = paper.default_cpus()
    p.add_argument("--client-cpus", default=client_cpus,
                   help="CPUs of the client, taskset -c syntax (default here: %(default)s)")
    p.add_argument("--client-threads", type=int, default=1,
                   help="lavapipe rasterizer threads of the client, LP_NUM_THREADS (default: %(default)s)")
    p.add_argument("--agent-cpus", default=agent_cpus,
                   help="CPUs of splitvk-agent, apart from the client's as on another machine (default here: "
                        "%(default)s)")
    p.add_argument("--out-dir", help="frame times and logs (default: BUILD/bench-payoff)")
    common.add_build_argument(p)
    common.add_driver_argument(p)


def frame_times(path, skip):
    with open(path) as f:
        next(f)
        values = [float(line.split(",")[1]) for line in f if line.strip()]
    return values[skip:]


def stats_rows(path, skip):
    """SPLITVK_STATS rows of frames >= skip."""
    with open(path, newline="") as f:
        return [r for r in csv.DictReader(f) if int(r["frame"]) >= skip]


def latencies(rows):
    return [float(r["frame_latency_ms"]) for r in rows if r.get("frame_latency_ms")]


def passed_through(row):
    return row["fovea_w"] == "0" and row["tile_bytes"] == "0"


def run(args):
    if min(args.frames, args.rounds, args.width, args.height) < 1 or not 0 <= args.settled_after < args.frames:
        raise common.BenchError("need positive sizes and 0 <= --settled-after < --frames")
    build = common.Build(args.build)
    build.check()
    agent = os.path.join(build.path, "bin", "splitvk-agent")
    if not os.path.exists(agent):
        raise common.MissingBuild(f"{agent} is missing; build the tree first")
    try:
        client_cpus, agent_cpus = paper.cpu_list(args.client_cpus), paper.cpu_list(args.agent_cpus)
    except ValueError as e:
        raise common.BenchError(f"bad CPU list: {e}")
    out_dir = args.out_dir or os.path.join(build.path, "bench-payoff")
    os.makedirs(out_dir, exist_ok=True)
    scene = []
    if args.scene == "cube":
        model = os.path.join(out_dir, "cube.obj")
        with open(model, "w") as f:
            f.write(CUBE_OBJ)
        scene = ["--model", model]
    timeout_s = 120 + args.frames

    vkcube = args.scene == "vkcube"

    def argv(times):
        if vkcube:
            return ["taskset", "-c", paper.cpu_text(client_cpus), "vkcube", "--width", str(args.width), "--height",
                    str(args.height), "--c", str(args.frames), "--present_mode", "0"]
        return ["taskset", "-c", paper.cpu_text(client_cpus), build.atrium, "--width", str(args.width), "--height", str(args.height), "--eyes", "2",
                "--frames", str(args.frames), "--present-mode", "immediate", "--frame-times", times] + scene

    fovea = f" SPLITVK_FOVEA={args.fovea}" if args.fovea else ""
    app = "vkcube (mono)" if vkcube else f"{APP_NAME} --scene {args.scene} stereo"
    print(f"payoff: {app} {args.width}x{args.height}, {args.frames} frames per run, "
          f"{args.rounds} rounds of native, unsplit (the layer, no agent), split (SPLITVK_SPLIT=always{fovea}) and "
          f"the defaults{fovea and ' but' + fovea} (measured after frame {args.settled_after}); client on CPU "
          f"{paper.cpu_text(client_cpus)} with LP_NUM_THREADS={args.client_threads}, agent on CPU "
          f"{paper.cpu_text(agent_cpus)}; load average {os.getloadavg()[0]:.2f}", flush=True)
    modes = ("unsplit", "split", "default") if vkcube else ("native", "unsplit", "split", "default")
    medians = {m: [] for m in modes}
    latency = {"unsplit": [], "default": []}
    layer_frame_ms = {"unsplit": [], "default": []} # the default's: its frames passed through
    verdict_lines = []
    with common.display(build) as disp:
        base = common.clean_env(args.icd)
        base["DISPLAY"] = disp
        client_env = dict(base, LP_NUM_THREADS=str(args.client_threads))
        agent_env = dict(base, LP_NUM_THREADS=str(len(agent_cpus)))
        with common.started_agent(build, agent, agent_env, out_dir, 0,
                                  ["taskset", "-c", paper.cpu_text(agent_cpus)]) as report:
            layered = dict(common.layer_env(client_env, build), SPLITVK_LOG_LEVEL="info")
            if args.fovea:
                layered["SPLITVK_FOVEA"] = args.fovea
            # As a new user runs it: the agent's address and nothing else (the log and the stats aside).
            default_env = dict(layered, SPLITVK_SERVER=report["address"])
            del default_env["SPLITVK_SPLIT"]
            split_env = dict(layered, SPLITVK_SERVER=report["address"], SPLITVK_EYES="1" if vkcube else "2")
            # No agent answers there: every frame is native, through the layer (its stats rows too).
            unsplit_env = dict(layered, SPLITVK_SERVER=f"127.0.0.1:{split.free_port()}")
            envs = {"native": client_env, "unsplit": unsplit_env, "split": split_env, "default": default_env}
            for i in range(args.rounds):
                line = []
                for mode in modes if i % 2 == 0 else modes[::-1]:
                    times = os.path.join(out_dir, f"{mode}-round{i + 1}-frames.csv")
                    stats = os.path.join(out_dir, f"{mode}-round{i + 1}-stats.csv")
                    env = dict(envs[mode], SPLITVK_STATS=stats) if mode in latency or vkcube else envs[mode]
                    r = common.run(argv(times), env, timeout_s)
                    if mode in ("split", "default") and "[splitvk] split:" not in r.stderr:
                        raise common.BenchError(f"the {mode} run did not split:\n" + common.tail(r.stderr))
                    if mode == "unsplit" and "running unsplit" not in r.stderr:
                        raise common.BenchError("the unsplit run found an agent:\n" + common.tail(r.stderr))
                    skip = args.settled_after if mode == "default" else 10
                    if vkcube:
                        times_ms = [float(row["frame_ms"]) for row in stats_rows(stats, skip)]
                    else:
                        times_ms = frame_times(times, skip)
                    medians[mode].append(statistics.median(times_ms))
                    line.append(f"{mode} {medians[mode][-1]:7.2f} ms")
                    if mode == "unsplit":
                        rows = stats_rows(stats, skip)
                        latency[mode].extend(latencies(rows))
                        layer_frame_ms[mode].extend(float(row["frame_ms"]) for row in rows if row["frame_ms"])
                    elif mode == "default":
                        rows = stats_rows(stats, skip)
                        passed = [row for row in rows if passed_through(row)]
                        latency[mode].extend(latencies(passed))
                        layer_frame_ms[mode].extend(float(row["frame_ms"]) for row in passed if row["frame_ms"])
                        line.append(f"({len(passed)} of {len(rows)} passed through)")
                        verdicts = [l for l in r.stderr.splitlines() if "SPLITVK_SPLIT=auto: the split" in l]
                        verdict_lines.append(verdicts[-1].split("info: ")[-1] if verdicts else "no verdict")
                print(f"  round {i + 1}/{args.rounds}: " + "   ".join(line), flush=True)
    unsplit, split_ms, default = (statistics.median(medians[m]) for m in ("unsplit", "split", "default"))
    native = unsplit if vkcube else statistics.median(medians["native"])
    print(f"median frame time over rounds: native {native:.2f} ms{' (the unsplit runs)' if vkcube else ''}, unsplit {unsplit:.2f} ms, split {split_ms:.2f} ms, "
          f"default {default:.2f} ms (after frame {args.settled_after})")
    for i, verdict in enumerate(verdict_lines):
        print(f"  default, round {i + 1}: {verdict}")
    if not latency["unsplit"]:
        raise common.BenchError("the unsplit runs wrote no frame_latency_ms")
    native_latency = statistics.median(latency["unsplit"])
    print(f"latency (frame_latency_ms, every round): unsplit median {native_latency:.2f} ms, p99 "
          f"{common.percentile(latency['unsplit'], 99):.2f} ms", end="")
    if latency["default"]:
        print(f"; default, frames passed through: median {statistics.median(latency['default']):.2f} ms, p99 "
              f"{common.percentile(latency['default'], 99):.2f} ms ({len(latency['default'])} frames)")
    else:
        print("; default: no frame passed through after the verdict (the split paid)")
    print(f"split/native: {split_ms / native:.3f}")
    print(f"default/native: {default / native:.3f}")
    if latency["default"]:
        print(f"latency-default/native: {statistics.median(latency['default']) / native_latency:.3f}")
    else:
        print("latency-default/native: none (no frame passed through)")
    if layer_frame_ms["default"] and layer_frame_ms["unsplit"]:
        print(f"passed-through/native: "
              f"{statistics.median(layer_frame_ms['default']) / statistics.median(layer_frame_ms['unsplit']):.3f}")
    else:
        print("passed-through/native: none (no frame passed through)")
    return 0
