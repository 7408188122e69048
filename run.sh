#!/usr/bin/env bash
# Installs what is missing, builds in Release and runs raypack on SCENE (default: the bundled scene).
set -euo pipefail
root=$(cd "$(dirname "$0")" && pwd)
"$root/scripts/install-deps.sh"
"$root/scripts/build.sh"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
scene=${1:-$root/scenes/data/default.ply}
build=${RAYPACK_BUILD_DIR:-$root/build}
mkdir -p "$root/out"
"$build/raypack-cli" render "$scene" --out "$root/out/render.png"
