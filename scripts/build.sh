#!/usr/bin/env bash
# Configures and builds SODA (both precisions) in build/ (Release by default).
# Usage: scripts/build.sh [BUILD_TYPE] [BUILD_DIR] [extra cmake args...]
set -euo pipefail
cd "$(dirname "$0")/.."
type="${1:-Release}"
dir="${2:-build}"
shift $(( $# > 2 ? 2 : $# ))
cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE="$type" "$@"
cmake --build "$dir" -j "$(nproc)"
