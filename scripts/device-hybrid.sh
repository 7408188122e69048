#!/usr/bin/env bash
# Issue 14 on the lent H200 machine: the hybrid packet / single-ray kernel (docs/gpu.md) against
# the single-ray and packet kernels, 1920x1080, primary and shadow rays, on the report suite and
# the scaling suite's three largest scenes (terrain 1M and 10M, the dragon subdivided to 13M),
# sweeping the split rule K over a quarter, an eighth and a sixteenth of the packet and the visit
# rule off / at 2, for one-subgroup (8x4 = 32 rays, one NVIDIA subgroup) and two-subgroup (8x8)
# packets. One `bench` per scene, so that each writes its JSON as soon as it is done and a failure
# or a timeout costs one scene; each failure is logged in OUT/errors.txt and the rest go on. After
# each scene OUT/table.md is rewritten: per scene and ray kind, Mrays/s of the single-ray kernel,
# packet / single (each shape) and hybrid / single (each shape, K and ratio), with N_TR.
#
# From the repository root on the device, carrying .gl/ (the Vulkan loader, scripts/device-env.sh)
# and .device/ (scripts/device-pack.sh BUILD_DIR: .device/round.tar.xz, unpacked here if needed,
# holding bin/raypack-cli, lib/ and scenes/ laid out as ../shared/scenes):
#   scripts/device-hybrid.sh [OUT_DIR]        (default: $OUT)
# Environment: SCENES (scene folder), BUDGET_S (default 450: the runs together stop within that many
# seconds; a run gets at most what is left, none starts with less than 30 s left), REPEAT (default
# 5), PACKETS (default 8x4,8x8), HYBRID_K (default 1/4,1/8,1/16), HYBRID_RATIOS (default 0,2), BUILDER (default: bench's; sah-binned to save time on the scans);
# for a try on another machine: CLI, DEVICE_ENV (/dev/null: none), WIDTH, HEIGHT, ONLY (scene names,
# comma-separated), LIMIT_S (each run's timeout instead of the table's).
# Measured build and load times: docs/benchmarks.md (13M dragon: 4.6 s exact SAH on 16 threads).
set -u
out=${1:-${OUT:-}}
if [ -z "$out" ]; then
  echo "usage: scripts/device-hybrid.sh OUT_DIR (or set OUT)" >&2
  exit 2
fi
mkdir -p "$out"
start=$(date +%s)
# The bundle of scripts/device-pack.sh, unpacked here when that has not been done yet.
if [ ! -x .device/bin/raypack-cli ] && [ -f .device/round.tar.xz ]; then
  tar xJf .device/round.tar.xz || echo "could not unpack .device/round.tar.xz" >> "$out/errors.txt"
fi
# shellcheck source=/dev/null
source "${DEVICE_ENV:-scripts/device-env.sh}" > "$out/env.log" 2>&1 || echo "device-env.sh failed (see env.log)" >> "$out/errors.txt"
cli=${CLI:-.device/bin/raypack-cli}
scenes=${SCENES:-.device/scenes}
budget=${BUDGET_S:-450}
repeat=${REPEAT:-5}
packets=${PACKETS:-8x4,8x8}
ks=${HYBRID_K:-1/4,1/8,1/16}
ratios=${HYBRID_RATIOS:-0,2}
width=${WIDTH:-1920}
height=${HEIGHT:-1080}
only=${ONLY:-}
builder=()
[ -n "${BUILDER:-}" ] && builder=(--builder "$BUILDER")

{
  echo "date: $(date -u +%FT%TZ)"
  nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv 2>&1
  echo "cpu: $(nproc) threads"
} > "$out/machine.txt"

# suite|scene name|timeout seconds; the scans where packets lose most (issue 14) early, so that a
# slow machine still measures them.
runs=(
  "report|Sibenik|90" "scaling|Dragon subdiv 3|170" "scaling|terrain 10M|150" "report|Conference|90"
  "report|Armadillo|90" "report|Dragon|90" "report|Sponza|90" "scaling|terrain 1M|100"
)

