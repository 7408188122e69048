#!/usr/bin/env bash
# Issue 14 on the lent H200 machine: the single-ray kernel under several tree configurations
# (builder x leaf size x shadow order), the report suite at 1920x1080, one bench run each, the
# driver's ray tracing in the first run only (its own BLAS, whatever raypack's tree), so every
# configuration is divided by the same driver figure. Then OUT/configs.md: Mrays/s per scene and
# ray kind, and each / the driver's.
# From the repository root on the device, with .device/ unpacked (scripts/device-pack.sh) and .gl/:
#   scripts/device-configs.sh [OUT_DIR]   (default: $OUT)
# Environment: CONFIGS (default below: "name:bench flags" entries separated by ";"), REPEAT (default
# 10), BUDGET_S (default 420: no run starts after that many seconds). A device call brings back at
# most 8 files: the runs' JSON and logs end up in OUT/runs.tar.xz.
set -u
source scripts/device-start.sh "$0" "${1:-}"
configs=${CONFIGS:-"exact-1:--builder sah-exact --leaf-size 1 --single-groups 8x16,8x32,16x8,8x4;\
exact-2:--builder sah-exact --leaf-size 2;exact-4:--builder sah-exact --leaf-size 4;\
split-1:--builder sah-split --leaf-size 1;split-2:--builder sah-split --leaf-size 2;\
split-4:--builder sah-split --leaf-size 4;split-2-tree:--builder sah-split --leaf-size 2 --shadow-order tree;\
split-4-tree:--builder sah-split --leaf-size 4 --shadow-order tree"}
budget=${BUDGET_S:-420}
start=$(date +%s)
first=1
IFS=';' read -r -a entries <<< "$configs"
for entry in "${entries[@]}"; do
  name=${entry%%:*}
  read -r -a flags <<< "${entry#*:}"
  if [ $(( $(date +%s) - start )) -gt "$budget" ]; then echo "$name: skipped (budget)" >> "$out/errors.txt"; continue; fi
  driver=(--no-driver-rt)
  [ "$first" = 1 ] && driver=()
  first=0
  .device/bin/raypack-cli bench --suite report --scene-dir .device/scenes --device gpu --kernel single \
    --width 1920 --height 1080 --repeat "${REPEAT:-10}" --no-embree "${driver[@]}" "${flags[@]}" \
    --out "$out/configs-$name.json" > "$out/configs-$name.log" 2>&1 ||
    echo "$name: bench failed (see configs-$name.log)" >> "$out/errors.txt"
done
python3 - "$out" > "$out/configs.md" <<'PY'
import glob, json, os, sys
out = sys.argv[1]
runs = {}
for path in sorted(glob.glob(os.path.join(out, "configs-*.json")), key=os.path.getmtime):
    with open(path) as f:
        runs[os.path.basename(path)[len("configs-"):-len(".json")]] = json.load(f)
if not runs:
    print("no runs"); sys.exit(0)
any_run = next(iter(runs.values()))
print(f"date {any_run['date']}, {any_run['machine'].get('gpu')}; each run: {any_run['command']} (flags per configuration)\n")
driver = {}
for run in runs.values():
    for r in run["records"]:
        if r.get("tracer") == "driver-rt":
            driver[(r["scene"], r["ray_kind"])] = r.get("perf_mrays_s")
print("| configuration | scene | rays | group | Mrays/s | / driver RT | N_TR | N_IT | SAH cost |")
print("|---|---|---|---|---:|---:|---:|---:|---:|")
for name, run in runs.items():
    for r in run["records"]:
        if r.get("tracer") != "gpu-single":
            continue
        mr = r.get("perf_mrays_s") or 0.0
        d = driver.get((r["scene"], r["ray_kind"]))
        print(f"| {name} | {r['scene']} | {r['ray_kind']} | {r.get('packet')} | {mr:,.0f} | "
              f"{mr / d if d else float('nan'):.3f} | {r.get('n_tr_nodes_per_ray') or 0:.1f} | "
              f"{r.get('n_it_tests_per_ray') or 0:.2f} | {r.get('sah_cost') or 0:.2f} |")
PY
(cd "$out" && tar cJf runs.tar.xz configs-*.json configs-*.log env.log && rm -f configs-*.json configs-*.log env.log)
