#!/usr/bin/env python3
"""Memory per rank of `soda run` under `mpirun -np R` against one rank.

Runs the same partitioned scene (K territories) on one process without MPI
(threads), then under `mpirun -np R` for each R of --ranks, and reads each
rank's peak resident memory from the run's JSON ("ranks": peak_rss_bytes,
getrusage of the rank's process at the end of the run; the threaded run's
from wait4). Prints one JSON object: per R, every rank's peak, the largest,
and the ratio largest / the 1-rank figure (< 1: a rank holds less than one
process running everything; the acceptance asks <= 0.6 at 2 ranks and
<= 0.35 at 4), each rank's Bullet objects, rank 0's memory estimate, the
wall seconds per step, and the state hashes (all must be equal: exit 1
otherwise). Ranks above the machine's cores are oversubscribed: memory is
unaffected, step times are not comparable (docs/mpi.md, "What a rank holds").

Beside each measured step time: the step-time model's prediction
(bench/mpi_model.py, docs/mpi-model.md) from the threaded run, which runs
with --threads 1 --serialise to give the model its inputs (each world's
thread CPU, messages and bytes to each world). Rank r steps worlds
[r K/R, (r+1) K/R) (--ranks-worlds), the model's machines. The model gives
each world a core; where the K worlds share fewer cores, its compute term is
also shown scaled by K / cores ("on these cores"), and the error is the
measured time against that. Network: --latency-us, --bandwidth and
--overhead-us (defaults: shared memory between ranks on one machine, and
the per-message cost measured in docs/mpi.md).

Usage: bench/rank_memory.py [--soda build/bin/soda] [--scene falling-cubes]
       [--n 1000000] [--territories 4] [--cell-size 4] [--steps 2]
       [--ranks 1,2,4] [--latency-us 1] [--bandwidth 5e9] [--overhead-us 140]
       [--out rank_memory.json]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mpi_model import HORIZON_PERIOD, model_rows, terms  # noqa: E402


def soda_json(cmd, path):
    print("+", " ".join(cmd), file=sys.stderr, flush=True)
    child = subprocess.Popen(cmd)
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        sys.exit(f"rank_memory: {' '.join(cmd)} exited with {child.returncode}")
    with open(path) as f:
        return json.load(f), usage.ru_maxrss * 1024


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--soda", default="build/bin/soda")
    p.add_argument("--scene", default="falling-cubes")
    p.add_argument("--n", type=int, default=1000000)
    p.add_argument("--territories", type=int, default=4)
    p.add_argument("--cell-size", type=float, default=4.0)
    p.add_argument("--steps", type=int, default=2)
    p.add_argument("--ranks", default="1,2,4")
    p.add_argument("--latency-us", type=float, default=1.0)
    p.add_argument("--bandwidth", type=float, default=5e9, help="bytes per second")
    p.add_argument("--overhead-us", type=float, default=140.0, help="per message sent or received")
    p.add_argument("--out", default="-")
    a = p.parse_args()
    # As the MPI tests run it (tests/mpi/CMakeLists.txt): root in a
    # container, shared memory, loopback, more ranks than cores allowed.
    for k, v in {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OMPI_MCA_btl": "self,vader",
                 "OMPI_MCA_oob_tcp_if_include": "lo", "OMPI_MCA_btl_tcp_if_include": "lo",
                 "OMPI_MCA_rmaps_base_oversubscribe": "1", "OMPI_MCA_hwloc_base_binding_policy": "none"}.items():
        os.environ.setdefault(k, v)
    run = [a.soda, "run", "--log-level", "warn", "--scene", a.scene, "--n", str(a.n), "--territories",
           str(a.territories), "--cell-size", str(a.cell_size), "--steps", str(a.steps)]
    path = tempfile.NamedTemporaryFile(suffix=".json", delete=False).name
    try:
        threaded, threaded_rss = soda_json(run + ["--threads", "1", "--serialise", "--json", path], path)
        k, cores = a.territories, os.cpu_count() or 1
        model_run, model_worlds, model_links = model_rows(dict(threaded), "threaded", "strong", a.n, k,
                                                          threaded["partition"], "threaded")
        out = {"scene": a.scene, "n": a.n, "territories": a.territories, "cell_size": a.cell_size,
               "steps": a.steps, "cores": os.cpu_count(),
               "model": {"latency_us": a.latency_us, "bandwidth": a.bandwidth, "overhead_us": a.overhead_us},
               "threaded": {"threads": 1, "serialise": True, "peak_rss_bytes": threaded_rss, "state_hash": threaded["state_hash"],
                            "memory_estimate_bytes": threaded["memory_estimate_bytes"],
                            "wall_seconds_per_step": threaded["wall_seconds"] / max(1, a.steps)},
               "mpirun": []}
        one = None
        for r in (int(x) for x in a.ranks.split(",")):
            if k % r:
                sys.exit(f"rank_memory: {k} territories do not split evenly over {r} ranks")
            per = k // r
            ranks_worlds = ",".join(str(w // per) for w in range(k))
            j, _ = soda_json(["mpirun", "-np", str(r)] + run + ["--ranks-worlds", ranks_worlds, "--json", path], path)
            t = terms(model_run, model_worlds, model_links, per, r, a.latency_us * 1e-6, a.bandwidth,
                      a.overhead_us * 1e-6, HORIZON_PERIOD, False)
            rest = t["latency"] + t["bandwidth"] + t["overhead"] + t["horizon"]
            predicted = t["compute"] + rest
            shared = t["compute"] * max(1.0, k / cores) + rest
            measured = j["wall_seconds"] / max(1, a.steps)
            peaks = [t["peak_rss_bytes"] for t in j["ranks"]]
            one = max(peaks) if one is None and r == 1 else one
            out["mpirun"].append({
                "ranks": r, "oversubscribed": r > (os.cpu_count() or 1), "state_hash": j["state_hash"],
                "peak_rss_bytes": peaks, "largest_peak_rss_bytes": max(peaks),
                "largest_over_one_rank": max(peaks) / one if one else None,
                "bullet_objects": [t["bullet_objects"] for t in j["ranks"]],
                "rank0_memory_estimate_bytes": j["memory_estimate_bytes"],
                "ranks_worlds": ranks_worlds, "wall_seconds_per_step": measured,
                "model_seconds_per_step": predicted, "model_seconds_per_step_on_these_cores": shared,
                "model_error": measured / shared - 1, "model_terms": t,
                "setup_seconds": j.get("setup_seconds")})
    finally:
        os.unlink(path)
    hashes = {out["threaded"]["state_hash"]} | {m["state_hash"] for m in out["mpirun"]}
    out["state_hash_equal"] = len(hashes) == 1
    text = json.dumps(out, indent=2)
    if a.out == "-":
        print(text)
    else:
        with open(a.out, "w") as f:
            f.write(text + "\n")
    sys.exit(0 if out["state_hash_equal"] else 1)


if __name__ == "__main__":
    main()
