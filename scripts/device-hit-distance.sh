#!/usr/bin/env bash
# Issue 14 on the lent H200 machine: the accurate hit distance in doubles against float pairs
# (HitDistanceMath, docs/trade.md). ROUNDS rounds of
# `bench --suite report --device gpu --kernel single --hit-distance auto,float-pair` (gpu-single and
# gpu-cwbvh, each arithmetic a cell of the same process), the report's tree and then sah-split
# leaves of 2; and, where carried, .device/bin/raypack-cli-old (the build before, float pairs
# only) once per round; then the hits of each report scene at 1920x1080 (the single-ray kernel,
# its start view) with --hit-distance fp64 and float-pair, compared record by record
# (OUT/hits.txt: differing records and largest t difference in ulps). Past BUDGET_S seconds what
# is left is skipped (OUT/errors.txt). OUT/hit-distance.md: per round, scene and tracer, primary Mrays/s of each
# arithmetic, their ratio and what auto resolved to.
#   scripts/device-hit-distance.sh [OUT_DIR]   (default: $OUT)
# Environment: ROUNDS (default 2), REPEAT (default 10), BUDGET_S (default 480), ONLY (report scenes,
# comma-separated, e.g. Sibenik,Sponza; default all five), TREES (default "exact split"), OLD (0: skip
# raypack-cli-old even where carried).
set -u
source scripts/device-start.sh "$0" "${1:-}"
rounds=${ROUNDS:-2}
repeat=${REPEAT:-10}
budget=${BUDGET_S:-480}
only=${ONLY:-Sibenik,Sponza,Conference,Armadillo,Dragon}
trees=${TREES:-exact split}
start=$(date +%s)
cli=.device/bin/raypack-cli
S=.device/scenes
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv > "$out/gpu.txt" 2>&1
for round in $(seq 1 "$rounds"); do
  for tree in $trees; do
    if [ $(( $(date +%s) - start )) -gt "$budget" ]; then echo "round $round $tree: skipped (budget)" >> "$out/errors.txt"; continue; fi
    extra=""; [ "$tree" = split ] && extra="--builder sah-split --leaf-size 2"
    "$cli" bench --suite report --only "$only" --scene-dir "$S" --device gpu --kernel single --hit-distance auto,float-pair \
      --width 1920 --height 1080 --repeat "$repeat" --no-embree --no-driver-rt --pipeline-statistics $extra \
      --out "$out/new-$tree-$round.json" > "$out/new-$tree-$round.log" 2>&1 || echo "new $tree round $round: bench failed" >> "$out/errors.txt"
  done
  if [ "${OLD:-1}" != 0 ] && [ -x .device/bin/raypack-cli-old ] && [ $(( $(date +%s) - start )) -le "$budget" ]; then
    .device/bin/raypack-cli-old bench --suite report --only "$only" --scene-dir "$S" --device gpu --kernel single \
      --width 1920 --height 1080 --repeat "$repeat" --no-embree --no-driver-rt \
      --out "$out/old-exact-$round.json" > "$out/old-exact-$round.log" 2>&1 || echo "old round $round: bench failed" >> "$out/errors.txt"
  fi
done
for scene in sibenik/sibenik_geom_75284.ply dabrovic_sponza/sponza.obj conference/conference_geom.ply \
             stanford/armadillo_decimated_99976.obj stanford/dragon_vrip_res2.ply; do
  name=$(basename "$scene" | sed 's/\..*//')
  case "$name" in sibenik*) label=Sibenik ;; sponza) label=Sponza ;; conference*) label=Conference ;;
    armadillo*) label=Armadillo ;; *) label=Dragon ;; esac
  [[ ",$only," == *",$label,"* ]] || continue
  if [ $(( $(date +%s) - start )) -gt "$budget" ]; then echo "$name hits: skipped (budget)" >> "$out/errors.txt"; continue; fi
  for math in fp64 float-pair; do
    "$cli" render "$S/$scene" --device gpu --kernel single --width 1920 --height 1080 --hit-distance "$math" \
      --hits "$out/hits-$name-$math.bin" > "$out/render-$name-$math.txt" 2>&1 || echo "$name $math: render failed" >> "$out/hits.txt"
  done
  python3 - "$out/hits-$name-fp64.bin" "$out/hits-$name-float-pair.bin" "$name" >> "$out/hits.txt" <<'PY'
