#!/usr/bin/env bash
# Issue 15 on the lent H200 machine: the full trade suite (bench --suite trade: the report scenes
# and the closed generated scenes, every builder x leaf size x intersect robust/fast x GPU packet,
# GPU single and CPU packet, plus the CPU reference at sah-exact leaf 1; docs/trade.md), then
# scripts/bench-report's tables and Pareto figures of it, all into $OUT (or OUT_DIR).
#
# Prepare here: scripts/device-pack.sh build (.device/round.tar.xz: raypack-cli, its libraries and
# the report scenes; the closed scenes are generated and need no files). Then on the device, from
# the repository root (the run tool, carry [".gl", ".device"]):
#   bash scripts/device-trade.sh [EXTRA BENCH FLAGS...]
# It unpacks .device/round.tar.xz when .device/bin is not there yet, and sources scripts/device-env.sh.
# The bench stops itself before the device's 10-minute limit (TRADE_TIMEOUT_S, default 560 s); it
# writes its results after every scene, so a run cut short keeps the scenes it finished
# ("complete": false in the JSON).
set -uo pipefail
out=${OUT:-${OUT_DIR:-out}}
mkdir -p "$out"
if [ ! -x .device/bin/raypack-cli ] && [ -f .device/round.tar.xz ]; then tar xJf .device/round.tar.xz; fi
source scripts/device-env.sh
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv > "$out/gpu.txt" 2>&1
lscpu > "$out/lscpu.txt" 2>&1
start=$(date +%s)
timeout "${TRADE_TIMEOUT_S:-560}" .device/bin/raypack-cli bench --suite trade --scene-dir .device/scenes \
  --out "$out/h200-trade.json" "$@" > "$out/trade.log" 2> "$out/trade-progress.log"
rc=$?
echo "bench exit $rc after $(( $(date +%s) - start )) s" | tee "$out/run-time.txt"
tail -3 "$out/trade-progress.log"
# The report needs matplotlib; where the device's python3 lacks it, run the same command here on
# the returned JSON.
if [ -f "$out/h200-trade.json" ]; then
  py=python3; [ -x /usr/bin/python3 ] && py=/usr/bin/python3
  "$py" scripts/bench-report "$out/h200-trade.json" --markdown "$out/h200-trade.md" --img-dir "$out/img" \
    > "$out/report.log" 2>&1 || echo "bench-report failed here (see report.log); run it on the JSON at home"
fi
exit $rc
