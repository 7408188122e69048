set -u
tar xJf .device/round.tar.xz && source scripts/device-env.sh
S=.device/scenes
scenes="$S/sibenik/sibenik_geom_75284.ply,$S/conference/conference_geom.ply,$S/stanford/dragon_vrip_res2.ply,gen:terrain:10M"
common=(bench --scenes "$scenes" --device gpu --kernel single --width 320 --height 240 --repeat 1 --no-driver-rt --no-embree --builder gpu-ploc)
for round in 1 2 3; do
  .device/bin/raypack-cli "${common[@]}" --out $OUT/adaptive-$round.json >/dev/null 2>>$OUT/err.txt
  .device/bin/raypack-cli-fixed "${common[@]}" --out $OUT/fixed-$round.json >/dev/null 2>>$OUT/err.txt
done
python3 - $OUT <<'PY'
import json,sys,statistics
out=sys.argv[1]
def tb(f):
    r={}
    for x in json.load(open(f))["records"]:
        if x.get("tracer")=="gpu-single" and x["ray_kind"]=="primary": r[x["scene"][-22:]]=(x["t_b_s"],x.get("t_b_device_s"))
    return r
for kind in ("adaptive","fixed"):
    runs=[tb(f"{out}/{kind}-{i}.json") for i in (1,2,3)]
    for s in runs[0]:
        w=[r[s][0] for r in runs]; d=[r[s][1] for r in runs]
        print(f"{kind:8s} {s:22s} T_B wall median {statistics.median(w)*1e3:7.2f} ms  device median {statistics.median(d)*1e3:7.2f} ms  (device {', '.join(f'{v*1e3:.2f}' for v in d)})")
PY
