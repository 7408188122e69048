#!/usr/bin/env bash
# Issue 13 on the lent H200 machine: from a scene in host memory to its first traced frame with the
# BVH built on the device in the tracer's own buffers (bench --builder gpu-lbvh and gpu-ploc: the GPU tracers take
# GpuTracer::buildOnDevice; records carry t_cu_s, t_b_s and t_scene_to_frame_s = T_CU + T_B + frame_s),
# against the CPU-built path (sah-binned: T_B on 16 threads, T_CU the host layout upload), for the
# terrains and the dragon subdivided to 13M at 1920x1080, single-ray kernel, in one call.
# Prepare here: scripts/device-pack.sh build. On the device (carry [".gl", ".device"]):
#   [UPLOAD_MODES="direct staged"] [SCENE_LIST=...] bash scripts/device-first-frame.sh
#       -> $OUT/first-frame.txt, $OUT/first-frame-BUILDER-MODE.json
set -uo pipefail
out=${OUT:-${OUT_DIR:-out}}
mkdir -p "$out"
if [ ! -x .device/bin/raypack-cli ] && [ -f .device/round.tar.xz ]; then tar xJf .device/round.tar.xz; fi
source scripts/device-env.sh 2>/dev/null
S=.device/scenes
scenes=${SCENE_LIST:-"$S/conference/conference_geom.ply,gen:terrain:1M,gen:terrain:10M,subdiv:3:$S/stanford/dragon_vrip_res2.ply"}
# UPLOAD_MODES: the vk::StagedUpload modes to run, each the whole set (RAYPACK_UPLOAD=direct: into
# mapped device memory where the device maps all of it; staged: through staging buffers).
modes=${UPLOAD_MODES:-direct}
for mode in $modes; do
  for builder in gpu-lbvh gpu-ploc sah-binned; do
    RAYPACK_UPLOAD=$mode timeout 250 .device/bin/raypack-cli bench --scenes "$scenes" --device gpu --kernel single \
      --no-driver-rt --width 1920 --height 1080 --repeat 5 --builder "$builder" \
      --out "$out/first-frame-$builder-$mode.json" > /dev/null 2>> "$out/first-frame-progress.log" ||
      echo "FAILED $builder $mode" | tee -a "$out/first-frame.txt"
  done
done
for mode in $modes; do
echo "upload mode $mode" >> "$out/first-frame.txt"
python3 - "$out" "$mode" >> "$out/first-frame.txt" <<'PY'
import json, sys
out, mode = sys.argv[1], sys.argv[2]
rows = {}
for builder in ("gpu-lbvh", "gpu-ploc", "sah-binned"):
    try:
        records = json.load(open(f"{out}/first-frame-{builder}-{mode}.json"))["records"]
    except Exception:
        continue
    for r in records:
        if r.get("tracer") == "gpu-single" and r.get("ray_kind") == "primary":
            rows.setdefault(r["scene"], {})[builder] = r
print(f"{'builder':9s} {'scene':28s} {'tris':>9s} | {'T_CU':>7s} {'T_B':>7s} {'frame':>7s} {'to frame':>8s} | {'binned T_B':>10s} {'T_CU':>7s} {'to frame':>8s} | {'ratio':>6s}")
for builder in ("gpu-lbvh", "gpu-ploc"):
    for scene, by in rows.items():
        l, b = by.get(builder), by.get("sah-binned")
        if not l or not b:
            continue
        lf = l["t_cu_s"] + l["t_b_s"] + l["frame_s"]
        bf = b["t_b_s"] + b["t_cu_s"] + b["frame_s"]
        print(f"{builder:9s} {scene[-28:]:28s} {l['triangles']:9d} | {l['t_cu_s']:7.4f} {l['t_b_s']:7.4f} {l['frame_s']:7.4f}"
              f" {lf:8.4f} | {b['t_b_s']:10.4f} {b['t_cu_s']:7.4f} {bf:8.4f} | {bf / lf:6.1f}")
print("seconds; to frame = T_CU + T_B + one frame's wall time (frame_s) of the first GPU cell (the scene in host memory to a traced frame,"
      " kernels compiled before); ratio = sah-binned path / device-built path")
print("T_CU split (allocation / conversion / transfer) and T_B's allocation, seconds:")
for scene, by in rows.items():
    for builder, r in by.items():
        print(f"  {builder:10s} {scene[-28:]:28s} T_CU {r['t_cu_s']:.4f} = {r.get('t_cu_allocation_s') or 0:.4f} / "
              f"{r.get('t_cu_conversion_s') or 0:.4f} / {r.get('t_cu_transfer_s') or 0:.4f}; "
              f"T_B {r['t_b_s']:.4f} (allocation {r.get('t_b_allocation_s') or 0:.4f}, device {r.get('t_b_device_s') or 0:.4f})")
PY
done
cat "$out/first-frame.txt"
