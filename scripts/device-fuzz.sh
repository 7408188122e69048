#!/usr/bin/env bash
# Runs every libFuzzer target of tests/fuzz on a machine without Debian's packages (the lent H200
# machine: 16 cores), from a bundle that scripts/device-fuzz-bundle.sh made:
#   scripts/device-fuzz.sh BUNDLE.tar.gz SECONDS OUT_DIR [PROCESSES_PER_TARGET]
# All targets at once, PROCESSES_PER_TARGET (default 2) independent fuzzer processes each, sharing
# the target's corpus folder, each with its own artifact prefix. The limits are scripts/fuzz.sh's
# (issue 11: an answer within 10 s and 1 GB, plus ASan's shadow). Writes OUT_DIR/fuzz-logs.tar.gz
# (logs, findings) and OUT_DIR/fuzz-corpus.tar.gz (the grown corpora) and prints one line per
# process: executions, seconds and findings.
set -uo pipefail
bundle=$1
seconds=$2
out=$3
per=${4:-2}
work=${RAYPACK_DEVICE_FUZZ_DIR:-/tmp/raypack-fuzz}
rm -rf "$work"
mkdir -p "$work" "$out"
tar xzf "$bundle" -C "$work"
cd "$work"
targets=(ply obj gltf glb settings_json hits png)
export LD_LIBRARY_PATH=$work/lib
export ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
mkdir -p logs findings
echo "raypack device fuzz: $(date -u +%FT%TZ) on $(nproc) cores, $(uname -r), ${seconds} s, $per per target"
for target in "${targets[@]}"; do
  mkdir -p "corpus/$target" "findings/$target"
  for p in $(seq 1 "$per"); do
    # SIGINT after SECONDS + 30 s: libFuzzer then still prints its final stats; -max_total_time
    # normally ends it first.
    timeout -s INT $((seconds + 30)) "bin/fuzz_$target" "corpus/$target" "seeds/$target" -max_total_time="$seconds" \
      -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=10 -max_len=65536 -print_final_stats=1 \
      -artifact_prefix="findings/$target/p$p-" >"logs/$target-$p.log" 2>&1 &
  done
done
wait
echo "raypack device fuzz: done $(date -u +%FT%TZ)"
for target in "${targets[@]}"; do
  for p in $(seq 1 "$per"); do
    log=logs/$target-$p.log
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
    took=$(grep -o 'Done [0-9]* runs in [0-9]* second' "$log" | grep -o 'in [0-9]*' | grep -o '[0-9]*' || echo "?")
    echo "raypack fuzz: $target p$p: $execs executions, ${took} s, corpus $(ls "corpus/$target" | wc -l) files," \
      "$(ls "findings/$target" | grep -c "^p$p-") findings"
  done
done
# Logs and findings apart from the corpora, so that they come back even when the corpora grow past
# what a call may bring back.
tar czf "$out/fuzz-logs.tar.gz" logs findings
tar czf "$out/fuzz-corpus.tar.gz" corpus
ls -l "$out"
