#!/usr/bin/env python3
"""An ESTIMATE of the step time of SODA on N machines (docs/mpi-model.md).

Not a measurement: what one machine cannot show (a real network between
worlds) is modelled from what it can measure. Inputs, from `soda run --json`
with --serialise (so the codec's encode and decode CPU is in the stages and
every message has its wire size) and --threads 1 (each world's thread CPU
clean on a small machine):

  * per world, the thread CPU per step and per stage (WorldMetrics::stages),
  * per run, the slowest world's CPU per step, summed (the thesis' measure),
  * per world, the messages and encoded bytes sent to each destination by
    kind, and per step the rounds of each kind and the depth of the merged
    islands' trees (WorldMetrics::traffic, docs/cli.md).

Model, per scene step, lockstep (anticipation 0), one world per machine:

  T(N) = C + R * L + V / B + H(N)

  C  compute: the slowest world's thread CPU per step (mean over steps of the
     per-step maximum over worlds; codec included),
  R  network rounds on the critical path: for the world with the most, per
     step, Ghosts + Glue + Fragments rounds + 2 * merge-tree depth (Gather
     climbs, Results descend) + Migrants,
  V  bytes through the busiest world's network link per step: max over
     worlds of max(bytes sent, bytes received) per step (full duplex),
  H  the commit-horizon reduction: two non-blocking collectives
     (reduce-scatter of counts, then a MIN all-reduce), each ceil(log2 N)
     latencies deep, once every --horizon-period steps (default 8), counted as if it
     never overlapped computation (an upper bound),
  L  one-way latency, B bandwidth, O (--overhead-us, default 0) a per-message
     software cost added per message sent and received by the busiest world.

With W worlds per machine (--worlds-per-machine), machine m holds worlds
[m*W, (m+1)*W) (grid partitions number worlds row by row: strips or blocks
of the grid) on W cores; messages between worlds of one machine cost nothing
on the network and rounds between them no latency.

Left out: contention in the network and in the switch, stragglers beyond
the measured slowest world, speculation (which could hide latency but may
roll back), rollbacks, load balancing, the cost of MPI's own progress
thread, OS noise.

Usage:
  bench/mpi_model.py --measure [--soda build/bin/soda] [--steps 300]
      runs the measured runs (minutes), writes the input CSVs to --inputs
  bench/mpi_model.py [--inputs docs/results] [--png FILE] [--md FILE]
      the estimate table (markdown) and the plot, from the committed inputs
"""
import argparse
import csv
import json
import math
import os
import sys

from scalability import run as soda_run  # bench/scalability.py: `soda run --json` of one configuration

KINDS = ["ghosts", "glue", "fragments", "migrants", "results", "gather", "control"]
STAGES = ["predict", "exchange_ghosts", "collide", "build_islands", "glue", "merge", "solve", "integrate",
          "migrate", "publish", "receive", "checkpoint", "rollback", "idle"]

# The measured runs: (name, scaling, n, territories, grid partition).
# Strong scaling: falling-cubes 16000 cut into K = 8, 64, 512 territories.
# Weak scaling: 250 bodies per world (falling-cubes keeps its density, a
# footprint of 2 sqrt(n) m on a side: a world's territory keeps its area):
# n = 2000 on 8 worlds and 16000 on 64 are measured; 512 worlds (128,000
# bodies) reuse the 64-world run's worlds (see docs/mpi-model.md).
RUNS = [
    ("one-1", "reference", 16000, 1, "grid:1x1x1"),
    ("strong-8", "strong", 16000, 8, "grid:4x1x2"),
    ("strong-64", "strong", 16000, 64, "grid:8x1x8"),
    ("strong-512", "strong", 16000, 512, "grid:32x1x16"),
    ("weak-8", "weak", 2000, 8, "grid:4x1x2"),
]

# The estimate's rows: (label, scaling, N machines, run name, worlds per machine).
ROWS = [
    ("strong", 8, "strong-8", 1),
    ("strong", 64, "strong-64", 1),
    ("strong", 512, "strong-512", 1),
    ("strong, 512 worlds", 8, "strong-512", 64),
    ("strong, 512 worlds", 64, "strong-512", 8),
    ("weak", 8, "weak-8", 1),
    ("weak", 64, "strong-64", 1),
    ("weak", 512, "strong-64", 1),
]

