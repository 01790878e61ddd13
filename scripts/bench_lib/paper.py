"""bench paper: the paper's experiment (Tables 1-2, Figure 3) on a weak client, in one run.

splitvk-atrium at 2400x1080, two eyes, fovea 512x360 per eye, periphery at scale 0.6, the camera
moving with the frame number. Native and split alternate, --rounds times, against a splitvk-agent
the bench starts. Native runs through splitvk's layer without an agent (SPLITVK_SERVER a port nothing
listens on: every frame unsplit), so that its latency is measured by the same clock at the same
points as the split's; scripts/bench passthrough --stats measures what that costs it. The weak
device is emulated: the client (the app, the layer and its decoders, native runs too) is confined
to --client-cpus with lavapipe's LP_NUM_THREADS=--client-threads; the agent (and splitvk-link with
--link) runs on --agent-cpus.

Each round also renders the scene natively at the periphery's size (scale x the window, 1440x648
by default) on the client's cores: the client's periphery render, estimated, since the layer does
not time the app's own rendering.

--path NAME (or --paths A,B,... or --path all) draws the frames through one or more of atrium's
render paths (splitvk-atrium --path: direct, hdr, deferred, multiview, secondary, compute); each
round runs every path in turn, each path's native and split alternating as for one path. Variants of
the split run beside the plain one in every round and path, each reported as VARIANT/split: --tls adds
a split over TLS 1.3 (split-tls: SPLITVK_TLS=on, the agent pinned by its fingerprint), and
--agent-scissor guard:N a split whose agent also cuts offscreen screen-space passes to the fovea
(split-guard: SPLITVK_AGENT_SCISSOR=guard:N), and --fovea auto[:WxH] a split whose fovea sizes itself
(split-auto: SPLITVK_FOVEA=auto, beside the plain split at 512x360), with the size it settled at and
split-auto/native, and --shaded-foveae a split whose client shades its foveae (split-shaded:
SPLITVK_FOVEA_MASK=off), with the periphery render of the plain split (whose depth mask leaves them
unshaded) over its: periphery masked/shaded. --agents 2 adds a split with an agent per eye
(split-agents: SPLITVK_AGENTS=2, a second splitvk-agent on --second-agent-cpus, each agent sending
its own eye's fovea), reported as split-agents/split beside the plain split with one agent. Each
process wants a core of its own (client, first agent, second agent); on a machine with fewer cores
the second agent shares the first's, which the bench says, and the split across agents cannot show
what it gains there (scripts/device-check measures it on the device machine's 16 cores).

--xr runs the experiment through OpenXR too: in every round and path, after the desktop runs,
splitvk-atrium --xr (one swapchain per eye, each --eye-size, by default half the window: the
paper's 1200x1080) native and split under scripts/xr-runtime (Monado, headless), on the same
confined client against the same agent with the same scale, fovea and tile wait (splitvk's OpenXR
layer on, one centred fovea per eye image). Its frame times are between xrEndFrame calls, which
the runtime's xrWaitFrame paces at 20 Hz: they are never under 50 ms, so the eyes must be large
enough that native frames take well over that (at 1200x1080 on one confined core they take
hundreds of ms). Reported as xr split/native beside the desktop split/native; with
--client-renders fovea the swapped split runs through OpenXR too (xr-swapped: the client cuts each
eye image to its fovea, the agent streams its periphery back at the image's release), reported as
xr swapped/native. Only --path direct, hdr or deferred (atrium --xr draws no other path per eye).

Prints median and IQR of the frame time (every frame of every run, after --warmup frames per run)
of native and split, the client's and the agent's per-stage medians, Mbit/s of tiles, and for every
mode (native, split, each variant, through OpenXR) the latency (SPLITVK_STATS' frame_latency_ms:
the app's acquire returning to the real present returning, or xrWaitFrame returning to xrEndFrame
returning), median and p99, beside the frame time's median, p99 and p99/median; draws the
frame-time distributions with a latency panel and one typical frame's timeline (docs/figures/
with /usr/bin/python3 and python3-matplotlib); with --write-docs (the default for a full run)
replaces the paper section of docs/BENCHMARKS.md (with any path but direct, or several, its
per-path section instead, and the figures stay in --out-dir). Per path it prints split/native, periphery/native (the client's
periphery render, SPLITVK_STATS' periphery_ms, over the native median frame time) and each variant's
VARIANT/split, as `NAME[PATH]: R` lines when there are several paths; then the first path's
periphery/native and VARIANT/split, and then four lines for the first path:
  split/native: R        split median frame time over native median frame time
  tile-wait/frame: R     median tile wait over the split median frame time
  exposed-wait/frame: R  all exposed wait (the tile wait after the client's GPU had finished its
                         frame, SPLITVK_STATS' exposed_wait_ms) over all split frame time
  tile-bytes/raw: R      compressed tile bytes over raw tile bytes
Before the final lines, with --picture-frame N (default 30), one line per split: the picture it held
at frame N-1, grabbed from the X server, against native's: SSIM and PSNR over the frame, and over the
periphery alone (the foveae are exact in both splits).
And with --client-renders fovea a fifth final line (and with --xr a sixth):
  swapped/native: R      the swapped split's median frame time over native's
  xr swapped/native: R   the same through OpenXR (xr-swapped over xr-native)
Then the latency and pacing lines, the last of all:
  latency-split/native: R    the split's median latency over native's
  latency-swapped/native: R  the swapped split's (with --client-renders fovea)
  pacing-split: R            the split's p99 frame time over its median
  pacing-swapped: R          the swapped split's (with --client-renders fovea)
(each path's, OpenXR's as latency-xr-split/native and pacing-xr-split, and native's pacing among the
ratio lines before them). Timings never pass or fail."""
import argparse
import contextlib
import datetime
import json
import math
import os
import platform
import re
import resource
import shlex
import shutil
import subprocess
import sys
import time

from . import common, split

try:  # bench_lib/link.py comes with splitvk-link; without it, Link below starts the binary itself
    from . import link as link_module
except ImportError:
    link_module = None

APP_NAME = "splitvk-atrium"
LINK_PROFILES = ("direct", "none", "gige", "wifi5", "wifi6")  # direct: no proxy; none: splitvk-link unshaped
PLOT_SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "paper_plots.py")
PLOT_PYTHON = "/usr/bin/python3"
DOC_BEGIN = "<!-- bench paper: begin (scripts/bench paper --write-docs replaces this section) -->"
DOC_END = "<!-- bench paper: end -->"
# Runs with other render paths than direct, or several, write their per-path table here instead, so
# that the direct path's full section (and its figures) stays what its own run measured.
PATHS_BEGIN = "<!-- bench paper paths: begin (scripts/bench paper --path/--paths --write-docs replaces this section) -->"
PATHS_END = "<!-- bench paper paths: end -->"
RENDER_PATHS = ("direct", "hdr", "deferred", "multiview", "secondary", "compute")  # splitvk-atrium --path
# The periphery render is measured by the layer (SPLITVK_STATS' periphery_ms, GPU timestamps);
# --periphery-frames N adds the older estimate, a native run at the periphery's size.
# Variants of the split measured beside it (see measure): name -> how the tables call it.
VARIANTS = {"split-tls": "split over TLS 1.3", "split-guard": "split, agent scissor", "split-auto": "split, auto fovea",
            "split-shaded": "split, foveae shaded", "split-swapped": "swapped split (client renders the foveae)",
            "split-agents": "split, an agent per eye"}
XR_PATHS = ("direct", "hdr", "deferred")  # splitvk-atrium --xr, one swapchain per eye
# The modes whose latency the bench reports (frame_latency_ms), in its tables' order, and their names there.
LATENCY_MODES = {"native": "native (the layer, no agent)", "split": "split", "split-tls": VARIANTS["split-tls"],
                 "split-guard": VARIANTS["split-guard"], "split-auto": VARIANTS["split-auto"],
                 "split-shaded": VARIANTS["split-shaded"], "split-swapped": "swapped split",
                 "split-agents": VARIANTS["split-agents"],
                 "xr-native": "native through OpenXR", "xr-split": "split through OpenXR",
                 "xr-swapped": "swapped split through OpenXR"}
# The final lines' latency and pacing ratios (path_ratios' names), after split/native's four.
FINAL_LATENCY_LINES = ("latency-split/native", "latency-swapped/native", "pacing-split", "pacing-swapped")
XR_LAYER_NAME = "XR_APILAYER_SPLITVK_split_render"
XR_RUNTIME = os.path.join(common.REPO, "scripts", "xr-runtime")
FULL = {"frames": 350, "rounds": 3, "periphery_frames": 0}
QUICK = {"frames": 40, "rounds": 2, "periphery_frames": 0}


def cpu_list(text):
    """'0', '1-3,6' -> sorted list of ints (raises ValueError)."""
    cpus = set()
    for part in text.split(","):
        part = part.strip()
        if "-" in part:
            lo, hi = part.split("-", 1)
            cpus.update(range(int(lo), int(hi) + 1))
        elif part:
            cpus.add(int(part))
    if not cpus:
        raise ValueError(f"empty CPU list '{text}'")
    return sorted(cpus)


def path_names(text):
    """'hdr', 'all', 'direct,hdr' -> list of atrium render paths, in the order given, once each."""
    names = []
    for name in text.split(","):
        name = name.strip()
        if name == "all":
            wanted = list(RENDER_PATHS)
        elif name in RENDER_PATHS:
            wanted = [name]
        else:
            raise argparse.ArgumentTypeError(f"unknown render path '{name}' (expected {', '.join(RENDER_PATHS)} or all)")
        names += [n for n in wanted if n not in names]
    if not names:
        raise argparse.ArgumentTypeError("no render path given")
    return names


def guard_setting(text):
    """'guard:64' -> itself; anything else is a usage error (off is the plain split)."""
    head, _, n = text.partition(":")
    if head != "guard" or not n.isdigit():
        raise argparse.ArgumentTypeError(f"--agent-scissor '{text}': expected guard:N, N pixels (e.g. guard:64)")
    return text


def eye_size(text):
    """'1200x1080' -> (1200, 1080) (splitvk-atrium --xr-eye-size takes 16..16384 each)."""
    w, x, h = text.partition("x")
    if not x or not w.isdigit() or not h.isdigit() or not (16 <= int(w) <= 16384 and 16 <= int(h) <= 16384):
        raise argparse.ArgumentTypeError(f"--eye-size '{text}': expected WxH, each 16..16384 (e.g. 1200x1080)")
    return int(w), int(h)


