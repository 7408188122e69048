#!/usr/bin/env bash
# Issue 14 on the lent H200 machine: builds of the single-ray kernel (each its own raypack-cli,
# named raypack-cli-VARIANT in .device/bin, scripts/device-pack.sh BUILD raypack-cli-VARIANT...)
# against each other, each at several workgroup shapes (--single-groups), with the compiler's
# register counts (--pipeline-statistics). The SM holds at most 32 workgroups, so 32-ray workgroups
# cap it at 32 warps whatever the registers; larger workgroups help only if the registers allow
# more warps too. Rounds interleave the variants, so that each comparison is measured side by side.
# From the repository root on the device, with .device/ unpacked and .gl/:
#   VARIANTS="base slim" scripts/device-occupancy.sh [OUT_DIR]   (default: $OUT)
# Environment: VARIANTS (required), SINGLE_GROUPS (default 8x4,8x8,8x16), ROUNDS (default 2), REPEAT
# (default 10), SUITE (default report), ONLY (--only, default all), BUDGET_S (default 420: no run
# starts after that many seconds). The driver's ray tracing runs in the first variant's first round.
# A device call brings back at most 8 files: the runs' JSON and logs end up in OUT/runs.tar.xz,
# beside OUT/occupancy.md and OUT/errors.txt.
set -u
out=${1:-${OUT:-}}
[ -n "$out" ] && [ -n "${VARIANTS:-}" ] || { echo "usage: VARIANTS=\"a b\" scripts/device-occupancy.sh OUT_DIR" >&2; exit 2; }
mkdir -p "$out"
source scripts/device-env.sh > "$out/env.log" 2>&1
groups=${SINGLE_GROUPS:-8x4,8x8,8x16}
rounds=${ROUNDS:-2}
budget=${BUDGET_S:-420}
start=$(date +%s)
first=${VARIANTS%% *}
only=()
[ -n "${ONLY:-}" ] && only=(--only "$ONLY")
for round in $(seq 1 "$rounds"); do
  for v in $VARIANTS; do
    if [ $(( $(date +%s) - start )) -gt "$budget" ]; then echo "$v round $round: skipped (budget)" >> "$out/errors.txt"; continue; fi
    driver=(--no-driver-rt)
    [ "$v" = "$first" ] && [ "$round" = 1 ] && driver=()
    ".device/bin/raypack-cli-$v" bench --suite "${SUITE:-report}" "${only[@]}" --scene-dir .device/scenes --device gpu \
      --kernel single --single-groups "$groups" --width 1920 --height 1080 --repeat "${REPEAT:-10}" --no-embree \
      --pipeline-statistics "${driver[@]}" --out "$out/occupancy-$v-$round.json" > "$out/occupancy-$v-$round.log" 2>&1 ||
      echo "$v round $round: bench failed (see occupancy-$v-$round.log)" >> "$out/errors.txt"
  done
done
python3 - "$out" "$first" > "$out/occupancy.md" <<'PY'
import glob, json, os, re, sys
out, first = sys.argv[1], sys.argv[2]
runs = {}
for path in sorted(glob.glob(os.path.join(out, "occupancy-*.json"))):
    m = re.match(r"occupancy-(.+)-(\d+)\.json$", os.path.basename(path))
    with open(path) as f:
        runs[(m.group(1), int(m.group(2)))] = json.load(f)
if not runs:
    print("no runs"); sys.exit(0)
any_run = next(iter(runs.values()))
print(f"date {any_run['date']}, {any_run['machine'].get('gpu')}, command of one run: {any_run['command']}\n")
driver = {}
for run in runs.values():
    for r in run["records"]:
        if r.get("tracer") == "driver-rt":
            driver[(r["scene"], r["ray_kind"])] = r.get("perf_mrays_s")
base = {}
for (v, rnd), run in runs.items():
    if v == first:
        for r in run["records"]:
            if r.get("tracer") == "gpu-single" and r.get("packet") == "8x4":
                base[(rnd, r["scene"], r["ray_kind"])] = r.get("perf_mrays_s")
print(f"Mrays/s, and / {first} 8x4 of the same round; registers from --pipeline-statistics.\n")
print("| variant | round | scene | rays | group | Mrays/s | / base 8x4 | / driver RT | registers |")
print("|---|---:|---|---|---|---:|---:|---:|---:|")
for (v, rnd), run in sorted(runs.items(), key=lambda kv: (kv[0][1], kv[0][0])):
    for r in run["records"]:
        if r.get("tracer") != "gpu-single":
            continue
        key = (r["scene"], r["ray_kind"])
        mr = r.get("perf_mrays_s") or 0.0
        b = base.get((rnd,) + key)
        d = driver.get(key)
        stats = r.get("pipeline_statistics") or {}
        regs = (stats.get(r["ray_kind"]) or stats).get("Register Count") if isinstance(stats, dict) else None
        print(f"| {v} | {rnd} | {key[0]} | {key[1]} | {r.get('packet')} | {mr:,.0f} | "
              f"{mr / b if b else float('nan'):.3f} | {mr / d if d else float('nan'):.3f} | {regs} |")
PY
(cd "$out" && tar cJf runs.tar.xz occupancy-*.json occupancy-*.log env.log && rm -f occupancy-*.json occupancy-*.log env.log)
