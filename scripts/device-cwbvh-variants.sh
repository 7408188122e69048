#!/usr/bin/env bash
# Issue 14 on the lent H200 machine: variants of the compressed 8-wide tree's kernel and collapse,
# each a raypack-cli of its own (scripts/variant-cli.sh, carried as .device/bin/raypack-cli-NAME by
# scripts/device-pack.sh), against the build itself: scripts/device-kernel-variants.sh with
# TRACER=gpu-cwbvh and no hits comparison (each binary's 8-wide Mrays/s, its ratio to the binary
# tree of the same process and to the build's 8-wide figure of the same round, in OUT/variants.md).
#   scripts/device-cwbvh-variants.sh [OUT_DIR]   (default: $OUT)
# Environment: as scripts/device-kernel-variants.sh (VARIANTS, ROUNDS, REPEAT, BUDGET_S).
TRACER=gpu-cwbvh HITS=${HITS:-0} exec "$(dirname "$0")/device-kernel-variants.sh" "$@"
