#!/usr/bin/env bash
# Installs what envlight needs from Debian (when missing; needs root), then configures and
# builds into ./build (or $1). Extra arguments go to cmake's configure step.
case "${1:-}" in  # --help: the usage and the header above, nothing run
  -h|--help) echo "usage: bash scripts/build.sh [BUILD_DIR] [CMAKE_ARG...]"; sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
esac
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
shift || true

packages=(build-essential cmake pkg-config libopenexr-dev libpng-dev clang python3 python3-numpy python3-pytest python3-venv povray povray-includes blender blender-data gnuplot-nox openimageio-tools valgrind xvfb xauth chromium tesseract-ocr)
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

# Debian 13's Blender 4.3 beside Debian 12's 3.4, for the test py_blender_addon_4_3 (issue 14):
# scripts/blender4.sh makes a trixie root under /var/cache/envlight once (about 5 min and
# 1.4 GB), then only checks it (0.3 s); its last line is the wrapper that runs that Blender.
blender4=()
if [ "$(id -u)" = 0 ]; then
  if ! run_blender=$(bash scripts/blender4.sh | tail -1) || [ ! -x "$run_blender" ]; then
    echo "envlight: scripts/blender4.sh failed (Blender 4.3 for the py_blender_addon_4_3 test)" >&2
    exit 1
  fi
  blender4=(-DENVL_BLENDER4="$run_blender")
else
  echo "envlight: not root: Debian 13's Blender 4.3 (scripts/blender4.sh, needs root) is not" \
    "set up; the py_blender_addon_4_3 test will be skipped" >&2
fi

# The tests' real consumers from npm (the glTF validator, ktx-parse, Babylon.js's SH):
# scripts/npm_tools.sh installs them once under /var/cache/envlight (about 10 s), then only
# checks them; without them the tests that need them skip.
npm_tools=()
if node_modules=$(bash scripts/npm_tools.sh | tail -1) && [ -d "$node_modules" ]; then
  npm_tools=(-DENVL_NODE_MODULES="$node_modules")
else
  echo "envlight: scripts/npm_tools.sh failed: the glTF and KTX2 consumer tests will skip" >&2
fi

cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo "${blender4[@]}" "${npm_tools[@]}" "$@" >/dev/null
cmake --build "$build" -j"$(nproc)"
