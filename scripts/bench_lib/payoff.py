"""bench payoff: SPLITVK_FOVEA=auto where the split does not pay.

Small frames are slower split than native: the agent's path alone outlasts the whole native frame.
`auto` measures both ways and passes frames through where the split loses. This bench runs
splitvk-atrium native, split at the default fovea, and split with SPLITVK_FOVEA=auto, in every round
(the order alternating), against one agent on one X server, and reports each run's median frame time
(atrium's own, present to present). The auto run is measured over its frames after the verdict
(--settled-after, past the split's first hold and both measurement windows), so its ratio tells what
the application runs at once auto has decided.

By default the scene is a cube (--scene cube: a model of 12 triangles written into --out-dir), whose
frames take a few milliseconds here, the case auto exists for; --scene atrium draws atrium's own
300,000-triangle scene, where the split pays on a weak client and auto must stay split. Ends with
two lines for tools, nothing after them:
  split/native: R   the split's median frame time over native's
  auto/native: R    auto's, after its verdict, over native's
Timings never pass or fail."""
import argparse
import os
import statistics

from . import common, paper

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
        "payoff", help="native, split and SPLITVK_FOVEA=auto on small frames: does auto pass them through",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", choices=("cube", "atrium"), default="cube", help="default: %(default)s")
    p.add_argument("--frames", type=int, default=600, help="frames per run (default: %(default)s)")
    p.add_argument("--settled-after", type=int, default=240,
                   help="frames of the auto run left out of its median (default: %(default)s: the split's "
                        "first hold, both measurement windows and the switches)")
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

    def argv(times):
        return ["taskset", "-c", paper.cpu_text(client_cpus), build.atrium, "--width", str(args.width), "--height", str(args.height), "--eyes", "2",
                "--frames", str(args.frames), "--present-mode", "immediate", "--frame-times", times] + scene

    print(f"payoff: {APP_NAME} --scene {args.scene} {args.width}x{args.height} stereo, {args.frames} frames per run, "
          f"{args.rounds} rounds of native, split and split with SPLITVK_FOVEA=auto (measured after frame "
          f"{args.settled_after}); client on CPU {paper.cpu_text(client_cpus)} with LP_NUM_THREADS="
          f"{args.client_threads}, agent on CPU {paper.cpu_text(agent_cpus)}; load average {os.getloadavg()[0]:.2f}",
          flush=True)
    modes = ("native", "split", "auto")
    medians = {m: [] for m in modes}
    passed_lines = []
    with common.display(build) as disp:
        base = common.clean_env(args.icd)
        base["DISPLAY"] = disp
        client_env = dict(base, LP_NUM_THREADS=str(args.client_threads))
        agent_env = dict(base, LP_NUM_THREADS=str(len(agent_cpus)))
        with common.started_agent(build, agent, agent_env, out_dir, 0,
                                  ["taskset", "-c", paper.cpu_text(agent_cpus)]) as report:
            split_env = dict(common.layer_env(client_env, build), SPLITVK_SERVER=report["address"],
                             SPLITVK_LOG_LEVEL="info", SPLITVK_EYES="2")
            envs = {"native": client_env, "split": split_env, "auto": dict(split_env, SPLITVK_FOVEA="auto")}
            for i in range(args.rounds):
                line = []
                for mode in modes if i % 2 == 0 else modes[::-1]:
                    times = os.path.join(out_dir, f"{mode}-round{i + 1}-frames.csv")
                    r = common.run(argv(times), envs[mode], timeout_s)
                    if mode != "native" and "[splitvk] split:" not in r.stderr:
                        raise common.BenchError(f"the {mode} run did not split:\n" + common.tail(r.stderr))
                    skip = args.settled_after if mode == "auto" else 10
                    medians[mode].append(statistics.median(frame_times(times, skip)))
                    if mode == "auto":
                        verdicts = [l for l in r.stderr.splitlines() if "SPLITVK_FOVEA=auto: the split" in l]
                        passed_lines.append(verdicts[-1].split("info: ")[-1] if verdicts else "no verdict")
                    line.append(f"{mode} {medians[mode][-1]:7.2f} ms")
                print(f"  round {i + 1}/{args.rounds}: " + "   ".join(line), flush=True)
    native, split, auto = (statistics.median(medians[m]) for m in modes)
    print(f"median frame time over rounds: native {native:.2f} ms, split {split:.2f} ms, auto {auto:.2f} ms "
          f"(after frame {args.settled_after})")
    for i, verdict in enumerate(passed_lines):
        print(f"  auto, round {i + 1}: {verdict}")
    print(f"split/native: {split / native:.3f}")
    print(f"auto/native: {auto / native:.3f}")
    return 0
