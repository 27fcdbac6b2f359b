#!/usr/bin/env bash
# Configures and builds the `asan` preset (build-asan/: AddressSanitizer + UndefinedBehaviorSanitizer,
# RelWithDebInfo) and runs the whole test suite under it. Exits non-zero when the build or any test
# fails (a sanitizer report fails its test: halt_on_error, UBSan without recovery at run time).
#
#   scripts/check_sanitizers.sh [CTEST ARGS...]     # e.g. -R BadInput, or -j1
#
# Environment: ASAN_JOBS (build and ctest parallelism, default: the number of cores). Slow: run it
# under `nice -n 19` on a shared machine.
set -euo pipefail
cd "$(dirname "$0")/.."
JOBS=${ASAN_JOBS:-$(nproc 2>/dev/null || echo 2)}
launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi
start=$(date +%s)
cmake --preset asan "${launcher[@]}" >/dev/null
cmake --build --preset asan -j"$JOBS"
built=$(date +%s)
# Any ASan or UBSan report aborts the test process (so the test fails). detect_leaks: LeakSanitizer
# runs with ASan on Linux.
export ASAN_OPTIONS=${ASAN_OPTIONS:-halt_on_error=1:abort_on_error=1:detect_leaks=1:strict_string_checks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:abort_on_error=1:print_stacktrace=1}
rc=0
ctest --preset asan -j"$JOBS" "$@" || rc=$?
end=$(date +%s)
echo "check_sanitizers: build $((built - start)) s, tests $((end - built)) s, ctest exit code $rc"
exit "$rc"
