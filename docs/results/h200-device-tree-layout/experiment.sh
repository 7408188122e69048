set -u
tar xJf .device/round.tar.xz && source scripts/device-env.sh
S=.device/scenes
scenes="$S/sibenik/sibenik_geom_75284.ply,$S/dabrovic_sponza/sponza.obj,$S/conference/conference_geom.ply,$S/stanford/armadillo_decimated_99976.obj,$S/stanford/dragon_vrip_res2.ply,gen:terrain:10M"
common=(bench --scenes "$scenes" --device gpu --kernel single --width 1920 --height 1080 --repeat 7 --no-driver-rt --no-embree)
for round in 1 2; do
  for b in gpu-ploc gpu-lbvh; do
    .device/bin/raypack-cli "${common[@]}" --builder $b --out $OUT/tracer-$b-$round.json >/dev/null 2>>$OUT/err.txt
    RAYPACK_EXPERIMENT_DOWNLOADED_LAYOUT=1 .device/bin/raypack-cli "${common[@]}" --builder $b --out $OUT/dfs-$b-$round.json >/dev/null 2>>$OUT/err.txt
  done
done
.device/bin/raypack-cli "${common[@]}" --builder sah-exact --out $OUT/exact.json >/dev/null 2>>$OUT/err.txt
python3 - $OUT <<'PY'
import json,sys,glob,os
out=sys.argv[1]
def load(f):
    r={}
    for x in json.load(open(f))["records"]:
        if x.get("tracer")=="gpu-single": r[(x["scene"][-22:],x["ray_kind"])]=x["mrays_per_s"]
    return r
ex=load(f"{out}/exact.json")
for b in ("gpu-ploc","gpu-lbvh"):
  for rnd in (1,2):
    t=load(f"{out}/tracer-{b}-{rnd}.json"); d=load(f"{out}/dfs-{b}-{rnd}.json")
    for k in sorted(t):
      print(f"{b} r{rnd} {k[0]:22s} {k[1]:8s} in-tracer {t[k]:8.0f} dfs {d.get(k,0):8.0f} dfs/in {d.get(k,0)/t[k]:5.2f}  in/exact {t[k]/ex.get(k,1):5.2f} dfs/exact {d.get(k,0)/ex.get(k,1):5.2f}")
PY
