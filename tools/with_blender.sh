#!/usr/bin/env bash
# Runs Blender 3.4 (host), 4.3 (trixie chroot) or 5.2 (sid chroot) with a fresh,
# throwaway user folder, so nothing from a previous run or from the user's own
# Blender leaks in.
#   tools/with_blender.sh 3.4|4.3|5.2 [blender args...]
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
which=${1:?usage: with_blender.sh 3.4|4.3|5.2 [blender args...]}
shift
case "$which" in
  3.4) ;;
  4.3) exec "$here/tools/chroot.sh" trixie run "$here/tools/with_blender.sh" inside "$@" ;;
  5.2) exec "$here/tools/chroot.sh" sid run "$here/tools/with_blender.sh" inside "$@" ;;
  inside) ;;
  *) echo "with_blender.sh: unknown Blender '$which' (3.4, 4.3 or 5.2)" >&2; exit 2 ;;
esac
# Blender resolves its Python's standard library through the first python3.X on
# PATH; a pyenv or virtualenv there would swap it for a foreign one.
export PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
user=$(mktemp -d "${TMPDIR:-/tmp}/motionkit-user.XXXXXX")
trap 'rm -rf "$user"' EXIT
export BLENDER_USER_RESOURCES=$user BLENDER_USER_CONFIG=$user/config \
  BLENDER_USER_SCRIPTS=$user/scripts BLENDER_USER_DATAFILES=$user/datafiles \
  BLENDER_USER_EXTENSIONS=$user/extensions MOTIONKIT_TEST_USER=$user
cd "$here"
set +e
blender "$@"
rc=$?
exit $rc
