#!/usr/bin/env bash
# Installs, with apt, the Debian 12 packages MotionKit builds, tests and demos
# with; only what is missing, so a prepared machine pays nothing.
#   tools/install_deps.sh            host packages (Blender 3.4 and its toolchain), and node's packages
#                                    that play and validate exported glTF files (tools/js, npm ci)
#   tools/install_deps.sh --chroots  also create or update the trixie (4.3) and
#                                    sid (5.2) chroots (tools/chroot.sh)
set -euo pipefail
packages=(
  blender python3 python3-dev python3-numpy python3-scipy python3-pytest python3-matplotlib python3-distributed
  g++ cmake make libeigen3-dev pybind11-dev libgtest-dev libgmock-dev libbenchmark-dev
  debootstrap util-linux zip ccache
  clang libclang-rt-dev
  xvfb xauth libgl1-mesa-dri libegl1 mesa-utils tesseract-ocr x11-apps
)
# node and npm run tools/js (three.js, Khronos' glTF validator). Debian's nodejs and npm unless the commands are
# already there (another packaging of node, which Debian's npm would conflict with, is kept).
command -v node >/dev/null || packages+=(nodejs)
command -v npm >/dev/null || packages+=(npm)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
if ((${#missing[@]})); then
  [ "$(id -u)" = 0 ] || { echo "install_deps.sh: run as root to install: ${missing[*]}" >&2; exit 1; }
  echo "install_deps.sh: installing ${missing[*]}"
  # Another apt (a concurrent setup) is waited for, not broken into.
  apt-get -o DPkg::Lock::Timeout=600 update -q
  DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 install -y -q --no-install-recommends "${missing[@]}"
fi
# The npm packages exactly as tools/js/package-lock.json pins them, installed again only when the lock changes.
js=$(cd "$(dirname "$0")" && pwd)/js
lock=$(sha256sum < "$js/package-lock.json")
if [ "$(cat "$js/node_modules/.motionkit-lock" 2>/dev/null)" != "$lock" ]; then
  echo "install_deps.sh: npm ci in $js"
  npm ci --prefix "$js" --no-audit --no-fund
  echo "$lock" > "$js/node_modules/.motionkit-lock"
fi
case "${1:-}" in
  --chroots|--blender5) for suite in trixie sid; do "$(dirname "$0")/chroot.sh" "$suite" setup; done ;;
esac
