#!/usr/bin/env bash
# The Blenders that Debian 12 does not ship, each from a newer Debian in a
# debootstrap chroot kept outside the repository so that every clone (and CI)
# reuses it:
#   sid     Blender 5.2 LTS (Python 3.14; g++ 16, Eigen 5, pybind11 3)
#   trixie  Blender 4.3     (Python 3.13; g++ 14, Eigen 3.4, pybind11 2.13)
#
#   tools/chroot.sh SUITE setup            create or update the chroot
#   tools/chroot.sh SUITE run CMD [ARG..]  run a command inside it
#   tools/chroot.sh SUITE blender [ARG..]  run its Blender inside it
#   tools/chroot.sh SUITE path             print the chroot's folder
#
# The chroot is ${MOTIONKIT_CACHE:-~/.cache/motionkit}/SUITE-chroot. The
# repository and ../shared are bind-mounted at their own absolute paths, so
# paths mean the same inside and outside. /proc and /dev are mounted in a
# private mount namespace (unshare), so they disappear when the command ends,
# even if it is killed; we still unmount explicitly for clarity.
set -euo pipefail

die() { echo "chroot.sh: $*" >&2; exit 1; }
usage="usage: $0 sid|trixie setup | run CMD [ARG...] | blender [ARG...] | path"

suite=${1:-}
[ $# -gt 0 ] && shift
apt_opts=(-o Dpkg::Use-Pty=0 -q -y)
case "$suite" in
  # sid's Release file on the mirror can be past its Valid-Until date (a
  # stable release's has none).
  sid) apt_opts+=(-o Acquire::Check-Valid-Until=false) ;;
  trixie) ;;
  *) die "$usage" ;;
esac

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
shared=$(cd "$here/.." && pwd)/shared
cache=${MOTIONKIT_CACHE:-${XDG_CACHE_HOME:-${HOME:-/root}/.cache}/motionkit}
root=$cache/$suite-chroot

# Everything the Blender side needs: the Blender itself, the toolchain that
# builds our module for its Python, and what the UI tests need: a windowed
# Blender under Xvfb (mesa's software OpenGL) and tesseract to read its
# screenshots; node, to play exported glTF files with the npm packages that tools/install_deps.sh installs
# into the repository (tools/js/node_modules). The same names in trixie and sid.
packages=(
  blender python3 python3-dev python3-numpy python3-scipy python3-pytest python3-distributed
  python3-matplotlib g++ cmake make libeigen3-dev pybind11-dev libgtest-dev
  libgmock-dev libbenchmark-dev ca-certificates xz-utils ccache
  xvfb xauth libgl1-mesa-dri libegl1 mesa-utils tesseract-ocr x11-apps nodejs
)

[ "$(id -u)" = 0 ] || die "must run as root (debootstrap and chroot need it)"

# The host's own Debian mirror, never a hard-coded one.
host_mirror() {
  local uri
  uri=$(grep -hE '^\s*URIs:' /etc/apt/sources.list.d/*.sources 2>/dev/null |
        awk '{print $2}' | grep -E '/debian/?$' | head -n1 || true)
  if [ -z "$uri" ] && [ -f /etc/apt/sources.list ]; then
    uri=$(grep -hE '^\s*deb\s' /etc/apt/sources.list |
          awk '{for (i = 2; i <= NF; i++) if ($i ~ /^[a-z]+:\/\//) {print $i; exit}}' |
          grep -E '/debian/?$' | head -n1 || true)
  fi
  [ -n "$uri" ] || die "no Debian mirror found in the host's apt configuration"
  echo "${uri%/}"
}

with_mounts() {
  # Runs "$@" in a private mount namespace with /proc, /dev, the repo and
  # ../shared mounted into the chroot.
  unshare --mount --propagation private -- bash -euo pipefail -c '
    root=$1 here=$2 shared=$3; shift 3
    mounts=()
    bind() { mkdir -p "$root$2"; mount --bind "$1" "$root$2"; mounts=("$root$2" "${mounts[@]}"); }
    mount -t proc proc "$root/proc"; mounts=("$root/proc")
    bind /dev /dev
    [ -d /dev/pts ] && bind /dev/pts /dev/pts
    bind "$here" "$here"
    [ -d "$shared" ] && bind "$shared" "$shared"
    [ -e /etc/resolv.conf ] && cp -L /etc/resolv.conf "$root/etc/resolv.conf" || true
    set +e
    "$@"; rc=$?
    for m in "${mounts[@]}"; do umount -l "$m" 2>/dev/null; done
    exit $rc
  ' _ "$root" "$here" "$shared" "$@"
}

in_chroot() {
  with_mounts chroot "$root" /usr/bin/env -i HOME=/root LANG=C.UTF-8 \
    PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    ${CI:+CI=$CI} ${MOTIONKIT_WERROR:+MOTIONKIT_WERROR=$MOTIONKIT_WERROR} \
    ${MOTIONKIT_CCACHE:+MOTIONKIT_CCACHE=$MOTIONKIT_CCACHE} ${MOTIONKIT_LONG:+MOTIONKIT_LONG=$MOTIONKIT_LONG} \
    bash -c 'cd "$1"; shift; exec "$@"' _ "$PWD" "$@"
}

setup() {
  mkdir -p "$cache"
  exec 9>"$cache/$suite-chroot.lock"
  flock 9
  local mirror stamp want
  mirror=$(host_mirror)
  if [ ! -x "$root/usr/bin/apt-get" ] || [ ! -f "$root/.debootstrap-done" ]; then
    command -v debootstrap >/dev/null ||
      DEBIAN_FRONTEND=noninteractive apt-get "${apt_opts[@]}" -o DPkg::Lock::Timeout=600 install debootstrap
    rm -rf "$root"
    echo "chroot.sh: debootstrap $suite from $mirror into $root"
    debootstrap --variant=minbase "$suite" "$root" "$mirror"
    touch "$root/.debootstrap-done"
  fi
  echo "deb $mirror $suite main" > "$root/etc/apt/sources.list"
  # Blender lists the mounted file systems (the file browser's side bar) from /etc/mtab.
  [ -e "$root/etc/mtab" ] || [ -L "$root/etc/mtab" ] || ln -s ../proc/self/mounts "$root/etc/mtab"
  if [ "$suite" = sid ]; then
    echo 'Acquire::Check-Valid-Until "false";' > "$root/etc/apt/apt.conf.d/99motionkit-valid-until"
  fi
  want=$(printf '%s\n' "$mirror" "${packages[@]}" | sha256sum | cut -c1-16)
  stamp=$root/.motionkit-packages
  if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
    echo "chroot.sh: installing Blender and the build packages in the $suite chroot"
    in_chroot env DEBIAN_FRONTEND=noninteractive apt-get "${apt_opts[@]}" update
    in_chroot env DEBIAN_FRONTEND=noninteractive apt-get "${apt_opts[@]}" \
      install --no-install-recommends "${packages[@]}"
    in_chroot apt-get clean
    echo "$want" > "$stamp"
  fi
  in_chroot blender --version | head -n1
}

ensure() { [ -f "$root/.motionkit-packages" ] || setup >&2; }

cmd=${1:-}
[ $# -gt 0 ] && shift
case "$cmd" in
  setup) setup ;;
  run) ensure; in_chroot "$@" ;;
  blender) ensure; in_chroot blender "$@" ;;
  path) echo "$root" ;;
  *) die "$usage" ;;
esac
