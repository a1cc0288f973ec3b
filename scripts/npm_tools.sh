#!/usr/bin/env bash
# The real consumers that the tests check envlight's outputs against, from the npm registry
# (pinned in tests/npm/package.json and its package-lock.json): the Khronos glTF validator
# (gltf-validator), ktx-parse (KTX2 containers) and Babylon.js's spherical harmonics
# (@babylonjs/core). Installs them once with `npm ci` under
# ${ENVL_CACHE:-/var/cache/envlight}/npm-<hash of the lock file>, installing Debian's nodejs and
# npm first when node or npm is missing (needs root then); the last line of stdout is the
# node_modules folder (scripts/build.sh passes it to CMake as ENVL_NODE_MODULES).
#
#     bash scripts/npm_tools.sh | tail -1
#
# A later run with the same lock file only checks the folder (well under a second).
case "${1:-}" in  # --help: the usage and the header above, nothing run
  -h|--help) echo "usage: bash scripts/npm_tools.sh   (last line of stdout: the node_modules folder)"; sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
esac
set -euo pipefail
cd "$(dirname "$0")/.."
exec 3>&1 1>&2 # stdout is for the last line only (fd 3)

if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  if [ "$(id -u)" != 0 ]; then
    echo "envlight: node and npm are missing (run as root to install Debian's nodejs and npm)"
    exit 1
  fi
  echo "envlight: installing nodejs npm"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
fi

hash=$(cat tests/npm/package.json tests/npm/package-lock.json | sha256sum | cut -c1-12)
dest=${ENVL_CACHE:-/var/cache/envlight}/npm-$hash
if [ ! -f "$dest/.envlight-ready" ]; then
  start=$(date +%s)
  rm -rf "$dest"
  mkdir -p "$dest"
  cp tests/npm/package.json tests/npm/package-lock.json "$dest/"
  (cd "$dest" && npm ci --no-audit --no-fund --loglevel=error)
  touch "$dest/.envlight-ready"
  echo "envlight: npm tools installed in $dest ($(( $(date +%s) - start )) s)"
fi
echo "$dest/node_modules" >&3
