#!/bin/bash
cd /work/main
for round in 4 5 6 7 8; do
for b in head tri; do
  .../raypack-cli-$b bench --suite report --only "Sibenik,Conference,Armadillo,Dragon" --device gpu --kernel single --width 320 --height 240 --repeat 9 --no-driver-rt --no-embree --out /tmp/tt/bench-$b-$round.json > /tmp/tt/log-$b-$round.txt 2>&1
  echo "$round $b rc=$? $(date -u +%T)"
done; done