import struct, sys
a, b = open(sys.argv[1], "rb").read(), open(sys.argv[2], "rb").read()
n = (len(a) - 32) // 40
differ = prim = ulps = hits = 0
for i in range(n):
    ra, rb = a[32 + 40 * i:72 + 40 * i], b[32 + 40 * i:72 + 40 * i]
    ta, pa = struct.unpack_from("<fI", ra, 24)
    tb, pb = struct.unpack_from("<fI", rb, 24)
    if pa != 0xFFFFFFFF: hits += 1
    if ra != rb: differ += 1
    if pa != pb: prim += 1
    elif pa != 0xFFFFFFFF:
        ua, ub = struct.unpack("<I", struct.pack("<f", ta))[0], struct.unpack("<I", struct.pack("<f", tb))[0]
        ulps = max(ulps, abs(ua - ub))
print(f"{sys.argv[3]}: {n} rays, {hits} hits; records differing {differ}, triangles differing {prim}, largest t difference {ulps} ulp")
PY
  rm -f "$out"/hits-"$name"-*.bin
done
python3 - "$out" "$rounds" > "$out/hit-distance.md" <<'PY'
import json, os, sys
out, rounds = sys.argv[1], int(sys.argv[2])
def load(name):
    p = os.path.join(out, name)
    return json.load(open(p))["records"] if os.path.exists(p) else []
print("| round | tree | scene | tracer | rays | auto -> | auto Mrays/s | float-pair Mrays/s | auto / float-pair | old (float pairs) Mrays/s | auto / old | registers auto / float-pair |")
print("|---|---|---|---|---|---|---:|---:|---:|---:|---:|---|")
for r in range(1, rounds + 1):
    old = load(f"old-exact-{r}.json")
    for tree in ("exact", "split"):
        recs = load(f"new-{tree}-{r}.json")
        for scene in ("Sibenik", "Sponza", "Conference", "Armadillo", "Dragon"):
            for tracer in ("gpu-single", "gpu-cwbvh"):
                for kind in ("primary", "shadow"):
                    def pick(rs, req):
                        for x in rs:
                            if x["scene"] == scene and x["tracer"] == tracer and x["ray_kind"] == kind and x.get("hit_distance_requested") == req:
                                return x
                    a, f = pick(recs, "auto"), pick(recs, "float-pair")
                    if not a or not f: continue
                    o = None
                    if tree == "exact":
                        for x in old:
                            if x["scene"] == scene and x["tracer"] == tracer and x["ray_kind"] == kind: o = x
                    reg = lambda x: (x.get("pipeline_statistics") or {}).get("Register Count", "-")
                    print(f"| {r} | {tree} | {scene} | {tracer} | {kind} | {a.get('hit_distance')} ({a.get('float64_rate') or 0:.3f}) | "
                          f"{a['perf_mrays_s']:.0f} | {f['perf_mrays_s']:.0f} | {a['perf_mrays_s'] / f['perf_mrays_s']:.3f} | "
                          + (f"{o['perf_mrays_s']:.0f} | {a['perf_mrays_s'] / o['perf_mrays_s']:.3f} |" if o else "- | - |")
                          + f" {reg(a)} / {reg(f)} |")
PY
echo "done in $(( $(date +%s) - start )) s" >> "$out/hit-distance.md"
(cd "$out" && files=$(ls | grep -v -e '^hit-distance.md$' -e '^results.tgz$' -e '^errors.txt$' -e '^hits.txt$' -e '^gpu.txt$') &&
  tar czf results.tgz $files && rm -f $files) || echo "could not pack $out" >&2
