#!/usr/bin/env bash
# Builds the libFuzzer BVH target with clang (ASan + UBSan) in build/fuzz and
# fuzzes ReadBvh/WriteBvh for a bounded time, starting from the regression
# inputs and the seed corpus. Exits non-zero on any finding.
#
#   tools/fuzz_bvh.sh [seconds] [libFuzzer flags...]    default 30 seconds
#   tools/fuzz_bvh.sh 600 -jobs=1                        the longer run in docs/reliability.md
#
# New interesting inputs go to build/fuzz/corpus-bvh (kept between runs, never
# into the repository); a crashing input is written to build/fuzz/artifacts/
# and belongs, once fixed, in tests/fuzz/regressions/bvh/.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
seconds=${1:-30}
[ $# -gt 0 ] && shift
[[ "$seconds" =~ ^[0-9]+$ ]] || { echo "fuzz_bvh.sh: seconds must be a whole number, got '$seconds'" >&2; exit 2; }
build=$here/build/fuzz

for tool in clang clang++ cmake; do
  command -v "$tool" >/dev/null || {
    echo "fuzz_bvh.sh: $tool not found; tools/install_deps.sh installs clang and libFuzzer" >&2
    exit 2
  }
done

# ccache, where installed, as build_addon.py uses it: nothing compiled twice, from any clone.
launcher=$([ "${MOTIONKIT_CCACHE:-1}" != 0 ] && command -v ccache || true)
export CCACHE_BASEDIR=$here CCACHE_NOHASHDIR=1
CC=clang CXX=clang++ cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_COMPILER_LAUNCHER="$launcher" \
  -DMOTIONKIT_FUZZ=ON -DMOTIONKIT_BUILD_PYTHON=OFF -DMOTIONKIT_BUILD_TESTS=OFF \
  -DMOTIONKIT_BUILD_BENCHMARKS=OFF -DMOTIONKIT_WERROR=ON >/dev/null
env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL cmake --build "$build" --target motionkit_bvh_fuzz -j2  # its own jobs, not make test's

mkdir -p "$build/corpus-bvh" "$build/artifacts"
cd "$build"
# libFuzzer keeps every input it ever saved; shrink the working corpus to the
# ones that still add coverage before it slows the start of a short run.
if [ "$(find corpus-bvh -type f | wc -l)" -gt 2000 ]; then
  rm -rf corpus-bvh.min && mkdir corpus-bvh.min
  ./motionkit_bvh_fuzz -merge=1 -max_len=65536 -timeout=10 corpus-bvh.min corpus-bvh >merge.log 2>&1 ||
    { cat merge.log >&2; exit 1; }
  rm -rf corpus-bvh && mv corpus-bvh.min corpus-bvh
fi
# The first directory receives new inputs; the other two are only read. libFuzzer
# runs every input in them before mutating, so a regression fails at once.
exec ./motionkit_bvh_fuzz -max_total_time="$seconds" -max_len=65536 -timeout=10 \
  -dict="$here/tests/fuzz/bvh.dict" -artifact_prefix="$build/artifacts/" -print_final_stats=1 \
  "$@" "$build/corpus-bvh" "$here/tests/fuzz/regressions/bvh" "$here/tests/fuzz/corpus/bvh"
