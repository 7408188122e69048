#!/usr/bin/env bash
# Issue 13 on the lent H200 machine: the viewer's rebuilds with device builders, measured in the
# viewer's own frame loop (--offscreen: no display there) on the dragon subdivided to 13M at
# 1920x1080. The first tree is CPU-built (sah-binned, uploaded); then the worker builds with gpu-ploc,
# at leaf size 4, with gpu-lbvh, each into buffers the tracer adopts, and last sah-binned again
# (uploaded), while the render thread keeps tracing (4,096 samples wanted, so every frame traces).
# Per tree, --summary's "trees" has the worker's build time, the render thread's time to take the
# tree (adopt or upload) and the frames drawn meanwhile with the longest of them.
# Prepare here: scripts/device-pack.sh build build/raypack. On the device (carry [".gl", ".device"]):
#   [VIEWER_SCENE=spec] [FRAMES=N] bash scripts/device-viewer-rebuild.sh
#       -> $OUT/viewer-rebuild.txt, $OUT/viewer-rebuild.json
set -uo pipefail
out=${OUT:-${OUT_DIR:-out}}
mkdir -p "$out"
if [ ! -x .device/bin/raypack ] && [ -f .device/round.tar.xz ]; then tar xJf .device/round.tar.xz; fi
source scripts/device-env.sh 2>/dev/null
scene=${VIEWER_SCENE:-subdiv:3:.device/scenes/stanford/dragon_vrip_res2.ply}
frames=${FRAMES:-1600}
step=$((frames / 5))
timeout 400 .device/bin/raypack --offscreen --scene "$scene" --width 1920 --height 1080 --tracer vulkan-single \
  --builder sah-binned --frames "$frames" --script 1:samples:4096 --script "$step:builder:gpu-ploc" \
  --script "$((2 * step)):leaf-size:4" --script "$((3 * step)):builder:gpu-lbvh" \
  --script "$((4 * step)):builder:sah-binned" --summary "$out/viewer-rebuild.json" 2>&1 | tee -a "$out/viewer-rebuild.txt"
