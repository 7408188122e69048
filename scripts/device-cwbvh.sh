#!/usr/bin/env bash
# Issue 14 on the lent H200 machine: the single-ray Vulkan kernel over the compressed 8-wide tree
# (tracer gpu-cwbvh, --bvh-width 8) against the same kernel over the binary tree (gpu-single), both
# cells of one bench run per suite (so each ratio is measured in one process), 1920x1080, primary
# and shadow rays. First the hits of both at 1920x1080, byte for byte, on the report scenes. Then
# the runs RUNS names: by default the report suite twice (the first with the driver's ray tracing
# beside them and the compilers' statistics), a sweep of workgroups, the report suite on sah-split
# leaves of 2 with the driver (the configuration in which docs/gpu.md met issue 14's driver goals),
# and the scaling suite. OUT/cwbvh.md: Mrays/s per
# scene and ray kind, 8-wide / binary, the best of the two / the driver, N_TR and N_IT of each.
# From the repository root on the device, with .device/round.tar.xz (scripts/device-pack.sh BUILD) and .gl/:
#   scripts/device-cwbvh.sh [OUT_DIR]   (default: $OUT)
# Environment: REPEAT (default 10), BUDGET_S (default 480: no run starts after that many seconds),
# RUNS (default "report-1 report-2 groups split2 scaling"; also scaling-rt, the scaling suite with
# the driver's ray tracing, and leaf2, leaf3, the report suite at sah-exact leaves of 2 and 3),
# GROUPS_LIST (the groups run's --single-groups).
set -u
source scripts/device-start.sh "$0" "${1:-}"
cli=.device/bin/raypack-cli
repeat=${REPEAT:-10}
budget=${BUDGET_S:-480}
runs=${RUNS:-report-1 report-2 groups split2 scaling}
start=$(date +%s)
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv >> "$out/env.log" 2>&1
for scene in sibenik/sibenik_geom_75284.ply dabrovic_sponza/sponza.obj conference/conference_geom.ply \
             stanford/armadillo_decimated_99976.obj stanford/dragon_vrip_res2.ply; do
  name=$(basename "$scene" | cut -d_ -f1 | cut -d. -f1)
  for width in 2 8; do
    "$cli" render ".device/scenes/$scene" --device gpu --kernel single --bvh-width "$width" --width 1920 --height 1080 \
      --hits "$out/$name-$width.hits" > "$out/render-$name-$width.log" 2>&1 || echo "render $name width $width failed" >> "$out/errors.txt"
  done
  if cmp -s "$out/$name-2.hits" "$out/$name-8.hits"; then verdict=identical; else verdict=DIFFERENT; fi
  echo "$name 1920x1080 hits, 8-wide against binary: $verdict" >> "$out/hits.txt"
  rm -f "$out/$name"-*.hits
done
run() {
  local name=$1 suite=$2
  shift 2
  if [ $(( $(date +%s) - start )) -gt "$budget" ]; then echo "$name: skipped (budget)" >> "$out/errors.txt"; return; fi
  "$cli" bench --suite "$suite" --scene-dir .device/scenes --device gpu --kernel single --width 1920 --height 1080 \
    --repeat "$repeat" --no-embree "$@" --out "$out/$name.json" > "$out/$name.log" 2>&1 ||
    echo "$name: bench failed (see $name.log)" >> "$out/errors.txt"
}
for r in $runs; do
  case $r in
    report-1) run report-1 report --pipeline-statistics ;;
    report-2) run report-2 report --no-driver-rt ;;
    groups) run groups report --no-driver-rt --single-groups "${GROUPS_LIST:-8x16/32x4,8x8/8x8,16x8/16x8,8x4/32x4}" ;;
    split2) run split2 report --builder sah-split --leaf-size 2 ;;
    scaling) run scaling scaling --no-driver-rt ;;
    scaling-rt) run scaling-rt scaling ;;
    leaf2) run leaf2 report --no-driver-rt --leaf-size 2 ;;
    leaf3) run leaf3 report --no-driver-rt --leaf-size 3 ;;
  esac
done
python3 - "$out" > "$out/cwbvh.md" <<'PY'
import json, os, sys
out = sys.argv[1]
def rec(run, tracer, scene, kind, packet=None):
    for r in run["records"]:
        if r.get("tracer") == tracer and r.get("scene") == scene and r.get("ray_kind") == kind and \
                (packet is None or r.get("packet") == packet):
            return r
    return None
for name in ("report-1", "report-2", "groups", "leaf2", "leaf3", "split2", "scaling", "scaling-rt"):
    path = os.path.join(out, name + ".json")
    if not os.path.exists(path):
        print(f"## {name}: missing\n"); continue
    run = json.load(open(path))
    print(f"## {name}\n\ndate {run['date']}, {run['machine'].get('gpu')}, {run['machine'].get('gpu_driver')}, "
          f"command: {run['command']}\n")
    print("| scene | rays | workgroup | binary Mrays/s | 8-wide Mrays/s | 8-wide / binary | 8-wide / driver RT | binary / driver RT | N_TR binary / 8-wide | N_IT binary / 8-wide |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|---:|")
    scenes = []
    for r in run["records"]:
        if r.get("scene") not in scenes: scenes.append(r.get("scene"))
    for scene in scenes:
        for kind in ("primary", "shadow"):
          packets = []
          for r in run["records"]:
              if r.get("scene") == scene and r.get("ray_kind") == kind and r.get("tracer") == "gpu-single" and r.get("packet") not in packets:
                  packets.append(r.get("packet"))
          for packet in packets:
            s, w = rec(run, "gpu-single", scene, kind, packet), rec(run, "gpu-cwbvh", scene, kind, packet)
            if not s or not w: continue
            ms, mw = s["perf_mrays_s"], w["perf_mrays_s"]
            rt = rec(run, "driver-rt", scene, kind)
            rtw = f"{mw / rt['perf_mrays_s']:.3f}" if rt and rt.get("perf_mrays_s") else "-"
            rts = f"{ms / rt['perf_mrays_s']:.3f}" if rt and rt.get("perf_mrays_s") else "-"
            print(f"| {scene} | {kind} | {packet} | {ms:.0f} | {mw:.0f} | {mw / ms:.3f} | {rtw} | {rts} | "
                  f"{s.get('n_tr_nodes_per_ray') or 0:.1f} / {w.get('n_tr_nodes_per_ray') or 0:.1f} | "
                  f"{s.get('n_it_tests_per_ray') or 0:.2f} / {w.get('n_it_tests_per_ray') or 0:.2f} |")
    print()
    for r in run["records"]:
        if r.get("tracer") in ("gpu-single", "gpu-cwbvh") and r.get("pipeline_statistics") and r.get("ray_kind") == "primary":
            print(f"pipeline statistics {r['tracer']} ({r['scene']}): " + json.dumps(r["pipeline_statistics"]))
    print()
PY
cat "$out/hits.txt" >> "$out/cwbvh.md" 2>/dev/null
echo "done in $(( $(date +%s) - start )) s" >> "$out/cwbvh.md"
# A device call returns at most 8 files: everything but the summary into one archive.
(cd "$out" && files=$(ls | grep -v -e '^cwbvh.md$' -e '^results.tgz$' -e '^errors.txt$') &&
  tar czf results.tgz $files && rm -f $files) || echo "could not pack $out" >&2