table() {
  python3 - "$out" > "$out/table.md.new" 2>> "$out/errors.txt" <<'EOF' && mv "$out/table.md.new" "$out/table.md"
import glob, json, os, sys
out = sys.argv[1]
rows = []
for path in sorted(glob.glob(os.path.join(out, "bench-*.json"))):
    try:
        records = json.load(open(path))["records"]
    except Exception as e:
        print(f"<!-- {path}: {e} -->")
        continue
    scenes = []
    for r in records:
        if r["scene"] not in scenes:
            scenes.append(r["scene"])
    for scene in scenes:
        for kind in ("primary", "shadow"):
            rs = [r for r in records if r["scene"] == scene and r["ray_kind"] == kind]
            single = [r for r in rs if r["tracer"] == "gpu-single"]
            if not single:
                continue
            s = single[0]
            base = s["perf_mrays_s"]
            tri = s.get("triangles", 0)
            rows.append(f"| {scene} | {tri:,} | {kind} | single | | {base:.4g} | 1.00 | {s['n_tr_nodes_per_ray']:.1f} |")
            for r in rs:
                if r["tracer"] not in ("gpu-packet", "gpu-hybrid"):
                    continue
                if r["tracer"] == "gpu-packet":
                    cfg = "packet"
                else:
                    cfg = f"hybrid K={r['hybrid_min_rays']} ({r['hybrid_min_rays_spec']}) ratio {r['hybrid_visit_ratio']:g}"
                rows.append(f"| {scene} | {tri:,} | {kind} | {cfg} | {r['packet']} | {r['perf_mrays_s']:.4g} | "
                            f"{r['perf_mrays_s'] / base:.2f} | {r['n_tr_nodes_per_ray']:.1f} |")
print("| scene | triangles | rays | kernel | packet | Mrays/s | / single | N_TR |")
print("|---|---:|---|---|---|---:|---:|---:|")
print("\n".join(rows))
EOF
}

for run in "${runs[@]}"; do
  IFS='|' read -r suite name limit <<< "$run"
  limit=${LIMIT_S:-$limit}
  now=$(date +%s)
  left=$((budget - (now - start)))
  if [ "$left" -lt 30 ]; then
    echo "skipped $name: $((now - start)) s elapsed, budget $budget s" >> "$out/errors.txt"
    continue
  fi
  [ "$limit" -gt "$left" ] && limit=$left
  if [ -n "$only" ] && [[ ",$only," != *",$name,"* ]]; then continue; fi
  file=$(echo "$name" | tr ' A-Z' '-a-z')
  echo "== $name ($suite), $((now - start)) s elapsed" | tee -a "$out/progress.txt"
  timeout "$limit" "$cli" bench --suite "$suite" --only "$name" --scene-dir "$scenes" --device gpu --kernel all \
    --no-driver-rt --width "$width" --height "$height" --repeat "$repeat" --packets "$packets" \
    --hybrid-min-rays "$ks" --hybrid-visit-ratios "$ratios" "${builder[@]}" \
    --out "$out/bench-$file.json" > "$out/bench-$file.log" 2>&1
  rc=$?
  [ $rc -ne 0 ] && echo "bench $name failed: exit $rc (124: timeout after $limit s), see bench-$file.log" >> "$out/errors.txt"
  table
done
echo "done in $(($(date +%s) - start)) s" | tee -a "$out/progress.txt"
cat "$out/table.md" 2>/dev/null
[ -f "$out/errors.txt" ] && cat "$out/errors.txt"
# A device call returns at most 8 files: everything but the summary goes into one archive
# (the files are removed only when the archive was written).
(cd "$out" && files=$(ls | grep -v -e '^table.md$' -e '^results.tgz$') &&
  tar czf results.tgz $files && rm -f $files) || echo "could not pack $out" >&2
exit 0
