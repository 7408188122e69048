#!/bin/bash
# Issue 13: build rate of sah-binned against Embree's medium build on the H200 machine's CPU (all
# its threads), in one run: the bench's T_B (raypack, buildBvh) and Embree's rtcCommitScene time
# (RTC_BUILD_QUALITY_MEDIUM), both per scene, each built BUILD_REPEAT times back to back in the
# same process (bench --build-repeat: T_B is the median, so that neither is measured cold while
# the other is warm), the runs repeated and interleaved; medians and ratios. The SAH cost of each
# tree against sah-exact's comes from one sah-exact run (EXACT=0 skips it).
# With dev/bin/raypack-cli-old (a raypack-cli with --build-repeat and the sah-binned builder before
# the change) also the old sah-binned (OLD_EMBREE=1: with Embree in its runs too, so that the old
# builder's ratio to Embree is also measured within one process). VARIANTS="A B": further
# dev/bin/raypack-cli-A ... run in every round without Embree; lines "PHASES n=<triangles> k=<ms>
# ..." that a variant writes to stderr (a builder timing its phases) are collected, and the table
# gives each variant's rate and the medians of its phases by scene (VARIANT_EMBREE=1: the variants
# with Embree in their runs too). WARMUP=1 (the default) runs the new binary once first, untimed:
# the first process after the machine starts built the small scenes up to twice as slowly as every
# later one (docs/results/h100-build-rate-1/).
#
# Prepare the carried bundle here (scenes are not on the device):
#   scripts/device-bundle.sh dev build/raypack-cli            # + cp OLD_BUILD/raypack-cli dev/bin/raypack-cli-old
#   mkdir -p dev/scenes && (cd ../shared/scenes && cp --parents sibenik/sibenik_geom_75284.ply \
#     dabrovic_sponza/sponza.obj conference/conference_geom.ply stanford/armadillo_decimated_99976.obj \
#     stanford/dragon_vrip_res2.ply "$OLDPWD/dev/scenes/")
# Run on the device from the repository root (carry dev): scripts/device-build-rate.sh
# Output: $OUT/build-rate-*.json (bench results) and $OUT/build-rate.txt (the table).
# Budget: about 4 minutes with REPEATS=5 (the 13M dragon is subdivided on load, each run).
set -u
OUT=${OUT:-/tmp/build-rate}
REPEATS=${REPEATS:-2}
BUILD_REPEAT=${BUILD_REPEAT:-5}
S=${SCENES:-dev/scenes}
export LD_LIBRARY_PATH=$PWD/dev/lib:${LD_LIBRARY_PATH:-}
mkdir -p "$OUT"
scenes="$S/sibenik/sibenik_geom_75284.ply,$S/dabrovic_sponza/sponza.obj,$S/conference/conference_geom.ply"
scenes+=",$S/stanford/armadillo_decimated_99976.obj,$S/stanford/dragon_vrip_res2.ply"
scenes+=",gen:terrain:1M,gen:terrain:10M,subdiv:3:$S/stanford/dragon_vrip_res2.ply"
scenes=${SCENE_LIST:-$scenes}  # override for a short trial run
common=(bench --scenes "$scenes" --device cpu --width 16 --height 16 --repeat 1 --no-driver-rt)
nproc >"$OUT/build-rate.txt"
if [ "${EXACT:-1}" != 0 ]; then
  dev/bin/raypack-cli "${common[@]}" --builder sah-exact --no-embree --out "$OUT/build-rate-exact-1.json" >/dev/null \
    2>>"$OUT/stderr.txt" || echo "FAILED sah-exact run" | tee -a "$OUT/build-rate.txt"
fi
common+=(--builder sah-binned)
if [ "${WARMUP:-1}" != 0 ]; then
  dev/bin/raypack-cli "${common[@]}" --build-repeat "$BUILD_REPEAT" --no-embree --out "$OUT/warmup.json" >/dev/null \
    2>>"$OUT/stderr.txt" || echo "FAILED warm-up run" | tee -a "$OUT/build-rate.txt"
  rm -f "$OUT/warmup.json"
fi
variant_embree=(--no-embree)
[ "${VARIANT_EMBREE:-0}" = 1 ] && variant_embree=()
for i in $(seq 1 "$REPEATS"); do
  # New binary with Embree (medium and high are built; only medium is compared).
  dev/bin/raypack-cli "${common[@]}" --build-repeat "$BUILD_REPEAT" --out "$OUT/build-rate-new-$i.json" >/dev/null \
    2>>"$OUT/stderr.txt" ||
    echo "FAILED new run $i" | tee -a "$OUT/build-rate.txt"
  if [ -x dev/bin/raypack-cli-old ]; then
    old_embree=(--no-embree)
    [ "${OLD_EMBREE:-0}" = 1 ] && old_embree=()
    dev/bin/raypack-cli-old "${common[@]}" --build-repeat "$BUILD_REPEAT" "${old_embree[@]}" --out "$OUT/build-rate-old-$i.json" >/dev/null \
      2>>"$OUT/stderr.txt" || echo "FAILED old run $i" | tee -a "$OUT/build-rate.txt"
  fi
  for v in ${VARIANTS:-}; do
    dev/bin/raypack-cli-"$v" "${common[@]}" --build-repeat "$BUILD_REPEAT" "${variant_embree[@]}" --out "$OUT/build-rate-var-$v-$i.json" \
      >/dev/null 2>"$OUT/phases-$v-$i.txt" || echo "FAILED variant $v run $i" | tee -a "$OUT/build-rate.txt"
  done
