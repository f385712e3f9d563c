#!/usr/bin/env bash
# The coloured solve's pool against oneTBB (docs/scheduler.md, "oneTBB for
# the coloured solve"): one territory, 2 solver threads, heap and cube-pile
# 4000, 600 steps, three rounds, the two binaries interleaved (the order
# alternating by round). Prints CSV (stepping wall and process CPU seconds
# from soda run's JSON, and the state hash, which must be the same).
#
#   scripts/build.sh Release build
#   cmake -S . -B build/tbb -G Ninja -DCMAKE_BUILD_TYPE=Release -DSODA_SOLVER_POOL_TBB=ON \
#     -DSODA_BUILD_TESTS=OFF -DSODA_BUILD_DOUBLE=OFF && cmake --build build/tbb --target soda
#   bench/solver_pool_tbb.sh build/bin/soda build/tbb/bin/soda > docs/results/solver-pool-tbb.csv
set -euo pipefail
own=${1:?usage: solver_pool_tbb.sh OWN_POOL_SODA TBB_SODA}
tbb=${2:?usage: solver_pool_tbb.sh OWN_POOL_SODA TBB_SODA}
json=$(mktemp)
trap 'rm -f "$json"' EXIT
echo "round,pool,scene,n,wall_seconds,process_cpu_seconds,state_hash"
for round in 1 2 3; do
  for scene in "heap 4000" "cube-pile 4000"; do
    set -- $scene
    order="own tbb"
    [ $((round % 2)) -eq 0 ] && order="tbb own"
    for pool in $order; do
      bin=$own
      [ "$pool" = tbb ] && bin=$tbb
      "$bin" run --scene "$1" --n "$2" --steps 600 --solver-threads 2 --log-level warn --json "$json" > /dev/null
      python3 -c "import json, sys; d = json.load(open(sys.argv[1])); print('$round,$pool,$1,$2,%.3f,%.3f,%s' % (d['wall_seconds'], d['process_cpu_seconds'], d['state_hash']))" "$json"
    done
  done
done
