#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, clang, ASan+UBSan) in build-fuzz/ and runs them
# (docs/reliability.md, "Fuzzing").
#
#   scripts/fuzz.sh                     every target for 60 s, one after the other
#   scripts/fuzz.sh --time 1800 ply obj  the named targets, 30 min each
#   scripts/fuzz.sh --parallel --time 3600   every target at once (one process each)
#   scripts/fuzz.sh --parallel --cpu 1800   every target at once, each until it has had 30 min of CPU
#                                       time (on a shared machine wall-clock time overstates the work)
#   scripts/fuzz.sh --ci                every target briefly: about a minute in all (setup.sh --test)
#   scripts/fuzz.sh --build-only        configure and build only
#   scripts/fuzz.sh --no-build ...      run the targets as they are built
#
# Targets: ply obj off stl pose views session_json. Each keeps a growing corpus in
# build-fuzz/corpus/<target>/ (started from fuzz/seeds/<target>/ and, for the geometry readers, the
# malformed files of tests/data/malformed/). A crash, sanitizer report, uncaught exception other
# than InputError, hang (60 s on one input; AUTOSCAN_FUZZ_TIMEOUT) or allocation beyond -rss_limit_mb
# writes the input to build-fuzz/findings/<target>/ and makes the script exit 1. Every run appends
# "date target seconds runs result cpu-seconds" to build-fuzz/fuzz-runs.tsv. The fuzzers run at nice 19.
# Reproduce a finding: build-fuzz/fuzz/fuzz_<target> build-fuzz/findings/<target>/crash-...
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)

ALL_TARGETS=(ply obj off stl pose views session_json)
SECONDS_EACH=60
CPU_EACH=0
CI=0
PARALLEL=0
BUILD_ONLY=0
NO_BUILD=0
# Seconds of wall-clock time one input may take: generous, because on a loaded machine a fuzzer at
# nice 19 can wait seconds for the CPU; a real hang (a quadratic parser) still exceeds it.
TIMEOUT=${AUTOSCAN_FUZZ_TIMEOUT:-60}
TARGETS=()
while [ $# -gt 0 ]; do
  case "$1" in
    --ci) CI=1 ;;
    --parallel) PARALLEL=1 ;;
    --build-only) BUILD_ONLY=1 ;;
    --no-build) NO_BUILD=1 ;;
    --time)
      [ $# -ge 2 ] || { echo "fuzz.sh: --time needs a number of seconds" >&2; exit 2; }
      SECONDS_EACH=$2
      shift ;;
    --cpu)
      [ $# -ge 2 ] || { echo "fuzz.sh: --cpu needs a number of seconds" >&2; exit 2; }
      CPU_EACH=$2
      shift ;;
    -h|--help) sed -n '2,21p' "$0"; exit 0 ;;
    -*) echo "fuzz.sh: unknown option '$1'" >&2; exit 2 ;;
    *)
      if [[ " ${ALL_TARGETS[*]} " != *" $1 "* ]]; then
        echo "fuzz.sh: unknown target '$1' (expected one of: ${ALL_TARGETS[*]})" >&2
        exit 2
      fi
      TARGETS+=("$1") ;;
  esac
  shift
done
if ! [[ "$SECONDS_EACH" =~ ^[1-9][0-9]*$ ]]; then
  echo "fuzz.sh: --time must be a positive whole number of seconds (got '$SECONDS_EACH')" >&2
  exit 2
fi
if ! [[ "$CPU_EACH" =~ ^[0-9]+$ ]]; then
  echo "fuzz.sh: --cpu must be a whole number of seconds (got '$CPU_EACH')" >&2
  exit 2
