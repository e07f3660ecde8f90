#!/usr/bin/env bash
# The README's other command, the demo, run whole into a scratch folder (out/ is left to `make demo`): a
# script or API change that breaks it, or a picture it no longer writes, fails the tests.
#   tools/test_demo.sh ZIP
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
zip=${1:?usage: test_demo.sh ZIP}
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
"$here/tools/with_blender.sh" 3.4 --background --factory-startup --python-exit-code 1 \
  --python "$here/demo/demo.py" -- --zip "$zip" --out "$scratch"
for picture in demo.png demo.blend contacts.png filters.png ik_reach.png feet_fingers.png reduction.png mirror.png \
    mixamo_pairs.png; do
  [ -s "$scratch/$picture" ] || { echo "test_demo.sh: the demo wrote no $picture" >&2; exit 1; }
done
