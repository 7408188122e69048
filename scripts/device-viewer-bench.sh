#!/usr/bin/env bash
# On the lent GPU machine (no display, no Debian packages): the viewer's frame loop offscreen on
# the report scenes at 1920x1080 along the paths of scripts/viewer-paths.sh, then the CPU tracers'
# thread scaling (bench --suite report --device cpu at 16, 8, 4, 2, 1 threads).
#   scripts/device-viewer-bench.sh BUNDLE.tar.xz OUT_DIR
# The bundle holds dev/ (scripts/device-bundle.sh of raypack-cli and raypack), scenes/ and paths/.
set -uo pipefail
bundle=$1
out=$2
B=/tmp/rpb
mkdir -p "$B" "$out"
tar xJf "$bundle" -C "$B"
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
export LD_LIBRARY_PATH=$B/dev/lib XDG_RUNTIME_DIR=/tmp
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f "$icd" ] && export VK_DRIVER_FILES=$icd VK_ICD_FILENAMES=$icd
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv > "$out/gpu.txt" 2>&1
lscpu > "$out/lscpu.txt"
declare -A files=([sibenik]=sibenik/sibenik_geom_75284.ply [sponza]=dabrovic_sponza/sponza.obj
  [conference]=conference/conference_geom.ply [armadillo]=stanford/armadillo_decimated_99976.obj
  [dragon]=stanford/dragon_vrip_res2.ply)
for tracer in vulkan-packet vulkan-single; do
  for scene in sibenik sponza conference armadillo dragon; do
    timeout 120 "$B/dev/bin/raypack" --offscreen --tracer "$tracer" --scene "$B/scenes/${files[$scene]}" \
      --width 1920 --height 1080 --play-path "$B/paths/$scene.json" --summary "$out/viewer-$tracer-$scene.json" \
      > "$out/viewer-$tracer-$scene.log" 2>&1 || echo "viewer $tracer $scene failed" >> "$out/errors.txt"
  done
done
CPUS=$(python3 -c "import os;print(' '.join(map(str,sorted(os.sched_getaffinity(0)))))" 2>/dev/null || seq -s' ' 0 15)
for n in 16 8 4 2 1; do
  L=$(echo $CPUS | tr ' ' '\n' | head -$n | paste -sd,)
  taskset -c "$L" "$B/dev/bin/raypack-cli" bench --suite report --scene-dir "$B/scenes" --device cpu --repeat 5 \
    --cpu-packets 16x16 --out "$out/cpu-$n.json" > "$out/cpu-$n.log" 2>&1 || echo "cpu $n failed" >> "$out/errors.txt"
done
cd "$out" && tar czf ../results.tgz . && mv ../results.tgz .
