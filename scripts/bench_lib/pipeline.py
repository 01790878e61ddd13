"""bench pipeline: SPLITVK_PRESENT_DEPTH against latency and pacing, on the paper's experiment.

splitvk-atrium at 2400x1080, two eyes, fovea 512x360 per eye, periphery at scale 0.6, on the weak
client of `scripts/bench paper` (its CPUs, LP_NUM_THREADS and SPLITVK_TILE_WAIT=2000: lockstep),
against a splitvk-agent the bench starts. Every round runs native, then the split at each of
--depths (SPLITVK_PRESENT_DEPTH), and with --client-renders fovea the swapped split at each depth
too. Native runs through the layer with SPLITVK_STATS and no agent, so both sides are measured with
the same clock at the same points.

From the SPLITVK_STATS rows (after --warmup frames a run) it prints per mode:
  frame time    median of frame_ms (present to present), and p99 over median: the pacing
  latency       median and p99 of frame_latency_ms (the application's acquire returning to the real
                vkQueuePresentKHR returning)
and ends with one line per mode and depth that scripts can read:
  latency-MODE@D/native: R    the mode's median latency at depth D over native's
  frametime-MODE@D/native: R  its median frame time over native's
  pacing-MODE@D: R            its p99 frame time over its median
Timings never pass or fail."""
import argparse
import os

from . import common, paper, split

MODES = {"split": {}, "swapped": {"SPLITVK_CLIENT_RENDERS": "fovea", "SPLITVK_PERIPHERY_QUALITY": "23"}}


def depth_list(text):
    depths = []
    for part in text.split(","):
        if part.strip() not in ("0", "1", "2"):
            raise argparse.ArgumentTypeError(f"--depths '{text}': each must be 0, 1 or 2")
        if int(part) not in depths:
            depths.append(int(part))
    return depths


def register(subparsers):
    client_cpus, agent_cpus = paper.default_cpus()
    p = subparsers.add_parser(
        "pipeline", help="SPLITVK_PRESENT_DEPTH against latency and pacing (the paper's experiment)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--frames", type=int, default=80, help="frames per run (default: %(default)s)")
    p.add_argument("--rounds", type=int, default=2, help="default: %(default)s")
    p.add_argument("--warmup", type=int, default=10, help="frames left out at the start of each run (default: %(default)s)")
    p.add_argument("--depths", type=depth_list, default=[0, 1, 2], help="SPLITVK_PRESENT_DEPTH values (default: 0,1,2)")
    p.add_argument("--client-renders", choices=("periphery", "fovea", "both"), default="periphery",
                   help="periphery: the paper's split; fovea: the swapped split; both (default: %(default)s)")
    p.add_argument("--width", type=int, default=2400, help="default: %(default)s")
    p.add_argument("--height", type=int, default=1080, help="default: %(default)s")
    p.add_argument("--tile-wait", type=int, default=2000, help="SPLITVK_TILE_WAIT in ms (default: %(default)s)")
    p.add_argument("--client-cpus", default=client_cpus, help="default here: %(default)s")
    p.add_argument("--agent-cpus", default=agent_cpus, help="default here: %(default)s")
    p.add_argument("--out-dir", help="SPLITVK_STATS CSVs and the agent's log (default: BUILD/bench-pipeline)")
    common.add_build_argument(p)
    common.add_driver_argument(p)


def summary(rows):
    frames = [float(r["frame_ms"]) for r in rows if r["frame_ms"] and float(r["frame_ms"]) > 0]
    latency = [float(r["frame_latency_ms"]) for r in rows if r.get("frame_latency_ms")]
    if not frames or not latency:
        raise common.BenchError("a run has no frame times or no frame_latency_ms in its SPLITVK_STATS rows")
    median = split.median(frames)
    return {"frame": median, "pacing": common.percentile(frames, 99) / median, "latency": split.median(latency),
            "latency_p99": common.percentile(latency, 99), "late": sum(r["late"] == "1" for r in rows),
            "frames": len(rows)}


