#!/usr/bin/env bash
# Builds raypack's libFuzzer targets (tests/fuzz/, clang with -fsanitize=fuzzer,address,undefined)
# and runs each for SECONDS (default 60) over its corpus, seeded by scripts/fuzz-seeds.py.
#   scripts/fuzz.sh [SECONDS] [TARGET...]     TARGET: ply obj gltf glb settings_json hits png
# Environment: RAYPACK_FUZZ_BUILD_DIR (default build-fuzz), RAYPACK_FUZZ_CORPUS (default
# fuzz-corpus), RAYPACK_FUZZ_JOBS (targets run at once, default 1), RAYPACK_FUZZ_OPT (optimisation
# and debug flags of a new build folder, default "-O2 -g"; CI's short run takes "-O1 -gline-tables-only",
# which compiles faster). Findings (crash-*, leak-*,
# timeout-*, oom-*) land in $RAYPACK_FUZZ_CORPUS/findings/TARGET/; the script exits 1 when there
# are any. Each target's log is $RAYPACK_FUZZ_CORPUS/logs/TARGET.log; the last line it prints per
# target gives the executions run.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
seconds=${1:-60}
shift || true
targets=("$@")
((${#targets[@]})) || targets=(ply obj gltf glb settings_json hits png)
build=${RAYPACK_FUZZ_BUILD_DIR:-$root/build-fuzz}
corpus=${RAYPACK_FUZZ_CORPUS:-$root/fuzz-corpus}
jobs=${RAYPACK_FUZZ_JOBS:-1}
opt=${RAYPACK_FUZZ_OPT:--O2 -g}

command -v clang++ >/dev/null || { echo "raypack: fuzz.sh needs clang++ (scripts/install-deps.sh installs it)" >&2; exit 2; }
if [ ! -f "$build/build.ninja" ]; then
  CCACHE_BASEDIR=${CCACHE_BASEDIR:-$root} cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=$opt -DNDEBUG" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=$opt -DNDEBUG" \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DRAYPACK_FUZZ=ON \
    -DRAYPACK_BUILD_TESTS=OFF -DRAYPACK_BUILD_VIEWER=OFF -DRAYPACK_WITH_EMBREE=OFF >/dev/null
fi
CCACHE_BASEDIR=${CCACHE_BASEDIR:-$root} cmake --build "$build" -j "$(nproc)" --target $(printf 'fuzz_%s ' "${targets[@]}")

python3 "$root/scripts/fuzz-seeds.py" "$corpus/seeds" >/dev/null
mkdir -p "$corpus/logs"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

run_one() {
  local target=$1
  local live="$corpus/$target" findings="$corpus/findings/$target"
  mkdir -p "$live" "$findings"
  # -rss_limit_mb / -timeout: issue 11's promise, an answer within 1 GB (plus ASan's shadow) and 10 s.
  "$build/tests/fuzz/fuzz_$target" "$live" "$corpus/seeds/$target" -max_total_time="$seconds" \
    -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=10 -max_len=65536 -print_final_stats=1 \
    -artifact_prefix="$findings/" >"$corpus/logs/$target.log" 2>&1 || true
  local execs
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$corpus/logs/$target.log" | grep -o '[0-9]*$' || echo "?")
  echo "raypack fuzz: $target: $execs executions in ${seconds} s, $(ls "$findings" | wc -l) findings"
}

status=0
running=0
for target in "${targets[@]}"; do
  run_one "$target" &
  running=$((running + 1))
  if ((running >= jobs)); then wait -n || true; running=$((running - 1)); fi
done
wait
for target in "${targets[@]}"; do
  if [ -n "$(ls -A "$corpus/findings/$target" 2>/dev/null)" ]; then
    echo "raypack fuzz: FINDINGS for $target in $corpus/findings/$target (log: $corpus/logs/$target.log)" >&2
    status=1
  fi
done
exit $status
