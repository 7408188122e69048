#!/usr/bin/env bash
# Installs the Debian 12 packages raypack needs, only those missing. Needs root or sudo.
set -euo pipefail
packages=(
  cmake ninja-build g++ pkg-config git
  libglm-dev libtinygltf-dev nlohmann-json3-dev libtinyobjloader-dev libstb-dev libcli11-dev
  libtbb-dev libgtest-dev
  libvulkan-dev mesa-vulkan-drivers glslang-tools vulkan-validationlayers
  libglfw3-dev libimgui-dev xvfb xauth xdotool
  libembree-dev python3 python3-matplotlib ccache
  clang libclang-rt-14-dev clang-format
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  exit 0
fi
echo "raypack: installing ${missing[*]}"
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "raypack: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  sudo=sudo
fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
