#!/bin/bash
cd "$(dirname "$0")/../../.."  # the repository root
for round in 1 2 3 4; do
for m in storage texel; do
  RAYPACK_NODE_FETCH=$m ./build/raypack-cli bench --suite report --only "Sibenik,Conference,Armadillo,Dragon" --device gpu --kernel all --packets 8x1 --width 320 --height 240 --repeat 5 --no-driver-rt --no-embree --out docs/results/lavapipe-node-fetch/bench-$m-$round.json > docs/results/lavapipe-node-fetch/log-$m-$round.txt 2>&1
  echo "$round $m rc=$? $(date -u +%T)"
done; done
