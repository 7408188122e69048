#!/usr/bin/env bash
# Issue 13 on the lent H200 machine: the device builders' Morton codes, the build against a
# raypack-cli built with the codes before (carried as .device/bin/raypack-cli-oldmorton, made by
# building the earlier shaders/lbvh_prepare.comp), in one call: bench --scenes <report scenes,
# terrain 1M and 10M, the dragon subdivided to 13M> --device gpu --kernel single at 1920x1080 with
# each of BUILDERS (default gpu-hploc gpu-lbvh) for both binaries, then sah-exact once with the
# build. OUT/morton.md: per scene and builder, SAH cost and primary Mrays/s of both trees, and their
# ratios to sah-exact's (all cells of one call).
#   scripts/device-morton.sh [OUT_DIR]   (default: $OUT)
set -u
out=${1:-${OUT:-}}
[ -n "$out" ] || { echo "usage: scripts/device-morton.sh OUT_DIR" >&2; exit 2; }
mkdir -p "$out/runs"
[ -d .device/bin ] || tar xJf .device/round.tar.xz
source scripts/device-env.sh > "$out/runs/env.log" 2>&1
S=.device/scenes
scenes="$S/sibenik/sibenik_geom_75284.ply,$S/dabrovic_sponza/sponza.obj,$S/conference/conference_geom.ply"
scenes+=",$S/stanford/armadillo_decimated_99976.obj,$S/stanford/dragon_vrip_res2.ply"
scenes+=",gen:terrain:1M,gen:terrain:10M,subdiv:3:$S/stanford/dragon_vrip_res2.ply"
builders=${BUILDERS:-gpu-hploc gpu-lbvh}
run() {  # NAME CLI BUILDER
  timeout 150 "$2" bench --scenes "$scenes" --device gpu --kernel single --width 1920 --height 1080 --builder "$3" \
    --no-driver-rt --no-embree --repeat 5 --out "$out/runs/$1.json" > /dev/null 2>> "$out/runs/progress.log" ||
    echo "FAILED $1" >> "$out/morton.md"
}
for b in $builders; do
  run "new-$b" .device/bin/raypack-cli "$b"
  run "old-$b" .device/bin/raypack-cli-oldmorton "$b"
done
run exact .device/bin/raypack-cli sah-exact
python3 - "$out/runs" $builders >> "$out/morton.md" <<'PY'
import json, sys
runs, builders = sys.argv[1], sys.argv[2:]
def load(name):
    try:
        return {r["scene"]: r for r in json.load(open(f"{runs}/{name}.json"))["records"]
                if r["tracer"] == "gpu-single" and r["ray_kind"] == "primary"}
    except Exception:
        return {}
exact = load("exact")
print("| builder | scene | SAH before | SAH now | now / before | SAH before / exact | SAH now / exact |"
      " Mrays/s before | Mrays/s now | now / before | trace now / exact | device build before | now |")
print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for b in builders:
    new, old = load(f"new-{b}"), load(f"old-{b}")
    for scene, n in new.items():
        o, e = old.get(scene), exact.get(scene)
        if not o or not e: continue
        print(f"| {b} | {scene[-24:]} | {o['sah_cost']:.2f} | {n['sah_cost']:.2f} | {n['sah_cost'] / o['sah_cost']:.3f} |"
              f" {o['sah_cost'] / e['sah_cost']:.3f} | {n['sah_cost'] / e['sah_cost']:.3f} | {o['perf_mrays_s']:.0f} |"
              f" {n['perf_mrays_s']:.0f} | {n['perf_mrays_s'] / o['perf_mrays_s']:.3f} | {n['perf_mrays_s'] / e['perf_mrays_s']:.3f} |"
              f" {o.get('t_b_device_s', 0) * 1e3:.1f} ms | {n.get('t_b_device_s', 0) * 1e3:.1f} ms |")
PY
(cd "$out" && tar czf results.tgz runs && rm -rf runs)
