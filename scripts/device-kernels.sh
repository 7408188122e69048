#!/usr/bin/env bash
# Issue 14 on the lent H200 machine: the single-ray Vulkan kernel's variants against its default,
# 1920x1080, primary and shadow rays, the report suite, one bench run per variant (each its own
# JSON): the default with the compiler's statistics of every kernel (--pipeline-statistics) and the
# driver's ray tracing beside it, and --shadow-order tree and larger. (The run of 2026-12-02 also
# measured a speculative traversal, since removed: docs/gpu.md.) Then OUT/kernels.md: Mrays/s per scene and ray kind, each variant / default, and
# the default / the driver's ray tracing.
# From the repository root on the device, with .device/ unpacked (scripts/device-pack.sh) and .gl/:
#   scripts/device-kernels.sh [OUT_DIR]   (default: $OUT)
# Environment: REPEAT (default 10), BUDGET_S (default 240: no run starts after that many seconds).
set -u
source scripts/device-start.sh "$0" "${1:-}"
cli=.device/bin/raypack-cli
repeat=${REPEAT:-10}
budget=${BUDGET_S:-240}
start=$(date +%s)
common=(bench --suite report --scene-dir .device/scenes --device gpu --kernel single --width 1920 --height 1080
        --repeat "$repeat" --no-embree)
run() {
  local name=$1
  shift
  if [ $(( $(date +%s) - start )) -gt "$budget" ]; then echo "$name: skipped (budget)" >> "$out/errors.txt"; return; fi
  "$cli" "${common[@]}" "$@" --out "$out/kernels-$name.json" > "$out/kernels-$name.log" 2>&1 ||
    echo "$name: bench failed (see kernels-$name.log)" >> "$out/errors.txt"
}
run default --pipeline-statistics
run tree --shadow-order tree --no-driver-rt
run larger --shadow-order larger --no-driver-rt
python3 - "$out" > "$out/kernels.md" <<'PY'
import glob, json, os, sys
out = sys.argv[1]
runs = {}
for path in sorted(glob.glob(os.path.join(out, "kernels-*.json"))):
    name = os.path.basename(path)[len("kernels-"):-len(".json")]
    with open(path) as f:
        runs[name] = json.load(f)
def mrays(run, tracer, scene, kind):
    for r in run["records"]:
        if r.get("tracer") == tracer and r.get("scene") == scene and r.get("ray_kind") == kind:
            return r.get("perf_mrays_s"), r
    return None, None
base = runs.get("default")
if not base:
    print("no default run"); sys.exit(0)
print(f"date {base['date']}, {base['machine'].get('gpu')}, command: {base['command']}\n")
variants = [v for v in runs if v != "default"]
print("| scene | rays | single Mrays/s | " + " | ".join(f"{v} / default" for v in variants) + " | default / driver RT | N_TR |")
print("|---|---|---:|" + "---:|" * len(variants) + "---:|---:|")
scenes = []
for r in base["records"]:
    if r.get("scene") not in scenes: scenes.append(r.get("scene"))
for scene in scenes:
    for kind in ("primary", "shadow"):
        m, rec = mrays(base, "gpu-single", scene, kind)
        if not m: continue
        cells = []
        for v in variants:
            mv, _ = mrays(runs[v], "gpu-single", scene, kind)
            cells.append(f"{mv / m:.3f}" if mv else "-")
        rt, _ = mrays(base, "driver-rt", scene, kind)
        print(f"| {scene} | {kind} | {m:.0f} | " + " | ".join(cells) + f" | {m / rt:.3f} |" if rt else f"| {scene} | {kind} | {m:.0f} | " + " | ".join(cells) + " | - |", f"{rec.get('n_tr_nodes_per_ray', 0):.1f} |")
print()
for r in base["records"]:
    if r.get("tracer") == "gpu-single" and r.get("pipeline_statistics"):
        print(f"pipeline statistics ({r['scene']}, {r['ray_kind']}): " + json.dumps(r["pipeline_statistics"]))
        break
PY
echo "done in $(( $(date +%s) - start )) s" >> "$out/kernels.md"
# A device call returns at most 8 files: everything but the summary goes into one archive
# (the files are removed only when the archive was written).
(cd "$out" && files=$(ls | grep -v -e '^kernels.md$' -e '^results.tgz$') &&
  tar czf results.tgz $files && rm -f $files) || echo "could not pack $out" >&2
