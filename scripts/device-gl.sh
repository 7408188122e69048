#!/usr/bin/env bash
# Fills .gl/ (ignored by git) with what scripts/device-env.sh unpacks on the lent GPU machine, which
# has no package registry: Debian 12's Vulkan loader and glvnd packages in .gl/, the Vulkan
# validation layer in .gl/extra/. Run once here, from the repository root; then carry ".gl" (with
# ".device", scripts/device-pack.sh) in every device call.
#   scripts/device-gl.sh
set -euo pipefail
mkdir -p .gl/extra /tmp/raypack-apt-amd64/partial
apt=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/raypack-apt-amd64)
apt-get "${apt[@]}" update > /dev/null
(cd .gl && apt-get "${apt[@]}" download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
(cd .gl/extra && apt-get "${apt[@]}" download vulkan-validationlayers)
ls -l .gl .gl/extra