def xr_eye_size(args):
    """The OpenXR runs' eye size: --eye-size, or one eye of the window (half its width)."""
    return args.eye_size or (max(16, args.width // 2), args.height)


def check_xr_paths(paths):
    """--xr draws per-eye swapchains, which atrium --xr does for direct, hdr and deferred only."""
    bad = [p for p in paths if p not in XR_PATHS]
    if bad:
        raise common.BenchError(f"--xr runs --path {', '.join(XR_PATHS)} only (atrium --xr draws no "
                                f"{', '.join(bad)} per eye)")


def cpu_text(cpus):
    return ",".join(str(c) for c in cpus)


def default_second_agent_cpus():
    """A core of its own for the second agent of --agents 2 when there is one past the client's and the
    first agent's defaults; else the first agent's."""
    cpus = sorted(os.sched_getaffinity(0))
    return cpu_text(cpus[2:3] or cpus[1:2] or cpus)


def default_cpus():
    """Client on the first CPU, the agent on the rest (on one CPU both share it)."""
    cpus = sorted(os.sched_getaffinity(0))
    client = cpus[:1]
    agent = cpus[1:] or cpus
    return cpu_text(client), cpu_text(agent)


def register(subparsers):
    client_cpus, agent_cpus = default_cpus()
    p = subparsers.add_parser(
        "paper", help="the paper's experiment on a confined (weak) client: tables, figures, docs",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true",
                   help=f"a short run: {QUICK['frames']} frames x {QUICK['rounds']} rounds (under 3 minutes); "
                        "does not write docs unless --write-docs")
    p.add_argument("--frames", type=int, help=f"frames per run (default: {FULL['frames']}; "
                                                f"the paper's 1000 frames are --frames 1000 --rounds 1)")
    p.add_argument("--rounds", type=int, help=f"native/split pairs (default: {FULL['rounds']})")
    p.add_argument("--warmup", type=int, default=10, help="frames left out at the start of each run (default: %(default)s)")
    p.add_argument("--periphery-frames", type=int,
                   help=f"frames of the per-round periphery-size native run, 0 for none (default: {FULL['periphery_frames']})")
    p.add_argument("--width", type=int, default=2400, help="window width (default: %(default)s)")
    p.add_argument("--height", type=int, default=1080, help="window height (default: %(default)s)")
    p.add_argument("--shaded-foveae", action="store_true",
                   help="also run each round's split with SPLITVK_FOVEA_MASK=off (split-shaded) and report the "
                        "periphery render of the split, whose foveae the depth mask leaves unshaded, over its")
    p.add_argument("--fovea", default="512x360",
                   help="SPLITVK_FOVEA per eye (default: %(default)s); auto or auto:WxH runs SPLITVK_FOVEA=auto beside "
                        "the split at 512x360 in every round (split-auto) and reports the size it settled at")
    p.add_argument("--scale", default="0.6", help="SPLITVK_SCALE (default: %(default)s)")
    p.add_argument("--client-renders", choices=("periphery", "fovea"), default="periphery",
                   help="fovea: also run each round's swapped split (split-swapped: SPLITVK_CLIENT_RENDERS=fovea, the "
                        "client renders only the foveae, the agent the periphery, lossily) and end with "
                        "swapped/native beside split/native (default: %(default)s: the paper's split alone)")
    p.add_argument("--picture-frame", type=int, default=30, metavar="N",
                   help="after the rounds, hold frame N-1 of native, the split and (with --client-renders fovea) the "
                        "swapped split on screen, grab each from the X server and report SSIM and PSNR against "
                        "native, over the frame and over the periphery; 0: none (default: %(default)s)")
    p.add_argument("--periphery-quality", default="23",
                   help="SPLITVK_PERIPHERY_QUALITY of the swapped split: x264 CRF 0-51 or lossless (default: %(default)s)")
    p.add_argument("--periphery-codec", choices=("h264", "hevc", "rgb"), default="h264",
                   help="SPLITVK_PERIPHERY_CODEC of the swapped split: 4:2:0 h264 or hevc, or rgb (x264 4:4:4) "
                        "(default: %(default)s)")
    p.add_argument("--codec", choices=("x264", "zstd", "raw"), default="x264", help="default: %(default)s")
    p.add_argument("--tile-wait", type=int, default=2000,
                   help="SPLITVK_TILE_WAIT in ms (default: %(default)s: frames are lockstep as in the paper, a "
                        "present waits for its tiles; the layer's 250 would show late frames from the periphery "
                        "alone, which flatters the split)")
    p.add_argument("--client-cpus", default=client_cpus,
                   help="CPUs of the weak client, taskset -c syntax (default here: %(default)s)")
    p.add_argument("--client-threads", type=int, default=1,
                   help="lavapipe rasterizer threads of the client, LP_NUM_THREADS (default: %(default)s)")
    p.add_argument("--agent-cpus", default=agent_cpus,
                   help="CPUs of splitvk-agent (and splitvk-link) (default here: %(default)s)")
    p.add_argument("--agents", type=int, choices=(1, 2), default=1,
                   help="2: also run each round's split with an agent per eye (split-agents: SPLITVK_AGENTS=2) "
                        "and report split-agents/split (default: %(default)s)")
    p.add_argument("--second-agent-cpus", default=default_second_agent_cpus(),
                   help="CPUs of the second agent with --agents 2 (default here: %(default)s)")
    p.add_argument("--link", choices=LINK_PROFILES, default="direct",
                   help="put splitvk-link with this profile between layer and agent: gige, wifi5 (the paper's "
                        "client link), wifi6, or none (forwarding only); direct: no proxy (default: %(default)s)")
    p.add_argument("--link-bin", help="splitvk-link to use (default: BUILD/bin/splitvk-link)")
    paths = p.add_mutually_exclusive_group()
    paths.add_argument("--path", dest="paths", type=path_names, metavar="NAME|all",
                       help=f"splitvk-atrium --path: {', '.join(RENDER_PATHS)}, or all of them (default: direct)")
    paths.add_argument("--paths", dest="paths", type=path_names, metavar="A,B,...",
                       help="several render paths, run in this order in every round")
    p.add_argument("--tls", action="store_true",
                   help="also run each round's split over TLS 1.3 (SPLITVK_TLS=on) and report split-tls/split")
    p.add_argument("--agent-scissor", type=guard_setting, metavar="guard:N",
                   help="also run each round's split with SPLITVK_AGENT_SCISSOR=guard:N and report split-guard/split")
    p.add_argument("--xr", action="store_true",
                   help="also run native and split through OpenXR (splitvk-atrium --xr under scripts/xr-runtime, "
                        "one swapchain per eye) and report xr split/native beside split/native")
    p.add_argument("--eye-size", type=eye_size, metavar="WxH",
                   help="with --xr: the eye swapchains' size (default: half the window, 1200x1080)")
    p.add_argument("--out-dir", help="per-frame CSVs, logs, results.json (default: BUILD/bench-paper)")
    p.add_argument("--figures-dir", help="where the PNGs go (default: docs/figures with --write-docs, else --out-dir)")
    docs = p.add_mutually_exclusive_group()
    docs.add_argument("--write-docs", dest="write_docs", action="store_true", default=None,
                      help="replace the paper section of docs/BENCHMARKS.md (default for a full run)")
    docs.add_argument("--no-write-docs", dest="write_docs", action="store_false")
    p.add_argument("--docs", default=os.path.join(common.REPO, "docs", "BENCHMARKS.md"), help=argparse.SUPPRESS)
    p.add_argument("--no-plots", action="store_true", help="skip the PNGs")
    p.add_argument("--from-results", metavar="JSON",
                   help="measure nothing: redo the tables, figures and docs from an earlier run's results.json")
    common.add_build_argument(p)
    common.add_driver_argument(p)
    p.add_argument("--agent-icd", default=None, metavar="JSON",
                   help="Vulkan driver manifest for splitvk-agent alone, e.g. a real GPU's "
                        "(default: the client's, --icd); scripts/device-check uses it")


# --- machine ------------------------------------------------------------------------------------

def machine_info():
    model = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem_gib = None
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    mem_gib = int(line.split()[1]) / (1024 * 1024)
    except OSError:
        pass
    mesa = "unknown"
    try:
        mesa = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", "mesa-vulkan-drivers"],
                              capture_output=True, text=True, timeout=10).stdout.strip() or mesa
    except (OSError, subprocess.SubprocessError):
        pass
    return {"cpu": model, "cores": os.cpu_count(), "mem_gib": mem_gib, "mesa": mesa,
            "kernel": platform.release(), "load_before": os.getloadavg()}


def describe_machine(m):
    mem = f"{m['mem_gib']:.0f} GiB" if m["mem_gib"] else "? GiB"
    return (f"{m['cpu']}, {m['cores']} cores, {mem}, Mesa {m['mesa']} (lavapipe), kernel {m['kernel']}")


# --- running --------------------------------------------------------------------------------------

class Link:
    """splitvk-link between the layer and the agent, or nothing for 'direct'. Uses bench_lib/link.py
    when this tree has it (and no --link-bin was given), else starts the binary with the same command
    line (--listen, --connect, --profile). `address` is what SPLITVK_SERVER must be."""

    def __init__(self, build, binary, profile, agent_port, cpus, env, log_path, explicit_binary):
        self.build, self.binary, self.profile, self.agent_port = build, binary, profile, agent_port
        self.cpus, self.env, self.log_path = cpus, env, log_path
        self.proc = None
        self.inner = None
        self.port = agent_port
        if profile != "direct" and link_module is not None and not explicit_binary:
            self.inner = link_module.Link(build, agent_port, profile=profile, cpus=cpus, env=env)

    @property
    def address(self):
        return self.inner.address if self.inner else f"127.0.0.1:{self.port}"

    def __enter__(self):
        if self.inner:
            self.inner.__enter__()
            return self
        if self.profile == "direct":
            return self
        self.port = split.free_port()
        self.log = open(self.log_path, "w")
        argv = ["taskset", "-c", self.cpus, self.binary, "--listen", f"127.0.0.1:{self.port}",
                                    "--connect", f"127.0.0.1:{self.agent_port}", "--profile", self.profile]
        self.proc = subprocess.Popen(argv, env=self.env, stdout=self.log, stderr=subprocess.STDOUT,
                                     start_new_session=True)
        time.sleep(0.5)
        if self.proc.poll() is not None:
            raise common.BenchError(f"splitvk-link did not start (see {self.log_path})")
        return self

    def __exit__(self, *exc):
        if self.inner:
            self.inner.__exit__(*exc)
            with open(self.log_path, "w") as f:
                f.write(self.inner.log)
        if self.proc:
            split.stop_group(self.proc)
            self.log.close()
        return False


def check_link(args, build):
    if args.link == "direct":
        return None
    binary = args.link_bin or os.path.join(build.path, "bin", "splitvk-link")
    if not os.path.exists(binary):
        raise common.MissingBuild(
            f"--link {args.link} needs splitvk-link, and {binary} does not exist: this tree does not build it "
            "yet (it comes with the splitvk-link work; once merged, rebuild with cmake --build build), "
            "or pass --link-bin PATH, or run with --link direct")
    return binary


def stereo_foveae(width, height, fovea):
    """The two foveae of a side-by-side window with SPLITVK_EYES=2: `fovea` (WxH, or the paper's
    512x360 for auto) centred in each eye, as (x, y, w, h)."""
    try:
        fw, fh = (int(v) for v in fovea.lower().split("x"))
    except ValueError:
        fw, fh = 512, 360
    eye_w = width // 2
    fw, fh = min(fw, eye_w), min(fh, height)
    return [(e * eye_w + (eye_w - fw) // 2, (height - fh) // 2, fw, fh) for e in (0, 1)]


SSIM_RE = re.compile(r"SSIM .*All:([0-9.]+|inf)")
PSNR_RE = re.compile(r"PSNR .*average:([0-9.]+|inf)")


def picture_quality(reference, picture, foveae):
    """SSIM and PSNR of the PNG `picture` against `reference` (ffmpeg's ssim and psnr filters), over the
    whole frame and over the periphery alone. For the periphery both pictures get the foveae painted
    black, so that the foveae add no error, and the error is spread over the periphery's pixels:
    PSNR exactly (the mean squared error over the periphery is the frame's over its share of the
    pixels), SSIM to the windows that straddle a fovea's edge (1 - SSIM over the periphery's share).
    Both splits' foveae are exact against native, so the periphery is where they differ."""
    def measure(boxes):
        paint = ",".join(f"drawbox=x={x}:y={y}:w={w}:h={h}:color=black:t=fill" for x, y, w, h in boxes) or "null"
        graph = (f"[0:v]format=rgb24,{paint},split[a1][a2];[1:v]format=rgb24,{paint},split[b1][b2];"
                 "[a1][b1]ssim;[a2][b2]psnr")
        r = subprocess.run(["ffmpeg", "-hide_banner", "-nostats", "-i", reference, "-i", picture,
                            "-filter_complex", graph, "-f", "null", "-"],
                           stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        ssim, psnr = SSIM_RE.search(r.stderr), PSNR_RE.search(r.stderr)
        if r.returncode != 0 or not ssim or not psnr:
            raise common.BenchError(f"ffmpeg could not compare {picture} with {reference}:\n" + common.tail(r.stderr))
        return float(ssim.group(1)), float(psnr.group(1))

    whole_ssim, whole_psnr = measure([])
    painted_ssim, painted_psnr = measure(foveae)
    with open(reference, "rb") as f:  # the PNG's IHDR: width and height at bytes 16..24
        header = f.read(24)
    pixels = int.from_bytes(header[16:20], "big") * int.from_bytes(header[20:24], "big")
    periphery_ssim, periphery_psnr = periphery_scores(painted_ssim, painted_psnr,
                                                      1 - sum(w * h for _, _, w, h in foveae) / pixels)
    return {"ssim": whole_ssim, "psnr": whole_psnr, "periphery_ssim": periphery_ssim, "periphery_psnr": periphery_psnr}


def periphery_scores(painted_ssim, painted_psnr, share):
    """The periphery's SSIM and PSNR from the frame's, measured with the foveae painted alike in both
    pictures, where the periphery is `share` of the pixels (see picture_quality)."""
    psnr = painted_psnr + 10 * math.log10(share) if math.isfinite(painted_psnr) else painted_psnr
    return 1 - (1 - painted_ssim) / share, psnr


def grab_pictures(args, build, path, out_dir, timeout_s, held_argv, envs):
    """--picture-frame: native, the split and the swapped split (where `envs` has one) each hold frame
    N-1 of `path` on screen, grabbed from the X server; returns {mode: picture_quality against native}."""
    frames = args.picture_frame
    prefix = "" if path == "direct" else f"{path}-"
    grabs = {}
    for mode, env in envs.items():
        if env is None:
            continue
        grabs[mode] = os.path.join(out_dir, f"{prefix}{mode}-frame{frames - 1}.png")
        common.run_held(build, held_argv(frames), env, frames - 1, grabs[mode], args.width, args.height, out_dir,
                        f"{prefix}{mode}-hold", timeout_s)
    foveae = stereo_foveae(args.width, args.height, args.fovea)
    quality = {mode: dict(picture_quality(grabs["native"], png, foveae), frame=frames - 1, png=png)
               for mode, png in grabs.items() if mode != "native"}
    print(f"  pictures{'' if path == 'direct' else ' ' + path} (frame {frames - 1} against native): "
          + "   ".join(f"{mode} SSIM {q['ssim']:.4f} PSNR {q['psnr']:.2f} dB (periphery {q['periphery_ssim']:.4f}, "
                       f"{q['periphery_psnr']:.2f} dB)" for mode, q in quality.items()), flush=True)
    return quality


def check_unsplit(r, what):
    """Raises unless the run r (the layer without an agent) found no agent and split nothing."""
    if "running unsplit until one answers" not in r.stderr or "[splitvk] split:" in r.stderr:
        raise common.BenchError(f"{what} was to run through the layer without an agent, unsplit:\n"
                                + common.tail(r.stderr))


def cpu_run(argv, env, timeout_s, frames, cpu):
    """common.run, adding the run's CPU time per frame (user + system of the app and its threads,
    start-up included, from the children's rusage) to the list `cpu`."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = common.run(argv, env, timeout_s)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu.append(((after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)) * 1000 / frames)
    return r


def read_frame_times(path, warmup):
    with open(path) as f:
        next(f)
        values = [float(line.split(",")[1]) for line in f if line.strip()]
    return values[warmup:]


def measure(args):
    build = common.Build(args.build)
    build.check()
    agent = os.path.join(build.path, "bin", "splitvk-agent")
    if not os.path.exists(agent):
        raise common.MissingBuild(f"{agent} is missing; build the tree first")
    link_bin = check_link(args, build)
    if min(args.frames, args.rounds, args.width, args.height, args.client_threads) < 1 or args.warmup < 0 \
            or args.warmup >= args.frames or args.periphery_frames < 0:
        raise common.BenchError("need positive sizes and --warmup < --frames")
    if args.periphery_frames and args.periphery_frames <= args.warmup:
        raise common.BenchError("--periphery-frames must exceed --warmup (or be 0)")
    if not shutil.which("taskset"):
        raise common.BenchError("taskset is missing (apt-get install util-linux)")
    try:
        client_cpus, agent_cpus = cpu_list(args.client_cpus), cpu_list(args.agent_cpus)
        second_cpus = cpu_list(args.second_agent_cpus) if args.agents > 1 else []
    except ValueError as e:
        raise common.BenchError(f"bad CPU list: {e}")
    if args.agents > 1 and args.link != "direct":
        raise common.BenchError("--agents 2 takes --link direct (the link emulates one agent's path)")
    available = os.sched_getaffinity(0)
    for c in client_cpus + agent_cpus + second_cpus:
        if c not in available:
            raise common.BenchError(f"CPU {c} is not available to this process (have {cpu_text(sorted(available))})")
    if args.picture_frame < 0 or args.picture_frame > args.frames:
        raise common.BenchError("--picture-frame must be between 0 and --frames")
    if args.eye_size and not args.xr:
        raise common.BenchError("--eye-size goes with --xr")
    if args.xr:
        check_xr_paths(args.paths)
        if not os.path.isdir(build.xr_manifest_dir):
            raise common.MissingBuild(f"{build.xr_manifest_dir} is missing: --xr needs splitvk's OpenXR layer built")
        # Monado, built once into the cache, before anything is timed.
        subprocess.run([XR_RUNTIME, "build"], check=True, stdout=subprocess.DEVNULL)
    ew, eh = xr_eye_size(args)
    scale = float(args.scale)
    pw, ph = max(16, round(args.width * scale)), max(16, round(args.height * scale))

    out_dir = args.out_dir or os.path.join(build.path, "bench-paper")
    os.makedirs(out_dir, exist_ok=True)
    for name in os.listdir(out_dir):  # no stale CSVs from an earlier run
        if name.endswith(".csv"):
            os.remove(os.path.join(out_dir, name))
    client_prefix = ["taskset", "-c", cpu_text(client_cpus)]
    agent_prefix = ["taskset", "-c", cpu_text(agent_cpus)]

    def argv(path, width, height, frames, times_path):
        return client_prefix + [build.atrium, "--path", path, "--width", str(width), "--height", str(height),
                                "--eyes", "2", "--frames", str(frames), "--present-mode", "immediate",
                                "--frame-times", times_path]

    def xr_argv(path, frames, times_path):
        # The runtime's service outside the confinement (the headset's compositor), the app inside it.
        return [XR_RUNTIME, "run", "--"] + client_prefix + [
            build.atrium, "--xr", "--path", path, "--xr-eye-size", f"{ew}x{eh}", "--frames", str(frames),
            "--frame-times", times_path]

    timeout_s = 300 + 3 * args.frames
    agent_port = split.free_port()
    machine = machine_info()
    print(f"paper: {APP_NAME} {args.width}x{args.height} stereo, fovea {args.fovea} per eye, scale {args.scale} "
          f"(periphery {pw}x{ph}), codec {args.codec}, moving camera; {args.frames} frames per run "
          f"({args.warmup} warm-up left out), {args.rounds} rounds native/split alternating"
          + (" with a split over TLS 1.3" if args.tls else "")
          + (f" with a split at SPLITVK_AGENT_SCISSOR={args.agent_scissor}" if args.agent_scissor else "")
          + (f", and native/split through OpenXR at {ew}x{eh} per eye" if args.xr else "")
          + f"; render path(s): {', '.join(args.paths)}"
          + (f", periphery-size native runs of {args.periphery_frames} frames" if args.periphery_frames else ""),
          flush=True)
    print(f"paper: weak client on CPU {cpu_text(client_cpus)} with LP_NUM_THREADS={args.client_threads}; "
          f"agent on CPU {cpu_text(agent_cpus)} (LP_NUM_THREADS={len(agent_cpus)}); link: {args.link}", flush=True)
    if args.agents > 1:
        shared = sorted(set(second_cpus) & set(agent_cpus + client_cpus))
        print(f"paper: --agents 2: second agent on CPU {cpu_text(second_cpus)} (LP_NUM_THREADS={len(second_cpus)})"
              + (f"; it shares CPU {cpu_text(shared)} with the client or the first agent, since this machine has "
                 f"{len(available)} cores: each agent renders the whole frame, so split-agents/split here says what "
                 f"sharing costs, not what a second GPU gains (scripts/device-check measures that on 16 cores)"
                 if shared else ""), flush=True)
    print(f"paper: machine: {describe_machine(machine)}; load average before: "
          + " ".join(f"{x:.2f}" for x in machine["load_before"]), flush=True)
    if args.quick:
        print(f"paper: --quick: {args.frames} frames x {args.rounds} rounds, a sketch of the full run "
              f"(scripts/bench paper: {FULL['frames']} x {FULL['rounds']}); its numbers are noisier", flush=True)

    # Per path: frame times of each run (after the warm-up), the split runs' stats rows, CPU per frame.
    modes = ["native", "split"] + [v for v, on in (("split-tls", args.tls), ("split-guard", args.agent_scissor),
                                                   ("split-auto", args.fovea_auto),
                                                   ("split-shaded", args.shaded_foveae),
                                                   ("split-swapped", args.client_renders == "fovea"),
                                                   ("split-agents", args.agents > 1)) if on]
    modes += ["xr-native", "xr-split"] if args.xr else []
    modes += ["xr-swapped"] if args.xr and args.client_renders == "fovea" else []
    # latency: each run's frame_latency_ms values (SPLITVK_STATS), every mode's, native's too.
    runs = {path: dict({m: [] for m in modes}, periphery=[], cpu={m: [] for m in modes}, variant_rows={},
                       latency={m: [] for m in modes})
            for path in args.paths}
    start = time.monotonic()
    with common.display(build) as disp:
        base = common.clean_env(args.icd)
        base["DISPLAY"] = disp
        client_env = dict(base, LP_NUM_THREADS=str(args.client_threads))
        agent_env = dict(base, LP_NUM_THREADS=str(len(agent_cpus)))
        if args.agent_icd:
            agent_env["VK_DRIVER_FILES"] = args.agent_icd
        second_env = dict(base, LP_NUM_THREADS=str(len(second_cpus) or 1))
        if args.agent_icd:
            second_env["VK_DRIVER_FILES"] = args.agent_icd
        with common.started_agent(build, agent, agent_env, out_dir, agent_port, agent_prefix), \
                Link(build, link_bin, args.link, agent_port, cpu_text(agent_cpus), base,
                     os.path.join(out_dir, "link.log"), bool(args.link_bin)) as link, \
                contextlib.ExitStack() as more_agents:
            second = more_agents.enter_context(common.started_agent(
                build, agent, second_env, out_dir, 0, ["taskset", "-c", cpu_text(second_cpus)],
                name="second-agent")) if args.agents > 1 else None
            split_env = dict(common.layer_env(client_env, build), SPLITVK_SERVER=link.address,
                             SPLITVK_LOG_LEVEL="info", SPLITVK_SCALE=args.scale, SPLITVK_CODEC=args.codec,
                             SPLITVK_EYES="2", SPLITVK_FOVEA=args.fovea,
                             SPLITVK_TILE_WAIT=str(args.tile_wait))
            # Lockstep under OpenXR too: the display-time deadline would show the periphery of every
            # frame a CPU agent finishes after the display time, and the experiment measures the split.
            split_env["SPLITVK_XR_DEADLINE"] = "off"
            variant_env = {}
            if args.tls:  # to the same agent (it serves both on one port), through the link too
                variant_env["split-tls"] = common.tls_split_env(split_env, agent, out_dir, base)
            if args.agent_scissor:
                variant_env["split-guard"] = dict(split_env, SPLITVK_AGENT_SCISSOR=args.agent_scissor)
            if args.fovea_auto:
                variant_env["split-auto"] = dict(split_env, SPLITVK_FOVEA=args.fovea_auto)
            if args.shaded_foveae:
                variant_env["split-shaded"] = dict(split_env, SPLITVK_FOVEA_MASK="off")
            if second:
                variant_env["split-agents"] = dict(split_env, SPLITVK_AGENTS="2",
                                                   SPLITVK_SERVER=f"{link.address},{second['address']}")
            if args.client_renders == "fovea":
                variant_env["split-swapped"] = dict(split_env, SPLITVK_CLIENT_RENDERS="fovea",
                                                    SPLITVK_PERIPHERY_QUALITY=args.periphery_quality,
                                                    SPLITVK_PERIPHERY_CODEC=args.periphery_codec)
            # Native is the layer without an agent (its SPLITVK_SERVER a port nothing listens on): every
            # frame unsplit, its latency measured by the same clock at the same points as the split's.
            # scripts/bench passthrough --stats measures what the layer costs it.
            native_env = dict(common.layer_env(client_env, build), SPLITVK_SERVER=f"127.0.0.1:{split.free_port()}")
            # Through OpenXR: splitvk's OpenXR layer too (docs/user-guide.md, "OpenXR applications").
            xr_layers = {"XR_API_LAYER_PATH": build.xr_manifest_dir, "XR_ENABLE_API_LAYERS": XR_LAYER_NAME}
            xr_split_env = dict(split_env, **xr_layers)
            xr_native_env = dict(native_env, **xr_layers)
            xr_swapped_env = dict(xr_split_env, SPLITVK_CLIENT_RENDERS="fovea",
                                  SPLITVK_PERIPHERY_QUALITY=args.periphery_quality)
            for i in range(args.rounds):
                # Native and split alternate their order every round; the variants trade ends with
                # native, so the plain split sits next to native in one round and to them in the next.
                order = tuple(modes)
                if i % 2:
                    order = order[::-1]
                for path in args.paths:
                    got, line = runs[path], []
                    prefix = "" if path == "direct" else f"{path}-"  # a direct run's files keep their names
                    for mode in order:
                        times = os.path.join(out_dir, f"{prefix}{mode}-round{i + 1}-frames.csv")
                        stats = os.path.join(out_dir, f"{prefix}{mode}-round{i + 1}.csv")
                        if mode in ("xr-native", "xr-split", "xr-swapped"):
                            # No client CPU time: the runtime's service is a child of the run too.
                            env = dict({"xr-native": xr_native_env, "xr-split": xr_split_env,
                                        "xr-swapped": xr_swapped_env}[mode], SPLITVK_STATS=stats)
                            r = common.run(xr_argv(path, args.frames, times), env, timeout_s)
                            # A row per eye image: two per frame.
                            got["latency"][mode].append(frame_latencies(split.read_stats(stats, 2 * args.warmup)))
                            if mode == "xr-native":
                                check_unsplit(r, f"the OpenXR native run (--path {path})")
                                got[mode].append(read_frame_times(times, args.warmup))
                            else:
                                summary = "[splitvk] split (client renders fovea):" if mode == "xr-swapped" \
                                    else "[splitvk] split:"
                                if "running unsplit" in r.stderr or "eye images of its Vulkan device are split" \
                                        not in r.stderr or summary not in r.stderr or \
                                        (mode == "xr-swapped" and "are cut to the foveae" not in r.stderr):
                                    raise common.BenchError(f"the OpenXR {mode} run (--path {path}) did not split:\n"
                                                            + common.tail(r.stderr))
                                got[mode].append((read_frame_times(times, args.warmup),
                                                  split.read_stats(stats, 2 * args.warmup)))
                        elif mode == "native":
                            r = cpu_run(argv(path, args.width, args.height, args.frames, times),
                                        dict(native_env, SPLITVK_STATS=stats), timeout_s, args.frames,
                                        got["cpu"]["native"])
                            check_unsplit(r, f"the native run (--path {path})")
                            got["native"].append(read_frame_times(times, args.warmup))
                            got["latency"]["native"].append(frame_latencies(split.read_stats(stats, args.warmup)))
                        elif mode == "split":
                            r = cpu_run(argv(path, args.width, args.height, args.frames, times),
                                        dict(split_env, SPLITVK_STATS=stats), timeout_s, args.frames,
                                        got["cpu"]["split"])
                            if "running unsplit" in r.stderr or "[splitvk] split:" not in r.stderr:
                                raise common.BenchError(f"the split run (--path {path}) did not split:\n"
                                                        + common.tail(r.stderr))
                            got["split"].append((read_frame_times(times, args.warmup),
                                                 split.read_stats(stats, args.warmup)))
                            got["latency"]["split"].append(frame_latencies(got["split"][-1][1]))
                        else:
                            # Its stats: the size an auto fovea settled at, a variant's periphery render.
                            r = cpu_run(argv(path, args.width, args.height, args.frames, times),
                                        dict(variant_env[mode], SPLITVK_STATS=stats), timeout_s, args.frames,
                                        got["cpu"][mode])
                            got["variant_rows"].setdefault(mode, []).append(split.read_stats(stats, args.warmup))
                            # The layer's info line: the periphery's stream and what decoded it.
                            decoder = re.search(r"^\[splitvk\] periphery: (.*)$", r.stderr, re.M)
                            if mode == "split-swapped" and decoder:
                                got["periphery_decoder"] = decoder.group(1)
                            got["latency"][mode].append(frame_latencies(got["variant_rows"][mode][-1]))
                            summary = "[splitvk] split (client renders fovea):" if mode == "split-swapped" \
                                else "[splitvk] split:"
                            if mode == "split-tls":
                                common.check_tls_split(r)
                            elif mode == "split-agents" and "for eye 2 of 2" not in r.stderr:
                                raise common.BenchError(f"the {mode} run (--path {path}) did not split with an "
                                                        "agent per eye:\n" + common.tail(r.stderr))
                            elif "running unsplit" in r.stderr or summary not in r.stderr:
                                raise common.BenchError(f"the {mode} run (--path {path}) did not split:\n"
                                                        + common.tail(r.stderr))
                            got[mode].append(read_frame_times(times, args.warmup))
                        m, iqr, _ = r.frame_time()
                        line.append(f"{mode} {m:7.2f} ms/frame (IQR {iqr:.2f})")
                    if args.periphery_frames:
                        times = os.path.join(out_dir, f"{prefix}periphery-round{i + 1}-frames.csv")
                        common.run(argv(path, pw, ph, args.periphery_frames, times), client_env, timeout_s)
                        got["periphery"].append(read_frame_times(times, args.warmup))
                        line.append(f"periphery {split.median(got['periphery'][-1]):6.2f}")
                    label = f" {path}" if len(args.paths) > 1 or path != "direct" else ""
                    print(f"  round {i + 1}/{args.rounds}{label}: " + "   ".join(line)
                          + f"   [{time.monotonic() - start:5.0f} s, load {os.getloadavg()[0]:.2f}]", flush=True)
            if args.picture_frame:
                for path in args.paths:
                    runs[path]["pictures"] = grab_pictures(
                        args, build, path, out_dir, timeout_s,
                        lambda frames, p=path: argv(p, args.width, args.height, frames, os.devnull) + ["--hold"],
                        {"native": client_env, "split": split_env, "split-swapped": variant_env.get("split-swapped")})
    machine["load_after"] = os.getloadavg()
    return summarize(args, machine, runs, (pw, ph), out_dir, time.monotonic() - start)


# --- numbers ---------------------------------------------------------------------------------------

def q3(values):
    q1, m, q3_ = common.quartiles(values)
    # The mean too: lockstep frames behind a slower agent alternate between two times (one waits,
    # the next does not), and the median then picks one mode rather than the rate frames come at.
    mean = sum(values) / len(values) if values else 0.0
    # p99 over the median is the pacing: how much longer the slow frames are than the typical one.
    return {"median": m, "mean": mean, "iqr": q3_ - q1, "q1": q1, "q3": q3_,
            "p99": common.percentile(values, 99) if values else 0.0, "n": len(values)}


def frame_latencies(rows):
    """SPLITVK_STATS' frame_latency_ms of each frame in `rows`: one per OpenXR frame (each of its eye
    images' rows carries the frame's one value), none where the layer did not see the frame start."""
    values, frames = [], set()
    for r in rows:
        if not r.get("frame_latency_ms"):
            continue
        xr_frame = int(r.get("xr_frame") or -1)
        if xr_frame >= 0:
            if xr_frame in frames:
                continue
            frames.add(xr_frame)
        values.append(float(r["frame_latency_ms"]))
    return values


def typical_frame(rows, stages):
    """The on-time split frame closest to the medians of its frame time and stages (and its predecessor)."""
    best, best_i = None, None
    keys = (("frame_ms", "frame"), ("tile_wait_ms", "tile_wait"), ("decode_ms", "decode"),
            ("merge_ms", "merge"), ("agent_draw_ms", "draw"), ("agent_encode_ms", "encode"),
            ("network_ms", "network"))
    for i in range(1, len(rows)):
        r, prev = rows[i], rows[i - 1]
        if r["late"] != "0" or int(r["frame"]) != int(prev["frame"]) + 1:
            continue
        score = 0.0
        for col, key in keys:
            ref = stages[key]
            score += abs(float(r[col]) - ref) / max(ref, 1.0)
        if best is None or score < best:
            best, best_i = score, i
    if best_i is None:
        return None
    return rows[best_i - 1], rows[best_i]


def timeline(prev, row, periphery_ms, periphery_kind="estimated"):
    """Segments (lane, label, start, duration) of one split frame, t = 0 at the previous frame's present.

    Known from the CSV: frame_ms (present to present, measured where the present starts waiting),
    the previous frame's tile wait and merge, this frame's tile wait, decode, merge, network, agent
    draw/readback/encode. Derived: the app's time before its present S = frame_ms - prev wait - prev
    merge; the tiles arrive at S + tile_wait - decode (the tile wait ends when the slower eye is
    decoded); the agent sends at arrival - network; encode, readback and draw end back to back before
    that. Assumed: the periphery render ends at the present's start (or starts at 0 when longer),
    because lavapipe executes a submit on the submitting thread and rasterises at the next flush."""
    f = lambda k, r=row: float(r[k])  # noqa: E731
    prev_tail = f("tile_wait_ms", prev) + f("merge_ms", prev)
    S = max(0.0, f("frame_ms") - prev_tail)
    wait, decode, merge, network = f("tile_wait_ms"), f("decode_ms"), f("merge_ms"), f("network_ms")
    arrive = max(0.0, S + wait - decode)  # the wait ends when the slower eye is decoded, or at once
    send = max(0.0, arrive - network)
    enc_start = send - f("agent_encode_ms")
    rb_start = enc_start - f("agent_readback_ms")
    draw_start = rb_start - f("agent_draw_ms")
    segs = [
        ("client app thread", "app: fence wait, acquire, record, capture, submit", 0.0, S),
        ("client app thread", "tile wait", S, wait),
        ("client app thread", "upload + merge", S + wait, merge),
        ("agent", "draw (replay, fovea only)", draw_start, f("agent_draw_ms")),
        ("agent", "readback", rb_start, f("agent_readback_ms")),
        ("agent", "encode (eyes in parallel)", enc_start, f("agent_encode_ms")),
        ("network", "FramePresent ->", S, 0.0),
        ("network", "tiles <- network", send, max(0.0, arrive - send)),
        ("client decoders", "decode (slower eye)", arrive, decode),
    ]
    if periphery_ms is not None:
        # The row's own GPU measurement when there is one (the latest completed split pass). Lavapipe
        # runs a submit's work on the submitting thread before vkQueueSubmit returns (it has no
        # queue thread), and atrium presents right after submitting: the periphery render ends about
        # where the present starts.
        own = float(row.get("periphery_ms") or 0) or periphery_ms
        segs.insert(1, ("client lavapipe", f"periphery render ({periphery_kind})", max(0.0, S - own), own))
    return {"frame": int(row["frame"]), "frame_ms": f("frame_ms"), "present_at": S + wait + merge, "segments": segs}


def periphery_label(config):
    return "GPU timestamps" if config.get("periphery_source") == "gpu" else "est."


def periphery_note(config):
    if config.get("periphery_source") == "gpu":
        return "periphery render as the layer measured it on the client's GPU (timestamp queries around the split pass)"
    return f"periphery render estimated by a native run at {config['periphery']}"


def path_summary(path, runs):
    """One render path's numbers from its runs (see measure), without the per-frame lists."""
    native = [v for run in runs["native"] for v in run]
    split_times = [v for run, _ in runs["split"] for v in run]
    rows = [r for _, rows in runs["split"] for r in rows]
    stages = split.stage_medians(rows)
    stages["frame"] = split.median([float(r["frame_ms"]) for r in rows if float(r["frame_ms"]) > 0])
    # Measured on the client's GPU when the layer wrote it; else the periphery-size native estimate.
    measured = [float(r["periphery_ms"]) for r in rows if float(r.get("periphery_ms") or 0) > 0]
    periphery = measured or [v for run in runs["periphery"] for v in run]
    return {
        "path": path, "native": q3(native), "split": q3(split_times),
        "variants": {v: dict(q3([t for run in runs[v] for t in run]), rounds=[split.median(r) for r in runs[v]])
                     for v in VARIANTS if runs.get(v)},
        "native_rounds": [split.median(r) for r in runs["native"]],
        "split_rounds": [split.median(r) for r, _ in runs["split"]],
        "periphery": q3(periphery) if periphery else None,
        "periphery_source": "gpu" if measured else ("estimate" if periphery else None),
        "stages": stages,
        "client_cpu": {k: split.median(v) for k, v in runs["cpu"].items() if v},
        "xr": xr_summary(runs),
        "auto": auto_summary(runs.get("variant_rows", {}).get("split-auto")),
        "swapped": swapped_summary(runs.get("variant_rows", {}).get("split-swapped"), runs.get("periphery_decoder")),
        "pictures": runs.get("pictures"),
        # frame_latency_ms of every mode that has it (runs of a bench from before it: none).
        "latency": {m: q3(values) for m, values in
                    ((m, [v for run in runs.get("latency", {}).get(m, []) for v in run]) for m in LATENCY_MODES)
                    if values},
        "variant_periphery": {v: q3(g) for v, g in
                              ((v, [float(r["periphery_ms"]) for rnd in rounds for r in rnd
                                    if float(r.get("periphery_ms") or 0) > 0])
                               for v, rounds in runs.get("variant_rows", {}).items()) if g},
    }


def auto_summary(rounds):
    """SPLITVK_FOVEA=auto's runs: the size it settled at (the median fovea of each round's last quarter
    of frames, the first eye's), its late frames and its tile traffic; None when it did not run."""
    if not rounds:
        return None
    settled = []
    for rows in rounds:
        tail = rows[len(rows) * 3 // 4:]
        w = split.median([float(r["fovea_w"]) for r in tail])
        h = split.median([float(r["fovea_h"]) for r in tail])
        settled.append(f"{w:.0f}x{h:.0f}")
    rows = [r for rnd in rounds for r in rnd]
    seconds = sum(float(r["frame_ms"]) for r in rows) / 1000
    return {"settled": settled, "late": sum(r["late"] != "0" for r in rows), "frames": len(rows),
            "mbps": sum(int(r["tile_bytes"]) for r in rows) * 8 / 1e6 / seconds if seconds else 0.0}


def swapped_summary(rounds, decoder=None):
    """The swapped split's runs (--client-renders fovea): the client's own render (SPLITVK_STATS'
    periphery_ms, its cut passes on its GPU), the agent's periphery draw (agent_draw_ms: the GPU time
    of the frame's replay, drawn scaled), the periphery's traffic and decode, late frames; None when it
    did not run."""
    if not rounds:
        return None
    rows = [r for rnd in rounds for r in rnd]
    seconds = sum(float(r["frame_ms"]) for r in rows) / 1000
    periphery_bytes = [int(r.get("periphery_bytes") or 0) for r in rows]
    own = [float(r["periphery_ms"]) for r in rows if float(r.get("periphery_ms") or 0) > 0]
    agent = [float(r["agent_draw_ms"]) for r in rows if float(r.get("agent_draw_ms") or 0) > 0]
    return {"client_render": q3(own) if own else None,
            "agent_draw": q3(agent) if agent else None,
            "mbps": sum(periphery_bytes) * 8 / 1e6 / seconds if seconds else 0.0,
            "kib_per_frame": sum(periphery_bytes) / 1024 / len(rows) if rows else 0.0,
            "decode": split.median([float(r.get("periphery_decode_ms") or 0) for r in rows]),
            # At 90 Hz, a headset's rate, beside the rate the runs went at ("mbps").
            "mbps_90hz": sum(periphery_bytes) * 8 * 90 / 1e6 / len(rows) if rows else 0.0,
            "decoder": decoder,
            "late": sum(r["late"] != "0" for r in rows), "frames": len(rows)}


def xr_summary(runs):
    """The OpenXR runs of one path (--xr): native and split frame times, the split's stages; None
    without them."""
    if not runs.get("xr-native") or not runs.get("xr-split"):
        return None
    rows = [r for _, rows in runs["xr-split"] for r in rows]
    return {"native": q3([v for run in runs["xr-native"] for v in run]),
            "split": q3([v for run, _ in runs["xr-split"] for v in run]),
            "native_rounds": [split.median(r) for r in runs["xr-native"]],
            "split_rounds": [split.median(r) for r, _ in runs["xr-split"]],
            "stages": split.stage_medians(rows),
            "swapped": q3([v for run, _ in runs["xr-swapped"] for v in run]) if runs.get("xr-swapped") else None}


def summarize(args, machine, runs, periphery_size, out_dir, wall_s):
    """The first path's numbers as the single-path report has them (tables, figures, docs), and
    every path's in per_path."""
    first = args.paths[0]
    per_path = [path_summary(path, runs[path]) for path in args.paths]
    p = per_path[0]
    rows = [r for _, rows in runs[first]["split"] for r in rows]
    typical = typical_frame(rows, p["stages"])
    res = {
        "date": datetime.date.today().isoformat(),
        "command": " ".join(["scripts/bench", "paper"] + [shlex.quote(a) for a in sys.argv[2:]])
                   if len(sys.argv) > 1 and sys.argv[1] == "paper" else "scripts/bench paper",
        "machine": machine, "wall_s": wall_s, "out_dir": out_dir,
        "config": {"width": args.width, "height": args.height, "fovea": args.fovea, "scale": args.scale,
                   "periphery": f"{periphery_size[0]}x{periphery_size[1]}", "codec": args.codec,
                   "frames": args.frames, "rounds": args.rounds, "warmup": args.warmup,
                   "periphery_frames": args.periphery_frames, "client_cpus": args.client_cpus,
                   "client_threads": args.client_threads, "tile_wait": args.tile_wait, "agent_cpus": args.agent_cpus, "link": args.link,
                   "quick": args.quick, "periphery_source": p["periphery_source"],
                   "paths": list(args.paths), "tls": args.tls,
                   "agent_scissor": args.agent_scissor, "fovea_auto": args.fovea_auto,
                   "shaded_foveae": args.shaded_foveae, "xr": args.xr,
                   "client_renders": args.client_renders, "periphery_quality": args.periphery_quality,
                   "periphery_codec": args.periphery_codec, "agents": args.agents,
                   "second_agent_cpus": args.second_agent_cpus if args.agents > 1 else None,
                   "eye_size": "{}x{}".format(*xr_eye_size(args)) if args.xr else None},
        "native": p["native"], "split": p["split"],
        "native_rounds": p["native_rounds"], "split_rounds": p["split_rounds"],
        "periphery": p["periphery"],
        "stages": p["stages"],
        "client_cpu": {k: v for k, v in p["client_cpu"].items() if k in ("native", "split")},
        "typical_rows": list(typical) if typical else None,
        "native_frames": [v for run in runs[first]["native"] for v in run],
        "split_frames": [v for run, _ in runs[first]["split"] for v in run],
        "latency_frames": {LATENCY_MODES[m]: [v for run in values for v in run]
                           for m, values in runs[first]["latency"].items() if any(values)},
        "per_path": per_path,
        "xr": p["xr"],
    }
    return res


# --- output ----------------------------------------------------------------------------------------

def variants_of(p):
    """A path_summary's split variants, name -> quartiles and rounds (results.json of runs from before
    the variants table kept the TLS split as split_tls)."""
    if "variants" in p:
        return p["variants"]
    return {"split-tls": dict(p["split_tls"], rounds=p.get("split_tls_rounds", []))} if p.get("split_tls") else {}


def run_variants(res):
    """The variants the run measured, in VARIANTS order."""
    config = res["config"]
    on = {"split-tls": config.get("tls"), "split-guard": config.get("agent_scissor"),
          "split-auto": config.get("fovea_auto"), "split-shaded": config.get("shaded_foveae"),
          "split-swapped": config.get("client_renders") == "fovea", "split-agents": config.get("agents", 1) > 1}
    return [v for v in VARIANTS if on[v]]


def variant_label(res, name):
    setting = {"split-guard": res["config"].get("agent_scissor"),
               "split-auto": res["config"].get("fovea_auto")}.get(name)
    auto = ((res.get("per_path") or [{}])[0]).get("auto") if name == "split-auto" else None
    settled = f", settled at {', '.join(auto['settled'])}" if auto else ""
    return f"{VARIANTS[name]} ({setting}{settled})" if setting else VARIANTS[name]


def variant_rows_markdown(res):
    """Each split variant and VARIANT/split under the end-to-end table."""
    rows = []
    for name, t in variants_of((res.get("per_path") or [{}])[0]).items():
        rounds = ", ".join(f"{v:.1f}" for v in t.get("rounds", []))
        rows += [f"| {variant_label(res, name)} | {t['median']:.2f} | {t['iqr']:.2f} | {t['n']} | {rounds} |",
                 f"| **{name} / split** | **{t['median'] / res['split']['median']:.3f}** | | | |"]
    return rows


def xr_rows_markdown(res):
    """Native and split through OpenXR and their ratio under the end-to-end table (--xr)."""
    xr = res.get("xr")
    if not xr:
        return []
    n, sp = xr["native"], xr["split"]
    eye = res["config"].get("eye_size")
    return [f"| native through OpenXR ({eye} per eye) | {n['median']:.2f} | {n['iqr']:.2f} | {n['n']} | "
            + ", ".join(f"{v:.1f}" for v in xr["native_rounds"]) + " |",
            f"| split through OpenXR ({xr['stages']['late']} of {xr['stages']['frames']} eye images late) | "
            f"{sp['median']:.2f} | {sp['iqr']:.2f} | {sp['n']} | " + ", ".join(f"{v:.1f}" for v in xr["split_rounds"]) + " |",
            f"| **split / native through OpenXR** | **{sp['median'] / n['median']:.3f}** | | | |"]


def latency_markdown(res):
    """The latency and pacing of every mode (none for results from before the bench measured them)."""
    first = (res.get("per_path") or [{}])[0]
    if not first.get("latency"):
        return []
    rows = ["", "Latency (`SPLITVK_STATS`' `frame_latency_ms`: the application's acquire returning to the real "
            "present returning; through OpenXR `xrWaitFrame` returning to `xrEndFrame` returning; native "
            "through the same layer without an agent) and pacing (p99 frame time over the median), ms:", "",
            "| mode | frame time median | frame time p99 | pacing (p99/median) | latency median | latency p99 |",
            "|---|---|---|---|---|---|"]
    for label, t, lat in latency_table(first):
        cells = f"{lat['median']:.2f} | {lat['p99']:.2f}" if lat else "n/a | n/a"
        rows.append(f"| {label} | {t['median']:.2f} | {t['p99']:.2f} | {t['p99'] / t['median']:.3f} | {cells} |")
    ratios = latency_ratios(first)
    rows += ["", " ".join(f"`{name}: {ratios[name]:.3f}`" for name in FINAL_LATENCY_LINES if name in ratios)
             + "".join(f" `{name}: {ratios[name]:.3f}`" for name in ("latency-xr-split/native", "pacing-xr-split")
                       if name in ratios)]
    return rows


def tables_markdown(res):
    s, n, sp, per = res["stages"], res["native"], res["split"], res["periphery"]
    per_text = f"{per['median']:.2f}" if per else "n/a"
    c = res["config"]
    return "\n".join([
        "| end to end, ms per frame | median | IQR | frames | median per round |",
        "|---|---|---|---|---|",
        f"| native (client alone) | {n['median']:.2f} | {n['iqr']:.2f} | {n['n']} | "
        + ", ".join(f"{v:.1f}" for v in res["native_rounds"]) + " |",
        f"| split | {sp['median']:.2f} | {sp['iqr']:.2f} | {sp['n']} | "
        + ", ".join(f"{v:.1f}" for v in res["split_rounds"]) + " |",
        f"| **split / native** | **{sp['median'] / n['median']:.3f}** | | | |",
    ] + variant_rows_markdown(res) + xr_rows_markdown(res) + latency_markdown(res) + [
        "",
        f"Client (Table 1), medians in ms; {periphery_note(c)}:",
        "",
        f"| fovea per eye | periphery render ({periphery_label(c)}) | tile wait | exposed wait | network | decode | upload + merge | merge (GPU) | Mbit/s |",
        "|---|---|---|---|---|---|---|---|---|",
        f"| {c['fovea']} | {per_text} | {s['tile_wait']:.2f} | {s.get('exposed_wait', 0.0):.2f} | {s['network']:.2f} | "
        f"{s['decode']:.2f} | {s['merge']:.2f} | {s.get('merge_gpu', 0.0):.2f} | {s['mbits']:.1f} |",
        "",
        f"Exposed wait (the part of the tile wait after the client's GPU had finished its frame) is "
        f"{s.get('exposed_share', 0.0):.3f} of all split frame time.",
        "",
        "Agent (Table 2), medians in ms:",
        "",
        "| fovea per eye | draw | readback | encode |",
        "|---|---|---|---|",
        f"| {c['fovea']} | {s['draw']:.2f} | {s['readback']:.2f} | {s['encode']:.2f} |",
        "",
        (f"Client CPU time per frame (the app's process, all threads, user + system, start-up included; "
         f"median over runs): native {res['client_cpu']['native']:.1f} ms, split {res['client_cpu']['split']:.1f} ms "
         f"({res['client_cpu']['split'] / res['client_cpu']['native']:.3f} of native).\n\n"
         if res.get("client_cpu") else "") +
        f"Tiles: {s['tile_bytes'] / max(1, s['frames'] - s['late']) / 1024:.0f} KiB per frame, "
        f"{s['tile_bytes'] / s['raw_bytes'] if s['raw_bytes'] else 0:.3f} of their raw size "
        "(Mbit/s scales with the frame rate, so KiB per frame is what compares with other machines); "
        f"late frames (centre from the periphery): {s['late']} of {s['frames']}.",
    ])


def print_tables(res):
    s, n, sp, per = res["stages"], res["native"], res["split"], res["periphery"]
    print()
    print("end to end (ms per frame)        median      IQR   frames")
    print(f"  native (client alone)     {n['median']:9.2f} {n['iqr']:8.2f} {n['n']:8d}")
    print(f"  split                     {sp['median']:9.2f} {sp['iqr']:8.2f} {sp['n']:8d}")
    if res.get("xr"):
        xr = res["xr"]
        print(f"  native through OpenXR     {xr['native']['median']:9.2f} {xr['native']['iqr']:8.2f} {xr['native']['n']:8d}")
        print(f"  split through OpenXR      {xr['split']['median']:9.2f} {xr['split']['iqr']:8.2f} {xr['split']['n']:8d}"
              f"   ({res['config'].get('eye_size')} per eye; {xr['stages']['late']} of {xr['stages']['frames']} "
              "eye images late)")
    label = "periphery(GPU)" if res["config"].get("periphery_source") == "gpu" else "periphery(est.)"
    print(f"client (median ms)   {label:>15}  tile wait  exposed wait   network   decode  upload+merge  "
          "merge(GPU)   Mbit/s")
    print(f"                     {per['median'] if per else float('nan'):15.2f} {s['tile_wait']:10.2f} "
          f"{s.get('exposed_wait', 0.0):13.2f} {s['network']:9.2f} {s['decode']:8.2f} {s['merge']:13.2f} "
          f"{s.get('merge_gpu', 0.0):11.2f} {s['mbits']:8.1f}")
    print("agent (median ms)         draw   readback   encode")
    print(f"                     {s['draw']:9.2f} {s['readback']:10.2f} {s['encode']:8.2f}")
    if res.get("client_cpu"):
        c = res["client_cpu"]
        print(f"client CPU per frame (all threads, start-up included): native {c['native']:.1f} ms, "
              f"split {c['split']:.1f} ms ({c['split'] / c['native']:.3f})")
    print(f"late frames (centre from the periphery): {s['late']} of {s['frames']}")
    first = (res.get("per_path") or [{}])[0]
    if first.get("latency"):
        print("latency and pacing (ms)                    frame median  frame p99  p99/median  latency median  "
              "latency p99")
        for label, t, lat in latency_table(first):
            cells = f"{lat['median']:15.2f} {lat['p99']:12.2f}" if lat else f"{'-':>15} {'-':>12}"
            print(f"  {label:<40} {t['median']:13.2f} {t['p99']:10.2f} {t['p99'] / t['median']:11.3f} {cells}")
    print("paper (Snapdragon 865 + GTX 1080): native 32.2 ms, split 26.17 ms (0.813); draw 4.42, encode 15.33, "
          "network 4.99, decode 18.64, merge 0.96 ms; 707.83 Mbit/s")
    per_path = res.get("per_path") or []
    variants = run_variants(res)
    if len(per_path) > 1 or variants or res["config"].get("paths", ["direct"]) != ["direct"]:
        print(f"render paths (ms per frame, medians; the tables above are --path {per_path[0]['path']}'s)")
        print("  path           native (IQR)      split (IQR) " + "".join(f"{v + ' (IQR)':>18}" for v in variants)
              + "  periphery(GPU)  periphery/native  split/native  by means"
              + "".join(f"  {v + '/split':>18}" for v in variants) + "  late")
        for p in per_path:
            r, measured = path_ratios(p), variants_of(p)
            cells = "".join(f"  {measured[v]['median']:8.2f} ({measured[v]['iqr']:5.2f})" if v in measured
                            else f"{'-':>18}" for v in variants)
            per = f"{p['periphery']['median']:15.2f}" if p.get("periphery") else f"{'-':>15}"
            print(f"  {p['path']:<10} {p['native']['median']:8.2f} ({p['native']['iqr']:5.2f}) "
                  f"{p['split']['median']:8.2f} ({p['split']['iqr']:5.2f}){cells} {per} "
                  f"{fmt_ratio(r['periphery/native']):>17} {fmt_ratio(r['split/native']):>13} "
                  f"{fmt_ratio(r['split/native by means']):>9}"
                  + "".join(f"  {fmt_ratio(r.get(v + '/split')):>18}" for v in variants)
                  + f" {p['stages']['late']:5d}")


def path_ratios(p):
    """split/native, periphery/native (the client's periphery render over the native median frame
    time, as the analysis compares them) and VARIANT/split for each variant of one path_summary; None
    where not measured."""
    n, sp = p["native"]["median"], p["split"]["median"]
    per = p.get("periphery")
    n_mean, sp_mean = p["native"].get("mean"), p["split"].get("mean")
    ratios = {"split/native": sp / n if n else None,
              "split/native by means": sp_mean / n_mean if n_mean and sp_mean else None,
              "periphery/native": per["median"] / n if per and n else None}
    for name, t in variants_of(p).items():
        ratios[f"{name}/split"] = t["median"] / sp if sp else None
    xr = p.get("xr")
    if xr:
        ratios["xr split/native"] = xr["split"]["median"] / xr["native"]["median"] if xr["native"]["median"] else None
        ratios["xr split/native by means"] = (xr["split"]["mean"] / xr["native"]["mean"]
                                              if xr["native"].get("mean") and xr["split"].get("mean") else None)
        if xr.get("swapped"):
            ratios["xr swapped/native"] = (xr["swapped"]["median"] / xr["native"]["median"]
                                           if xr["native"]["median"] else None)
    ratios.update(latency_ratios(p))
    return ratios


def mode_frame_times(p):
    """A path_summary's frame-time quartiles per mode (LATENCY_MODES' names)."""
    modes = {"native": p.get("native"), "split": p.get("split")}
    modes.update(variants_of(p))
    if p.get("xr"):
        modes.update({"xr-native": p["xr"]["native"], "xr-split": p["xr"]["split"]})
        if p["xr"].get("swapped"):
            modes["xr-swapped"] = p["xr"]["swapped"]
    return {m: t for m, t in modes.items() if t}


def latency_table(p):
    """(name, frame-time quartiles, latency quartiles or None) of each mode of one path_summary, in
    LATENCY_MODES' order."""
    frames, latency = mode_frame_times(p), p.get("latency") or {}
    return [(label, frames[m], latency.get(m)) for m, label in LATENCY_MODES.items() if m in frames]


def latency_ratios(p):
    """latency-MODE/native (median frame_latency_ms over native's, through OpenXR over OpenXR
    native's) and pacing-MODE (p99 frame time over the median) of one path_summary, for the modes it
    measured; none for runs from before the bench measured them."""
    short = {"split": "split", "split-swapped": "swapped", "xr-split": "xr-split", "native": "native",
             "xr-native": "xr-native", "xr-swapped": "xr-swapped"}
    ratios = {}
    latency = p.get("latency") or {}
    for mode in ("split", "split-swapped", "xr-split", "xr-swapped"):
        base = latency.get("xr-native" if mode.startswith("xr-") else "native")
        if mode in latency and base and base["median"]:
            ratios[f"latency-{short[mode]}/native"] = latency[mode]["median"] / base["median"]
    for mode, t in mode_frame_times(p).items():
        if mode in short and "p99" in t and t["median"]:
            ratios[f"pacing-{short[mode]}"] = t["p99"] / t["median"]
    return ratios


def fmt_ratio(value, missing="-"):
    return missing if value is None else f"{value:.3f}"


def print_ratio_lines(res):
    """The per-path ratio lines (NAME[PATH]: R) when there are several paths, then the first path's
    periphery/native and VARIANT/split; the four final lines follow them."""
    per_path = res.get("per_path") or []
    if len(per_path) > 1:
        for p in per_path:
            for name, value in path_ratios(p).items():
                if value is not None:
                    print(f"{name}[{p['path']}]: {value:.3f}")
    if per_path:
        for name, value in path_ratios(per_path[0]).items():
            if name not in ("split/native", "split/native by means") + FINAL_LATENCY_LINES and value is not None:
                print(f"{name}: {value:.3f}")
        auto, measured = per_path[0].get("auto"), variants_of(per_path[0])
        if auto and "split-auto" in measured and per_path[0]["native"]["median"]:
            print(f"auto fovea: settled at {', '.join(auto['settled'])} (each round's last quarter), "
                  f"{auto['late']} late of {auto['frames']}, {auto['mbps']:.1f} Mbit/s")
            print(f"split-auto/native: {measured['split-auto']['median'] / per_path[0]['native']['median']:.3f}")
        swapped = per_path[0].get("swapped")
        if swapped and "split-swapped" in measured and per_path[0]["native"]["median"]:
            native = per_path[0]["native"]["median"]
            own = swapped["client_render"]
            print(f"swapped split: client's own render (GPU, its cut passes) "
                  + (f"{own['median']:.2f} ms, {own['median'] / native:.3f} of native" if own else "not measured")
                  + f"; periphery {swapped['mbps']:.1f} Mbit/s, {swapped['kib_per_frame']:.1f} KiB per frame, "
                  f"decode {swapped['decode']:.2f} ms; {swapped['late']} late of {swapped['frames']}")
            agent = swapped.get("agent_draw")
            print("swapped split: agent's periphery draw (GPU, its replay of the frame) "
                  + (f"{agent['median']:.2f} ms, {agent['median'] / native:.3f} of native" if agent
                     else "not measured"))
            print(f"swapped periphery ({res['config'].get('periphery_codec', 'h264')}): {swapped['kib_per_frame']:.1f} KiB per frame, "
                  f"{swapped.get('mbps_90hz', 0.0):.1f} Mbit/s at 90 Hz, decode {swapped['decode']:.2f} ms per frame, "
                  f"{swapped.get('decoder') or 'decoder not named'}")
            # Lockstep behind a slower agent alternates a long and a short frame: the means give the rate.
            n_mean, s_mean = per_path[0]["native"].get("mean"), measured["split-swapped"].get("mean")
            if n_mean and s_mean:
                print(f"swapped/native by means: {s_mean / n_mean:.3f}")
        for mode, q in (per_path[0].get("pictures") or {}).items():
            print(f"picture of {mode} against native (frame {q['frame']}, from the X server): SSIM {q['ssim']:.4f}, "
                  f"PSNR {q['psnr']:.2f} dB; periphery SSIM {q['periphery_ssim']:.4f}, PSNR {q['periphery_psnr']:.2f} dB")
        for name, t in (per_path[0].get("variant_periphery") or {}).items():
            if name == "split-swapped":
                continue  # the swapped split's own render is in its line above, not a periphery
            print(f"periphery (GPU) of {name}: {t['median']:.2f} ms")
        shaded = (per_path[0].get("variant_periphery") or {}).get("split-shaded")
        if shaded and per_path[0].get("periphery") and shaded["median"]:
            print(f"periphery (GPU) masked {per_path[0]['periphery']['median']:.2f} ms, foveae shaded "
                  f"{shaded['median']:.2f} ms")
            print(f"periphery masked/shaded: {per_path[0]['periphery']['median'] / shaded['median']:.3f}")


def plot(res, figures_dir, out_dir):
    """Runs paper_plots.py under /usr/bin/python3; returns the PNG paths, or None with a message."""
    if not os.path.exists(PLOT_PYTHON):
        print(f"paper: no plots: {PLOT_PYTHON} is missing", file=sys.stderr)
        return None
    probe = subprocess.run([PLOT_PYTHON, "-c", "import matplotlib"], capture_output=True)
    if probe.returncode != 0:
        print("paper: no plots: matplotlib is missing for /usr/bin/python3; install it with "
              "'apt-get install python3-matplotlib' and re-run (the numbers above are complete)", file=sys.stderr)
        return None
    os.makedirs(figures_dir, exist_ok=True)
    data = os.path.join(out_dir, "results.json")
    with open(data, "w") as f:
        json.dump(res, f)
    paths = {"distribution": os.path.join(figures_dir, "paper-frame-times.png"),
             "timeline": os.path.join(figures_dir, "paper-timeline.png")}
    r = subprocess.run([PLOT_PYTHON, PLOT_SCRIPT, data, paths["distribution"], paths["timeline"]],
                       capture_output=True, text=True)
    if r.returncode != 0:
        print("paper: plotting failed:\n" + common.tail(r.stdout + r.stderr), file=sys.stderr)
        return None
    if r.stderr.strip():
        print("paper: " + r.stderr.strip(), file=sys.stderr)
    return {k: p for k, p in paths.items() if os.path.exists(p)}


def critical_path(res):
    """The median split frame on the client's app thread, in measured parts that add up to it."""
    s = res["stages"]
    frame, wait, merge = res["split"]["median"], s["tile_wait"], s["merge"]
    return {"app before its present (fence wait, acquire, record, capture, submit)": max(0.0, frame - wait - merge),
            "tile wait": wait, "upload + merge": merge}


def section_markdown(res, figures, docs_path, analysis):
    m, c = res["machine"], res["config"]
    rel = lambda p: os.path.relpath(p, os.path.dirname(docs_path))  # noqa: E731
    lb = " ".join(f"{x:.2f}" for x in m["load_before"])
    la = " ".join(f"{x:.2f}" for x in m["load_after"])
    out = [
        DOC_BEGIN,
        "## The paper's experiment (`scripts/bench paper`)",
        "",
        "What it measures: the paper's Tables 1-2 and Figure 3 on an emulated weak client. splitvk-atrium "
        f"renders {c['width']}x{c['height']} side-by-side stereo with a moving camera; split, the agent shades "
        f"a {c['fovea']} fovea per eye and the client the periphery at scale {c['scale']} ({c['periphery']}). "
        f"The client (app, layer, tile decoders; native runs too) is confined to CPU {c['client_cpus']} with "
        f"lavapipe's `LP_NUM_THREADS={c['client_threads']}`, the agent to CPU {c['agent_cpus']}; link: "
        f"{c['link']} ({'loopback, no proxy' if c['link'] == 'direct' else 'splitvk-link on loopback'}); `SPLITVK_TILE_WAIT={c.get('tile_wait', 250)}` (lockstep as in the paper). Native and split alternate, {c['rounds']} rounds of {c['frames']} frames, "
        f"the first {c['warmup']} of each run left out; {periphery_note(c)}. Medians and IQRs are over every "
        "remaining frame. Native runs through splitvk's layer without an agent (every frame unsplit), "
        "which measures its latency at the same points as the split's." + (" " + xr_note(c) if c.get("xr") else ""),
        "",
        f"- date: {res['date']}",
        f"- machine: {describe_machine(m)}; Xvfb display",
        f"- load average (1, 5, 15 min) before: {lb}; after: {la} (other engineers' builds share the machine)",
        f"- command: `{res['command']}` ({res['wall_s'] / 60:.1f} minutes)"
        + (f"; this section and the figures written from its results.json by `{res['rendered_by']}`"
           if res.get("rendered_by") else ""),
        "",
        tables_markdown(res),
        "",
        "Paper (Snapdragon 865 client, GTX 1080 server, 5 GHz WiFi): native 32.2 ms (IQR 7.8), split 26.17 ms "
        "(IQR 4.6), split/native 0.813; client network 4.99, decode 18.64, merge 0.96 ms, 707.83 Mbit/s; "
        "server draw 4.42, encode 15.33 ms.",
        "",
    ]
    if figures and "distribution" in figures:
        out += [
            f"![frame-time distributions]({rel(figures['distribution'])})",
            "",
            "**Frame-time distributions** (as the paper's Figure 3): per-frame present-to-present times of "
            "every native and split frame as histograms on one axis, the medians as vertical lines; the inset "
            "legend gives median and IQR. Read it as: the further left and narrower, the faster and steadier. "
            "Below them, the latency panel: each mode's `frame_latency_ms` as a box (quartiles, the median a "
            "line) with whiskers from p1 to p99, its median and p99 beside it; the shorter, the sooner a frame "
            "reaches the screen after the application began it.",
            "",
        ]
    if figures and "timeline" in figures:
        out += [
            f"![timeline of a typical split frame]({rel(figures['timeline'])})",
            "",
            "**Timeline of one typical split frame** (the on-time frame whose frame time and stages are "
            "closest to the medians), t = 0 at the previous frame's present. Built from that frame's CSV "
            "row (and its predecessor's): the app's time before its present is frame time minus the previous "
            "frame's tile wait and merge; the tiles arrive at the present's wait start + tile wait - decode "
            "(the wait ends when the slower eye is decoded); the agent sends them network-ms earlier; encode, "
            "readback and draw end back to back before that. Assumptions: FramePresent takes ~0 ms on "
            "loopback; the periphery render (its GPU time as the layer measured it with timestamp queries, or "
            "hatched where it is only estimated from a periphery-size native run) is drawn ending where the "
            "present starts, or from the frame's start when it is longer: lavapipe has no queue thread, so "
            "the submitting thread runs the pass's vertex work inside vkQueueSubmit and the rasterisation at "
            "the next flush (the composite's submit), and its GPU time spreads over the app thread's own "
            "stages rather than running beside them. The agent's path is drawn ending where the tiles arrive. "
            "Bars that overlap in time "
            "on different lanes ran in parallel; on this machine the agent has its own core, the client's "
            "lanes share one.",
            "",
        ]
    out += [analysis, "", DOC_END]
    return "\n".join(out)


def write_docs(path, section, begin=DOC_BEGIN, end=DOC_END):
    """Replaces the section between begin and end in path. A new per-path section goes after the
    paper's section and the subsections that follow it (before the next `## ` heading)."""
    text = open(path).read() if os.path.exists(path) else "# Benchmarks\n"
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        _, tail = rest.split(end, 1)
        text = head + section + tail
    elif begin == PATHS_BEGIN and DOC_END in text and "\n## " in text.split(DOC_END, 1)[1]:
        head, rest = text.split(DOC_END, 1)
        before, after = rest.split("\n## ", 1)
        text = head + DOC_END + before.rstrip("\n") + "\n\n" + section + "\n\n## " + after
    else:
        text = text.rstrip("\n") + "\n\n" + section + "\n"
    with open(path, "w") as f:
        f.write(text)


def writes_paths_section(config):
    """Whether a run's docs are the per-path section (any path but direct, or several) rather than
    the direct path's full section."""
    return config.get("paths", ["direct"]) != ["direct"]


def paths_markdown(res):
    """The per-path section: one row per render path, the ratios measured in the same run."""
    m, c = res["machine"], res["config"]
    lb = " ".join(f"{x:.2f}" for x in m["load_before"])
    la = " ".join(f"{x:.2f}" for x in m["load_after"])
    variants = run_variants(res)
    tls = "split-tls" in variants
    head = ["path", "native, ms (IQR)", "split, ms (IQR)"] + [f"{variant_label(res, v)}, ms (IQR)" for v in variants] + \
        ["periphery (GPU), ms", "periphery/native", "tile wait", "exposed wait / frame", "split/native",
         "split/native by means"] + \
        [f"{v}/split" for v in variants] + ["tile-bytes/raw", "client CPU split/native", "late frames",
                                            "latency split/native", "pacing split"] + \
        (["OpenXR native, ms (IQR)", "OpenXR split, ms (IQR)", "OpenXR split/native"] if c.get("xr") else [])
    rows = []
    for p in res["per_path"]:
        s, r, cpu = p["stages"], path_ratios(p), p.get("client_cpu", {})
        row = [f"`{p['path']}`", f"{p['native']['median']:.2f} ({p['native']['iqr']:.2f})",
               f"{p['split']['median']:.2f} ({p['split']['iqr']:.2f})"]
        measured = variants_of(p)
        row += [f"{measured[v]['median']:.2f} ({measured[v]['iqr']:.2f})" if v in measured else "n/a"
                for v in variants]
        estimated = " (est.)" if p.get("periphery_source") == "estimate" else ""
        row += [f"{p['periphery']['median']:.2f}{estimated}" if p.get("periphery") else "n/a",
                fmt_ratio(r["periphery/native"], "n/a"), f"{s['tile_wait']:.2f}", f"{s.get('exposed_share', 0.0):.3f}",
                f"**{fmt_ratio(r['split/native'])}**", fmt_ratio(r["split/native by means"], "n/a")]
        row += [fmt_ratio(r.get(f"{v}/split"), "n/a") for v in variants]
        row += [f"{s['tile_bytes'] / s['raw_bytes']:.3f}" if s["raw_bytes"] else "n/a",
                f"{cpu['split'] / cpu['native']:.3f}" if cpu.get("native") and cpu.get("split") else "n/a",
                f"{s['late']} of {s['frames']}", fmt_ratio(r.get("latency-split/native"), "n/a"),
                fmt_ratio(r.get("pacing-split"), "n/a")]
        if c.get("xr"):
            xr = p.get("xr")
            row += [f"{xr['native']['median']:.2f} ({xr['native']['iqr']:.2f})",
                    f"{xr['split']['median']:.2f} ({xr['split']['iqr']:.2f})",
                    f"**{fmt_ratio(r['xr split/native'])}**"] if xr else ["n/a"] * 3
        rows.append("| " + " | ".join(row) + " |")
    out = [
        PATHS_BEGIN,
        "## The paper's experiment on each render path (`scripts/bench paper --path`)",
        "",
        "What it measures: the experiment above with splitvk-atrium drawing each frame through one of its "
        "render paths (`--path`; docs/user-guide.md, \"The workload\", says what each does). "
        f"{c['width']}x{c['height']} stereo, fovea {c['fovea']} per eye, periphery at scale {c['scale']} "
        f"({c['periphery']}), codec {c['codec']}; client on CPU {c['client_cpus']} with `LP_NUM_THREADS="
        f"{c['client_threads']}`, agent on CPU {c['agent_cpus']}; link: {c['link']}; `SPLITVK_TILE_WAIT="
        f"{c.get('tile_wait', 250)}`. Every round runs each path in turn, native and split alternating"
        + (" and a split over TLS 1.3 (`SPLITVK_TLS=on` on loopback, the agent pinned by its fingerprint)"
           if tls else "")
        + (f" and a split whose agent also cuts offscreen screen-space passes to the fovea "
           f"(`SPLITVK_AGENT_SCISSOR={c['agent_scissor']}`)" if "split-guard" in variants else "")
        + (" at the other end of the round from native" if len(variants) else "")
        + f"; {c['rounds']} rounds of {c['frames']} frames, the first {c['warmup']} of each run left out. "
        + (xr_note(c) + " " if c.get("xr") else "")
        + "Frame times are medians (IQR) over every remaining frame; periphery is the client's periphery "
        "render on its GPU (`SPLITVK_STATS`' `periphery_ms`, timestamp queries), and periphery/native that "
        "over the native median frame: the share of a native frame the client still renders itself. "
        "split/native by means compares mean frame times: where the agent is slower than the client, "
        "lockstep frames alternate between a short and a long time and the median is one of the two, "
        "so the means say how fast frames really come (n/a for runs recorded before means were kept). "
        "Where the layer wrote no periphery time (`secondary` before it timed passes with secondary "
        "contents): n/a, or (est.) from a native run at the periphery's size with `--periphery-frames N`.",
        "",
        f"- date: {res['date']}",
        f"- machine: {describe_machine(m)}; Xvfb display",
        f"- load average (1, 5, 15 min) before: {lb}; after: {la}",
        f"- command: `{res['command']}` ({res['wall_s'] / 60:.1f} minutes)"
        + (f"; this section written from its results.json by `{res['rendered_by']}`"
           if res.get("rendered_by") else ""),
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
        *rows,
        "",
        PATHS_END,
    ]
    return "\n".join(out)


def xr_note(c):
    """What the OpenXR runs (--xr) are, for the docs."""
    return (f"Through OpenXR: splitvk-atrium `--xr --xr-eye-size {c['eye_size']}` (one swapchain per eye, each split "
            "with one centred fovea of the same size) under `scripts/xr-runtime run` (Monado, headless null "
            "compositor; its service is not confined), native and split in the same rounds on the same "
            "confined client and agent with splitvk's OpenXR layer on; frame times are between `xrEndFrame` "
            "calls, which the runtime paces at 20 Hz, so none is under 50 ms (the eyes are sized so that "
            "native frames take several times that; xrWaitFrame can still add part of a 50 ms period to a "
            "frame, native and split alike).")


def analysis_text(res):
    """What dominates the median split frame and what to change next, from the numbers alone."""
    s, n, sp, per = res["stages"], res["native"], res["split"], res["periphery"]
    F = sp["median"]
    parts = critical_path(res)
    agent_stages = {"agent draw": s["draw"], "agent readback": s["readback"], "agent encode": s["encode"],
                    "network": s["network"], "client decode": s["decode"]}
    agent_path = sum(agent_stages.values())
    worst_agent = max(agent_stages, key=agent_stages.get)
    P = per["median"] if per else None
    out = ["**What dominates the split frame.** On the client's app thread the median split frame "
           f"({F:.1f} ms) is " + ", ".join(f"{k} {v:.1f} ms ({v / F:.0%})" for k, v in parts.items()) + ". "
           f"The tile wait is the agent's path showing: draw + readback + encode + network + decode add up to "
           f"{agent_path:.1f} ms against a {s['tile_wait']:.1f} ms wait, its largest stage {worst_agent} "
           f"({agent_stages[worst_agent]:.1f} ms)."]
    if P is not None:
        out[-1] += (f" In parallel with it the client renders its periphery ({periphery_label(res['config'])} "
                    f"{P:.1f} ms, "
                    f"{P / n['median']:.0%} of a native frame for {float(res['config']['scale']) ** 2:.0%} of its "
                    "pixels: the geometry work does not shrink with the scale)")
        if P >= agent_path:
            out[-1] += (", which is at least as long: the two race, and the client's own periphery render is "
                        f"the larger of the two. **The periphery render dominates** ({periphery_label(res['config'])}), with "
                        f"{worst_agent} close behind it.")
        else:
            out[-1] += (f", which is shorter: **the agent's {worst_agent} dominates**; the client idles "
                        f"{agent_path - P:.1f} ms of each frame.")
    cpu = res.get("client_cpu")
    if cpu:
        out[-1] += (f" The split used {cpu['split'] / cpu['native']:.0%} of native's client CPU time per frame "
                    f"({cpu['split']:.0f} against {cpu['native']:.0f} ms)")
        if cpu["native"] < 0.8 * n["median"]:
            out[-1] += (f", but the client's core was shared: native got {cpu['native']:.0f} ms of CPU in a "
                        f"{n['median']:.0f} ms frame, so wall times here are stretched by the machine's load and "
                        "the CPU ratio is the better measure of the client's saving")
        out[-1] += "."
    out += ["", "**What to change next.**"]
    steps = []
    if parts["upload + merge"] > 0.05 * F:
        steps.append(f"Upload + merge is serial after the wait and costs {parts['upload + merge']:.1f} ms "
                     f"({parts['upload + merge'] / F:.0%}; the paper's 0.96 ms): the compositor upsamples the whole "
                     "frame in a full-screen fragment pass, which the client's CPU rasteriser runs on the app's own "
                     "thread when the composite is submitted (lavapipe has no queue thread). A client with a GPU "
                     "runs it in the paper's time; here, leaving the foveae out of the upsample pass (the tiles "
                     "overwrite them), or a vkCmdBlitImage, would shorten it.")
    if P is not None and P >= agent_path:
        steps.append("The client still shades the foveae's pixels in its periphery buffer, which the tiles then "
                     "overwrite: masking them out (depth or stencil pre-pass, or splitting the render area around "
                     "the foveae) and a lower --scale cut the periphery render; moving the balance to the agent "
                     "(a larger fovea) only pays while the agent's path stays shorter than the periphery render.")
    if worst_agent == "agent draw":
        steps.append(f"On the agent, draw ({s['draw']:.1f} ms) replays every draw at full geometry cost and only "
                     "scissors the shading: culling draws whose bounds miss the foveae would cut it (on a real "
                     "server GPU it is the paper's 4.42 ms, and the client alone sets the pace).")
    elif worst_agent == "agent encode":
        steps.append("Stream x264 slices as they finish (the NAL callback) so that network and decode overlap encode.")
    elif worst_agent == "client decode":
        steps.append("Decode is on the weak client: zstd on the difference decodes about ten times cheaper (docs/architecture.md §5).")
    out[-1] += " " + " ".join(f"({i + 1}) {t}" for i, t in enumerate(steps))
    return "\n".join(out)


def run(args):
    preset = QUICK if args.quick else FULL
    # --fovea auto[:WxH]: the plain split keeps the paper's fovea and split-auto runs beside it.
    args.fovea_auto = args.fovea if args.fovea.lower().startswith("auto") else None
    if args.fovea_auto:
        args.fovea = "512x360"
    for key, value in preset.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    write = args.write_docs if args.write_docs is not None else not args.quick
    if args.from_results:
        with open(args.from_results) as f:
            res = json.load(f)
        res["rendered_by"] = " ".join(["scripts/bench", "paper"] + [shlex.quote(a) for a in sys.argv[2:]])
        args.quick = res["config"]["quick"]
        write = args.write_docs if args.write_docs is not None else not args.quick
    else:
        if args.paths is None:
            args.paths = ["direct"]
        res = measure(args)
    per = res["periphery"]
    res["typical"] = (timeline(*res["typical_rows"], per["median"] if per else None, periphery_label(res["config"]))
                      if res["typical_rows"] else None)
    paths_section = writes_paths_section(res["config"])
    # The figures in docs/ belong to the direct path's section: a per-path run keeps its own in out_dir.
    figures_dir = args.figures_dir or (os.path.join(common.REPO, "docs", "figures") if write and not paths_section
                                       else res["out_dir"])
    figures = None if args.no_plots else plot(res, figures_dir, res["out_dir"])
    with open(os.path.join(res["out_dir"], "results.json"), "w") as f:
        json.dump(res, f)
    if write and paths_section:
        write_docs(args.docs, paths_markdown(res), PATHS_BEGIN, PATHS_END)
    elif write:
        write_docs(args.docs, section_markdown(res, figures, args.docs, analysis_text(res)))
    print_tables(res)
    if figures:
        print("figures: " + "\n         ".join(figures.values()))
    print(f"per-frame data: {res['out_dir']}" + (f"; docs: {args.docs} ({'per-path' if paths_section else 'paper'} "
                                                  "section replaced)" if write else ""))
    print_ratio_lines(res)
    print_final_lines(res)
    return 0


def print_final_lines(res):
    """The lines scripts read, nothing after them: split/native's four, swapped/native where the
    swapped split ran, then the first path's latency and pacing (FINAL_LATENCY_LINES, those measured)."""
    s = res["stages"]
    split.print_final_lines(res["split"]["median"], res["native"]["median"], s["tile_wait"],
                            s.get("exposed_share", 0.0), s["tile_bytes"], s["raw_bytes"])
    first = (res.get("per_path") or [{}])[0]
    swapped = variants_of(first).get("split-swapped")
    if swapped and res["native"]["median"]:
        print(f"swapped/native: {swapped['median'] / res['native']['median']:.3f}")
    xr = first.get("xr") if first else None
    if xr and xr.get("swapped") and xr["native"]["median"]:
        print(f"xr swapped/native: {xr['swapped']['median'] / xr['native']['median']:.3f}")
    ratios = latency_ratios(first) if first else {}
    for name in FINAL_LATENCY_LINES:
        if name in ratios:
            print(f"{name}: {ratios[name]:.3f}")
