"""bench split: the image-space split stage by stage, against native, in one run.

Starts splitvk-agent on a free loopback port and runs splitvk-atrium natively (no layer) and split
(the layer, SPLITVK_STATS on), alternating, for --rounds pairs. From the layer's per-frame CSV it
prints the paper's per-stage tables (Tables 1-2 of the paper):
  client  network, decode, upload + merge (CPU and GPU), tile wait, exposed wait; Mbit/s of tiles
  agent   draw, readback, encode (carried with the tiles)
and end to end the frame time of native and split (median and IQR) with their ratio, the
compressed tile bytes over the raw tile bytes, and the exposed wait's share of all frame time. The
first --warmup frames of each run (scene upload, the first keyframes) are left out of the medians.

With --tls each round also runs the split with SPLITVK_TLS=on (TLS 1.3 on loopback, as on a LAN
but for the network itself) and it reports the TLS split's frame time over the plaintext split's,
measured in the same run (split-tls/split).

With --png-dir it also grabs what the X server shows for the last frame of one native and one split
run (splitvk-atrium --hold), as PNGs.

Client and agent share this machine's cores, so the split's timings include the agent's work
competing with the client's: on two machines the client would only wait for it."""
import argparse
import contextlib
import csv
import os
import signal
import socket
import subprocess

from . import common

APP_NAME = "splitvk-atrium"


def register(subparsers):
    p = subparsers.add_parser(
        "split", help="per-stage medians of the split and split/native (splitvk-atrium)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(p)


def add_arguments(p, frames=200, rounds=2):
    p.add_argument("--frames", type=int, default=frames, help="frames per run (default: %(default)s)")
    p.add_argument("--warmup", type=int, default=10, help="frames left out of each run's medians (default: %(default)s)")
    p.add_argument("--rounds", type=int, default=rounds, help="native/split pairs (default: %(default)s)")
    p.add_argument("--width", type=int, default=2400, help="window width (default: %(default)s)")
    p.add_argument("--height", type=int, default=1080, help="window height (default: %(default)s)")
    p.add_argument("--eyes", type=int, choices=(1, 2), default=2, help="default: %(default)s")
    p.add_argument("--codec", choices=("x264", "zstd", "raw"), default="x264", help="default: %(default)s")
    p.add_argument("--scale", default="0.6", help="SPLITVK_SCALE (default: %(default)s)")
    p.add_argument("--png-dir", help="save PNGs of the last native and split frame there")
    p.add_argument("--tls", action="store_true",
                   help="also run each round's split over TLS 1.3 (SPLITVK_TLS=on) and report split-tls/split")
    p.add_argument("--out-dir", help="keep the per-frame CSVs and logs there (default: a temporary folder)")
    common.add_build_argument(p)
    common.add_driver_argument(p)


def stop_group(proc):
    """SIGTERM to the process group a start_new_session Popen made, SIGKILL if it lingers."""
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGTERM)
    try:
        proc.wait(timeout=30)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def read_stats(path, warmup):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if len(rows) <= warmup:
        raise common.BenchError(f"{path} has {len(rows)} frames, not more than --warmup {warmup}")
    return rows[warmup:]


def median(values):
    _, m, _ = common.quartiles(values)
    return m


