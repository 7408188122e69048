#!/usr/bin/env bash
# Issue 14 on the lent GPU machine: where the hybrid kernel's gap to the single-ray kernel comes
# from. One bench process per suite runs, as cells of that process:
#   - the single-ray kernel in its default workgroups (8x16 primary, 32x4 shadow), in the packet's
#     8x4 and in 8x16 for both passes;
#   - the hybrid kernel with one-subgroup 8x4 packets, one and four a workgroup, at K = 32 (the
#     default: split at the first node that not all 32 rays want) and K = 33 (more rays than the
#     packet holds: every packet splits at its first vote, at the root, so the packet phase is
#     gone and what is left is the hybrid kernel's own cost: its code, its doubled stack, its
#     workgroup);
#   - the report's packet kernel, 8x4.
# Then OUT/hybrid-gap.md: the gap in steps, each a ratio of two cells of one process: the single
# kernel's workgroup (8x4 / default), the hybrid's structure (hybrid K = 33 / single in the same
# workgroup shape), the packet phase (K = 32 / K = 33), with registers, code size and N_TR.
# From the repository root on the device, with .device/round.tar.xz (scripts/device-pack.sh) and .gl/:
#   scripts/device-hybrid-gap.sh [OUT_DIR]   (default: $OUT)
# Environment: REPEAT (default 5), SCALING (default "terrain 1M,terrain 10M,Dragon subdiv 3"; empty:
# the report suite only; run in each binary's first round), ROUNDS (default 1), BINARIES (default
# "new": .device/bin/raypack-cli; any other name .device/bin/raypack-cli-NAME, scripts/device-pack.sh
# BUILD BINARY...), alternated process by process within each round.
set -u
source scripts/device-start.sh "$0" "${1:-}"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt" 2>&1
common=(bench --scene-dir .device/scenes --device gpu --kernel all --packets 8x4
        --single-groups 8x16/32x4,8x4/8x4,8x16/8x16 --hybrid-min-rays 32,33 --hybrid-visit-ratios 0
        --hybrid-packets-per-group 1,4 --width 1920 --height 1080 --repeat "${REPEAT:-5}"
        --no-embree --no-driver-rt --pipeline-statistics)
scaling=${SCALING-terrain 1M,terrain 10M,Dragon subdiv 3}
for round in $(seq 1 "${ROUNDS:-1}"); do
  for bin in ${BINARIES:-new}; do
    cli=.device/bin/raypack-cli; [ "$bin" = new ] || cli=.device/bin/raypack-cli-$bin
    name=gap-$bin-$round
    "$cli" "${common[@]}" --suite report --out "$out/$name-report.json" > "$out/$name-report.log" 2>&1 ||
      echo "$name report: bench failed" >> "$out/errors.txt"
    # The scaling scenes once per binary: they take as long as the whole report suite.
    if [ -n "$scaling" ] && [ "$round" = 1 ]; then
      "$cli" "${common[@]}" --suite scaling --only "$scaling" --out "$out/$name-scaling.json" \
        > "$out/$name-scaling.log" 2>&1 || echo "$name scaling: bench failed" >> "$out/errors.txt"
    fi
    { echo "## $bin, round $round"; echo; python3 scripts/hybrid-gap-report "$out/$name"-*.json; echo; } \
      >> "$out/hybrid-gap.md" 2>> "$out/errors.txt"
  done
done
(cd "$out" && tar cJf runs.tar.xz gap-*.json gap-*.log env.log && rm -f gap-*.json gap-*.log env.log)
