#!/usr/bin/env bash
# Fuzzes every reader of a user's file (fuzz/README.md): configures build-fuzz/ (clang, libFuzzer +
# AddressSanitizer + UndefinedBehaviorSanitizer, FSP_FUZZ=ON), builds the targets of fuzz/, runs
# each for SECONDS and prints per target the executions and the findings (crash-, leak-, timeout-
# and oom- files, kept in build-fuzz/findings/TARGET/). Exits non-zero on any finding.
#
#   scripts/fuzz.sh SECONDS [TARGET...]     # default: every fuzz/fuzz_*.cc
#
# Environment: FUZZ_PARALLEL (targets run at once, default 1), FUZZ_TIMEOUT (seconds one input may
# take before it counts as a hang, default 10), FUZZ_RSS_MB (memory limit, default 2048),
# FUZZ_BUILD_JOBS (default 2), FSP_TEST_DATA (the shared real data, read for extra seeds when it
# exists; default ../shared/data), FSP_DMVIO_WALK (the DM-VIO walk, read for a fuzz_dso seed when it
# exists; default /work/scratch/dmvio). Run it under `nice -n 19` on a shared machine.
#
# Corpora: build-fuzz/corpus/TARGET/ grows from run to run; it starts from the project's seeds
# (fuzz/corpus/TARGET/, plus the scene and config files of assets/) and, read at run time, from small
# pieces of the shared real data (build-fuzz/seeds/TARGET/; never copied into the repository).
# Reproduce a finding: build-fuzz/fuzz/TARGET build-fuzz/findings/TARGET/crash-...
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)