done
python3 - "$OUT" >>"$OUT/build-rate.txt" <<'EOF'
import glob, json, statistics, sys
out = sys.argv[1]
def times(kind):
    # scene -> {"raypack": [T_B...], "embree": [T_B...]}, one value per bench run
    result = {}
    for path in sorted(glob.glob(f"{out}/build-rate-{kind}-*.json")):
        seen = set()
        for r in json.load(open(path))["records"]:
            scene = r.get("scene_spec", r.get("scene"))
            tracer = r.get("tracer")
            key = (scene, "embree" if tracer == "embree" else "raypack")
            if key in seen or (tracer == "embree" and r.get("embree_quality") != "medium"):
                continue
            seen.add(key)
            result.setdefault(scene, {}).setdefault(key[1], []).append((r["t_b_s"], r.get("triangles")))
            if tracer != "embree": sah.setdefault(kind, {})[scene] = r.get("sah_cost", float("nan"))
    return result
sah = {}
new, old, exact = times("new"), times("old"), times("exact")
def embree_ratio(by):
    med = lambda xs: statistics.median(t for t, _ in xs)
    return med(by["embree"]) / med(by["raypack"]) if "embree" in by else float("nan")
print(f"{'scene':60s} {'tris':>10s} {'new Mtri/s':>10s} {'embree':>10s} {'old':>10s} {'new/embree':>10s} {'new/old':>8s} {'SAH/exact':>9s} (medians)")
for scene, by in new.items():
    tris = by["raypack"][0][1]
    med = lambda xs: statistics.median(t for t, _ in xs)
    n, e = med(by["raypack"]), med(by.get("embree", [(float("nan"), 0)]))
    o = med(old[scene]["raypack"]) if scene in old else float("nan")
    rate = lambda s: tris / s / 1e6
    ratio = sah.get("new", {}).get(scene, float("nan")) / sah.get("exact", {}).get(scene, float("nan"))
    print(f"{scene[-60:]:60s} {tris:10d} {rate(n):10.2f} {rate(e):10.2f} {rate(o):10.2f} {e / n:10.2f} {o / n:8.2f} {ratio:9.4f}")
if any("embree" in by for by in old.values()):
    print("\nold builder / Embree, within the old binary's runs:")
    for scene, by in old.items(): print(f"{scene[-60:]:60s} {embree_ratio(by):10.2f}")
import os
kinds = ["new", "old"] + [f"var-{v}" for v in os.environ.get("VARIANTS", "").split()]
print("\nEmbree medium / sah-binned T_B inside each process, by round (>= 1.0: raypack faster):")
for kind in kinds:
    for scene, by in times(kind).items():
        if "embree" in by and len(by["embree"]) == len(by["raypack"]):
            rounds = " ".join(f"{e / r:.2f}" for (e, _), (r, _) in zip(by["embree"], by["raypack"]))
            print(f"{kind:10s} {scene[-60:]:60s} {rounds}")
for v in os.environ.get("VARIANTS", "").split():
    var = times(f"var-{v}")
    print(f"\nvariant {v}: Mtri/s, new / variant, and its phases (medians, ms):")
    phases = {}
    for path in sorted(glob.glob(f"{out}/phases-{v}-*.txt")):
        for line in open(path):
            if not line.startswith("PHASES"): continue
            fields = dict(kv.split("=") for kv in line.split()[1:])
            phases.setdefault(int(fields.pop("n")), []).append({k: float(x) for k, x in fields.items()})
    for scene, by in var.items():
        tris = by["raypack"][0][1]
        t = statistics.median(s for s, _ in by["raypack"])
        nt = statistics.median(s for s, _ in new[scene]["raypack"]) if scene in new else float("nan")
        rows = phases.get(tris, [])
        text = " ".join(f"{k} {statistics.median(r[k] for r in rows):.2f}" for k in (rows[0] if rows else {}))
        print(f"{scene[-60:]:60s} {tris / t / 1e6:10.2f} {t / nt:8.2f}  {text}")
EOF
cat "$OUT/build-rate.txt"
# A call returns a few files only: everything in one archive beside the table.
files=$(cd "$OUT" && ls | grep -v -e build-rate.txt -e build-rate-all.tgz)
tar czf "$OUT/build-rate-all.tgz" -C "$OUT" $files && (cd "$OUT" && rm -f $files)
