#!/usr/bin/env bash
# The coloured solve of large islands (docs/coloured-solve.md, its
# benchmark), side by side in one session, for each scene of SCENES
# (cube-pile, then heap): stock Bullet, one territory on 1 and on 2 solver
# threads, two territories on 2 threads (one world per thread; the waiting
# world serves the root's solve as a guest). REPEAT rounds, each running every
# configuration once, interleaved; every ratio is against the one-territory,
# one-thread run *of the same round* (this machine's speed drifts by tens of
# per cent from minute to minute, so a round is the unit that is side by side).
#
# Output, CSV on stdout: one row per run
#   scene,n,steps,round,config,wall_s,cpu_s,ratio,hash
# (cpu_s: the process's CPU seconds while stepping, every thread; ratio: the round's K1T1
# wall over this run's wall), then one summary row per scene and configuration
#   scene,n,steps,summary,config,least_wall_s,median_ratio,rounds_at_target,target
# (median of the per-round ratios; rounds whose ratio is at least TARGET).
# Progress and the load average go to stderr. Every SODA configuration must
# give one hash per scene (exit 1 if not).
# Environment: SCENES ("cube-pile heap"; SCENE=x runs x alone), N (4000),
# STEPS (600), REPEAT (3), TARGET (1.6), BIN (build/bin/soda). Not a test.
set -euo pipefail
cd "$(dirname "$0")/.."
scenes="${SCENES:-${SCENE:-cube-pile heap}}"
n="${N:-4000}"
steps="${STEPS:-600}"
repeat="${REPEAT:-3}"
target="${TARGET:-1.6}"
bin="${BIN:-build/bin/soda}"
configs=("stock|--world stock"
         "K1T1|--territories 1 --solver-threads 1"
         "K1T2|--territories 1 --solver-threads 2"
         "K2|--territories 2 --threads 2")
json=$(mktemp)
trap 'rm -f "$json"' EXIT
# A top-level field of the run's JSON (python3: scripts/setup.sh installs it).
field() {
  python3 -c 'import json, sys; v = json.load(open(sys.argv[1]))[sys.argv[2]]; print(f"{v:.3f}" if isinstance(v, float) else v)' \
    "$json" "$1"
}
status=0
echo "scene,n,steps,round,config,wall_s,cpu_s,ratio,hash"
for scene in $scenes; do
  unset wall ratio hash rows
  declare -A wall ratio hash rows
  echo "# $scene n=$n steps=$steps repeat=$repeat; $(nproc) CPUs; load average $(cut -d' ' -f1-3 /proc/loadavg)" >&2
  for ((r = 1; r <= repeat; ++r)); do
    for c in "${configs[@]}"; do
      name="${c%%|*}"
      # shellcheck disable=SC2086
      "$bin" run --scene "$scene" --n "$n" --steps "$steps" ${c#*|} --json "$json" >/dev/null 2>&1
      wall[$r,$name]=$(field wall_seconds)
      cpu=$(field process_cpu_seconds)  # every thread (cpu_seconds: the stepping threads only)
      hash[$r,$name]=$(field state_hash)
      echo "#   round $r $name: ${wall[$r,$name]} s wall, $cpu s CPU (load $(cut -d' ' -f1 /proc/loadavg))" >&2
      rows[$r,$name]="$scene,$n,$steps,$r,$name,${wall[$r,$name]},$cpu"
    done
    for c in "${configs[@]}"; do
      name="${c%%|*}"
      ratio[$r,$name]=$(awk "BEGIN{printf \"%.3f\", ${wall[$r,K1T1]} / ${wall[$r,$name]}}")
      echo "${rows[$r,$name]},${ratio[$r,$name]},${hash[$r,$name]}"
      if [[ "$name" != stock && "${hash[$r,$name]}" != "${hash[1,K1T1]}" ]]; then
        echo "# $scene round $r $name: hash ${hash[$r,$name]} differs from ${hash[1,K1T1]}" >&2
        status=1
      fi
    done
  done
  for c in "${configs[@]}"; do
    name="${c%%|*}"
    least=$(for ((r = 1; r <= repeat; ++r)); do echo "${wall[$r,$name]}"; done | sort -g | head -1)
    median=$(for ((r = 1; r <= repeat; ++r)); do echo "${ratio[$r,$name]}"; done | sort -g |
             awk '{v[NR] = $1} END {printf "%.3f", NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}')
    at=$(for ((r = 1; r <= repeat; ++r)); do echo "${ratio[$r,$name]}"; done | awk -v t="$target" '$1 >= t {++k} END {print k + 0}')
    echo "$scene,$n,$steps,summary,$name,$least,$median,$at/$repeat,$target"
  done
done
exit $status