if [ $# -lt 1 ] || ! [[ $1 =~ ^[0-9]+$ ]] || [ "$1" -lt 1 ]; then
  echo "usage: scripts/fuzz.sh SECONDS [TARGET...]" >&2
  exit 2
fi
SECS=$1
shift
if [ $# -gt 0 ]; then
  TARGETS=("$@")
else
  TARGETS=()
  for f in fuzz/fuzz_*.cc; do TARGETS+=("$(basename "$f" .cc)"); done
fi
PARALLEL=${FUZZ_PARALLEL:-1}
TIMEOUT=${FUZZ_TIMEOUT:-10}
RSS_MB=${FUZZ_RSS_MB:-2048}
BUILD=build-fuzz
DATA=${FSP_TEST_DATA:-$ROOT/../shared/data}
DMVIO=${FSP_DMVIO_WALK:-/work/scratch/dmvio}

# --- configure and build -------------------------------------------------------------------------
if ! command -v clang++ >/dev/null; then
  echo "error: clang++ not found (Debian: apt-get install clang libclang-rt-14-dev)" >&2
  exit 2
fi
launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi
cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_C_COMPILER=clang -DFSP_FUZZ=ON -DFSP_BUILD_TESTS=OFF "${launcher[@]}" >/dev/null
cmake --build "$BUILD" -j"${FUZZ_BUILD_JOBS:-2}" --target "${TARGETS[@]}"

# --- seeds from the shared real data (read at run time, small pieces only) -----------------------
# head of a file, at most LINES lines and 4 KB
piece() { head -n "$2" "$1" | head -c 4096; }
seed_shared() {
  local t=$1 dir=$BUILD/seeds/$1
  rm -rf "$dir"
  mkdir -p "$dir"
  if [ "$t" = fuzz_dso ]; then seed_dmvio "$dir" || echo "warning: no seed from $DMVIO" >&2; fi
  [ -d "$DATA" ] || return 0
  local m=$DATA/euroc_v101_micro/mav0
  case $t in
    fuzz_calibration)
      for f in "$m/cam0/sensor.yaml" "$m/imu0/sensor.yaml" "$DATA"/vio_calibration/*/kalibr_*.yaml; do
        [ -f "$f" ] && cp "$f" "$dir/$(echo "${f#"$DATA"/}" | tr / _)"
      done ;;
    fuzz_imu_csv)
      [ -f "$m/imu0/data.csv" ] && piece "$m/imu0/data.csv" 30 >"$dir/euroc_imu0.csv" ;;
    fuzz_trajectory)
      for f in "$DATA"/traj_eval/evo/*.txt "$DATA"/traj_eval/evo/*.csv \
        "$m"/state_groundtruth_estimate0/*.csv "$m"/state_groundtruth_estimate0/*.txt; do
        [ -f "$f" ] && piece "$f" 20 >"$dir/$(basename "$f")"
      done ;;
    fuzz_corners_csv)
      local n=0
      for f in "$DATA"/euroc_imu_april_corners/cam0/*.csv; do
        [ -f "$f" ] || continue
        piece "$f" 20 >"$dir/$(basename "$f")"
        n=$((n + 1))
        [ $n -ge 3 ] && break
      done ;;
    fuzz_euroc)
      if [ -f "$m/cam0/data.csv" ]; then
        {
          piece "$m/cam0/data.csv" 6
          echo "--- next file ---"
          piece "$m/imu0/data.csv" 30
          echo "--- next file ---"
          cat "$m/cam0/sensor.yaml"
          echo "--- next file ---"
          cat "$m/imu0/sensor.yaml"
        } >"$dir/euroc_v101_micro.txt"
      fi ;;
  esac
  return 0
}

# fuzz_dso's seed from the DM-VIO walk, when it is present (not in the shared data: see its README):
# the first 4 frames of cam0/times.txt, the IMU rows from 50 ms before to 50 ms after them,
# camchain.yaml and the first other YAML beside it that holds an IMU noise (d515.yaml), and
# camera.txt with its pixel intrinsics scaled to the 32x24 test images the target writes (else
# every input would stop at the image size check).
seed_dmvio() {
  local out=$1/dmvio_walk.txt d=$DMVIO
  [ -f "$d/cam0/times.txt" ] && [ -f "$d/cam0/camera.txt" ] && [ -f "$d/imu.txt" ] || return 0
  local times w=0 h=0 lo=0 hi=0 noise=
  times=$(awk '!/^#/ && n++ < 4' "$d/cam0/times.txt")
  read -r w h < <(awk 'NR == 2' "$d/cam0/camera.txt") || true
  read -r lo hi < <(echo "$times" | awk 'NR == 1 { lo = $2 } { hi = $2 }
    END { printf "%.0f %.0f\n", (lo - 0.05) * 1e9, (hi + 0.05) * 1e9 }') || true
  for f in "$d"/*.yaml "$d"/*.yml; do
    if [ -f "$f" ] && [ "$f" != "$d/camchain.yaml" ] && grep -q noise_density "$f"; then
      noise=$f
      break
    fi
  done
  {
    echo "$times"
    echo "--- next file ---"
    # Line 1: [model] fx fy cx cy ...; pixels (not DSO's relative fractions) are scaled.
    awk -v W="$w" -v H="$h" 'NR == 1 && W > 0 && H > 0 {
        i = ($1 ~ /^[A-Za-z]/) ? 2 : 1
        if (!($(i + 2) < 1 && $(i + 3) < 1)) {
          $i *= 32 / W; $(i + 1) *= 24 / H
          $(i + 2) = ($(i + 2) + 0.5) * 32 / W - 0.5; $(i + 3) = ($(i + 3) + 0.5) * 24 / H - 0.5
        }
      }
      NR == 2 { $0 = "32 24" }
      { print }' "$d/cam0/camera.txt"
    echo "--- next file ---"
    awk -F '[ ,\t]+' -v lo="$lo" -v hi="$hi" \
      '/^#/ || ($1 + 0 >= lo + 0 && $1 + 0 <= hi + 0 && n++ < 100)' "$d/imu.txt"
    echo "--- next file ---"
    if [ -f "$d/camchain.yaml" ]; then head -c 4096 "$d/camchain.yaml"; fi
    if [ -n "$noise" ]; then
      echo "--- next file ---"
      head -c 4096 "$noise"
    fi
  } >"$out"
}

# The project's own seeds besides fuzz/corpus: the scene and config files of assets/.
seed_assets() {
  local t=$1 dir=$BUILD/seeds/$1
  case $t in
    fuzz_scene) cp assets/scenes/*.yaml "$dir/" ;;
    fuzz_run_config) cp assets/config/default.yaml "$dir/" ;;
  esac
  return 0
}

# A dictionary per target: fuzz/numbers.dict plus every YAML key of its seeds ("width:", ...), so
# that mutations write keys and extreme numbers, not only bytes.
make_dict() {
  local t=$1 dict=$BUILD/dicts/$1.dict
  mkdir -p "$BUILD/dicts"
  cp fuzz/numbers.dict "$dict"
  [ -f "fuzz/$t.dict" ] && cat "fuzz/$t.dict" >>"$dict"
  local seeds=("$BUILD/seeds/$t")
  [ -d "fuzz/corpus/$t" ] && seeds+=("fuzz/corpus/$t")
  find "${seeds[@]}" -type f -exec grep -ohE '[A-Za-z_][A-Za-z0-9_]*:' {} + 2>/dev/null |
    sort -u | sed 's/.*/"&"/' >>"$dict" || true
}

# --- run ------------------------------------------------------------------------------------------
mkdir -p "$BUILD/findings" "$BUILD/logs" "$BUILD/corpus" "$BUILD/tmp"
run_target() {
  local t=$1
  local corpus=$BUILD/corpus/$t findings=$BUILD/findings/$t tmp=$BUILD/tmp/$t
  rm -rf "$findings" "$tmp"
  mkdir -p "$corpus" "$findings" "$tmp"
  local dirs=("$corpus")
  [ -d "fuzz/corpus/$t" ] && dirs+=("fuzz/corpus/$t")
  dirs+=("$BUILD/seeds/$t")
  local rc=0 start=$SECONDS
  TMPDIR=$ROOT/$tmp "$BUILD/fuzz/$t" -max_total_time="$SECS" -timeout="$TIMEOUT" \
    -rss_limit_mb="$RSS_MB" -max_len=16384 -print_final_stats=1 -dict="$BUILD/dicts/$t.dict" \
    -artifact_prefix="$findings/" "${dirs[@]}" >"$BUILD/logs/$t.log" 2>&1 || rc=$?
  echo "$rc" >"$BUILD/logs/$t.rc"
  echo $((SECONDS - start)) >"$BUILD/logs/$t.secs"
  rm -rf "$tmp"
}

if [ -d "$DATA" ]; then
  echo "seeds: fuzz/corpus/, assets/ and pieces of the shared data in $DATA"
else
  echo "seeds: fuzz/corpus/ and assets/ only (no shared data at $DATA: set FSP_TEST_DATA)"
fi
for t in "${TARGETS[@]}"; do
  seed_shared "$t"
  seed_assets "$t"
  make_dict "$t"
done
echo "fuzzing ${#TARGETS[@]} target(s) for ${SECS} s each, ${PARALLEL} at a time (logs: $BUILD/logs/)"
running=0
for t in "${TARGETS[@]}"; do
  run_target "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$PARALLEL" ]; then
    wait -n || true
    running=$((running - 1))
  fi
