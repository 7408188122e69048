#!/usr/bin/env bash
# Builds a variant of build/raypack-cli for measuring a kernel or tree variant beside the build
# itself in one device call (scripts/device-pack.sh BUILD /tmp/v-NAME/raypack-cli-NAME ...):
# trace.comp compiled with SHADER_MACRO (glslangValidator -D..., "" for none) and
# renderer/gpu_wide.cpp, renderer/gpu_tracer.cpp and renderer/vk/context.cpp with HOST_MACRO (a
# compiler -D..., "" for none), linked against the rest of build/'s objects, into
# /tmp/v-NAME/raypack-cli-NAME. build/ must be a current Release build.
#   scripts/variant-cli.sh NAME SHADER_MACRO HOST_MACRO
# SHADER_REV=COMMIT in the environment compiles the working tree's shaders with that commit's own
# changes to shaders/ applied (git diff COMMIT^ COMMIT): a kernel variant kept in a commit that was
# reverted, measured against the build as it is now (the host side stays the working tree's, so
# the change may not touch bindings or specialization constants).
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: scripts/variant-cli.sh NAME SHADER_MACRO HOST_MACRO" >&2; exit 2; }
root=$(cd "$(dirname "$0")/.." && pwd)
name=$1 sm=$2 hm=$3
d=/tmp/v-$name; rm -rf $d; mkdir -p $d/shaders
cp $root/build/libraypack.a $d/libraypack.a
CXX="/usr/bin/c++ -DGLM_ENABLE_EXPERIMENTAL -DGLM_FORCE_XYZW_ONLY -DRAYPACK_HAVE_EMBREE=1 -I$root -isystem /usr/include/stb -O3 -DNDEBUG -ffp-contract=off -fno-fast-math -std=c++20"
cd $root
src=shaders
if [ -n "${SHADER_REV:-}" ]; then
  mkdir -p $d/rev && cp -r $root/shaders $d/rev/
  git -C $root diff "$SHADER_REV^" "$SHADER_REV" -- shaders > $d/rev/variant.diff
  [ -s $d/rev/variant.diff ] || { echo "variant-cli: $SHADER_REV changes nothing under shaders/" >&2; exit 2; }
  (cd $d/rev && git apply variant.diff) || { echo "variant-cli: $SHADER_REV's change does not apply to the working tree's shaders" >&2; exit 2; }
  src=$d/rev/shaders
fi
if [ -n "$sm" ] || [ -n "${SHADER_REV:-}" ]; then
  glslangValidator -V --target-env vulkan1.2 -I$src $sm --vn trace_spv -o $d/shaders/trace.spv.h $src/trace.comp > /dev/null
  # The module with doubles too: where a device's doubles are fast (the H100 and H200), primary
  # passes run that one (gpu_tracer.cpp, key.float64); without it a variant's primary figures
  # would be the build's own.
  glslangValidator -V --target-env vulkan1.2 -I$src -DRP_FLOAT64=1 $sm --vn trace_f64_spv \
    -o $d/shaders/trace_f64.spv.h $src/trace.comp > /dev/null
fi
if [ -n "$sm" ] || [ -n "$hm" ] || [ -n "${SHADER_REV:-}" ]; then
  $CXX -I$d/shaders -I$root/build/shaders $hm -c renderer/gpu_tracer.cpp -o $d/gpu_tracer.cpp.o
  (cd $d && ar r libraypack.a gpu_tracer.cpp.o)
fi
if [ -n "$hm" ]; then
  $CXX -I$root/build/shaders $hm -c renderer/gpu_wide.cpp -o $d/gpu_wide.cpp.o
  $CXX -I$root/build/shaders $hm -c renderer/vk/context.cpp -o $d/context.cpp.o
  (cd $d && ar r libraypack.a gpu_wide.cpp.o context.cpp.o)
fi
(cd $root/build && ninja -t commands raypack-cli | tail -1) > /tmp/link.sh
cd $root/build
sed -e "s# libraypack\.a # $d/libraypack.a #g" -e "s#-o raypack-cli #-o $d/raypack-cli-$name #" /tmp/link.sh > $d/link.sh
bash $d/link.sh
ls -la $d/raypack-cli-$name
