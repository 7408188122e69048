#!/usr/bin/env bash
# The three single-ray kernel variants that wait for a GPU (docs/gpu.md, "Three kernel variants
# waiting for a GPU"), each against the build in one device call, by scripts/device-kernel-variants.sh:
#   cull     292a41a  pending nodes beyond the nearest hit dropped when popped
#   octant   c68ff20  box tests without the per-axis min and max where a subgroup shares an octant
#   fastbox  bc2bbbe  the fast path's box test in the fused form
# Build them here first (build/ a current Release build of the commit to compare against), then pack:
#   SHADER_REV=292a41a scripts/variant-cli.sh cull "" ""
#   SHADER_REV=c68ff20 scripts/variant-cli.sh octant "" ""
#   SHADER_REV=bc2bbbe scripts/variant-cli.sh fastbox "" ""
#   scripts/device-pack.sh build /tmp/v-cull/raypack-cli-cull /tmp/v-octant/raypack-cli-octant \
#     /tmp/v-fastbox/raypack-cli-fastbox
# On the device (carry [".gl", ".device"]):
#   scripts/device-waiting-variants.sh [OUT_DIR]   (default: $OUT)
# OUT/split: cull and octant, robust, sah-split leaves of 2 (the Sibenik goal's tree), two rounds
# with the hits compared; OUT/report: the same on the report's tree, one round; OUT/fast: fastbox
# with --intersect fast on sah-split leaves of 2, two rounds. Each holds variants.md (the ratios to
# the build of the same round), hits.txt and results.tgz. About 7 minutes on an H100. cull's and
# octant's hits must be the build's; fastbox's may differ (the fast path's box test rounds
# differently in fused form, and the fast path promises no exact hits).
set -u
source scripts/device-start.sh "$0" "${1:-}"
split="--builder sah-split --leaf-size 2"
nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv > "$out/gpu.txt" 2>&1
VARIANTS="cull octant" TREE_ARGS="$split" BUDGET_S=200 scripts/device-kernel-variants.sh "$out/split"
VARIANTS="cull octant" HITS=0 ROUNDS=1 BUDGET_S=100 scripts/device-kernel-variants.sh "$out/report"
VARIANTS="fastbox" INTERSECT=fast TREE_ARGS="$split" BUDGET_S=120 scripts/device-kernel-variants.sh "$out/fast"
cat "$out/gpu.txt"
for part in split report fast; do echo "## $part"; cat "$out/$part/variants.md" "$out/$part/hits.txt" "$out/$part/errors.txt" 2>/dev/null; done
