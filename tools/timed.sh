#!/usr/bin/env bash
# Runs a command as one tier of `make test` and appends "name<TAB>seconds" to build/tiers.txt, for the
# table that closes the run (the README quotes it).
#   tools/timed.sh NAME COMMAND [ARGS...]
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
name=${1:?usage: timed.sh NAME COMMAND [ARGS...]}
shift
start=$(date +%s)
"$@"
rc=$?
mkdir -p "$here/build"
printf '%s\t%d\n' "$name" "$(($(date +%s) - start))" >> "$here/build/tiers.txt"
[ $rc = 0 ] || echo "timed.sh: $name failed with exit status $rc after $(($(date +%s) - start)) s" >&2
exit $rc
