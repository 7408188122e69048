#!/usr/bin/env bash
# Issue 13 on the lent H200 machine: the GPU builders gpu-lbvh, gpu-ploc and gpu-hploc against the driver's own BLAS build
# and the CPU builders, in one call. For every scene of the report and scaling suites' largest
# (Sibenik, Sponza, Conference, Armadillo, Dragon, terrain 1M and 10M, the dragon subdivided to
# 13M): bench --device gpu --kernel single at 1920x1080 with --builder gpu-lbvh, gpu-ploc and gpu-hploc (three
# runs each, for T_B medians; the driver's ray tracing peer runs in the first and times its BLAS
# build), then once with
# sah-binned and sah-exact (SAH cost and single-ray trace speed of their trees). The summary table
# (build rates, ratios to the driver, SAH and trace ratios to sah-exact) goes to $OUT/gpu-build.txt,
# everything else into $OUT/results.tgz.
#
# Prepare here: scripts/device-pack.sh build. On the device, from the repository root (the run
# tool, carry [".gl", ".device"]): bash scripts/device-gpu-build.sh
# Environment: SCENE_LIST (bench --scenes), PLOC_RADII (default "16": one gpu-ploc row per
# --ploc-radius), HPLOC_RADII (default "0", gpu-hploc's own radius, 8; rows "hploc", or "hploc<r>"), LBVH_RUNS, PLOC_RUNS and
# HPLOC_RUNS (default 3 each; the first of each runs 5 repeats), TEST_BINARIES (run first, each
# on the device's GPU with the validation layer, output in $OUT/tests.txt),
# SKIP_BINNED=1 (no sah-binned run), RUN_TIMEOUT_S (default 140 per bench run).
set -uo pipefail
source scripts/device-gpu-scenes.sh
nvidia-smi --query-gpu=name,driver_version --format=csv > "$out/runs/gpu.txt" 2>&1
common=(bench --scenes "$scenes" --device gpu --kernel single --width 1920 --height 1080)
run() {  # NAME BUILDER [FLAGS...]
  local name=$1 builder=$2
  shift 2
  timeout "${RUN_TIMEOUT_S:-140}" .device/bin/raypack-cli "${common[@]}" --builder "$builder" "$@" --out "$out/runs/$name.json" \
    > /dev/null 2>> "$out/runs/progress.log" || echo "FAILED $name" | tee -a "$out/gpu-build.txt"
}
radii=${PLOC_RADII:-16}
hradii=${HPLOC_RADII:-0}
if [ -n "${TEST_BINARIES:-}" ] && [ ! -d /work/main/../shared/scenes ]; then
  # The tests read the scenes from the path they were built with.
  mkdir -p /work/main /work/shared && ln -sfn "$PWD/.device/scenes" /work/shared/scenes
fi
for t in ${TEST_BINARIES:-}; do
  echo "== $t" >> "$out/tests.txt"
  timeout 300 ".device/bin/$t" ${TEST_FILTER:+--gtest_filter=$TEST_FILTER} >> "$out/tests.txt" 2>&1
  echo "exit $?" >> "$out/tests.txt"
done
run lbvh-1 gpu-lbvh --repeat 5
for i in $(seq 2 "${LBVH_RUNS:-3}"); do run "lbvh-$i" gpu-lbvh --no-driver-rt --repeat 1; done
for radius in $radii; do
  run "ploc$radius-1" gpu-ploc --no-driver-rt --repeat 5 --ploc-radius "$radius"
  for i in $(seq 2 "${PLOC_RUNS:-3}"); do run "ploc$radius-$i" gpu-ploc --no-driver-rt --repeat 1 --ploc-radius "$radius"; done
done
for radius in $hradii; do
  name=hploc${radius#0}  # radius 0, the builder's own: "hploc"
  run "$name-1" gpu-hploc --no-driver-rt --repeat 5 --ploc-radius "$radius"
  for i in $(seq 2 "${HPLOC_RUNS:-3}"); do run "$name-$i" gpu-hploc --no-driver-rt --repeat 1 --ploc-radius "$radius"; done
done
[ "${SKIP_BINNED:-0}" = 1 ] || run binned sah-binned --no-driver-rt --repeat 1
run exact sah-exact --no-driver-rt --repeat 5
python3 - "$out/runs" "$radii" "$hradii" >> "$out/gpu-build.txt" <<'PY'
import glob, json, statistics, sys
runs = sys.argv[1]
radii = sys.argv[2].split()
hradii = sys.argv[3].split()
def load(name):
    try:
        return json.load(open(f"{runs}/{name}.json"))["records"]
    except Exception:
        return []
def by_scene(records, tracer, kind="primary"):
    out = {}
    for r in records:
        if r.get("tracer") == tracer and r.get("ray_kind", "primary") == kind:
            out.setdefault(r["scene"], r)
    return out
driver = by_scene(load("lbvh-1"), "driver-rt")
binned, exact = by_scene(load("binned"), "gpu-single"), by_scene(load("exact"), "gpu-single")
print(f"{'builder':8s} {'scene':22s} {'tris':>9s} {'T_B':>9s} {'device':>9s} {'Mtri/s':>8s} {'driver':>9s} {'Mtri/s':>8s}"
      f" {'dev/drv':>7s} {'binned T_B':>10s} {'SAH/exact':>9s} {'trace/exact':>11s} {'scratch B/tri':>13s}")
for builder in ["lbvh"] + [f"ploc{r}" for r in radii] + ["hploc" + r.lstrip("0") for r in hradii]:
    runs_of = [by_scene(load(f"{builder}-{i}"), "gpu-single") for i in range(1, 10)]
    runs_of = [r for r in runs_of if r]
    if not runs_of:
        continue
    for scene, first in runs_of[0].items():
        rows = [r[scene] for r in runs_of if scene in r]
        tris = first["triangles"]
        wall = statistics.median(r["t_b_s"] for r in rows)
        device = statistics.median(r.get("t_b_device_s", 0) for r in rows)
        d = driver.get(scene, {}).get("t_b_blas_s", float("nan"))
        e, b = exact.get(scene), binned.get(scene)
        sah = first["sah_cost"] / e["sah_cost"] if e else float("nan")
        trace = first["perf_mrays_s"] / e["perf_mrays_s"] if e else float("nan")
        print(f"{builder:8s} {scene[-22:]:22s} {tris:9d} {wall:9.4f} {device:9.4f} {tris / device / 1e6:8.1f} {d:9.4f}"
              f" {tris / d / 1e6:8.1f} {d / device:7.2f} {b['t_b_s'] if b else float('nan'):10.4f} {sah:9.3f}"
              f" {trace:11.3f} {first.get('build_scratch_bytes', 0) / tris:13.1f}")
print("T_B: host wall time of the device build (scratch allocation, submission, wait); device: its timestamps;"
      " driver: the driver's BLAS build by timestamps (driver-rt peer, run lbvh-1); dev/drv > 1: gpu-lbvh faster;"
      " SAH and trace: the device-built tree / sah-exact tree, single-ray kernel primary Mrays/s; medians over the runs of each builder (gpu-ploc's device time spans its submissions, host waits included); ploc<r>: --ploc-radius r")
PY
cat "$out/gpu-build.txt"
tar czf "$out/results.tgz" -C "$out" runs
rm -rf "$out/runs"
