#!/usr/bin/env bash
# Quick start 2: install what is missing, build, and run the whole test suite
# (both precisions), then the concurrency tests under ThreadSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
# Where the time goes: each stage's start, in seconds since this script's.
stage() { echo "== scripts/test.sh at ${SECONDS} s: $1"; }
scripts/setup.sh
# worlds/ and runtime/: no library file over 450 lines, no function over 100
# (exit 1 naming each one over).
scripts/room-sizes.py
# Each library and the CLI compiled as one unit (SODA_UNITY_BUILD,
# CMakeLists.txt), as scripts/bench.sh builds them: a third of the CPU of
# compiling file by file. The ThreadSanitizer build below gives the same
# bits at -O1 (checked at the end).
stage "build (Release)"
scripts/build.sh Release build -DSODA_UNITY_BUILD=ON
stage "tests (Release)"
(cd build && ctest --output-on-failure -j "$(nproc)" --timeout 900)
# Committed result files older than the code they measure (docs/results/sources.tsv):
# printed as a warning, never a failure.
scripts/stale-results.py || true
# The installed package (docs/embedding.md, "Using SODA from CMake"): install
# to a prefix inside build/, compile every public header alone against it
# (tests/install/), then build and run the find_package(soda) consumer
# (examples/consumer/: 2 territories == 1, float and double).
stage "installed package and examples"
prefix="$PWD/build/install-prefix"
rm -rf "$prefix" build/install-check build/consumer
cmake --install build --prefix "$prefix"
cmake -S tests/install -B build/install-check -G Ninja -DCMAKE_PREFIX_PATH="$prefix"
cmake --build build/install-check -j "$(nproc)"
cmake -S examples/consumer -B build/consumer -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix"
cmake --build build/consumer -j "$(nproc)"
build/consumer/consumer
build/consumer/consumer_double
# The embedding examples, built against the installed package: each ends on
# the one-world hash (exit 1 if it differs).
build/consumer/game_loop
build/consumer/game_loop --stepping
build/consumer/picking
build/consumer/contact_sounds
build/consumer/trigger_zones
build/consumer/snapshot_restore
build/consumer/save_resume
build/consumer/moving_platform
build/consumer/ragdoll_pile
build/consumer/drawbridge
# soda::mpi from the installed package (where MPI is found): 4 territories on
# 2 ranks against one territory, run as the mpi tests run theirs (this
# machine only, oversubscribed, root allowed).
if [ -x build/consumer/ranked_cubes ]; then
  OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl=self,vader \
    OMPI_MCA_oob_tcp_if_include=lo OMPI_MCA_btl_tcp_if_include=lo OMPI_MCA_rmaps_base_oversubscribe=1 \
    OMPI_MCA_hwloc_base_binding_policy=none timeout 300 mpirun --oversubscribe -np 2 build/consumer/ranked_cubes
fi
# ThreadSanitizer cannot see inside Debian's (uninstrumented) Bullet; see
# docs/bullet-globals.md for how its shared state is handled.
stage "build (ThreadSanitizer)"
# Its libraries compiled as one unit too (a third of the CPU; the sources
# compile file by file in every build made without SODA_UNITY_BUILD, the
# default of scripts/build.sh).
cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSODA_SANITIZE=thread -DSODA_BUILD_DOUBLE=OFF \
  -DSODA_UNITY_BUILD=ON
cmake --build build-tsan --target concurrency_tests falling_cubes -j "$(nproc)"
# Two suites at a time: each is threads already, and more threads than cores
# shakes out more interleavings (300 s instead of 470 s on 2 cores).
stage "tests (ThreadSanitizer)"
(cd build-tsan && TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" \
   ctest --output-on-failure -j "$(nproc)" -L concurrency --timeout 900)
# The same bits from both builds: the libraries at -O3 (build/) and at -O1
# under ThreadSanitizer (build-tsan/), the smallest embedding
# (examples/falling_cubes.cpp) on 1 and 3 territories.
# IEEE arithmetic under -ffp-contract=off and without fast-math does not
# depend on what is inlined or optimised where (docs/architecture.md).
stage "the same bits from both builds"
for k in 1 3; do
  a=$(build/bin/falling_cubes 500 300 $k 2>/dev/null | grep -o 'state_hash [0-9a-f]*')
  b=$(TSAN_OPTIONS="halt_on_error=1" build-tsan/bin/falling_cubes 500 300 $k 2>/dev/null | grep -o 'state_hash [0-9a-f]*')
  echo "build check, falling-cubes 500, 300 steps, $k territories: -O3 $a, -O1 under TSan $b"
  [ -n "$a" ] && [ "$a" = "$b" ] || { echo "build check: the hashes differ" >&2; exit 1; }
done
stage "done"
