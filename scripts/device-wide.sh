#!/usr/bin/env bash
# Issue 14 on the lent H200 machine: the single-ray Vulkan kernel over the 4-wide tree (tracer
# gpu-wide, --bvh-width 4) against the same kernel over the binary tree (gpu-single), both cells of
# one bench run per scene (so the ratio is measured in one process), 1920x1080, primary and shadow
# rays: the report suite twice (the first with the driver's ray tracing beside them and the
# compilers' statistics) and the scaling suite once. First the hits of both at 1920x1080, byte for
# byte, on four report scenes. Then OUT/wide.md: Mrays/s per scene and ray kind, wide / single,
# the best of the two / the driver's ray tracing, N_TR of each.
# From the repository root on the device, with .device/ unpacked (scripts/device-pack.sh BUILD) and .gl/:
#   scripts/device-wide.sh [OUT_DIR]   (default: $OUT)
# Environment: REPEAT (default 10), BUDGET_S (default 420: no run starts after that many seconds).
set -u
out=${1:-${OUT:-}}
[ -n "$out" ] || { echo "usage: scripts/device-wide.sh OUT_DIR" >&2; exit 2; }
mkdir -p "$out"
source scripts/device-env.sh > "$out/env.log" 2>&1
cli=.device/bin/raypack-cli
repeat=${REPEAT:-10}
budget=${BUDGET_S:-420}
start=$(date +%s)
for scene in sibenik/sibenik_geom_75284.ply conference/conference_geom.ply stanford/armadillo_decimated_99976.obj \
             stanford/dragon_vrip_res2.ply; do
  name=$(basename "$scene" | cut -d_ -f1 | cut -d. -f1)
  for width in 2 4; do
    "$cli" render ".device/scenes/$scene" --device gpu --kernel single --bvh-width "$width" --width 1920 --height 1080 \
      --hits "$out/$name-$width.hits" > "$out/render-$name-$width.log" 2>&1 || echo "render $name width $width failed" >> "$out/errors.txt"
  done
  if cmp -s "$out/$name-2.hits" "$out/$name-4.hits"; then verdict=identical; else verdict=DIFFERENT; fi
  echo "$name 1920x1080 hits, 4-wide against binary: $verdict" >> "$out/hits.txt"
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
run report-1 report --pipeline-statistics
run report-2 report --no-driver-rt
run scaling scaling --no-driver-rt
python3 - "$out" > "$out/wide.md" <<'PY'
import glob, json, os, sys
out = sys.argv[1]
def rec(run, tracer, scene, kind):
    for r in run["records"]:
        if r.get("tracer") == tracer and r.get("scene") == scene and r.get("ray_kind") == kind:
            return r
    return None
for name in ("report-1", "report-2", "scaling"):
    path = os.path.join(out, name + ".json")
    if not os.path.exists(path):
        print(f"## {name}: missing\n"); continue
    run = json.load(open(path))
    print(f"## {name}\n\ndate {run['date']}, {run['machine'].get('gpu')}, {run['machine'].get('gpu_driver')}, "
          f"command: {run['command']}\n")
    print("| scene | rays | single Mrays/s | wide Mrays/s | wide / single | best / driver RT | N_TR single | N_TR wide |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    scenes = []
    for r in run["records"]:
        if r.get("scene") not in scenes: scenes.append(r.get("scene"))
    for scene in scenes:
        for kind in ("primary", "shadow"):
            s, w = rec(run, "gpu-single", scene, kind), rec(run, "gpu-wide", scene, kind)
            if not s or not w: continue
            ms, mw = s["perf_mrays_s"], w["perf_mrays_s"]
            rt = rec(run, "driver-rt", scene, kind)
            rtc = f"{max(ms, mw) / rt['perf_mrays_s']:.3f}" if rt and rt.get("perf_mrays_s") else "-"
            print(f"| {scene} | {kind} | {ms:.0f} | {mw:.0f} | {mw / ms:.3f} | {rtc} | "
                  f"{s.get('n_tr_nodes_per_ray') or 0:.1f} | {w.get('n_tr_nodes_per_ray') or 0:.1f} |")
    print()
    for r in run["records"]:
        if r.get("tracer") in ("gpu-single", "gpu-wide") and r.get("pipeline_statistics") and r.get("ray_kind") == "primary":
            print(f"pipeline statistics {r['tracer']} ({r['scene']}): " + json.dumps(r["pipeline_statistics"]))
    print()
PY
cat "$out/hits.txt" >> "$out/wide.md" 2>/dev/null
echo "done in $(( $(date +%s) - start )) s" >> "$out/wide.md"
# A device call returns at most 8 files: everything but the summary into one archive.
(cd "$out" && files=$(ls | grep -v -e '^wide.md$' -e '^results.tgz$' -e '^errors.txt$') &&
  tar czf results.tgz $files && rm -f $files) || echo "could not pack $out" >&2
