#!/usr/bin/env bash
# Issue 14 on the lent H200 machine: variants of the compressed 8-wide tree's kernel and collapse,
# each a raypack-cli of its own (scripts/variant-cli.sh, carried as .device/bin/raypack-cli-NAME by
# scripts/device-pack.sh), against the build itself (.device/bin/raypack-cli): the report suite per
# binary, `bench --kernel single` (gpu-single beside gpu-cwbvh in each process), 1920x1080,
# ROUNDS interleaved rounds. OUT/variants.md: per scene and ray kind, each binary's 8-wide Mrays/s
# and its ratio to the binary tree of the same process, and to the build's 8-wide figure of the
# same round.
#   scripts/device-cwbvh-variants.sh [OUT_DIR]   (default: $OUT)
# Environment: VARIANTS (names after raypack-cli-, default: every one carried), ROUNDS (default 2),
# REPEAT (default 10), BUDGET_S (default 420).
set -u
out=${1:-${OUT:-}}
[ -n "$out" ] || { echo "usage: scripts/device-cwbvh-variants.sh OUT_DIR" >&2; exit 2; }
mkdir -p "$out"
[ -d .device/bin ] || tar xJf .device/round.tar.xz
source scripts/device-env.sh > "$out/env.log" 2>&1
variants=${VARIANTS:-$(cd .device/bin && ls raypack-cli-* 2>/dev/null | sed 's/^raypack-cli-//')}
rounds=${ROUNDS:-2}
repeat=${REPEAT:-10}
budget=${BUDGET_S:-420}
start=$(date +%s)
for round in $(seq 1 "$rounds"); do
  for v in build $variants; do
    cli=.device/bin/raypack-cli; [ "$v" = build ] || cli=.device/bin/raypack-cli-$v
    if [ $(( $(date +%s) - start )) -gt "$budget" ]; then echo "$v round $round: skipped (budget)" >> "$out/errors.txt"; continue; fi
    "$cli" bench --suite report --scene-dir .device/scenes --device gpu --kernel single --width 1920 --height 1080 \
      --repeat "$repeat" --no-embree --no-driver-rt --pipeline-statistics --out "$out/$v-$round.json" > "$out/$v-$round.log" 2>&1 ||
      echo "$v round $round: bench failed" >> "$out/errors.txt"
  done
done
python3 - "$out" "$rounds" build $variants > "$out/variants.md" <<'PY'
import json, os, sys
out, rounds, names = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
def load(name, r):
    p = os.path.join(out, f"{name}-{r}.json")
    return json.load(open(p)) if os.path.exists(p) else None
def mr(run, tracer, scene, kind):
    for x in run["records"]:
        if x["tracer"] == tracer and x["scene"] == scene and x["ray_kind"] == kind:
            return x
    return None
print("| round | variant | scene | rays | 8-wide Mrays/s | / binary tree, same process | / build's 8-wide, same round | N_TR | N_IT | registers |")
print("|---|---|---|---|---:|---:|---:|---:|---:|---:|")
for r in range(1, rounds + 1):
    base = load("build", r)
    for name in names:
        run = load(name, r)
        if not run: continue
        for scene in ("Sibenik", "Sponza", "Conference", "Armadillo", "Dragon"):
            for kind in ("primary", "shadow"):
                w, s = mr(run, "gpu-cwbvh", scene, kind), mr(run, "gpu-single", scene, kind)
                if not w or not s: continue
                b = mr(base, "gpu-cwbvh", scene, kind) if base else None
                regs = (w.get("pipeline_statistics") or {}).get("Register Count", "-")
                rel = f"{w['perf_mrays_s'] / b['perf_mrays_s']:.3f}" if b else "-"
                print(f"| {r} | {name} | {scene} | {kind} | {w['perf_mrays_s']:.0f} | {w['perf_mrays_s'] / s['perf_mrays_s']:.3f} | {rel} | "
                      f"{w.get('n_tr_nodes_per_ray') or 0:.1f} | {w.get('n_it_tests_per_ray') or 0:.2f} | {regs} |")
PY
echo "done in $(( $(date +%s) - start )) s" >> "$out/variants.md"
(cd "$out" && files=$(ls | grep -v -e '^variants.md$' -e '^results.tgz$' -e '^errors.txt$') &&
  tar czf results.tgz $files && rm -f $files) || echo "could not pack $out" >&2
