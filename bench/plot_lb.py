#!/usr/bin/python3
"""Plots of a load-balance experiment written by `soda lb --out DIR`.

    /usr/bin/python3 bench/plot_lb.py DIR [--window W]

Reads DIR/steps.csv (policy, step, world, busy_ms, wait_ms, bodies, cells,
lead), DIR/maps.csv (policy, step, x, y, z, owner) and DIR/summary.json, and
writes into DIR:
  load.png       busy CPU per step of every world over time, one panel per
                 policy (a rolling mean over W steps, default 20; thin lines
                 are the raw series)
  imbalance.png  imbalance (max / mean busy CPU over the worlds) per step,
                 rolling mean over W steps, one line per policy, with each
                 policy's mean imbalance in the legend
  maps.png       the territory map at each recorded step, one row per policy:
                 cells seen from above (x right, z down), coloured by the
                 owner most of the cell column's y layers have
docs/loadbalance.md explains how to read them. Needs Debian's
python3-matplotlib (scripts/setup.sh); run with /usr/bin/python3.
"""
import argparse
import collections
import csv
import json
import os
import sys

try:
    import matplotlib
except ImportError:
    sys.exit("plot_lb.py needs Debian's python3-matplotlib (scripts/setup.sh) and Debian's "
             "/usr/bin/python3; run it as `/usr/bin/python3 bench/plot_lb.py DIR`")

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402


def rolling(values, window):
    out, total, queue = [], 0.0, collections.deque()
    for v in values:
        queue.append(v)
        total += v
        if len(queue) > window:
            total -= queue.popleft()
        out.append(total / len(queue))
    return out


def read_steps(path):
    """policy -> world -> ([steps], [busy_ms]); keeps the policies' order of appearance."""
    series = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            per_world = series.setdefault(row["policy"], {})
            steps, busy = per_world.setdefault(int(row["world"]), ([], []))
            steps.append(int(row["step"]))
            busy.append(float(row["busy_ms"]))
    return series


def imbalance(per_world):
    """Per step: max / mean busy ms over the worlds (steps where every world was idle are skipped)."""
    by_step = collections.defaultdict(list)
    for steps, busy in per_world.values():
        for s, b in zip(steps, busy):
            by_step[s].append(b)
    xs, ys = [], []
    for s in sorted(by_step):
        mean = sum(by_step[s]) / len(by_step[s])
        if mean > 0:
            xs.append(s)
            ys.append(max(by_step[s]) / mean)
    return xs, ys


def plot_load(series, window, out):
    fig, axes = plt.subplots(len(series), 1, figsize=(10, 2.6 * len(series)), sharex=True, squeeze=False)
    for ax, (policy, per_world) in zip(axes[:, 0], series.items()):
        for world, (steps, busy) in sorted(per_world.items()):
            line, = ax.plot(steps, rolling(busy, window), label=f"world {world}", linewidth=1.4)
            ax.plot(steps, busy, color=line.get_color(), linewidth=0.3, alpha=0.35)
        ax.set_title(f"{policy}: busy CPU per step")
        ax.set_ylabel("ms")
        ax.legend(fontsize=7, ncol=8, loc="upper right")
    axes[-1, 0].set_xlabel("scene step")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def plot_imbalance(series, summary, window, out):
    fig, ax = plt.subplots(figsize=(10, 3.6))
    for policy, per_world in series.items():
        xs, ys = imbalance(per_world)
        mean = summary.get(policy, {}).get("imbalance_mean")
        label = policy if mean is None else f"{policy} (mean {mean:.2f})"
        ax.plot(xs, rolling(ys, window), label=label, linewidth=1.4)
    ax.axhline(1.0, color="grey", linewidth=0.6, linestyle=":")
    ax.set_xlabel("scene step")
    ax.set_ylabel("max / mean busy CPU")
    ax.set_title(f"imbalance per step (rolling mean over {window} steps)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def plot_maps(path, out):
    maps = collections.defaultdict(lambda: collections.defaultdict(collections.Counter))
    worlds = 1
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            owner = int(row["owner"])
            worlds = max(worlds, owner + 1)
            maps[(row["policy"], int(row["step"]))][(int(row["x"]), int(row["z"]))][owner] += 1
    if not maps:
        return False
    policies = list(dict.fromkeys(p for p, _ in maps))
    steps = sorted({s for _, s in maps})
    fig, axes = plt.subplots(len(policies), len(steps), figsize=(2.6 * len(steps), 2.6 * len(policies)),
                             squeeze=False)
    palette = plt.get_cmap("tab10" if worlds <= 10 else "tab20").colors
    cmap = ListedColormap([palette[w % len(palette)] for w in range(max(worlds, 2))])
    for i, policy in enumerate(policies):
        for j, step in enumerate(steps):
            ax = axes[i, j]
            ax.set_xticks([])
            ax.set_yticks([])
            cells = maps.get((policy, step))
            if i == 0:
                ax.set_title(f"step {step}", fontsize=9)
            if j == 0:
                ax.set_ylabel(policy)
            if not cells:
                continue
            xs = [x for x, _ in cells]
            zs = [z for _, z in cells]
            x0, z0 = min(xs), min(zs)
            grid = [[float("nan")] * (max(xs) - x0 + 1) for _ in range(max(zs) - z0 + 1)]
            for (x, z), owners in cells.items():
                grid[z - z0][x - x0] = owners.most_common(1)[0][0]
            ax.imshow(grid, cmap=cmap, vmin=-0.5, vmax=max(worlds, 2) - 0.5, interpolation="nearest")
    fig.suptitle("territory maps from above (colour: owner)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return True


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dir", help="the directory soda lb --out wrote")
    parser.add_argument("--window", type=int, default=20, help="rolling mean window, steps (default 20)")
    args = parser.parse_args()
    if args.window < 1:
        sys.exit("--window must be >= 1")
    steps_csv = os.path.join(args.dir, "steps.csv")
    if not os.path.exists(steps_csv):
        sys.exit(f"{steps_csv}: not found (run `soda lb --out {args.dir}` first)")
    summary = {}
    summary_json = os.path.join(args.dir, "summary.json")
    if os.path.exists(summary_json):
        with open(summary_json) as f:
            summary = {p["policy"]: p for p in json.load(f).get("policies", [])}
    series = read_steps(steps_csv)
    if not series:
        sys.exit(f"{steps_csv}: no rows")
    written = [os.path.join(args.dir, "load.png"), os.path.join(args.dir, "imbalance.png")]
    plot_load(series, args.window, written[0])
    plot_imbalance(series, summary, args.window, written[1])
    maps_csv = os.path.join(args.dir, "maps.csv")
    if os.path.exists(maps_csv) and plot_maps(maps_csv, os.path.join(args.dir, "maps.png")):
        written.append(os.path.join(args.dir, "maps.png"))
    print("\n".join(written))


if __name__ == "__main__":
    main()
