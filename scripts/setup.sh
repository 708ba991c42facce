#!/usr/bin/env bash
# Installs what is missing (Debian 12, apt-get), then configures and builds vilma.
# Idempotent: a second run only rebuilds what changed.
#   VILMA_BUILD_DIR   build folder (default: <repo>/build)
#   VILMA_BUILD_TYPE  CMake build type (default: Release)
#   VILMA_JOBS        parallel build jobs (default: 2)
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${VILMA_BUILD_DIR:-$repo/build}"
jobs="${VILMA_JOBS:-2}"

mapfile -t wanted < <(grep -v '^\s*#' "$repo/scripts/debian-packages.txt" | sed '/^\s*$/d')
missing=()
for pkg in "${wanted[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done
if [ ${#missing[@]} -gt 0 ]; then
  cmd="apt-get install -y --no-install-recommends ${missing[*]}"
  if [ "$(id -u)" -eq 0 ]; then
    echo "setup: installing ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q
    $cmd
  else
    echo "setup: missing Debian packages; run as root:" >&2
    echo "  sudo apt-get update && sudo $cmd" >&2
    exit 1
  fi
fi

# LCM's UDP multicast (ttl=0) needs some route for 239.255.76.67; where there is none (a
# container or robot without network), route it through the loopback device. See docs/lcm.md.
if ! ip route get 239.255.76.67 > /dev/null 2>&1; then
  "$repo/scripts/setup-lcm-loopback.sh"
fi

mkdir -p "$build"
cmake -S "$repo" -B "$build" -DCMAKE_BUILD_TYPE="${VILMA_BUILD_TYPE:-Release}" > "$build/configure.log" 2>&1 \
  || { cat "$build/configure.log" >&2; exit 1; }
cmake --build "$build" -j "$jobs"
