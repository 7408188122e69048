#!/usr/bin/env bash
# Issue 13 on the lent H200 machine: the treelet rounds over gpu-hploc's tree (--treelet-rounds,
# --treelet-gamma; shaders/treelet.comp). For the report scenes, terrain 1M and 10M and the dragon
# subdivided to 13M: bench --device gpu --kernel single at 1920x1080 with --builder gpu-hploc at each of
# CONFIGS (default "0 1 3"; an entry R, R:G or R:G:T: R rounds at gamma G, 7 if not given, after the
# top rebuilt from T triangles, --top-rebuild T, none if not given), the list run twice
# interleaved (a run with the driver's ray tracing peer first, for its BLAS build), then sah-exact.
# Prepare here: scripts/device-pack.sh build. On the device (carry [".gl", ".device"]):
# bash scripts/device-treelet.sh; the table goes to $OUT/treelet.txt, the records into $OUT/results.tgz.
# With .device/bin/raypack-cli-old (scripts/device-pack.sh build OLD_BUILD/raypack-cli-old), each pass
# also runs that binary at OLD_CONFIGS (default "1"), rows "old-R", to compare two versions in one call.
set -uo pipefail
source scripts/device-gpu-scenes.sh
configs=${CONFIGS:-${ROUNDS:-0 1 3}}
common=(bench --scenes "$scenes" --device gpu --kernel single --width 1920 --height 1080 --repeat 3)
old_configs=${OLD_CONFIGS:-1}
[ -x .device/bin/raypack-cli-old ] || old_configs=
cli=.device/bin/raypack-cli
run() {  # NAME BUILDER [FLAGS...]
  local name=$1 builder=$2
  shift 2
  timeout "${RUN_TIMEOUT_S:-100}" "$cli" "${common[@]}" --builder "$builder" "$@" --out "$out/runs/$name.json" \
    > /dev/null 2>> "$out/runs/progress.log" || echo "FAILED $name" | tee -a "$out/treelet.txt"
}
treelet_flags() {  # R, R:G or R:G:T
  local r g t
  IFS=: read -r r g t <<< "$1"
  echo --treelet-rounds "$r" --treelet-gamma "${g:-7}" --top-rebuild "${t:-0}"
}
run driver gpu-hploc --build-repeat 1
for pass in 1 2; do
  for c in $configs; do run "r$c-$pass" gpu-hploc --no-driver-rt $(treelet_flags "$c"); done
  cli=.device/bin/raypack-cli-old
  for r in $old_configs; do run "rold-$r-$pass" gpu-hploc --no-driver-rt --treelet-rounds "$r"; done
  cli=.device/bin/raypack-cli
done
run exact sah-exact --no-driver-rt
python3 - "$out/runs" "$configs $(for r in $old_configs; do printf 'old-%s ' "$r"; done)" >> "$out/treelet.txt" <<'PY'
import json, statistics, sys
runs, rounds = sys.argv[1], sys.argv[2].split()
def load(name):
    try:
        return json.load(open(f"{runs}/{name}.json"))["records"]
    except Exception:
        return []
def cells(name, tracer="gpu-single", kind="primary"):
    return {r["scene"]: r for r in load(name) if r.get("tracer") == tracer and r.get("ray_kind", "primary") == kind}
driver, exact = cells("driver", "driver-rt"), cells("exact")
print(f"{'config':>6s} {'scene':24s} {'tris':>9s} {'device ms':>9s} {'hier ms':>8s} {'drv ms':>7s} {'drv/dev':>7s}"
      f" {'SAH/exact':>9s} {'N_TR':>6s} {'exact':>6s} {'trace/exact p1':>14s} {'p2':>6s} {'shadow p1':>9s} {'p2':>6s}")
for r in rounds:
    a, b = cells(f"r{r}-1"), cells(f"r{r}-2")
    sa, sb, se = cells(f"r{r}-1", kind="shadow"), cells(f"r{r}-2", kind="shadow"), cells("exact", kind="shadow")
    for scene, x in a.items():
        e = exact.get(scene)
        y = b.get(scene, x)
        dev = statistics.median([x["t_b_device_s"], y["t_b_device_s"]])
        hier = statistics.median([x.get("t_b_device_hierarchy_s", 0), y.get("t_b_device_hierarchy_s", 0)])
        d = driver.get(scene, {}).get("t_b_blas_s", float("nan"))
        def ratio(c, ref): return c["perf_mrays_s"] / ref["perf_mrays_s"] if c and ref else float("nan")
        print(f"{r:>6s} {scene[-24:]:24s} {x['triangles']:9d} {dev*1e3:9.2f} {hier*1e3:8.2f} {d*1e3:7.2f} {d/dev:7.2f}"
              f" {x['sah_cost']/e['sah_cost']:9.3f} {x['n_tr_nodes_per_ray']:6.2f} {e['n_tr_nodes_per_ray']:6.2f}"
              f" {ratio(x, e):14.3f} {ratio(y, e):6.3f} {ratio(sa.get(scene), se.get(scene)):9.3f} {ratio(sb.get(scene), se.get(scene)):6.3f}")
print("device: the build's timestamps (median of the two passes), hier: its clustering + treelet part; drv: the driver's"
      " BLAS build (driver-rt peer); SAH, N_TR (primary) and Mrays/s against the sah-exact tree (another process)")
PY
cat "$out/treelet.txt"
tar czf "$out/results.tgz" -C "$out" runs
rm -rf "$out/runs"
