#!/usr/bin/env bash
# The GPU benchmark matrix with one raypack-cli process per kernel configuration:
#   scripts/bench-gpu.sh OUT_DIR SUITE [PACKETS] [bench flags...]
# e.g. scripts/bench-gpu.sh docs/results/h100 report 8x4,4x8,5x6,8x8,16x16,32x1 --width 1920 --height 1080 --repeat 10
# writes OUT_DIR/SUITE-single.json (single-ray kernel and the driver's ray tracing) and
# OUT_DIR/SUITE-packet-WxH.json per packet shape; scripts/bench-report takes them all at once.
# Why not one `bench --kernel all` process: on the H100 (2026-11-22) cells late in a long
# single-process run sometimes measured 2-4x slower than the same cell in a process of its own
# (cause not yet found; docs/benchmarks.md); one process per configuration reproduces the figures
# of `raypack-cli render --repeat` run by hand.
set -euo pipefail
out=${1:?usage: bench-gpu.sh OUT_DIR SUITE [PACKETS] [bench flags...]}
suite=${2:?usage: bench-gpu.sh OUT_DIR SUITE [PACKETS] [bench flags...]}
packets=${3:-8x4,4x8,5x6,8x8,16x16}
shift 3 || shift $#
cli=${RAYPACK_CLI:-$(cd "$(dirname "$0")/.." && pwd)/build/raypack-cli}
mkdir -p "$out"
"$cli" bench --suite "$suite" --device gpu --kernel single "$@" --out "$out/$suite-single.json"
for shape in ${packets//,/ }; do
  "$cli" bench --suite "$suite" --device gpu --kernel packet --packets "$shape" --no-driver-rt "$@" \
    --out "$out/$suite-packet-$shape.json"
done
"$(dirname "$0")/merge-bench-results" "$out/$suite.json" "$out/$suite-single.json" \
  $(for shape in ${packets//,/ }; do echo "$out/$suite-packet-$shape.json"; done)
