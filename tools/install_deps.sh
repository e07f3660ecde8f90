#!/usr/bin/env bash
# Installs, with apt, the Debian 12 packages MotionKit builds, tests and demos
# with; only what is missing, so a prepared machine pays nothing.
#   tools/install_deps.sh            host packages (Blender 3.4 and its toolchain)
#   tools/install_deps.sh --blender5 also create or update the sid chroot (5.2)
set -euo pipefail
packages=(
  blender python3 python3-dev python3-numpy python3-scipy python3-pytest python3-matplotlib
  g++ cmake make libeigen3-dev pybind11-dev libgtest-dev libgmock-dev libbenchmark-dev
  debootstrap util-linux zip
  clang libclang-rt-dev
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
if ((${#missing[@]})); then
  [ "$(id -u)" = 0 ] || { echo "install_deps.sh: run as root to install: ${missing[*]}" >&2; exit 1; }
  echo "install_deps.sh: installing ${missing[*]}"
  apt-get update -q
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
if [ "${1:-}" = --blender5 ]; then
  "$(dirname "$0")/blender5.sh" setup
fi
