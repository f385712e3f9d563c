#!/usr/bin/env bash
# Quick start 2: install what is missing, build, and run the whole test suite
# (both precisions), then the concurrency tests under ThreadSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh Release build
(cd build && ctest --output-on-failure -j "$(nproc)" --timeout 900)
# ThreadSanitizer cannot see inside Debian's (uninstrumented) Bullet; see
# docs/bullet-globals.md for how its shared state is handled.
cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSODA_SANITIZE=thread -DSODA_BUILD_DOUBLE=OFF
cmake --build build-tsan --target concurrency_tests -j "$(nproc)"
(cd build-tsan && TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" \
   ctest --output-on-failure -L concurrency --timeout 900)
