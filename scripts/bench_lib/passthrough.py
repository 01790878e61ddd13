"""bench passthrough: the layer's overhead while it passes every call through.

Runs splitvk-atrium alternately without the layer (native) and with it (explicitly enabled from the
build tree), R rounds, in one invocation on one X server, and reports the frame time with the layer
divided by the frame time without it: per round, then the median of the per-round ratios with its
min and max. The order inside a round alternates (native first, then layer first, ...), so a slow
drift of the machine does not favour one side.

With --stats the layer runs as scripts/bench paper's native does: SPLITVK_STATS on (a row and a
frame_latency_ms per frame) and SPLITVK_SERVER at a loopback port nothing listens on."""
import argparse
import json
import os
import tempfile

from . import common, split

APP_NAME = "splitvk-atrium"


def register(subparsers):
    p = subparsers.add_parser(
        "passthrough", help="frame time with the pass-through layer / without it (splitvk-atrium)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--frames", type=int, default=60, help="frames per run (default: %(default)s)")
    p.add_argument("--rounds", type=int, default=6,
                   help="native/layer pairs (default: %(default)s; more for a tighter spread)")
    p.add_argument("--width", type=int, default=2400, help="window width (default: %(default)s)")
    p.add_argument("--height", type=int, default=1080, help="window height (default: %(default)s)")
    p.add_argument("--eyes", type=int, choices=(1, 2), default=2, help="default: %(default)s")
    p.add_argument("--present-mode", choices=("fifo", "mailbox", "immediate"), default="immediate",
                   help="default: %(default)s (measure rendering, not the display's pace)")
    p.add_argument("--stats", action="store_true",
                   help="the layer with SPLITVK_STATS on and no agent, as bench paper's native runs")
    p.add_argument("--json", metavar="PATH", help="also write the numbers as JSON to PATH")
    common.add_build_argument(p)
    common.add_driver_argument(p)


def run(args):
    if args.frames < 1 or args.rounds < 1 or args.width < 1 or args.height < 1:
        raise common.BenchError("--frames, --rounds, --width and --height must be positive")
    build = common.Build(args.build)
    build.check()
    argv = [build.atrium, "--width", str(args.width), "--height", str(args.height), "--eyes", str(args.eyes),
            "--frames", str(args.frames), "--present-mode", args.present_mode]
    # Generous: lavapipe on a small machine can take a second per frame at 2400x1080.
    timeout_s = 120 + 3 * args.frames
    driver = "lavapipe" if args.icd == common.LAVAPIPE_ICD else args.icd

    print(f"passthrough: {APP_NAME} {args.width}x{args.height}, {args.eyes} eye(s), {args.frames} frames per run, "
          f"{args.rounds} rounds, present mode {args.present_mode}, driver {driver}, build {build.path}"
          + (", the layer with SPLITVK_STATS and no agent" if args.stats else ""), flush=True)
    load_start = os.getloadavg()[0]
    rounds = []
    with common.display(build) as disp, tempfile.TemporaryDirectory(prefix="splitvk-bench-passthrough-") as tmp:
        base = common.clean_env(args.icd)
        base["DISPLAY"] = disp
        base["SPLITVK_LOG_LEVEL"] = "info"  # so each run proves whether the layer was there
        native_env = base
        layered_env = common.layer_env(base, build)
        if args.stats:
            layered_env.update(SPLITVK_STATS=os.path.join(tmp, "stats.csv"),
                               SPLITVK_SERVER=f"127.0.0.1:{split.free_port()}")
        for i in range(args.rounds):
            order = ("native", "layer") if i % 2 == 0 else ("layer", "native")
            result = {}
            for side in order:
                r = common.run(argv, native_env if side == "native" else layered_env, timeout_s)
                active = common.layer_active_line(APP_NAME) in r.stderr
                if side == "layer" and not active:
                    raise common.BenchError("the layer did not load in the 'layer' run (no '"
                                            + common.layer_active_line(APP_NAME) + "'):\n" + common.tail(r.stderr))
                if side == "native" and "[splitvk]" in r.stderr:
                    raise common.BenchError("the layer spoke in the 'native' run:\n" + common.tail(r.stderr))
                median, iqr, frames = r.frame_time()
                result[side] = {"median_ms": median, "iqr_ms": iqr, "frames": frames, "wall_s": round(r.wall_s, 2)}
            ratio = result["layer"]["median_ms"] / result["native"]["median_ms"]
            result["ratio"] = ratio
            rounds.append(result)
            print(f"  round {i + 1}/{args.rounds}: native {result['native']['median_ms']:8.2f} ms "
                  f"(IQR {result['native']['iqr_ms']:.2f})   layer {result['layer']['median_ms']:8.2f} ms "
                  f"(IQR {result['layer']['iqr_ms']:.2f})   ratio {ratio:.4f}", flush=True)

    ratios = [r["ratio"] for r in rounds]
    q1, med, q3 = common.quartiles(ratios)
    native_medians = [r["native"]["median_ms"] for r in rounds]
    layer_medians = [r["layer"]["median_ms"] for r in rounds]
    _, native_med, _ = common.quartiles(native_medians)
    _, layer_med, _ = common.quartiles(layer_medians)
    # Interference from other work only ever adds time, so the fastest run of each side is the
    # least disturbed estimate; its ratio is printed next to the median of per-round ratios.
    best_ratio = min(layer_medians) / min(native_medians)
    load_end = os.getloadavg()[0]
    print(f"frame time with layer / without: {med:.4f} (median of {len(ratios)} per-round ratios; "
          f"min {min(ratios):.4f}, max {max(ratios):.4f}, IQR {q3 - q1:.4f})")
    print(f"  native median frame time {native_med:.2f} ms, with layer {layer_med:.2f} ms "
          f"(medians over rounds of each run's median)")
    print(f"  fastest runs: native {min(native_medians):.2f} ms, with layer {min(layer_medians):.2f} ms, "
          f"ratio {best_ratio:.4f}")
    print(f"  1-minute load average {load_start:.2f} at the start, {load_end:.2f} at the end "
          f"({os.cpu_count()} CPUs); other work on the machine widens the spread")
    if args.json:
        summary = {
            "benchmark": "passthrough", "app": APP_NAME, "width": args.width, "height": args.height,
            "eyes": args.eyes, "frames": args.frames, "rounds": args.rounds, "present_mode": args.present_mode,
            "stats": args.stats,
            "driver": driver, "build": build.path, "load_average": [load_start, load_end],
            "ratio": {"median": med, "min": min(ratios), "max": max(ratios), "iqr": q3 - q1,
                      "fastest_runs": best_ratio},
            "per_round": rounds,
        }
        with open(args.json, "w") as f:
            json.dump(summary, f, indent=2)
            f.write("\n")
        print(f"  wrote {os.path.abspath(args.json)}")
    return 0
