#!/usr/bin/env bash
# Blender 5.2 LTS in the sid chroot: the same as tools/chroot.sh sid (see there), kept for old commands.
exec "$(dirname "${BASH_SOURCE[0]}")/chroot.sh" sid "$@"
