#!/usr/bin/env bash
# Configures and builds the release preset (build/). Used by setup.sh and test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
JOBS=$(nproc 2>/dev/null || echo 2)
cmake --preset release >/dev/null
cmake --build --preset release -j"$JOBS"
