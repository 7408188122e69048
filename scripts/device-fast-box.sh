#!/usr/bin/env bash
# The fast path's box test on the lent GPU: the build (.device/bin/raypack-cli) against another
# binary carried as .device/bin/raypack-cli-base (scripts/device-pack.sh BUILD /path/raypack-cli-base),
# e.g. the build of bc2bbbe (fast path's box test in fused form) against its parent. Two rounds of
# `bench --suite report --device gpu --kernel single --width 1920 --height 1080 --repeat 10`:
# base with --intersect fast, the build with fast and robust; then Sibenik's and Armadillo's fast
# hits at 1920x1080 from both binaries compared (OUT/f/hits.txt). Everything in OUT/fast.tar.xz.
#   scripts/device-fast-box.sh [OUT_DIR]   (default: $OUT)
set -u
source scripts/device-start.sh "$0" "${1:-}"; o=$out/f; mkdir -p $o
nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv > $o/gpu.txt
for round in 1 2; do for cfg in base:fast new:fast new:robust; do b=${cfg%%:*}; m=${cfg##*:}
  cli=.device/bin/raypack-cli; [ $b = base ] && cli=.device/bin/raypack-cli-base
  $cli bench --suite report --scene-dir .device/scenes --device gpu --kernel single --intersect $m --width 1920 --height 1080 --repeat 10 --no-embree --no-driver-rt --out $o/$b-$m-$round.json > $o/$b-$m-$round.log 2>&1 || echo "$cfg $round failed" >> $o/errors.txt
done; done
for s in sibenik/sibenik_geom_75284.ply stanford/armadillo_decimated_99976.obj; do n=$(basename $s | cut -c1-8)
  for b in base new; do cli=.device/bin/raypack-cli; [ $b = base ] && cli=.device/bin/raypack-cli-base
    $cli render .device/scenes/$s --device gpu --kernel single --intersect fast --width 1920 --height 1080 --hits $o/h-$n-$b.bin > /dev/null 2>&1; done
  if cmp -s $o/h-$n-base.bin $o/h-$n-new.bin; then echo "$n identical" >> $o/hits.txt; else echo "$n differ: $(cmp -l $o/h-$n-base.bin $o/h-$n-new.bin | wc -l) bytes of $(stat -c %s $o/h-$n-new.bin)" >> $o/hits.txt; fi
  rm -f $o/h-*.bin
done
tar cJf $out/fast.tar.xz -C $out f; cat $o/gpu.txt $o/hits.txt $o/errors.txt 2>/dev/null
