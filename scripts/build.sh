#!/usr/bin/env bash
# Installs what envlight needs from Debian (when missing; needs root), then configures and
# builds into ./build (or $1). Extra arguments go to cmake's configure step.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
shift || true

packages=(build-essential cmake pkg-config libopenexr-dev libpng-dev clang python3 python3-numpy python3-pytest povray blender gnuplot-nox openimageio-tools valgrind xvfb xauth)
missing=()
for p in "${packages[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if ((${#missing[@]})); then
  if [ "$(id -u)" != 0 ]; then
    echo "envlight: missing Debian packages: ${missing[*]} (run as root to install them)" >&2
    exit 1
  fi
  echo "envlight: installing ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@" >/dev/null
cmake --build "$build" -j"$(nproc)"
