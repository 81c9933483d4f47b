#!/usr/bin/env bash
# Bit-identity of two Tessera builds: renders every example and every scene under ../shared/scenes
# with both binaries (--deterministic, 64x64, 16 spp, the default adaptive sampler and uniform),
# and every real-time frame plugin on examples/realtime (3 frames with an orbit), then compares
# each pair with `tessera diff` and prints one line per image. Exit 1 when any pair differs.
#
#   scripts/compare_builds.sh BEFORE_BINARY AFTER_BINARY [OUTDIR]
#
# A refactoring that must not change behaviour passes with "identical" on every line (MSE 0).
set -euo pipefail

before="${1:?usage: compare_builds.sh BEFORE_BINARY AFTER_BINARY [OUTDIR]}"
after="${2:?usage: compare_builds.sh BEFORE_BINARY AFTER_BINARY [OUTDIR]}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${3:-$(mktemp -d)}"
shared="$root/../shared/scenes"
threads="${THREADS:-2}"
mkdir -p "$out/before" "$out/after"

scenes=()
for s in "$root"/examples/*/*.pbrt; do scenes+=("$s"); done
if [[ -d "$shared" ]]; then
  while IFS= read -r s; do scenes+=("$s"); done < <(
    find "$shared" -maxdepth 3 \( -name 'scene-v4.pbrt' -o -name '*.obj' -o -name 'bunny.ply' \) | sort)
else
  echo "compare_builds: no $shared, examples only"
fi

differ=0
json_keys() {  # every key path of a JSON file, one per line
  python3 -c 'import json, sys
def walk(v, p):
    if isinstance(v, dict):
        for k in sorted(v): yield from walk(v[k], p + "/" + k)
    else: yield p
print("\n".join(walk(json.load(open(sys.argv[1])), "")))' "$1"
}
compare() {  # name, then the render arguments
  local name="$1"; shift
  local side bin
  for side in before after; do
    if [[ $side == before ]]; then bin="$before"; else bin="$after"; fi
    "$bin" render "$@" -o "$out/$side/$name.exr" --stats "$out/$side/$name.json" --quiet \
      > "$out/$side/$name.log" 2>&1 || true
  done
  # The stats JSON keeps its keys (values such as timings differ from run to run).
  if [[ -f "$out/before/$name.json" ]] && ! cmp -s <(json_keys "$out/before/$name.json") \
       <(json_keys "$out/after/$name.json" 2>/dev/null); then
    echo "DIFFERENT (stats keys) $name"; differ=1
  fi
  if [[ ! -f "$out/before/$name.exr" || ! -f "$out/after/$name.exr" ]]; then
    if cmp -s <(sed 's#.*/##' "$out/before/$name.log") <(sed 's#.*/##' "$out/after/$name.log"); then
      echo "no image (same error) $name"
    else
      echo "DIFFERENT (error) $name"; differ=1
    fi
    return
  fi
  if cmp -s "$out/before/$name.exr" "$out/after/$name.exr"; then
    echo "identical (bytes) $name"
    return
  fi
  local d
  d="$("$after" diff "$out/after/$name.exr" "$out/before/$name.exr")"
  if [[ "$(awk '$1 == "MSE" { print $2 + $3 + $4 }' <<<"$d")" == "0" ]]; then
    echo "identical (MSE 0) $name"
  else
    echo "DIFFERENT $name: $(tr '\n' ' ' <<<"$d")"; differ=1
  fi
}

for s in "${scenes[@]}"; do
  rel="${s#"$root"/}"; rel="${rel#../shared/scenes/}"; rel="${rel#"$shared"/}"
  tag="$(tr '/.' '__' <<<"$rel")"
  for sampler in adaptive uniform; do
    compare "$tag-$sampler" "$s" --deterministic --resolution 64x64 --spp 16 \
      --sampler "$sampler" --threads "$threads"
  done
done
for s in "$root"/examples/realtime/*.pbrt; do
  tag="$(basename "$s" .pbrt)"
  for plugin in fixed:spp=4 jin kim fliptri flipquad suffern; do
    compare "$tag-${plugin%%:*}" "$s" --resolution 96x64 --sampler "$plugin" --frames 3 \
      --orbit 10 --threads "$threads"
  done
done
exit "$differ"