done
wait || true

# --- report ---------------------------------------------------------------------------------------
total=0
printf '%-20s %8s %12s %10s %8s  %s\n' target seconds executions exec/s findings artifacts
for t in "${TARGETS[@]}"; do
  log=$BUILD/logs/$t.log
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | awk '{print $2}' | tail -1)
  [ -n "$execs" ] || execs=$(grep -o '^#[0-9]*' "$log" | tr -d '#' | tail -1)
  [ -n "$execs" ] || execs=0
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | awk '{print $2}' | tail -1)
  secs=$(cat "$BUILD/logs/$t.secs")
  artifacts=$(find "$BUILD/findings/$t" -maxdepth 1 -type f \
    \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' \) -printf '%f ')
  n=$(echo "$artifacts" | wc -w)
  rc=$(cat "$BUILD/logs/$t.rc")
  # A non-zero exit without an artifact (the fuzzer could not start, ...) is a finding too.
  if [ "$n" -eq 0 ] && [ "$rc" -ne 0 ]; then
    n=1
    artifacts="exit code $rc, see $log"
  fi
  total=$((total + n))
  printf '%-20s %8s %12s %10s %8s  %s\n' "$t" "$secs" "$execs" "${rate:--}" "$n" "$artifacts"
done
if [ "$total" -ne 0 ]; then
  echo "fuzz: $total finding(s); artifacts in $BUILD/findings/, logs in $BUILD/logs/" >&2
  exit 1
fi
echo "fuzz: no findings"
