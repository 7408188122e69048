#!/usr/bin/env bash
# Packs what the lent H200 machine needs for the benchmark scripts (scripts/device-trade.sh,
# device-hybrid.sh, device-build-rate.sh) into one compressed file that travels with the checkout:
# .device/round.tar.xz holding .device/bin (raypack-cli and any further BINARY given, e.g. an old
# build as raypack-cli-old), .device/lib (their libraries, scripts/device-bundle.sh) and
# .device/scenes (the report scenes, laid out as in ../shared/scenes). Embree's library alone is
# 44 MB, so uncompressed the bundle would not fit the 64 MiB a run may carry.
#   scripts/device-pack.sh BUILD_DIR [BINARY...]
# EXTRA_SCENES: further files under ../shared/scenes to carry (the GPU tests' glTF, for instance).
# On the device (carry [".gl", ".device"]): tar xJf .device/round.tar.xz && ln -sfn .device dev
set -euo pipefail
build=${1:?usage: scripts/device-pack.sh BUILD_DIR [BINARY...]}
shift
scenes=${RAYPACK_SHARED_SCENES:-../shared/scenes}
rm -rf .device/bin .device/lib .device/scenes
scripts/device-bundle.sh .device "$build/raypack-cli" "$@"
for f in sibenik/sibenik_geom_75284.ply dabrovic_sponza/sponza.obj conference/conference_geom.ply \
         stanford/armadillo_decimated_99976.obj stanford/dragon_vrip_res2.ply ${EXTRA_SCENES:-}; do
  mkdir -p ".device/scenes/$(dirname "$f")"
  cp "$scenes/$f" ".device/scenes/$f"
done
tar cJf .device/round.tar.xz .device/bin .device/lib .device/scenes
rm -rf .device/bin .device/lib .device/scenes
ls -la .device/round.tar.xz
