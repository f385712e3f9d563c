#!/usr/bin/env python3
"""Plots a bench/scalability.py CSV: projected speed-up against territory count.

The speed-up is bench/scalability.py's PROJECTION (one-territory CPU over the
sum of the slowest world's CPU per step, worlds stepped on one thread), not
a measured wall-time speed-up; the plot says so in its title.

Usage: /usr/bin/python3 bench/plot_scalability.py CSV PNG [--title TEXT]
"""
import argparse
import csv

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("csv")
    p.add_argument("png")
    p.add_argument("--title", default="")
    a = p.parse_args()
    with open(a.csv) as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise SystemExit(f"{a.csv}: no rows")
    ks = [int(r["territories"]) for r in rows]
    speedup = [float(r["projected_speedup"]) for r in rows]
    overhead = [float(r["cpu_seconds"]) / float(rows[0]["cpu_seconds"]) for r in rows]
    identical = all(r["identical_to_one_territory"] == "True" for r in rows)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(ks, ks, ":", color="grey", label="ideal (K)")
    ax.plot(ks, speedup, "o-", label="projected speed-up (one core per world)")
    ax.plot(ks, overhead, "s--", label="total CPU / one territory's (work added)")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log", base=2)
    ax.set_xticks(ks)
    ax.set_xticklabels([str(k) for k in ks])
    ax.set_xlabel("territories K")
    ax.set_ylabel("ratio to one territory")
    title = a.title or "projected scalability"
    ax.set_title(title + ("\n(every K's state hash equal to one territory's)" if identical else ""), fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.png, dpi=100)
    print(f"wrote {a.png}")


if __name__ == "__main__":
    main()