# Steps between two commit-horizon reductions: the default --checkpoint-every
# (8): kept states are freed at checkpoints, so a horizon known more often
# frees nothing sooner.
HORIZON_PERIOD = 8

NETWORKS = [("2 µs, 10 GB/s", 2e-6, 10e9), ("50 µs, 1 GB/s", 50e-6, 1e9)]


def model_rows(j, name, scaling, n, k, partition, cmd):
    """The model's input rows (runs, worlds, links CSV rows) of one `soda run --json`."""
    steps = j["steps"]
    if k == 1:  # one world: no per-world rows, its CPU is the slowest world's
        j["slowest_world_cpu_seconds"], j["messages"], j["message_bytes"], j["worlds"] = j["cpu_seconds"], 0, 0, []
    run = {"run": name, "scaling": scaling, "scene": j["scene"], "n": n, "territories": k,
           "partition": partition, "steps": steps, "precision": j["precision"],
           "state_hash": j["state_hash"], "cpu_seconds": j["cpu_seconds"],
           "slowest_world_cpu_seconds": j["slowest_world_cpu_seconds"], "messages": j["messages"],
           "message_bytes": j["message_bytes"], "command": cmd}
    worlds, links = [], []
    for w in j["worlds"]:
        t = w["traffic"]
        row = {"run": name, "world": w["world"], "internal_steps": t["internal_steps"],
               "cpu_seconds": w["cpu_seconds"], "cpu_step_max_ms": w["cpu_step_max_ms"],
               "owned_bodies": w["owned_bodies"], "neighbours": w["neighbours"],
               "messages_sent": w["messages_sent"],
               "bytes_sent": sum(f["bytes"] for f in t["flows"]),
               "island_depth_sum": t["island_depth_sum"], "island_depth_max": t["island_depth_max"]}
        for kind in KINDS:
            row["rounds_" + kind] = t["rounds"][kind]
        for stage in STAGES:
            row["cpu_" + stage] = w["stages"][stage]["cpu_seconds"]
        worlds.append(row)
        per_to = {}
        for f in t["flows"]:
            m, b = per_to.get(f["to"], (0, 0))
            per_to[f["to"]] = (m + f["messages"], b + f["bytes"])
        for to, (m, b) in sorted(per_to.items()):
            links.append({"run": name, "from": w["world"], "to": to, "messages": m, "bytes": b})
    return run, worlds, links


def measure(a):
    runs, worlds, links = [], [], []
    for name, scaling, n, k, partition in RUNS:
        args = ["--scene", "falling-cubes", "--n", str(n), "--steps", str(a.steps), "--territories", str(k)]
        if k > 1:
            args += ["--partition", partition, "--threads", "1", "--serialise"]
        j, cmd = soda_run(a.soda, args), " ".join(["soda", "run"] + args)
        run, w, l = model_rows(j, name, scaling, n, k, partition, cmd)
        runs.append(run)
        worlds += w
        links += l
    os.makedirs(a.inputs, exist_ok=True)
    for stem, rows in (("runs", runs), ("worlds", worlds), ("links", links)):
        path = os.path.join(a.inputs, f"mpi-model-{stem}.csv")
        with open(path, "w", newline="") as f:
            wr = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            wr.writeheader()
            wr.writerows(rows)
        print(f"wrote {path}", file=sys.stderr)


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def load(inputs):
    runs = {r["run"]: r for r in read_csv(os.path.join(inputs, "mpi-model-runs.csv"))}
    worlds, links = {}, {}
    for r in read_csv(os.path.join(inputs, "mpi-model-worlds.csv")):
        worlds.setdefault(r["run"], []).append(r)
    for r in read_csv(os.path.join(inputs, "mpi-model-links.csv")):
        links.setdefault(r["run"], []).append(r)
    return runs, worlds, links