def stage_medians(rows):
    on_time = [r for r in rows if r["late"] == "0"]
    if not on_time:
        raise common.BenchError("every frame was late: the agent never kept up (see the agent's log)")

    def col(name, source=on_time):
        return median([float(r[name]) for r in source])

    total_s = sum(float(r["frame_ms"]) for r in rows) / 1000
    tile_bytes = sum(int(r["tile_bytes"]) for r in rows)
    raw_bytes = sum(int(r["raw_bytes"]) for r in on_time)
    return {
        "network": col("network_ms"), "decode": col("decode_ms"), "merge": col("merge_ms"),
        "tile_wait": col("tile_wait_ms", rows), "draw": col("agent_draw_ms"),
        "readback": col("agent_readback_ms"), "encode": col("agent_encode_ms"),
        "mbits": tile_bytes * 8 / total_s / 1e6 if total_s > 0 else 0.0,
        "tile_bytes": sum(int(r["tile_bytes"]) for r in on_time), "raw_bytes": raw_bytes,
        "late": len(rows) - len(on_time), "frames": len(rows),
        # GPU time of the client's split pass (timestamp queries); 0 where the layer had none yet.
        "periphery": median([float(r["periphery_ms"]) for r in rows if float(r.get("periphery_ms") or 0) > 0] or [0.0]),
        # GPU time of the composite (timestamp queries), next to merge (CPU time around its submit).
        "merge_gpu": median([float(r["merge_gpu_ms"]) for r in rows if float(r.get("merge_gpu_ms") or 0) > 0] or [0.0]),
        # The part of the tile wait after the client's GPU had finished the frame: the median, and
        # all of it over all frame time (the share of the frame it costs).
        "exposed_wait": col("exposed_wait_ms", rows),
        "exposed_share": (sum(float(r.get("exposed_wait_ms") or 0) for r in rows) / (total_s * 1000)
                          if total_s > 0 else 0.0),
    }


def measure(args):
    """Runs the rounds; returns a dict of results (also used by the demo)."""
    if min(args.frames, args.rounds, args.width, args.height) < 1 or args.warmup < 0 or args.warmup >= args.frames:
        raise common.BenchError("need positive sizes and --warmup < --frames")
    build = common.Build(args.build)
    build.check()
    agent = os.path.join(build.path, "bin", "splitvk-agent")
    if not os.path.exists(agent):
        raise common.MissingBuild(f"{agent} is missing; build the tree first")
    out_dir = args.out_dir or os.path.join(build.path, "bench-split")
    os.makedirs(out_dir, exist_ok=True)

    def argv(frames):
        return [build.atrium, "--width", str(args.width), "--height", str(args.height), "--eyes", str(args.eyes),
                "--frames", str(frames), "--present-mode", "immediate"]

    timeout_s = 120 + 4 * args.frames
    port = free_port()
    print(f"split: {APP_NAME} {args.width}x{args.height}, {args.eyes} eye(s), {args.frames} frames per run, "
          f"{args.rounds} rounds, scale {args.scale}, codec {args.codec}, agent on 127.0.0.1:{port}", flush=True)

    natives, splits, tls_splits = [], [], []
    with common.display(build) as disp:
        base = common.clean_env(args.icd)
        base["DISPLAY"] = disp
        split_env = dict(common.layer_env(base, build), SPLITVK_SERVER=f"127.0.0.1:{port}", SPLITVK_LOG_LEVEL="info",
                         SPLITVK_SCALE=args.scale, SPLITVK_CODEC=args.codec, SPLITVK_EYES=str(args.eyes))
        with common.started_agent(build, agent, base, out_dir, port):
            # The same split over TLS, to the same agent (it serves both on one port).
            tls_env = common.tls_split_env(split_env, agent, out_dir, base) if getattr(args, "tls", False) else None
            for i in range(args.rounds):
                order = ("native", "split") if i % 2 == 0 else ("split", "native")
                line = []
                for mode in order:
                    if mode == "native":
                        r = common.run(argv(args.frames), base, timeout_s)
                        m, iqr, _ = r.frame_time()
                        natives.append(r)
                        line.append(f"native {m:7.2f} ms/frame (IQR {iqr:.2f})")
                    else:
                        stats = os.path.join(out_dir, f"split-round{i + 1}.csv")
                        r = common.run(argv(args.frames), dict(split_env, SPLITVK_STATS=stats), timeout_s)
                        if "running unsplit" in r.stderr or "[splitvk] split:" not in r.stderr:
                            raise common.BenchError("the split run did not split:\n" + common.tail(r.stderr))
                        splits.append((r, read_stats(stats, args.warmup)))
                        m, iqr, _ = r.frame_time()
                        line.append(f"split {m:7.2f} ms/frame (IQR {iqr:.2f})")
                if tls_env:
                    r = common.run(argv(args.frames), tls_env, timeout_s)
                    common.check_tls_split(r)
                    tls_splits.append(r)
                    m, iqr, _ = r.frame_time()
                    line.append(f"split+TLS {m:7.2f} ms/frame (IQR {iqr:.2f})")
                print(f"  round {i + 1}/{args.rounds}: " + "   ".join(line), flush=True)
            pngs = None
            if args.png_dir:
                os.makedirs(args.png_dir, exist_ok=True)
                frames = min(args.frames, 60)
                pngs = (os.path.join(args.png_dir, f"native-frame-{frames - 1}.png"),
                        os.path.join(args.png_dir, f"split-frame-{frames - 1}.png"))
                common.run_held(build, argv(frames) + ["--hold"], base, frames - 1, pngs[0], args.width,
                                args.height, out_dir, "native-hold", timeout_s)
                common.run_held(build, argv(frames) + ["--hold"], split_env, frames - 1, pngs[1], args.width,
                                args.height, out_dir, "split-hold", timeout_s)

    rows = [row for _, rows in splits for row in rows]
    stages = stage_medians(rows)
    # End to end, both from the app's own frame-time line (present to present, the same clock).
    native_all = [r.frame_time() for r in natives]
    split_all = [r.frame_time() for r, _ in splits]
    return {
        "stages": stages, "pngs": pngs, "out_dir": out_dir,
        "native_median": median([m for m, _, _ in native_all]),
        "native_iqr": median([iqr for _, iqr, _ in native_all]),
        "split_median": median([m for m, _, _ in split_all]),
        "split_iqr": median([iqr for _, iqr, _ in split_all]),
        "split_tls_median": median([r.frame_time()[0] for r in tls_splits]) if tls_splits else None,
    }


