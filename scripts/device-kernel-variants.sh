#!/usr/bin/env bash
# Issue 14 on the lent H200 machine: variants of a single-ray kernel (TRACER: gpu-single, the binary
# tree, or gpu-cwbvh, the compressed 8-wide tree's kernel and collapse), each a raypack-cli of its
# own (scripts/variant-cli.sh NAME SHADER_MACRO HOST_MACRO, carried as .device/bin/raypack-cli-NAME
# by scripts/device-pack.sh), against the build itself (.device/bin/raypack-cli): the report suite
# per binary, `bench --kernel single` (gpu-single beside gpu-cwbvh in each process) at 1920x1080,
# ROUNDS interleaved rounds. OUT/variants.md: per scene and ray kind, each binary's Mrays/s of
# TRACER, its ratio to the build's of the same round (for gpu-cwbvh also to gpu-single of the same
# process), N_TR, N_IT and the pipeline's register count. Before the benches (HITS=1), the build and
# every variant render each report scene's hits at 1920x1080 (its start view, TRACER's tree) and the
# hits files are compared (OUT/hits.txt).
#   scripts/device-kernel-variants.sh [OUT_DIR]   (default: $OUT)
# Environment: VARIANTS (names after raypack-cli-, default: every one carried), ROUNDS (default 2),
# REPEAT (default 10), BUDGET_S (default 420), TRACER (default gpu-single), HITS (default 1),
# TREE_ARGS (further bench and render flags for the tree, e.g. "--builder sah-split --leaf-size 2",
# the Sibenik goal's tree; default none: the report's) and INTERSECT (robust or fast, default robust).
set -u
source scripts/device-start.sh "$0" "${1:-}"
variants=${VARIANTS:-$(cd .device/bin && ls raypack-cli-* 2>/dev/null | sed 's/^raypack-cli-//')}
rounds=${ROUNDS:-2}
repeat=${REPEAT:-10}
budget=${BUDGET_S:-420}
tracer=${TRACER:-gpu-single}
tree_args=${TREE_ARGS:-}
intersect=${INTERSECT:-robust}
width=2; [ "$tracer" = gpu-cwbvh ] && width=8
start=$(date +%s)
S=.device/scenes
[ "${HITS:-1}" = 1 ] && for scene in sibenik/sibenik_geom_75284.ply dabrovic_sponza/sponza.obj conference/conference_geom.ply \
             stanford/armadillo_decimated_99976.obj stanford/dragon_vrip_res2.ply; do
  name=$(basename "$scene" | sed 's/\..*//')
  for v in build $variants; do
    cli=.device/bin/raypack-cli; [ "$v" = build ] || cli=.device/bin/raypack-cli-$v
    "$cli" render "$S/$scene" --device gpu --kernel single --bvh-width "$width" --width 1920 --height 1080 \
      --intersect "$intersect" $tree_args --hits "$out/hits-$name-$v.bin" > /dev/null 2>> "$out/hits.txt" ||
      echo "$v $name: render failed" >> "$out/hits.txt"
    if [ "$v" != build ]; then
      if cmp -s "$out/hits-$name-build.bin" "$out/hits-$name-$v.bin"; then echo "$name $v: hits identical" >> "$out/hits.txt"
      else echo "$name $v: hits DIFFER" >> "$out/hits.txt"; fi
    fi
  done
  rm -f "$out"/hits-"$name"-*.bin
done
for round in $(seq 1 "$rounds"); do
  for v in build $variants; do
    cli=.device/bin/raypack-cli; [ "$v" = build ] || cli=.device/bin/raypack-cli-$v
    if [ $(( $(date +%s) - start )) -gt "$budget" ]; then echo "$v round $round: skipped (budget)" >> "$out/errors.txt"; continue; fi
    "$cli" bench --suite report --scene-dir .device/scenes --device gpu --kernel single --width 1920 --height 1080 \
      --intersect "$intersect" $tree_args --repeat "$repeat" --no-embree --no-driver-rt --pipeline-statistics --out "$out/$v-$round.json" > "$out/$v-$round.log" 2>&1 ||
      echo "$v round $round: bench failed" >> "$out/errors.txt"
  done
done
python3 - "$out" "$rounds" "$tracer" build $variants > "$out/variants.md" <<'PY'
import json, os, sys
out, rounds, tracer, names = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4:]
def load(name, r):
    p = os.path.join(out, f"{name}-{r}.json")
    return json.load(open(p)) if os.path.exists(p) else None
def mr(run, scene, kind, of=tracer):
    for x in run["records"]:
        if x["tracer"] == of and x["scene"] == scene and x["ray_kind"] == kind:
            return x
    return None
# gpu-cwbvh's figures also against the binary tree's kernel of the same process.
beside = tracer != "gpu-single"
print(f"| round | binary | scene | rays | {tracer} Mrays/s |" + (" / gpu-single, same process |" if beside else "")
      + " / build, same round | N_TR | N_IT | registers |")
print("|---|---|---|---|---:|" + ("---:|" if beside else "") + "---:|---:|---:|---:|")
for r in range(1, rounds + 1):
    base = load("build", r)
    for name in names:
        run = load(name, r)
        if not run: continue
        for scene in ("Sibenik", "Sponza", "Conference", "Armadillo", "Dragon"):
            for kind in ("primary", "shadow"):
                x, s = mr(run, scene, kind), mr(run, scene, kind, "gpu-single")
                if not x or not s: continue
                b = mr(base, scene, kind) if base else None
                regs = (x.get("pipeline_statistics") or {}).get("Register Count", "-")
                rel = f"{x['perf_mrays_s'] / b['perf_mrays_s']:.3f}" if b else "-"
                single = f" {x['perf_mrays_s'] / s['perf_mrays_s']:.3f} |" if beside else ""
                print(f"| {r} | {name} | {scene} | {kind} | {x['perf_mrays_s']:.0f} |{single} {rel} | "
                      f"{x.get('n_tr_nodes_per_ray') or 0:.1f} | {x.get('n_it_tests_per_ray') or 0:.2f} | {regs} |")
PY
echo "done in $(( $(date +%s) - start )) s" >> "$out/variants.md"
(cd "$out" && files=$(ls | grep -v -e '^variants.md$' -e '^results.tgz$' -e '^errors.txt$' -e '^hits.txt$') &&
  tar czf results.tgz $files && rm -f $files) || echo "could not pack $out" >&2
