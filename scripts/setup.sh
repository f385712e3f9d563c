#!/usr/bin/env bash
# Installs the Debian 12 packages SODA builds against, skipping those already
# there. Needs root (or sudo). Safe to run again.
#   scripts/setup.sh          everything: the build, the plots, the viewer and
#                             the browser tests (scripts/test.sh)
#   scripts/setup.sh build    only what configuring and building needs
#                             (scripts/bench.sh): no plotting, no three.js,
#                             no chromium, node or playwright-core
set -euo pipefail

mode="${1:-all}"
case "$mode" in
  all|build) ;;
  *) echo "setup: unknown mode '$mode' (all or build)" >&2; exit 2 ;;
esac

# What CMake needs to configure and build every target (MPI too: SODA_MPI
# is decided, and cached, at the first configure).
packages=(
  g++ cmake ninja-build pkg-config
  libbullet-dev          # Bullet 3.24, float and -float64 libraries
  libeigen3-dev libspdlog-dev
  libcli11-dev nlohmann-json3-dev
  libgtest-dev
  zlib1g-dev             # replay files (replay/: zlib chunks)
  libcpp-httplib-dev     # the viewer's frame server (soda view, soda run --serve)
  libopenmpi-dev openmpi-bin  # territories on MPI ranks (mpi/, docs/mpi.md; mpirun for its tests)
)
if [ "$mode" = all ]; then
  packages+=(
    python3-matplotlib   # bench/plot_accuracy.py (plots only; the C++ never needs it)
    universal-ctags      # scripts/room-sizes.py (function lengths; scripts/test.sh's size check)
    libtbb-dev           # oneTBB: -DSODA_SOLVER_POOL_TBB=ON, the coloured solve's pool measured (docs/scheduler.md)
    libjs-three          # three.js for the browser viewer (served from /usr/share/javascript/three)
    chromium             # the browser tests (headless, WebGL on SwiftShader)
  )
  # node (>= 20: playwright-core's requirement; the machine's own) runs the
  # browser tests; Debian's nodejs if there is none at all.
  command -v node >/dev/null || packages+=(nodejs npm)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

# The browser tests' driver: playwright-core (no browser download: it drives
# Debian's chromium) from the npm registry into viewer/tests/node_modules, at
# the version package-lock.json pins.
install_playwright() {
  local dir viewer_tests
  dir="$(cd "$(dirname "$0")/.." && pwd)"
  viewer_tests="$dir/viewer/tests"
  if [ -f "$viewer_tests/node_modules/playwright-core/package.json" ]; then
    echo "setup: playwright-core present"
  else
    echo "setup: installing playwright-core into $viewer_tests/node_modules"
    (cd "$viewer_tests" && npm ci --no-audit --no-fund --loglevel=error)
  fi
}

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  [ "$mode" = all ] && install_playwright
  exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null; then sudo="sudo"; else
    echo "setup: need root to install: ${missing[*]}" >&2
    exit 1
  fi
fi
echo "setup: installing ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
[ "$mode" = all ] && install_playwright
exit 0
