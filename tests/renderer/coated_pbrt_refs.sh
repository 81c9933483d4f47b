#!/usr/bin/env bash
# Renders the coated-sphere cases of tests/renderer/test_coated_render.cpp with pbrt-v4 (the
# oracle in ../shared/tools/pbrt-v4) and prints the table of reference means that the test
# holds. Each case is rendered SEEDS times (independent sampler, SPP samples per pixel, the
# scene of coated_sphere.pbrt.in); the reference is the mean over the seeds of the mean of the
# sphere's pixels (centres within 21 pixels of the image centre), its noise the standard error
# of that mean over the seeds.
#
#   tests/renderer/coated_pbrt_refs.sh [--spp N] [--seeds K]     (defaults: 1024, 4)
#
# Needs pbrt-v4 (PBRT=... to override), oiiotool (OpenImageIO, to read the EXRs) and python3.
# About 10 minutes on 2 cores.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
PBRT="${PBRT:-$here/../../../shared/tools/pbrt-v4/bin/pbrt}"
SPP=1024
SEEDS=4
while [ $# -gt 0 ]; do
    case "$1" in
        --spp) SPP="$2"; shift 2 ;;
        --seeds) SEEDS="$2"; shift 2 ;;
        *) echo "usage: $0 [--spp N] [--seeds K]" >&2; exit 2 ;;
    esac
done
[ -x "$PBRT" ] || { echo "$0: no pbrt-v4 at $PBRT (set PBRT=...)" >&2; exit 2; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# name|Material line (keep in sync with kCases in test_coated_render.cpp: this script prints
# the whole table).
cases=(
    'diffuse_0.9|Material "diffuse" "rgb reflectance" [ 0.9 0.9 0.9 ]'
    'coateddiffuse_0.5_r0.001|Material "coateddiffuse" "rgb reflectance" [ 0.5 0.5 0.5 ] "float roughness" [ 0.001 ]'
    'coateddiffuse_0.9_r0.001|Material "coateddiffuse" "rgb reflectance" [ 0.9 0.9 0.9 ] "float roughness" [ 0.001 ]'
    'coateddiffuse_0.5_r0.2|Material "coateddiffuse" "rgb reflectance" [ 0.5 0.5 0.5 ] "float roughness" [ 0.2 ]'
    'coateddiffuse_0.9_r0.2|Material "coateddiffuse" "rgb reflectance" [ 0.9 0.9 0.9 ] "float roughness" [ 0.2 ]'
    'coateddiffuse_1.0_r0.25|Material "coateddiffuse" "rgb reflectance" [ 1 1 1 ] "float roughness" [ 0.25 ]'
    'coateddiffuse_medium|Material "coateddiffuse" "rgb reflectance" [ 0.8 0.8 0.8 ] "float roughness" [ 0.1 ] "float thickness" [ 0.3 ] "rgb albedo" [ 0.7 0.7 0.7 ] "float g" [ 0.5 ]'
    'coatedconductor_smooth_coat|Material "coatedconductor" "rgb reflectance" [ 0.9 0.9 0.9 ] "float interface.roughness" [ 0 ] "float conductor.roughness" [ 0.2 ]'
    'coatedconductor_rough|Material "coatedconductor" "rgb reflectance" [ 0.8 0.8 0.8 ] "float interface.roughness" [ 0.1 ] "float conductor.roughness" [ 0.05 ] "float thickness" [ 0.1 ] "rgb albedo" [ 0.5 0.5 0.5 ]'
)

# Mean of the sphere's pixels of an EXR (through a FITS copy: plain big-endian floats).
sphere_mean() {
    oiiotool "$1" --ch R,G,B -d float -o "$1.fits"
    python3 - "$1.fits" <<'PY'
import math, struct, sys
data = open(sys.argv[1], 'rb').read()
hdr, off = {}, 0
while 'END' not in hdr:
    for i in range(0, 2880, 80):
        card = data[off + i:off + i + 80].decode('ascii')
        key = card[:8].strip()
        hdr[key] = card[10:].split('/')[0].strip() if card[8:10] == '= ' else ''
        if key == 'END':
            break
    off += 2880
c, w, h = int(hdr['NAXIS1']), int(hdr['NAXIS2']), int(hdr['NAXIS3'])
v = struct.unpack('>%df' % (c * w * h), data[off:off + 4 * c * w * h])
s, n = 0.0, 0
for y in range(h):
    for x in range(w):
        if math.hypot(x + 0.5 - w / 2, y + 0.5 - h / 2) <= 21.0:
            i = (y * w + x) * c
            s += (v[i] + v[i + 1] + v[i + 2]) / 3
            n += 1
print('%.7f' % (s / n))
PY
}

echo "    // pbrt-v4 ($PBRT), $SEEDS seeds x $SPP spp, 64x64"
for entry in "${cases[@]}"; do
    name="${entry%%|*}"
    material="${entry#*|}"
    means=()
    for seed in $(seq 1 "$SEEDS"); do
        sed "s|@MATERIAL@|$material|" "$here/coated_sphere.pbrt.in" > "$tmp/$name.pbrt"
        "$PBRT" --spp "$SPP" --seed "$seed" --nthreads 2 --quiet \
            --outfile "$tmp/$name.$seed.exr" "$tmp/$name.pbrt"
        means+=("$(sphere_mean "$tmp/$name.$seed.exr")")
    done
    python3 - "$name" "$material" "${means[@]}" <<'PY'
import math, sys
name, material, m = sys.argv[1], sys.argv[2], [float(x) for x in sys.argv[3:]]
mean = sum(m) / len(m)
se = math.sqrt(sum((x - mean) ** 2 for x in m) / (len(m) - 1) / len(m)) if len(m) > 1 else 0
esc = material.replace('\\', '\\\\').replace('"', '\\"')
print('    {"%s",\n     "%s",\n     %.5f, %.5f},' % (name, esc, mean, se))
PY
done
