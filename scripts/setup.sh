#!/usr/bin/env bash
# Installs the Debian 12 packages SODA builds against, skipping those already
# there. Needs root (or sudo). Safe to run again.
set -euo pipefail

packages=(
  g++ cmake ninja-build pkg-config
  libbullet-dev          # Bullet 3.24, float and -float64 libraries
  libeigen3-dev libspdlog-dev
  libcli11-dev nlohmann-json3-dev
  libgtest-dev
  zlib1g-dev             # replay files (replay/: zlib chunks)
  python3-matplotlib     # bench/plot_accuracy.py (plots only; the C++ never needs it)
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
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
