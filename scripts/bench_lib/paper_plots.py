"""The figures of scripts/bench paper, run by Debian's /usr/bin/python3 (python3-matplotlib).

  paper_plots.py RESULTS.json DISTRIBUTION.png TIMELINE.png

RESULTS.json is what bench paper writes: native_frames and split_frames (ms per frame), their
medians and IQRs, latency_frames (each mode's frame_latency_ms values, by the mode's name; absent
in results from before the bench measured latency), and `typical`, the timeline segments of one
typical split frame."""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from common import percentile  # noqa: E402  (bench_lib/common.py: this script's folder is on the path)

NATIVE, SPLIT, OTHER = "#4c72b0", "#dd8452", "#55a868"


def distribution(res, path):
    native, split = res["native_frames"], res["split_frames"]
    latency = {mode: values for mode, values in (res.get("latency_frames") or {}).items() if values}
    lo = min(min(native), min(split))
    hi = max(sorted(native)[int(0.99 * (len(native) - 1))], sorted(split)[int(0.99 * (len(split) - 1))])
    bins = 60
    step = (hi - lo) / bins if hi > lo else 1.0
    edges = [lo + i * step for i in range(bins + 1)]
    if latency:
        fig, (ax, lat_ax) = plt.subplots(2, 1, figsize=(7.5, 3.8 + 0.45 * len(latency) + 1.0), dpi=100,
                                         gridspec_kw={"height_ratios": [3.8, 0.45 * len(latency) + 1.0]})
    else:
        fig, ax = plt.subplots(figsize=(7.5, 3.8), dpi=100)
    for values, colour, name, stats in ((native, NATIVE, "native (client alone)", res["native"]),
                                        (split, SPLIT, "split", res["split"])):
        ax.hist([min(v, hi) for v in values], bins=edges, color=colour, alpha=0.55,
                label=f"{name}: median {stats['median']:.1f} ms, IQR {stats['iqr']:.1f}, {stats['n']} frames")
        ax.axvline(stats["median"], color=colour, linewidth=2)
        ax.text(stats["median"], ax.get_ylim()[1] * 0.02, f" {stats['median']:.1f}", color=colour,
                rotation=90, va="bottom", ha="right", fontsize=8)
    c = res["config"]
    ratio = res["split"]["median"] / res["native"]["median"]
    render_path = c.get("paths", ["direct"])[0]
    ax.set_title(f"splitvk-atrium {'' if render_path == 'direct' else f'--path {render_path} '}{c['width']}x{c['height']}, fovea {c['fovea']}/eye, scale {c['scale']}: "
                 f"split/native {ratio:.3f}", fontsize=10)
    ax.set_xlabel("frame time, ms (present to present; the top 1 % clipped into the last bin)")
    ax.set_ylabel("frames")
    ax.legend(fontsize=8, loc="upper right")
    if latency:
        latency_panel(lat_ax, latency)
    fig.tight_layout()
    fig.savefig(path)


def latency_panel(ax, latency):
    """Each mode's frame latency as a box (quartiles, the median a line), whiskers from p1 to p99, and
    its median and p99 written beside it; the first mode on top."""
    modes = list(latency)
    data = [latency[m] for m in modes]
    colours = [NATIVE if m.startswith("native") else SPLIT if m == "split" else OTHER for m in modes]
    boxes = ax.boxplot(data, vert=False, whis=(1, 99), showfliers=False, patch_artist=True,
                       positions=list(range(len(modes), 0, -1)), widths=0.6)
    for patch, colour in zip(boxes["boxes"], colours):
        patch.set_facecolor(colour)
        patch.set_alpha(0.55)
    for median in boxes["medians"]:
        median.set_color("black")
    ax.set_yticks(list(range(len(modes), 0, -1)))
    ax.set_yticklabels(modes, fontsize=7)
    right = max(percentile(v, 99) for v in data)
    for y, values in zip(range(len(modes), 0, -1), data):
        ax.text(right * 1.02, y, f"median {percentile(values, 50):.1f}, p99 {percentile(values, 99):.1f}",
                va="center", fontsize=7)
    ax.set_xlim(0, right * 1.35)
    ax.set_xlabel("frame latency, ms (acquire to the real present, or xrWaitFrame to xrEndFrame; whiskers p1-p99)",
                  fontsize=8)



LANE_ORDER = ["client app thread", "client lavapipe", "client decoders", "network", "agent"]
COLOURS = {
    "app: fence wait, acquire, record, capture, submit": "#8fbc8f",
    "periphery render (estimated)": "#2e8b57",
    "tile wait": "#f4a582",
    "upload + merge": "#b2182b",
    "draw (replay, fovea only)": "#4393c3",
    "readback": "#92c5de",
    "encode (eyes in parallel)": "#2166ac",
    "FramePresent ->": "#999999",
    "tiles <- network": "#7f7f7f",
    "decode (slower eye)": "#d6604d",
}


def timeline(res, path):
    t = res["typical"]
    fig, ax = plt.subplots(figsize=(9, 3.6), dpi=100)
    lanes = [lane for lane in LANE_ORDER if any(s[0] == lane for s in t["segments"])]
    y = {lane: len(lanes) - 1 - i for i, lane in enumerate(lanes)}
    seen = []
    for lane, label, start, dur in t["segments"]:
        hatch = "//" if "estimated" in label else None
        if dur <= 0:
            ax.plot([start, start], [y[lane] - 0.35, y[lane] + 0.35], color=COLOURS.get(label, "k"), linewidth=2)
        else:
            ax.barh(y[lane], dur, left=start, height=0.6, color=COLOURS.get(label, "#777777"),
                    edgecolor="black", linewidth=0.4, hatch=hatch)
            if dur > 0.06 * t["frame_ms"]:
                ax.text(start + dur / 2, y[lane], f"{dur:.0f}", ha="center", va="center", fontsize=7)
        if label not in seen:
            seen.append(label)
    ax.axvline(0, color="black", linewidth=0.8, linestyle=":")
    ax.axvline(t["present_at"], color="black", linewidth=1.2)
    ax.text(t["present_at"], -0.5, " present", fontsize=8, va="bottom")
    ax.set_yticks([y[lane] for lane in lanes])
    ax.set_yticklabels(lanes, fontsize=8)
    ax.set_xlabel("ms from the previous frame's present (numbers in bars: ms)")
    ax.set_title(f"split frame {t['frame']} (typical: frame time {t['frame_ms']:.1f} ms, split median "
                 f"{res['split']['median']:.1f} ms); hatched = estimated", fontsize=9)
    handles = [Patch(facecolor=COLOURS.get(label, "#777777"), edgecolor="black", linewidth=0.4,
                     hatch="//" if "estimated" in label else None, label=label) for label in seen]
    ax.legend(handles=handles, fontsize=6.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    fig.tight_layout()
    fig.savefig(path)


def main():
    with open(sys.argv[1]) as f:
        res = json.load(f)
    distribution(res, sys.argv[2])
    if res.get("typical"):
        timeline(res, sys.argv[3])
    else:
        print("no on-time split frame with a predecessor: no timeline", file=sys.stderr)


if __name__ == "__main__":
    main()
