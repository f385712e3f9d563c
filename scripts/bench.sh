#!/usr/bin/env bash
# Quick start 1: install what is missing, build (Release), and run the
# falling-cubes benchmark against stock Bullet, side by side.
# Extra arguments go to `soda bench` (e.g. --n 16000 --repeat 5).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh Release build
build/bin/soda bench falling-cubes --n 2000 --steps 600 --repeat 3 --json build/bench-falling-cubes.json "$@"
echo "results: build/bench-falling-cubes.json"