def run(args):
    build = common.Build(args.build)
    build.check()
    agent = os.path.join(build.path, "bin", "splitvk-agent")
    if not os.path.exists(agent):
        raise common.MissingBuild(f"{agent} is missing; build the tree first")
    if min(args.frames, args.rounds) < 1 or not 0 <= args.warmup < args.frames:
        raise common.BenchError("need positive --frames and --rounds, and --warmup < --frames")
    modes = {"periphery": ["split"], "fovea": ["swapped"], "both": ["split", "swapped"]}[args.client_renders]
    out_dir = args.out_dir or os.path.join(build.path, "bench-pipeline")
    os.makedirs(out_dir, exist_ok=True)
    client = ["taskset", "-c", args.client_cpus]
    argv = client + [build.atrium, "--path", "direct", "--width", str(args.width), "--height", str(args.height),
                     "--eyes", "2", "--frames", str(args.frames), "--present-mode", "immediate"]
    timeout_s = 300 + 3 * args.frames
    print(f"pipeline: {paper.APP_NAME} {args.width}x{args.height} stereo, fovea 512x360, scale 0.6; "
          f"{args.frames} frames x {args.rounds} rounds ({args.warmup} warm-up left out); client on CPU "
          f"{args.client_cpus}, agent on CPU {args.agent_cpus}; load average "
          + " ".join(f"{x:.2f}" for x in os.getloadavg()), flush=True)
    rows = {}
    with common.display(build) as disp:
        base = dict(common.clean_env(args.icd), DISPLAY=disp)
        client_env = common.layer_env(dict(base, LP_NUM_THREADS="1"), build)
        agent_env = dict(base, LP_NUM_THREADS=str(len(paper.cpu_list(args.agent_cpus))))
        with common.started_agent(build, agent, agent_env, out_dir, 0, ["taskset", "-c", args.agent_cpus]) as a:
            split_env = dict(client_env, SPLITVK_SERVER=a["address"], SPLITVK_LOG_LEVEL="info", SPLITVK_SCALE="0.6",
                             SPLITVK_CODEC="x264", SPLITVK_EYES="2", SPLITVK_FOVEA="512x360",
                             SPLITVK_TILE_WAIT=str(args.tile_wait))
            # Native: the layer with no agent to reach (a port nothing listens on) passes every frame.
            runs = [("native", dict(client_env, SPLITVK_SERVER=f"127.0.0.1:{split.free_port()}"))]
            for mode in modes:
                for depth in args.depths:
                    runs.append((f"{mode}@{depth}", dict(split_env, SPLITVK_PRESENT_DEPTH=str(depth), **MODES[mode])))
            for i in range(args.rounds):
                line = []
                for name, env in runs if i % 2 == 0 else runs[::-1]:
                    stats = os.path.join(out_dir, f"{name.replace('@', '-depth')}-round{i + 1}.csv")
                    r = common.run(argv, dict(env, SPLITVK_STATS=stats), timeout_s)
                    if name != "native" and "[splitvk] split" not in r.stderr:
                        raise common.BenchError(f"the {name} run did not split:\n" + common.tail(r.stderr))
                    got = split.read_stats(stats, args.warmup)
                    rows.setdefault(name, []).extend(got)
                    s = summary(got)
                    line.append(f"{name} {s['frame']:.0f}/{s['latency']:.0f}")
                print(f"  round {i + 1}/{args.rounds} (frame/latency ms): " + "  ".join(line)
                      + f"  [load {os.getloadavg()[0]:.2f}]", flush=True)
    results = {name: summary(got) for name, got in rows.items()}
    print(f"\n{'mode':<12} {'frame ms':>9} {'p99/median':>10} {'latency ms':>10} {'latency p99':>11} "
          f"{'late':>5} {'frames':>6}")
    for name, s in results.items():
        print(f"{name:<12} {s['frame']:9.1f} {s['pacing']:10.2f} {s['latency']:10.1f} {s['latency_p99']:11.1f} "
              f"{s['late']:5d} {s['frames']:6d}")
    print("load average after: " + " ".join(f"{x:.2f}" for x in os.getloadavg()))
    native = results["native"]
    for name, s in results.items():
        if name == "native":
            continue
        print(f"latency-{name}/native: {s['latency'] / native['latency']:.3f}")
        print(f"frametime-{name}/native: {s['frame'] / native['frame']:.3f}")
        print(f"pacing-{name}: {s['pacing']:.3f}")
    return 0
