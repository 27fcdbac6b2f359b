#!/usr/bin/env bash
# One command on a fresh Debian 12 machine: install what is missing, build, run the main job.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/build.sh
build/apps/fsp render assets/scenes/default_room.yaml --out out/default_room && build/apps/fsp run out/default_room --frontend rect --out out/default_room/run && build/apps/fsp eval --gt out/default_room --est out/default_room/run --out out/default_room/run/metrics.json
