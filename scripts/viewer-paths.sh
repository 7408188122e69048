#!/usr/bin/env bash
# Records one camera path per report scene for the viewer's frame-loop benchmark (docs/viewer.md):
# the bench camera of the scene (app/cli/bench_suites.cpp), then 180 frames of scripted flight
# (forward and a slow turn), recorded by `raypack --record-path` under Xvfb. The paths' timing is
# the recording machine's; played back (`--play-path`) they follow it on the wall clock.
#   scripts/viewer-paths.sh OUT_DIR [SCENE_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=$1
scenes=${2:-$root/../shared/scenes}
viewer=${RAYPACK_BUILD_DIR:-$root/build}/raypack
mkdir -p "$out"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
steps=()
for f in $(seq 2 181); do steps+=(--script "$f:move:0,0,0.01" --script "$f:look:1,0"); done
record() {  # NAME FILE EYE AT FOV
  xvfb-run -a -s "-screen 0 640x480x24" "$viewer" --scene "$scenes/$2" --eye "$3" --at "$4" --up 0,1,0 \
    --fov "$5" --width 320 --height 240 --frames 190 --script 1:wait "${steps[@]}" --record-path "$out/$1.json" \
    >/dev/null
  echo "$out/$1.json"
}
record sibenik sibenik/sibenik_geom_75284.ply -18,-11,0 0,-8,0 70
record sponza dabrovic_sponza/sponza.obj -14,4,0 10,5,0 70
record conference conference/conference_geom.ply 1500,350,-900 0,150,0 70
record armadillo stanford/armadillo_decimated_99976.obj 0,0.1,2.4 0,0,0 45
record dragon stanford/dragon_vrip_res2.ply 0,0.14,0.32 -0.005,0.125,0 45
