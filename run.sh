#!/usr/bin/env bash
# Installs what is missing, builds in Release and opens the viewer on SCENE (default: the bundled
# scene, scenes/data/default.ply). Further arguments (or all of them, when the first is a flag) go
# to the viewer (`build/raypack --help`).
# Without a display it says so and renders the scene headless to out/render.png instead.
set -euo pipefail
root=$(cd "$(dirname "$0")" && pwd)
"$root/scripts/install-deps.sh"
"$root/scripts/build.sh"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
# The first argument is the scene unless it is a flag (`./run.sh --tracer cpu-reference`).
scene=$root/scenes/data/default.ply
if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then
  scene=$1
  shift
fi
build=${RAYPACK_BUILD_DIR:-$root/build}
if [ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ]; then
  exec "$build/raypack" --scene "$scene" "$@"
fi
echo "run.sh: no display (DISPLAY and WAYLAND_DISPLAY are unset), so no viewer window;" \
     "rendering $scene headless to out/render.png instead (xvfb-run -a ./run.sh runs the viewer" \
     "on a virtual display)." >&2
mkdir -p "$root/out"
"$build/raypack-cli" render "$scene" --device gpu --out "$root/out/render.png"