def terms(run, worlds, links, per_machine, n_machines, latency, bandwidth, overhead, horizon_period,
          interior_only):
    """The model's terms (seconds per scene step) for one row."""
    steps = int(run["steps"])
    substeps = max(1, int(worlds[0]["internal_steps"]) // steps)
    machine = lambda w: w // per_machine  # noqa: E731
    chosen = [w for w in worlds if not interior_only or int(w["neighbours"]) == max(int(x["neighbours"]) for x in worlds)]
    ids = {int(w["world"]) for w in chosen}
    # Bytes and messages per world that leave its machine, sent and received.
    sent_b, recv_b, sent_m, recv_m = {}, {}, {}, {}
    for l in links:
        f, t = int(l["from"]), int(l["to"])
        if machine(f) == machine(t):
            continue
        sent_b[f] = sent_b.get(f, 0) + int(l["bytes"])
        recv_b[t] = recv_b.get(t, 0) + int(l["bytes"])
        sent_m[f] = sent_m.get(f, 0) + int(l["messages"])
        recv_m[t] = recv_m.get(t, 0) + int(l["messages"])
    # Per machine: its worlds' traffic shares one link.
    link_bytes, link_msgs = {}, {}
    for w in ids:
        m = machine(w)
        s, r = link_bytes.get(m, (0, 0))
        link_bytes[m] = (s + sent_b.get(w, 0), r + recv_b.get(w, 0))
        s, r = link_msgs.get(m, (0, 0))
        link_msgs[m] = (s + sent_m.get(w, 0), r + recv_m.get(w, 0))
    volume = max((max(s, r) for s, r in link_bytes.values()), default=0) / steps
    messages = max((s + r for s, r in link_msgs.values()), default=0) / steps
    rounds = 0.0
    # The step waits for the slowest neighbour: the rounds of a world with a
    # neighbour on another machine (every world, one world per machine).
    remote = {int(l["from"]) for l in links if machine(int(l["from"])) != machine(int(l["to"]))}
    if n_machines > 1:
        for w in (w for w in chosen if int(w["world"]) in remote):
            r = sum(float(w["rounds_" + k]) for k in ("ghosts", "glue", "fragments", "migrants"))
            r += 2 * float(w["island_depth_sum"])
            rounds = max(rounds, r / steps)
    compute = float(run["slowest_world_cpu_seconds"]) / steps
    horizon = 2 * math.ceil(math.log2(n_machines)) * latency / horizon_period if n_machines > 1 else 0.0
    return {"compute": compute, "rounds": rounds, "latency": rounds * latency, "bytes": volume,
            "bandwidth": volume / bandwidth, "messages": messages, "overhead": messages * overhead,
            "horizon": horizon, "substeps": substeps}


def estimate(a):
    runs, worlds, links = load(a.inputs)
    table = []
    for scaling, n, name, per_machine in ROWS:
        run = runs[name]
        k = int(run["territories"])
        if per_machine * n != k and not scaling.startswith("weak"):
            raise SystemExit(f"{name}: {k} worlds on {n} machines of {per_machine}")
        # Weak scaling beyond the measured K: the measured run's interior worlds
        # stand for every world (constant density, constant territory).
        interior = scaling == "weak" and n != k
        for net, latency, bandwidth in NETWORKS:
            t = terms(run, worlds[name], links[name], per_machine, n, latency, bandwidth, a.overhead_us * 1e-6,
                      a.horizon_period, interior)
            total = t["compute"] + t["latency"] + t["bandwidth"] + t["overhead"] + t["horizon"]
            # Strong scaling: against one world on one machine (measured CPU).
            one = float(runs["one-1"]["cpu_seconds"]) / float(runs["one-1"]["steps"])
            table.append({"scaling": scaling, "machines": n, "worlds": k if not interior else n * per_machine,
                          "bodies": int(run["n"]) * (n // k if interior else 1), "run": name, "network": net,
                          **t, "total": total,
                          "speedup": one / total if scaling.startswith("strong") else None})
    return runs, table


def ms(x):
    return f"{x * 1e3:.3f}"


def markdown(runs, table, a):
    out = ["**Estimate** (not a measurement): scene-step time in ms on N machines, lockstep, "
           f"horizon reduction every {a.horizon_period} step(s), per-message overhead {a.overhead_us:g} µs; "
           "inputs in docs/results/mpi-model-*.csv (docs/mpi-model.md).", "",
           "| scaling | N machines | worlds | bodies | network | compute | rounds | latency | bytes/step | "
           "bandwidth | horizon | **estimate** | compute share | speed-up vs 1 world |",
           "|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in table:
        speedup = f"{r['speedup']:.1f}" if r["speedup"] is not None else "—"
        out.append(f"| {r['scaling']} | {r['machines']} | {r['worlds']} | {r['bodies']} | {r['network']} | "
                   f"{ms(r['compute'])} | {r['rounds']:.2f} | {ms(r['latency'])} | {r['bytes'] / 1e3:.1f} kB | "
                   f"{ms(r['bandwidth'])} | {ms(r['horizon'])} | **{ms(r['total'])}** | "
                   f"{100 * r['compute'] / r['total']:.0f} % | {speedup} |")
    one = runs["one-1"]
    out += ["", f"One world on one machine (measured, {one['command']}): "
            f"{ms(float(one['cpu_seconds']) / float(one['steps']))} ms CPU per step."]
    return "\n".join(out) + "\n"


def plot(runs, table, a):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    one = float(runs["one-1"]["cpu_seconds"]) / float(runs["one-1"]["steps"])
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.6), sharey=True)
    for ax, scaling in zip(axes, ["strong", "weak"]):
        for (net, _, _), colour in zip(NETWORKS, ["C0", "C1"]):
            rows = [r for r in table if r["scaling"] == scaling and r["network"] == net]
            n = [r["machines"] for r in rows]
            ax.plot(n, [r["total"] * 1e3 for r in rows], "o-", color=colour, label=f"estimate, {net}")
            if scaling == "strong":  # the 512-world run on 8, 64 and 512 machines
                rows = [r for r in table if r["run"] == "strong-512" and r["network"] == net]
                ax.plot([r["machines"] for r in rows], [r["total"] * 1e3 for r in rows], "x--", color=colour,
                        alpha=0.6, label=f"estimate, {net}, 512 worlds on N machines")
        if scaling == "strong":
            ax.axhline(one * 1e3, color="black", lw=0.8, ls="-.", label="one world on one machine (measured CPU)")
        rows = [r for r in table if r["scaling"] == scaling and r["network"] == NETWORKS[0][0]]
        ax.plot([r["machines"] for r in rows], [r["compute"] * 1e3 for r in rows], "s:", color="grey",
                label="compute alone (measured CPU)")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_ylim(0.3, 1000)  # room for the legend above the one-world line
        ax.set_xticks([8, 64, 512])
        ax.set_xticklabels(["8", "64", "512"])
        ax.set_xlabel("machines N (one world each unless said)")
        what = "falling-cubes 16000" if scaling == "strong" else "250 bodies per world"
        ax.set_title(f"{scaling} scaling: {what}", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_ylabel("scene-step time, ms (ESTIMATE)")
    fig.suptitle("ESTIMATE, not a measurement: lockstep step time on N machines "
                 "(bench/mpi_model.py, docs/mpi-model.md)", fontsize=10)
    fig.tight_layout()
    fig.savefig(a.png, dpi=100)
    print(f"wrote {a.png}", file=sys.stderr)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--measure", action="store_true", help="run the measured runs and write the input CSVs")
    p.add_argument("--soda", default="build/bin/soda")
    p.add_argument("--steps", type=int, default=300)
    p.add_argument("--inputs", default="docs/results")
    p.add_argument("--png", default="docs/results/mpi-model.png")
    p.add_argument("--md", default="-", help="where the table goes (markdown; - for stdout)")
    p.add_argument("--overhead-us", type=float, default=0.0)
    p.add_argument("--horizon-period", type=int, default=HORIZON_PERIOD, help="steps between horizon reductions")
    a = p.parse_args()
    if a.measure:
        measure(a)
    runs, table = estimate(a)
    text = markdown(runs, table, a)
    if a.md == "-":
        print(text, end="")
    else:
        with open(a.md, "w") as f:
            f.write(text)
    plot(runs, table, a)


if __name__ == "__main__":
    main()
