# Sourced by the device benchmark scripts from the repository root on the lent GPU machine:
#   source scripts/device-start.sh "$0" "${1:-}"
# Sets `out` to the script's OUT_DIR argument, else $OUT, and creates it (without either it prints
# the script's usage and exits 2); unpacks the carried bundle (.device/round.tar.xz,
# scripts/device-pack.sh) unless .device/bin is there already; sources scripts/device-env.sh, its
# output in OUT/env.log.
out=${2:-${OUT:-}}
if [ -z "$out" ]; then
  echo "usage: $1 OUT_DIR" >&2
  exit 2
fi
mkdir -p "$out"
if [ ! -d .device/bin ] && [ -f .device/round.tar.xz ]; then tar xJf .device/round.tar.xz; fi
source scripts/device-env.sh > "$out/env.log" 2>&1
