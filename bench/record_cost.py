#!/usr/bin/env python3
"""Cost of `soda run --record`: the same run with and without recording,
interleaved (off, on, off, on, ...), side by side in one invocation.

Per run it reads `soda run --json` (run_json; with --record its "record"
object: frames, bytes, the recording thread's CPU seconds, bytes per 1,000
bodies per simulated second). Writes one JSON object (--out): every run, and the
medians' ratios on/off of wall seconds and of CPU seconds (the worlds' CPU
plus, when recording, the recording thread's). The state hashes must agree
(exit 1 otherwise). Wall times on a shared machine are noise; the CPU ratio
is the figure to quote (docs/replay-format.md, "Cost").

Usage: bench/record_cost.py [--soda build/bin/soda] [--scene falling-cubes]
       [--n 2000] [--territories 4] [--steps 600] [--repeat 3] [--level 1]
       [--out record_cost.json]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scalability import run  # noqa: E402  (soda run --json, the parsed JSON)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--soda", default="build/bin/soda")
    p.add_argument("--scene", default="falling-cubes")
    p.add_argument("--n", type=int, default=2000)
    p.add_argument("--territories", type=int, default=4)
    p.add_argument("--steps", type=int, default=600)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--level", type=int, default=1)
    p.add_argument("--out", default="record_cost.json")
    a = p.parse_args()
    base = ["--scene", a.scene, "--n", str(a.n), "--territories", str(a.territories), "--steps", str(a.steps)]
    replay = tempfile.NamedTemporaryFile(suffix=".replay", delete=False).name
    off, on = [], []
    try:
        for _ in range(a.repeat):
            off.append(run(a.soda, base))
            on.append(run(a.soda, base + ["--record", replay, "--record-level", str(a.level)]))
    finally:
        os.unlink(replay)
    hashes = {r["state_hash"] for r in off + on}

    def cpu(r):
        return r["cpu_seconds"] + r.get("record", {}).get("cpu_seconds", 0.0)

    med = statistics.median
    out = {
        "scene": a.scene, "n": a.n, "territories": a.territories, "steps": a.steps, "repeat": a.repeat,
        "zlib_level": a.level, "state_hash_equal": len(hashes) == 1,
        "off": [{"wall_seconds": r["wall_seconds"], "cpu_seconds": cpu(r)} for r in off],
        "on": [{"wall_seconds": r["wall_seconds"], "cpu_seconds": cpu(r), "record": r["record"]} for r in on],
        "cost_wall_on_off": med(r["wall_seconds"] for r in on) / med(r["wall_seconds"] for r in off),
        "cost_cpu_on_off": med(cpu(r) for r in on) / med(cpu(r) for r in off),
        "record_cpu_share": med(r["record"]["cpu_seconds"] / cpu(r) for r in on),
        "bytes_per_1000_bodies_per_simulated_second":
            med(r["record"]["bytes_per_1000_bodies_per_simulated_second"] for r in on),
    }
    with open(a.out, "w") as f:
        json.dump(out, f, indent=2)
        f.write("\n")
    print(json.dumps({k: v for k, v in out.items() if k not in ("off", "on")}, indent=2))
    return 0 if out["state_hash_equal"] else 1


if __name__ == "__main__":
    sys.exit(main())
