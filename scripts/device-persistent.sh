#!/usr/bin/env bash
# Issue 14 on the lent H200 machine: the single-ray Vulkan kernel with persistent threads and
# dynamic ray fetch (--persistent N) against the same kernel with one invocation per pixel, and
# against the build before the kernel's main loop was reworked for them (.device/bin/raypack-cli-old),
# 1920x1080, primary and shadow rays, the report suite, two rounds (each variant a bench run of its
# own JSON), then the scaling suite once for the default and the persistent variants. First the
# persistent-threads test of test_gpu_shapes on the GPU (hits, images and counters equal to the
# per-pixel kernel's). Then OUT/persistent.md: Mrays/s per scene and ray kind, each variant / the
# default of the same round, old / default, and the default / the driver's ray tracing.
# From the repository root on the device, with .device/ unpacked (scripts/device-pack.sh BUILD
# OLD_CLI test_gpu_shapes) and .gl/:
#   scripts/device-persistent.sh [OUT_DIR]   (default: $OUT)
# Environment: REPEAT (default 10), BUDGET_S (default 420: no run starts after that many seconds),
# FETCH (default "1 8 16 24 32": the --persistent values).
set -u
out=${1:-${OUT:-}}
[ -n "$out" ] || { echo "usage: scripts/device-persistent.sh OUT_DIR" >&2; exit 2; }
mkdir -p "$out"
source scripts/device-env.sh > "$out/env.log" 2>&1
bin=.device/bin
repeat=${REPEAT:-10}
budget=${BUDGET_S:-420}
fetch=${FETCH:-1 8 16 24 32}
start=$(date +%s)
"$bin/test_gpu_shapes" --gtest_filter='*Persistent*:*ShadowOrders*' > "$out/test-persistent.log" 2>&1 ||
  echo "test_gpu_shapes failed (see test-persistent.log)" >> "$out/errors.txt"
# The full-size frames of Sibenik and the Dragon, per pixel and persistent: hits files byte for byte.
for scene in sibenik/sibenik_geom_75284.ply stanford/dragon_vrip_res2.ply; do
  name=$(basename "$scene" | cut -d_ -f1)
  for n in 0 1 16 32; do
    "$bin/raypack-cli" render ".device/scenes/$scene" --device gpu --kernel single --persistent "$n" --width 1920 \
      --height 1080 --hits "$out/$name-p$n.hits" > /dev/null 2>> "$out/render.log" ||
      echo "render $name --persistent $n failed" >> "$out/errors.txt"
  done
  for n in 1 16 32; do
    if cmp -s "$out/$name-p0.hits" "$out/$name-p$n.hits"; then verdict=identical; else verdict=DIFFERENT; fi
    echo "$name 1920x1080 hits, --persistent $n against per pixel: $verdict" >> "$out/test-persistent.log"
  done
  rm -f "$out/$name"-p*.hits
done
run() {
  local name=$1 cli=$2 suite=$3
  shift 3
  if [ $(( $(date +%s) - start )) -gt "$budget" ]; then echo "$name: skipped (budget)" >> "$out/errors.txt"; return; fi
  "$cli" bench --suite "$suite" --scene-dir .device/scenes --device gpu --kernel single --width 1920 --height 1080 \
    --repeat "$repeat" --no-embree "$@" --out "$out/$name.json" > "$out/$name.log" 2>&1 ||
    echo "$name: bench failed (see $name.log)" >> "$out/errors.txt"
}
for round in 1 2; do
  run "r$round-old" "$bin/raypack-cli-old" report --no-driver-rt
  if [ "$round" = 1 ]; then
    run "r$round-default" "$bin/raypack-cli" report --pipeline-statistics
  else
    run "r$round-default" "$bin/raypack-cli" report --no-driver-rt
  fi
  for n in $fetch; do run "r$round-p$n" "$bin/raypack-cli" report --no-driver-rt --persistent "$n" --pipeline-statistics; done
done
run "scaling-default" "$bin/raypack-cli" scaling --no-driver-rt
for n in 1 16 32; do run "scaling-p$n" "$bin/raypack-cli" scaling --no-driver-rt --persistent "$n"; done
python3 - "$out" > "$out/persistent.md" <<'PY'
import glob, json, os, sys
out = sys.argv[1]
runs = {}
for path in sorted(glob.glob(os.path.join(out, "*.json"))):
    with open(path) as f:
        runs[os.path.basename(path)[:-len(".json")]] = json.load(f)
def rec(run, tracer, scene, kind):
    for r in run["records"]:
        if r.get("tracer") == tracer and r.get("scene") == scene and r.get("ray_kind") == kind:
            return r
    return None
def table(prefix, title):
    base = runs.get(prefix + "default")
    if not base:
        print(f"{title}: no default run\n"); return
    print(f"## {title}\n\ndate {base['date']}, {base['machine'].get('gpu')}, {base['machine'].get('gpu_driver')}, "
          f"command: {base['command']}\n")
    variants = [k[len(prefix):] for k in runs if k.startswith(prefix) and k != prefix + "default"]
    variants.sort(key=lambda v: (v != "old", int(v[1:]) if v[1:].isdigit() else 0))
    print("| scene | rays | default Mrays/s | " + " | ".join(f"{v} / default" for v in variants) +
          " | default / driver RT | N_TR |")
    print("|---|---|---:|" + "---:|" * len(variants) + "---:|---:|")
    scenes = []
    for r in base["records"]:
        if r.get("scene") not in scenes: scenes.append(r.get("scene"))
    for scene in scenes:
        for kind in ("primary", "shadow"):
            d = rec(base, "gpu-single", scene, kind)
            if not d or not d.get("perf_mrays_s"): continue
            m = d["perf_mrays_s"]
            cells = []
            for v in variants:
                r = rec(runs[prefix + v], "gpu-single", scene, kind)
                cells.append(f"{r['perf_mrays_s'] / m:.3f}" if r and r.get("perf_mrays_s") else "-")
            rt = rec(base, "driver-rt", scene, kind)
            rtc = f"{m / rt['perf_mrays_s']:.3f}" if rt and rt.get("perf_mrays_s") else "-"
            print(f"| {scene} | {kind} | {m:.0f} | " + " | ".join(cells) + f" | {rtc} | "
                  f"{d.get('n_tr_nodes_per_ray', 0) or 0:.1f} |")
    print()
table("r1-", "Report suite, round 1")
table("r2-", "Report suite, round 2")
table("scaling-", "Scaling suite")
for name in ("r1-default", "r1-p16"):
    run = runs.get(name)
    if not run: continue
    for r in run["records"]:
        if r.get("tracer") == "gpu-single" and r.get("pipeline_statistics"):
            print(f"pipeline statistics {name} ({r['scene']}): " + json.dumps(r["pipeline_statistics"]))
            break
PY
echo "done in $(( $(date +%s) - start )) s" >> "$out/persistent.md"
# A device call returns at most 8 files: everything but the summary and the test log goes into one
# archive (the files are removed only when the archive was written).
(cd "$out" && files=$(ls | grep -v -e '^persistent.md$' -e '^results.tgz$' -e '^test-persistent.log$' -e '^errors.txt$') &&
  tar czf results.tgz $files && rm -f $files) || echo "could not pack $out" >&2
