#!/usr/bin/env bash
# Quick start 1: install what a build needs, build the `soda` command
# (Release, float: only what `soda bench` links, not the double-precision
# build, the tests or the examples; scripts/test.sh builds everything), and
# run the falling-cubes benchmark against stock Bullet, side by side.
# Sizes: N=16000 REPEAT=3 scripts/bench.sh; other arguments go to `soda bench`.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh build
start=$SECONDS
# build/ as scripts/build.sh configures it (both precisions, tests on), so
# that scripts/test.sh builds the rest there later, with each library and
# the CLI compiled as one unit (SODA_UNITY_BUILD, CMakeLists.txt: a build
# from scratch takes a fraction of the CPU; the results are the same bits).
# The option stays in build/'s cache; `cmake -B build -DSODA_UNITY_BUILD=OFF`
# goes back to compiling file by file.
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DSODA_UNITY_BUILD=ON
cmake --build build -j "$(nproc)" --target soda
echo "bench: soda built in $((SECONDS - start)) s"
# The headline: stock Bullet, SODA on one territory and SODA on as many
# territories as cores, sleeping on and again off, side by side in one
# process; prints a table of the speed-ups, the bodies asleep and the hash
# check (exit 1 if the K-territory hash differs from the one-territory hash).
# Size, measured: falling-cubes n=4000, 600 steps, 1 repeat, K=2 takes 47-59 s
# of CPU in all (two runs; sleeping off is about twice sleeping on; the two
# territories run in parallel), so about 40-50 s of wall time on 2 otherwise
# idle cores. Override with N=, STEPS=, REPEAT=, TERRITORIES= in the
# environment; other options of `soda bench` as arguments (e.g. --partition rcb).
n="${N:-4000}"
steps="${STEPS:-600}"
repeat="${REPEAT:-1}"
territories="${TERRITORIES:-$(nproc)}"
start=$SECONDS
echo "soda bench falling-cubes --n $n --steps $steps --repeat $repeat --territories $territories" \
  "(sleeping on and off; about a minute on 2 idle cores at the default size)"
build/bin/soda bench falling-cubes --n "$n" --steps "$steps" --repeat "$repeat" --territories "$territories" \
  --log-level warn --json build/bench-falling-cubes.json "$@"
echo "bench: $((SECONDS - start)) s wall; every figure and each run's details: build/bench-falling-cubes.json"