def print_tables(res):
    s = res["stages"]
    print()
    print("client (median ms per frame)  periphery (GPU)   network   decode   upload+merge  merge (GPU)   "
          "tile wait  exposed wait     Mbit/s")
    print(f"                              {s['periphery']:15.2f} {s['network']:9.2f} {s['decode']:8.2f} "
          f"{s['merge']:14.2f} {s['merge_gpu']:12.2f} {s['tile_wait']:11.2f} {s['exposed_wait']:13.2f} "
          f"{s['mbits']:10.1f}")
    print("agent (median ms per frame)          draw   readback   encode")
    print(f"                                 {s['draw']:9.2f} {s['readback']:10.2f} {s['encode']:8.2f}")
    print("end to end (ms per frame)        median      IQR")
    print(f"  native                       {res['native_median']:9.2f} {res['native_iqr']:8.2f}")
    print(f"  split                        {res['split_median']:9.2f} {res['split_iqr']:8.2f}")
    print(f"late frames (centre from the periphery): {s['late']} of {s['frames']}")
    if res.get("split_tls_median"):
        print(f"  split over TLS 1.3           {res['split_tls_median']:9.2f}")
        print(f"split-tls/split: {res['split_tls_median'] / res['split_median'] if res['split_median'] else 0.0:.3f}")
    print_final_lines(res["split_median"], res["native_median"], s["tile_wait"], s["exposed_share"],
                      s["tile_bytes"], s["raw_bytes"])


def print_final_lines(split_median, native_median, tile_wait_median, exposed_share, tile_bytes, raw_bytes):
    """The lines every split-measuring bench ends with, for tools to read (nothing may follow): the
    three ratios, and the exposed wait's share of the frame next to the tile wait's."""
    print(f"split/native: {split_median / native_median if native_median else 0.0:.3f}")
    print(f"tile-wait/frame: {tile_wait_median / split_median if split_median else 0.0:.3f}")
    print(f"exposed-wait/frame: {exposed_share:.3f}")
    print(f"tile-bytes/raw: {tile_bytes / raw_bytes if raw_bytes else 0.0:.3f}")


def run(args):
    res = measure(args)
    if res["pngs"]:
        print(f"native frame: {res['pngs'][0]}\nsplit frame:  {res['pngs'][1]}")
    print_tables(res)  # ends with the ratio lines
    return 0
