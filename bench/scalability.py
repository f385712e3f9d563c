#!/usr/bin/env python3
"""Projected scalability of the partitioned runtime, as the SODA thesis defines it.

For each territory count K, runs `soda run --territories K --threads 1` (worlds
stepped round-robin on one thread, so each world's thread CPU time is clean on
a small machine) and computes

    projected_speedup(K) = CPU seconds of the one-territory run
                           / sum over steps of the slowest world's CPU time

i.e. the speed-up the run would reach with one core per world. It is a
PROJECTION, not a measurement: messages cost nothing extra here and no core
is shared. Every K run's state hash is checked against the one-territory run.

Usage: bench/scalability.py [--soda build/bin/soda] [--scene falling-cubes]
       [--n 16000] [--steps 600] [--ks 2,4,8,16,32,64] [--csv out.csv]
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile


def run(soda, args):
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as f:
        path = f.name
    try:
        cmd = [soda, "run", "--log-level", "warn", "--json", path] + args
        print("+", " ".join(cmd), file=sys.stderr, flush=True)
        subprocess.run(cmd, check=True)
        with open(path) as f:
            return json.load(f)
    finally:
        os.unlink(path)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--soda", default="build/bin/soda")
    p.add_argument("--scene", default="falling-cubes")
    p.add_argument("--n", type=int, default=16000)
    p.add_argument("--steps", type=int, default=600)
    p.add_argument("--partition", default="kmeans")
    p.add_argument("--ks", default="2,4,8,16,32,64")
    p.add_argument("--csv", default="-")
    a = p.parse_args()
    common = ["--scene", a.scene, "--n", str(a.n), "--steps", str(a.steps)]
    one = run(a.soda, common + ["--territories", "1"])
    rows = [{"territories": 1, "partition": "-", "wall_seconds": one["wall_seconds"],
             "cpu_seconds": one["cpu_seconds"], "slowest_world_cpu_seconds": one["cpu_seconds"],
             "projected_speedup": 1.0, "state_hash": one["state_hash"], "identical_to_one_territory": True,
             "mean_blocked_seconds": 0.0, "messages": 0}]
    for k in [int(x) for x in a.ks.split(",")]:
        r = run(a.soda, common + ["--territories", str(k), "--partition", a.partition, "--threads", "1"])
        slowest = r["slowest_world_cpu_seconds"]
        rows.append({"territories": k, "partition": a.partition, "wall_seconds": r["wall_seconds"],
                     "cpu_seconds": r["cpu_seconds"], "slowest_world_cpu_seconds": slowest,
                     "projected_speedup": one["cpu_seconds"] / slowest if slowest > 0 else 0.0,
                     "state_hash": r["state_hash"], "identical_to_one_territory": r["state_hash"] == one["state_hash"],
                     "mean_blocked_seconds": sum(w["blocked_seconds"] for w in r["worlds"]) / len(r["worlds"]),
                     "messages": r["messages"]})
    out = sys.stdout if a.csv == "-" else open(a.csv, "w", newline="")
    w = csv.DictWriter(out, fieldnames=list(rows[0].keys()))
    w.writeheader()
    for row in rows:
        w.writerow(row)
    if any(not r["identical_to_one_territory"] for r in rows):
        print("DECOMPOSITION MISMATCH: a K-territory hash differs from the one-territory hash", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
