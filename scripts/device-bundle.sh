#!/usr/bin/env bash
# Packs built programs and the shared libraries they need (but glibc and the C++ runtime, which the target has in a newer version) into a folder that can be
# carried to a machine without Debian's packages, e.g. the lent GPU machine. Usage:
#   scripts/device-bundle.sh OUT_DIR BINARY...
# Run there with: LD_LIBRARY_PATH=OUT_DIR/lib OUT_DIR/bin/raypack-cli ...
set -euo pipefail
out=$1
shift
mkdir -p "$out/bin" "$out/lib"
for bin in "$@"; do
  cp "$bin" "$out/bin/"
  ldd "$bin" | awk '/=> \//{print $3}' | while read -r lib; do
    case $(basename "$lib") in
      libc.so.*|libm.so.*|libstdc++.so.*|libgcc_s.so.*|libpthread.so.*|libdl.so.*|librt.so.*|ld-linux*) ;;
      *) cp -L "$lib" "$out/lib/" ;;
    esac
  done
done
du -sh "$out"
