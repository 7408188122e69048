#!/usr/bin/env bash
# Packs the fuzz targets (built by scripts/fuzz.sh or cmake -DRAYPACK_FUZZ=ON), the shared
# libraries they need that a machine without Debian's packages may lack (scripts/device-bundle.sh),
# the seed corpora (scripts/fuzz-seeds.py) and optionally a corpus grown earlier into one tarball for scripts/device-fuzz.sh:
#   scripts/device-fuzz-bundle.sh OUT.tar.gz [CORPUS_DIR]
# CORPUS_DIR holds one folder per target (e.g. the corpus/ of a fuzz-result.tar.gz).
# Environment: RAYPACK_FUZZ_BUILD_DIR (default build-fuzz).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=$(realpath -m "$1")
corpus=${2:-}
build=${RAYPACK_FUZZ_BUILD_DIR:-$root/build-fuzz}
targets=(ply obj gltf glb settings_json hits png)
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
binaries=()
for target in "${targets[@]}"; do binaries+=("$build/tests/fuzz/fuzz_$target"); done
# No llvm-symbolizer: it needs libLLVM (about 100 MB), over what a call may carry. Reports there
# name addresses; a finding is reproduced and symbolized here.
"$root/scripts/device-bundle.sh" "$stage" "${binaries[@]}" >/dev/null
python3 "$root/scripts/fuzz-seeds.py" "$stage/seeds" >/dev/null
mkdir -p "$stage/corpus"
if [ -n "$corpus" ]; then cp -r "$corpus"/. "$stage/corpus/"; fi
cp "$root/scripts/device-fuzz.sh" "$stage/"
mkdir -p "$(dirname "$out")"
tar czf "$out" -C "$stage" .
echo "$out: $(du -h "$out" | cut -f1); $(ls "$stage/lib" | wc -l) libraries, $(find "$stage/corpus" -type f | wc -l) corpus files"
