#!/usr/bin/env bash
# One command on a fresh Debian 12 machine: install what is missing, build, run the main job.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/build.sh
seq=out/default_room
run=$seq/run
# The default scene is rendered once, then reused.
if [ ! -f "$seq/mav0/cam0/data.csv" ]; then
  build/apps/fsp render assets/scenes/default_room.yaml --out "$seq"
fi
build/apps/fsp run "$seq" --frontend rect --out "$run" --video "$run/annotated.mp4"
build/apps/fsp eval --gt "$seq" --est "$run" --out "$run/metrics.json"
echo
echo "map: $run/map.json; annotated video: $run/annotated.mp4; top view: $run/eval_top_view.png"