fi
# --cpu: the CPU budget ends the run; the wall-clock limit only guards against a stall (a week).
if [ "$CPU_EACH" -gt 0 ]; then SECONDS_EACH=604800; fi
[ ${#TARGETS[@]} -gt 0 ] || TARGETS=("${ALL_TARGETS[@]}")
# CI: about a minute in all, split over the targets.
if [ "$CI" = 1 ]; then SECONDS_EACH=$(( (60 + ${#TARGETS[@]} - 1) / ${#TARGETS[@]} )); fi

CXX_FUZZ=${AUTOSCAN_FUZZ_CXX:-}
if [ -z "$CXX_FUZZ" ]; then
  for c in clang++-14 clang++; do
    if command -v "$c" >/dev/null 2>&1; then CXX_FUZZ=$c; break; fi
  done
fi
if [ -z "$CXX_FUZZ" ]; then
  echo "fuzz.sh: clang++ not found (Debian: apt-get install clang-14 libclang-rt-14-dev; scripts/setup.sh does)" >&2
  exit 2
fi

BUILD=build-fuzz
JOBS=${AUTOSCAN_JOBS:-$(nproc)}
if [ ! -f "$BUILD/build.ninja" ]; then
  nice -n 19 cmake -S . -B "$BUILD" -G Ninja -DCMAKE_CXX_COMPILER="$CXX_FUZZ" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only" -DAUTOSCAN_FUZZ=ON -DAUTOSCAN_BUILD_TESTS=OFF \
    -DAUTOSCAN_BUILD_BENCHMARKS=OFF -DAUTOSCAN_BUILD_CLI=OFF >/dev/null
fi
[ "$NO_BUILD" = 1 ] || nice -n 19 cmake --build "$BUILD" -j "$JOBS" --target "${TARGETS[@]/#/fuzz_}"
[ "$BUILD_ONLY" = 1 ] && exit 0

dict_of() {
  case "$1" in
    ply|obj|off|stl) echo "$ROOT/fuzz/dict/$1.dict" ;;
    *) echo "$ROOT/fuzz/dict/json.dict" ;;
  esac
}

# Seeds a target's corpus (copies; the fuzzer adds to the corpus directory, never to fuzz/seeds).
seed_corpus() {
  local t=$1 dir=$BUILD/corpus/$1
  mkdir -p "$dir"
  cp -n fuzz/seeds/"$t"/* "$dir"/ 2>/dev/null || true
  case "$t" in
    ply|obj|off|stl) cp -n tests/data/malformed/*."$t" "$dir"/ 2>/dev/null || true ;;
  esac
}

export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

# Runs one target for SECONDS_EACH seconds; prints and records its executions.
run_target() {
  local t=$1
  local exe=$BUILD/fuzz/fuzz_$t findings=$BUILD/findings/$t log=$BUILD/logs/$t-$(date -u +%Y%m%dT%H%M%S).log
  mkdir -p "$findings" "$BUILD/logs"
  seed_corpus "$t"
  local rc=0 start
  start=$(date +%s)
  nice -n 19 "$exe" -max_total_time="$SECONDS_EACH" -timeout="$TIMEOUT" -rss_limit_mb=2048 -max_len=65536 \
    -print_final_stats=1 -dict="$(dict_of "$t")" -artifact_prefix="$findings/" "$BUILD/corpus/$t" \
    >"$log" 2>&1 &
  local pid=$! cpu=0
  # Polls the fuzzer's CPU time (utime + stime, /proc/<pid>/stat fields 14 and 15); with --cpu, stops
  # it with SIGINT (a normal end for libFuzzer: exit 72, final stats printed) once the budget is spent.
  local tick
  tick=$(getconf CLK_TCK)
  while kill -0 "$pid" 2>/dev/null; do
    local st
    st=$(cat /proc/"$pid"/stat 2>/dev/null) || break
    st=${st##*) }
    read -r -a f <<<"$st"
    cpu=$(( (f[11] + f[12]) / tick ))
    if [ "$CPU_EACH" -gt 0 ] && [ "$cpu" -ge "$CPU_EACH" ]; then kill -INT "$pid" 2>/dev/null || true; fi
    sleep 5
  done
  wait "$pid" || rc=$?
  local runs secs result
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  secs=$(( $(date +%s) - start ))
  # 72: libFuzzer's exit code when interrupted (Ctrl-C, kill -INT): no finding.
  case "$rc" in
    0) result=ok ;;
    72) result=interrupted; rc=0 ;;
    *) result="FINDING (exit $rc)" ;;
  esac
  printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$(date -u +%FT%TZ)" "$t" "${secs:-?}" "${runs:-?}" "$result" "$cpu" >>"$BUILD/fuzz-runs.tsv"
  printf 'fuzz %-13s %6s s (CPU %6s s) %12s runs  %s\n' "$t" "${secs:-?}" "$cpu" "${runs:-?}" "$result"
  if [ "$rc" != 0 ]; then
    echo "---- $log (last lines); the input is in $findings/" >&2
    tail -40 "$log" >&2
    return 1
  fi
}

failed=0
if [ "$PARALLEL" = 1 ]; then
  pids=()
  for t in "${TARGETS[@]}"; do
    run_target "$t" &
    pids+=($!)
  done
  for p in "${pids[@]}"; do wait "$p" || failed=1; done
else
  for t in "${TARGETS[@]}"; do run_target "$t" || failed=1; done
fi
exit $failed
