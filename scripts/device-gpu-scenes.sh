# Sourced by the device scripts that bench the GPU builders (device-gpu-build.sh, device-treelet.sh):
# makes $out/runs, unpacks the bundle of scripts/device-pack.sh if it is not unpacked yet, sources
# scripts/device-env.sh and sets S (the carried scenes) and scenes (bench --scenes: the report scenes,
# terrain 1M and 10M, the dragon subdivided to 13M; SCENE_LIST replaces them).
out=${OUT:-${OUT_DIR:-out}}
mkdir -p "$out/runs"
if [ ! -x .device/bin/raypack-cli ] && [ -f .device/round.tar.xz ]; then tar xJf .device/round.tar.xz; fi
source scripts/device-env.sh
S=.device/scenes
scenes="$S/sibenik/sibenik_geom_75284.ply,$S/dabrovic_sponza/sponza.obj,$S/conference/conference_geom.ply"
scenes+=",$S/stanford/armadillo_decimated_99976.obj,$S/stanford/dragon_vrip_res2.ply"
scenes+=",gen:terrain:1M,gen:terrain:10M,subdiv:3:$S/stanford/dragon_vrip_res2.ply"
scenes=${SCENE_LIST:-$scenes}
