#!/usr/bin/env bash
# Issue 14 on the lent H200 machine: the hybrid kernel with 1, 2 and 4 one-subgroup packets (8x4,
# K = a quarter of the packet) per workgroup, beside the single-ray kernel (its default 8x16 / 32x4
# workgroups) and the packet kernel (8x4), 1920x1080, the report suite and the scaling suite's
# three largest scenes. Then OUT/hybrid-groups.md: Mrays/s per cell and each / the single-ray kernel.
# From the repository root on the device, with .device/ unpacked (scripts/device-pack.sh) and .gl/:
#   scripts/device-hybrid-groups.sh [OUT_DIR]   (default: $OUT)
# Environment: REPEAT (default 5), GROUPS_PER (default 1,2,4).
set -u
source scripts/device-start.sh "$0" "${1:-}"
common=(bench --scene-dir .device/scenes --device gpu --kernel all --packets 8x4 --hybrid-min-rays 1/4
        --hybrid-packets-per-group "${GROUPS_PER:-1,2,4}" --width 1920 --height 1080 --repeat "${REPEAT:-5}"
        --no-embree --no-driver-rt)
.device/bin/raypack-cli "${common[@]}" --suite report --out "$out/hybrid-report.json" > "$out/hybrid-report.log" 2>&1 ||
  echo "report: bench failed" >> "$out/errors.txt"
.device/bin/raypack-cli "${common[@]}" --suite scaling --only "terrain 1M,terrain 10M,Dragon subdiv 3" \
  --out "$out/hybrid-scaling.json" > "$out/hybrid-scaling.log" 2>&1 || echo "scaling: bench failed" >> "$out/errors.txt"
python3 - "$out" > "$out/hybrid-groups.md" <<'PY'
import glob, json, os, sys
out = sys.argv[1]
print("| scene | rays | cell | Mrays/s | / single | N_TR |")
print("|---|---|---|---:|---:|---:|")
for path in sorted(glob.glob(os.path.join(out, "hybrid-*.json"))):
    with open(path) as f:
        run = json.load(f)
    single = {(r["scene"], r["ray_kind"]): r["perf_mrays_s"] for r in run["records"] if r["tracer"] == "gpu-single"}
    for r in run["records"]:
        cell = r["tracer"] + " " + str(r.get("packet"))
        if r.get("hybrid_packets_per_group"):
            cell += f" K={r['hybrid_min_rays']}, {r['hybrid_packets_per_group']} a workgroup"
        s = single.get((r["scene"], r["ray_kind"]))
        mr = r.get("perf_mrays_s") or 0.0
        print(f"| {r['scene']} | {r['ray_kind']} | {cell} | {mr:,.0f} | {mr / s if s else float('nan'):.3f} | "
              f"{r.get('n_tr_nodes_per_ray') or 0:.1f} |")
PY
(cd "$out" && tar cJf runs.tar.xz hybrid-*.json hybrid-*.log env.log && rm -f hybrid-*.json hybrid-*.log env.log)
