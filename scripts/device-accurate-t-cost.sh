#!/bin/bash
# Issue 15: the cost of the accurate hit distance on the H200 machine, before (old) / after (new),
# interleaved, Sibenik 1920x1080 primary rays only; GPU kernels and the CPU tracers (16 threads).
# Run on the device from an unpacked bundle (scripts/device-bundle.sh) holding dev/bin/raypack-cli-old
# (built before the change) and dev/bin/raypack-cli, and the scene in dev/scenes.
S=dev/scenes/sibenik_geom_75284.ply
for cfg in "gpu packet" "gpu single" "cpu packet"; do
  set -- $cfg
  for i in 1 2 3; do
    for bin in raypack-cli-old raypack-cli; do
      dev/bin/$bin render $S --width 1920 --height 1080 --device $1 --kernel $2 --no-shadows --repeat 10 --json /tmp/tc.json >/dev/null 2>&1 || echo "FAILED $bin $cfg"
      python3 -c "import json; j=json.load(open('/tmp/tc.json')); print('$1 $2 $bin', j['table2']['primary']['t_k_s'], j['table2']['primary']['n_q_rays'])" 2>/dev/null || grep -o '"t_k_s": [0-9.e-]*' /tmp/tc.json | head -1
    done
  done
done
