# Sourced on the lent GPU machine (no Debian packages there) from the repository root:
# unpacks the carried Vulkan loader and glvnd (.gl/*.deb), the validation layer (.gl/extra; both
# made here by scripts/device-gl.sh) and points the loader at the NVIDIA driver; programs and their
# libraries come from .device/ (scripts/device-bundle.sh).
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
mkdir -p /opt/vvl
for f in .gl/extra/*.deb; do dpkg -x "$f" /opt/vvl; done
export LD_LIBRARY_PATH=$PWD/.device/lib:/opt/vvl/usr/lib/x86_64-linux-gnu
export VK_LAYER_PATH=/opt/vvl/usr/share/vulkan/explicit_layer.d
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -f "$icd" ]; then export VK_DRIVER_FILES=$icd VK_ICD_FILENAMES=$icd; fi
export XDG_RUNTIME_DIR=/tmp
