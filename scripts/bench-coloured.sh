#!/usr/bin/env bash
# The coloured solve of large islands (docs/coloured-solve.md), side by side
# in one session, for each scene of SCENES (cube-pile, then heap): stock Bullet, one territory on 1 and on 2 solver threads,
# two territories (thread per world) on 1 and on 2 solver threads; every
# configuration REPEAT times, interleaved, the minimum wall time of each
# kept. Prints one line per run and a table of ratios against one territory
# on one thread; every canonical run must give one hash (exit 1 if not).
# Environment: SCENES ("cube-pile heap"; SCENE=x runs x alone), N (4000),
# STEPS (600), REPEAT (1), BIN (build/bin/soda). Not a test: timings on a
# shared machine drift.
set -euo pipefail
cd "$(dirname "$0")/.."
scenes="${SCENES:-${SCENE:-cube-pile heap}}"
n="${N:-4000}"
steps="${STEPS:-600}"
repeat="${REPEAT:-1}"
bin="${BIN:-build/bin/soda}"
configs=("stock|--world stock"
         "K=1 T=1|--territories 1 --solver-threads 1"
         "K=1 T=2|--territories 1 --solver-threads 2"
         "K=2 T=1|--territories 2 --solver-threads 1"
         "K=2 T=2|--territories 2 --solver-threads 2")
status=0
for scene in $scenes; do
  unset best hash
  declare -A best hash
  echo "# $scene n=$n steps=$steps repeat=$repeat; $(nproc) CPUs; load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"
  for ((r = 0; r < repeat; ++r)); do
    for c in "${configs[@]}"; do
      name="${c%%|*}"
      args="${c#*|}"
      # shellcheck disable=SC2086
      line=$("$bin" run --scene "$scene" --n "$n" --steps "$steps" $args 2>/dev/null | head -1)
      wall=$(sed -E 's/.* steps in ([0-9.]+) s.*/\1/' <<<"$line")
      h=$(sed -E 's/.*state_hash ([0-9a-f]+).*/\1/' <<<"$line")
      echo "$name: ${wall} s, hash $h (load $(cut -d' ' -f1 /proc/loadavg))"
      if [[ -z "${best[$name]:-}" ]] || awk "BEGIN{exit !($wall < ${best[$name]})}"; then best[$name]=$wall; fi
      hash[$name]=$h
    done
  done
  echo "# load average at end: $(cut -d' ' -f1-3 /proc/loadavg)"
  ref=${best["K=1 T=1"]}
  printf '%-8s %10s %18s %12s\n' config "wall s" "vs K=1 T=1 (x)" hash
  for c in "${configs[@]}"; do
    name="${c%%|*}"
    printf '%-8s %10s %18s %12s\n' "$name" "${best[$name]}" "$(awk "BEGIN{printf \"%.2f\", $ref / ${best[$name]}}")" "${hash[$name]}"
    if [[ "$name" != stock && "${hash[$name]}" != "${hash["K=1 T=1"]}" ]]; then status=1; fi
  done
done
exit $status
