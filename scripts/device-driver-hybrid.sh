#!/usr/bin/env bash
# Issue 14 on the lent H200 machine, one call: (1) the single-ray kernel against the driver's ray
# tracing with the accurate hit distance in doubles (`bench --suite report --device gpu --kernel
# single`, 1920x1080, repeat 10, the report's tree and sah-split leaves of 2, ROUNDS rounds), and
# (2) the hybrid kernel's split rule K swept against the single-ray kernel on the report and
# scaling scenes (scripts/device-hybrid.sh, one-subgroup 8x4 packets, K = HYBRID_K), for the figure
# of scripts/hybrid-density; and (3) Sibenik at sah-split leaves of 2 with --intersect robust and fast
# (two rounds, one process each). Everything lands in OUT/driver-*.json|log and OUT/hybrid/, packed into
# OUT/results.tar.xz as well (a call returns a few files only).
#   scripts/device-driver-hybrid.sh [OUT_DIR]   (default: $OUT)
# Environment: ROUNDS (default 1), DRIVER_BUDGET_S (default 240), HYBRID_K (default 1/16,1/8,1/4,1/2,1/1; 1/1: split at the first node not all of the packet's rays want),
# HYBRID_BUDGET_S (default 300), SKIP_DRIVER / SKIP_FAST / SKIP_HYBRID (1: skip that part).
set -u
source scripts/device-start.sh "$0" "${1:-}"
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv > "$out/gpu.txt" 2>&1
start=$(date +%s)
if [ "${SKIP_DRIVER:-0}" != 1 ]; then
  for round in $(seq 1 "${ROUNDS:-1}"); do
    for tree in exact split; do
      if [ $(( $(date +%s) - start )) -gt "${DRIVER_BUDGET_S:-240}" ]; then echo "driver $tree $round: skipped (budget)" >> "$out/errors.txt"; continue; fi
      extra=""; [ "$tree" = split ] && extra="--builder sah-split --leaf-size 2"
      .device/bin/raypack-cli bench --suite report --scene-dir .device/scenes --device gpu --kernel single \
        --width 1920 --height 1080 --repeat 10 --no-embree $extra --out "$out/driver-$tree-$round.json" \
        > "$out/driver-$tree-$round.log" 2>&1 || echo "driver $tree $round: bench failed" >> "$out/errors.txt"
      echo "driver $tree $round done at $(( $(date +%s) - start )) s" >> "$out/progress.txt"
    done
  done
fi
# Sibenik's best tree with the fast path (issue 15's trade) beside the robust one, two rounds.
if [ "${SKIP_FAST:-0}" != 1 ]; then
  for round in 1 2; do
    for mode in robust fast; do
      .device/bin/raypack-cli bench --suite report --only Sibenik --scene-dir .device/scenes --device gpu --kernel single \
        --width 1920 --height 1080 --repeat 10 --no-embree --no-driver-rt --builder sah-split --leaf-size 2 --intersect "$mode" \
        --out "$out/sibenik-$mode-$round.json" > "$out/sibenik-$mode-$round.log" 2>&1 || echo "sibenik $mode $round: bench failed" >> "$out/errors.txt"
    done
  done
  echo "sibenik robust / fast done at $(( $(date +%s) - start )) s" >> "$out/progress.txt"
fi
if [ "${SKIP_HYBRID:-0}" != 1 ]; then
  PACKETS=8x4 HYBRID_K=${HYBRID_K:-1/16,1/8,1/4,1/2,1/1} HYBRID_RATIOS=0 REPEAT=5 BUDGET_S=${HYBRID_BUDGET_S:-300} \
    scripts/device-hybrid.sh "$out/hybrid" > "$out/hybrid.log" 2>&1 || echo "hybrid sweep failed" >> "$out/errors.txt"
  echo "hybrid done at $(( $(date +%s) - start )) s" >> "$out/progress.txt"
fi
tar cJf "$out/results.tar.xz" -C "$out" --exclude results.tar.xz .
