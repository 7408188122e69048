#!/usr/bin/env bash
# Issue 13 on the lent H200 machine: the treelet rounds over gpu-hploc's tree (--treelet-rounds,
# --treelet-gamma; shaders/treelet.comp). For the report scenes, terrain 1M and 10M and the dragon
# subdivided to 13M: bench --device gpu --kernel single at 1920x1080 with --builder gpu-hploc at each of
# CONFIGS (default "0 1 3"; an entry R, R:G or R:G:T: R rounds at gamma G, 7 if not given, after the
# top rebuilt from T triangles, --top-rebuild T, none if not given), the list run twice
# interleaved (PASSES times, default 2; a run with the driver's ray tracing peer first, for its BLAS
# build), with sah-exact before and after (the trace ratios divide by the median of the two).
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
run exact sah-exact --no-driver-rt
passes=${PASSES:-2}
for pass in $(seq 1 "$passes"); do
  for c in $configs; do run "r$c-$pass" gpu-hploc --no-driver-rt $(treelet_flags "$c"); done
  cli=.device/bin/raypack-cli-old
  for r in $old_configs; do run "rold-$r-$pass" gpu-hploc --no-driver-rt --treelet-rounds "$r"; done
  cli=.device/bin/raypack-cli
done
run exact-2 sah-exact --no-driver-rt
python3 - "$out/runs" "$configs $(for r in $old_configs; do printf 'old-%s ' "$r"; done)" "$passes" >> "$out/treelet.txt" <<'PY'
import json, statistics, sys
runs, rounds, passes = sys.argv[1], sys.argv[2].split(), int(sys.argv[3])
def load(name):
    try:
        return json.load(open(f"{runs}/{name}.json"))["records"]
    except Exception:
        return []
def cells(name, tracer="gpu-single", kind="primary"):
    return {r["scene"]: r for r in load(name) if r.get("tracer") == tracer and r.get("ray_kind", "primary") == kind}
driver = cells("driver", "driver-rt")
exacts = {kind: [cells(name, kind=kind) for name in ("exact", "exact-2")] for kind in ("primary", "shadow")}
def exact_rate(scene, kind):
    rates = [c[scene]["perf_mrays_s"] for c in exacts[kind] if scene in c]
    return statistics.median(rates) if rates else float("nan")
print(f"{'config':>6s} {'scene':24s} {'tris':>9s} {'device ms':>9s} {'hier ms':>8s} {'drv ms':>7s} {'drv/dev':>7s}"
      f" {'SAH/exact':>9s} {'N_TR':>6s} {'exact':>6s}  trace/exact (each pass)  shadow/exact (each pass)")
for r in rounds:
    per = [cells(f"r{r}-{p}") for p in range(1, passes + 1)]
    shadows = [cells(f"r{r}-{p}", kind="shadow") for p in range(1, passes + 1)]
    for scene, x in per[0].items():
        e = exacts["primary"][0].get(scene) or exacts["primary"][1].get(scene)
        mine = [c[scene] for c in per if scene in c]
        dev = statistics.median([c["t_b_device_s"] for c in mine])
        hier = statistics.median([c.get("t_b_device_hierarchy_s", 0) for c in mine])
        d = driver.get(scene, {}).get("t_b_blas_s", float("nan"))
        trace = " ".join(f"{c['perf_mrays_s'] / exact_rate(scene, 'primary'):.3f}" for c in mine)
        shadow = " ".join(f"{c[scene]['perf_mrays_s'] / exact_rate(scene, 'shadow'):.3f}" for c in shadows if scene in c)
        print(f"{r:>6s} {scene[-24:]:24s} {x['triangles']:9d} {dev*1e3:9.2f} {hier*1e3:8.2f} {d*1e3:7.2f} {d/dev:7.2f}"
              f" {x['sah_cost']/e['sah_cost']:9.3f} {x['n_tr_nodes_per_ray']:6.2f} {e['n_tr_nodes_per_ray']:6.2f}"
              f"  {trace}  {shadow}")
print("device: the build's timestamps (median of the passes), hier: its clustering + treelet part; drv: the driver's"
      " BLAS build (driver-rt peer); SAH, N_TR (primary) and Mrays/s against the sah-exact tree (other processes:"
      " the median of a run before the passes and one after)")
PY
cat "$out/treelet.txt"
tar czf "$out/results.tgz" -C "$out" runs
rm -rf "$out/runs"
