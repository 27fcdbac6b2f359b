#!/usr/bin/env bash
# Installs what is missing, checks the formatting, builds, and runs the whole test suite (CI runs exactly this).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/check_format.sh
scripts/build.sh
ctest --preset release -j"$(nproc 2>/dev/null || echo 2)" "$@"
