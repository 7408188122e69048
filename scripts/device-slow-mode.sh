#!/usr/bin/env bash
# The large scans' slow mode on the lent GPU machine (docs/gpu.md, "The slow mode of the large
# scans"): some cells of the 10M terrain and the 13M dragon run 2-3x slower than the same cell in
# another process. This call alternates processes that upload straight into mapped device memory
# (the default where the device maps all of it) with processes that stage (RAYPACK_UPLOAD=staged),
# each `bench --suite scaling --only "terrain 10M,Dragon subdiv 3" --device gpu --kernel single`
# (gpu-single, gpu-cwbvh and the driver's ray tracing), while nvidia-smi samples the clocks, power,
# utilisation and throttle reasons every 100 ms, so that a slow cell can be put beside what the
# card was doing at the time. Each bench's progress lines carry the host's time. Each round runs
# every binary of BINARIES: "new" is .device/bin/raypack-cli, any other name .device/bin/raypack-cli-NAME
# (scripts/device-pack.sh BUILD OLD_BINARY, e.g. the build before the settling warm-up as "old").
#   scripts/device-slow-mode.sh [OUT_DIR]   (default: $OUT)
# Environment: ROUNDS (default 4), BINARIES (default "new"), MODES (default "direct staged"), BUDGET_S
# (default 330), BUILDER (default sah-binned).
set -u
source scripts/device-start.sh "$0" "${1:-}"
# A call brings back at most 8 files: the runs go to OUT/runs, packed at the end into
# OUT/results.tar.xz beside OUT/slow-mode.md (scripts/slow-mode-report's table).
final=$out
out=$out/runs
mkdir -p "$out"
mv "$final/env.log" "$out/"
nvidia-smi -q > "$out/nvidia-smi-before.txt" 2>&1
nvidia-smi --query-gpu=timestamp,clocks.sm,clocks.mem,power.draw,temperature.gpu,utilization.gpu,utilization.memory,clocks_throttle_reasons.active \
  --format=csv,noheader -lms 100 > "$out/smi.csv" 2>&1 &
smi=$!
stamp() { while IFS= read -r line; do printf '%s %s\n' "$(date +%s.%N)" "$line"; done; }
start=$(date +%s)
for round in $(seq 1 "${ROUNDS:-4}"); do
  for bin in ${BINARIES:-new}; do
    cli=.device/bin/raypack-cli; [ "$bin" = new ] || cli=.device/bin/raypack-cli-$bin
    for mode in ${MODES:-direct staged}; do
      name=$bin-$mode-$round
      if [ $(( $(date +%s) - start )) -gt "${BUDGET_S:-330}" ]; then echo "$name: skipped (budget)" >> "$final/errors.txt"; continue; fi
      echo "$(date +%s.%N) start $name" >> "$out/progress.txt"
      RAYPACK_UPLOAD=$mode "$cli" bench --suite scaling --only "terrain 10M,Dragon subdiv 3" \
        --scene-dir .device/scenes --device gpu --kernel single --width 1920 --height 1080 --repeat 10 --no-embree \
        --builder "${BUILDER:-sah-binned}" --out "$out/$name.json" 2>&1 | stamp > "$out/$name.log"
      echo "$(date +%s.%N) end $name" >> "$out/progress.txt"
    done
  done
done
kill "$smi" 2> /dev/null
nvidia-smi --query-compute-apps=pid,name,used_memory --format=csv > "$out/apps.txt" 2>&1
nvidia-smi -q > "$out/nvidia-smi-after.txt" 2>&1
python3 scripts/slow-mode-report "$out" > "$final/slow-mode.md" 2>> "$final/errors.txt"
tar cJf "$final/results.tar.xz" -C "$out" . && rm -rf "$out"
