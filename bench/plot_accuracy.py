#!/usr/bin/python3
"""Pareto plot of `soda bench accuracy`: run-time ratio against error.

    /usr/bin/python3 bench/plot_accuracy.py accuracy.csv accuracy.png [--metric traj_rms_m] [--table T.md]

One panel per scene and metric (columns of the CSV, default: short-horizon
trajectory error, maximum penetration, final centre-of-mass error). Every
configuration that ran is a point, coloured by the axis it varies; the
Pareto front (no other point is both faster and more accurate) is the dashed
line; the dotted line is the floor: the reference's own settings run in the
other precision, i.e. what rounding alone changes (chaotic metrics cannot be
told apart below it). Rows that did not run ("not available", "failed") are listed under the
plot, never drawn. Needs Debian's python3-matplotlib (scripts/setup.sh).
"""
import argparse
import csv
import sys

try:
    import matplotlib
except ImportError:
    sys.exit("plot_accuracy.py needs Debian's python3-matplotlib (scripts/setup.sh) and Debian's "
             "/usr/bin/python3; run it as `/usr/bin/python3 bench/plot_accuracy.py ...`")

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

AXIS_STYLE = {
    "default": ("black", "*"),
    "dt": ("tab:blue", "o"),
    "iterations": ("tab:orange", "s"),
    "precision": ("tab:green", "D"),
    "ccd": ("tab:red", "^"),
    "combo": ("tab:purple", "P"),
    "territories": ("tab:brown", "v"),
}
LABELS = {
    "traj_rms_m": "short-horizon trajectory error, RMS (m)",
    "pen_max_m": "max penetration (m)",
    "pen_mean_m": "mean penetration (m)",
    "com_err_m": "final centre-of-mass error (m)",
    "height_rms_m": "final height-profile error, RMS (m)",
    "energy_err": "final energy error / E0",
}


def pareto(points):
    """Points (x, y) not dominated by another (smaller x and smaller y)."""
    front, best = [], float("inf")
    for x, y in sorted(points):
        if y < best:
            front.append((x, y))
            best = y
    return front


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("csv")
    p.add_argument("png")
    p.add_argument("--metric", action="append",
                   help="CSV column(s) to plot (default: traj_rms_m, pen_max_m, com_err_m)")
    p.add_argument("--table", help="also write a markdown table of every row to this file")
    a = p.parse_args()
    metrics = a.metric or ["traj_rms_m", "pen_max_m", "com_err_m"]
    with open(a.csv, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        # Sweeps written before the column was renamed call it ratio_vs_default
        # (the same figure: docs/cli.md, "What the ratios mean").
        r.setdefault("cost_vs_default", r.get("ratio_vs_default", ""))
    if not rows:
        sys.exit(f"{a.csv}: no rows")
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    fig, axes = plt.subplots(len(metrics), len(scenes), figsize=(6.2 * len(scenes), 4.2 * len(metrics)),
                             squeeze=False)
    skipped = []
    for col, scene in enumerate(scenes):
        srows = [r for r in rows if r["scene"] == scene]
        ok = [r for r in srows if r["status"] == "ok" and r["axis"] != "reference" and r[metrics[0]] != ""]
        skipped += [f'{scene} {r["axis"]}={r["value"]}: {r["status"]} ({r["note"]})'
                    for r in srows if r["status"] != "ok"]
        seen = set()
        for row_i, metric in enumerate(metrics):
            ax = axes[row_i][col]
            pts = []
            default = next((r for r in ok if r["axis"] == "default"), None)
            same = ("dt", "iterations", "precision", "world", "ccd")
            for r in ok:
                if r["axis"] == "territories":
                    continue  # identical bits to the default row: same point
                if default and r["axis"] != "default" and all(r[k] == default[k] for k in same):
                    continue  # the default run, listed again on its axis
                x, y = float(r["cost_vs_default"]), abs(float(r[metric]))
                if y <= 0:
                    continue
                if r["axis"] == "floor":
                    # Rounding alone (reference settings, other precision): errors
                    # below this line are chaos, not the configuration.
                    ax.axhline(y, color="tab:gray", ls=":", lw=1.2, label="floor: reference settings, " + r["precision"])
                    continue
                color, marker = AXIS_STYLE.get(r["axis"], ("tab:cyan", "o"))
                label = r["axis"] if (r["axis"], metric) not in seen else None
                seen.add((r["axis"], metric))
                ax.scatter([x], [y], c=color, marker=marker, s=130 if r["axis"] == "default" else 45,
                           label=label, zorder=4 if r["axis"] == "default" else 3)
                ax.annotate(r["value"] if r["axis"] != "default" else "default 1/60 x 10",
                            (x, y), textcoords="offset points", xytext=(4, 3), fontsize=7)
                pts.append((x, y))
            front = pareto(pts)
            if front:
                ax.plot([q[0] for q in front], [q[1] for q in front], "k--", lw=1, zorder=2, label="Pareto front")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.grid(True, which="both", alpha=0.3)
            ax.set_xlabel("run time / default run time")
            ax.set_ylabel(LABELS.get(metric, metric))
            n = srows[0]["n"]
            ref_dt = float(srows[0]["ref_dt"])
            ref = f"1/{round(1 / ref_dt)}" if abs(1 / ref_dt - round(1 / ref_dt)) < 1e-6 else f"{ref_dt:g}"
            ax.set_title(f"{scene} (n={n}), error against the reference: dt {ref}, "
                         f"{srows[0]['ref_iterations']} iterations, {srows[0]['ref_precision']}", fontsize=9)
            ax.legend(fontsize=7, loc="best")
    if skipped:
        text = "Not drawn:\n" + "\n".join(s[:150] for s in skipped[:12])
        fig.text(0.01, 0.005, text, fontsize=6, va="bottom", family="monospace")
        fig.subplots_adjust(bottom=0.08 + 0.012 * min(len(skipped), 12))
    fig.tight_layout(rect=(0, 0.02 + 0.012 * min(len(skipped), 12), 1, 1))
    fig.savefig(a.png, dpi=110)
    print(f"wrote {a.png}")
    if a.table:
        write_table(rows, a.table)
        print(f"wrote {a.table}")


def write_table(rows, path):
    """Every row of the sweep as a markdown table (numbers as in the CSV, 3 significant digits)."""
    cols = [("scene", "scene"), ("axis", "axis"), ("value", "value"), ("cost_vs_default", "time ratio"),
            ("traj_rms_m", "traj RMS m"), ("angle_rms_rad", "angle RMS rad"), ("pen_max_m", "pen max m"),
            ("pen_mean_m", "pen mean m"), ("energy_gain", "E gain"), ("energy_err", "E err"),
            ("com_err_m", "COM err m"), ("height_rms_m", "height RMS m"), ("lost_bodies", "lost"),
            ("decomposition_error", "decomp. err"), ("status", "status")]

    def fmt(key, v):
        if v == "" or key in ("scene", "axis", "value", "status", "lost_bodies", "decomposition_error"):
            return v
        try:
            return f"{float(v):.3g}"
        except ValueError:
            return v

    with open(path, "w") as f:
        f.write("| " + " | ".join(c[1] for c in cols) + " |\n")
        f.write("|" + "---|" * len(cols) + "\n")
        for r in rows:
            f.write("| " + " | ".join(fmt(k, r.get(k, "")) for k, _ in cols) + " |\n")


if __name__ == "__main__":
    main()
