#!/usr/bin/env bash
# CLI contract tests for `tessera` (run by ctest, one case per test):
#
#   tests/cli/cli_contract.sh /path/to/tessera CASE
#
# Bad input must exit with code 2, print "file:line: message" on stderr and leave no output
# file behind (no EXR, no PNG, no stats JSON, no *.tmp-* temporary). A good scene must exit 0 and
# write EXR + PNG + the --stats JSON. Every case works in its own temporary folder, removed on
# exit. Prints "PASS" or "FAIL: why" and exits 0 / 1.
set -uo pipefail

tessera="${1:?usage: cli_contract.sh TESSERA CASE}"
case_name="${2:?usage: cli_contract.sh TESSERA CASE}"
[[ -x "$tessera" ]] || { echo "FAIL: $tessera is not an executable"; exit 1; }
# The cases run in a temporary folder: make the path absolute first.
tessera="$(cd "$(dirname "$tessera")" && pwd)/$(basename "$tessera")"

tmp="$(mktemp -d "${TMPDIR:-/tmp}/tessera-cli-XXXXXX")"
trap 'rm -rf "$tmp"' EXIT
cd "$tmp" || exit 1

fail() {
    echo "FAIL [$case_name]: $*"
    if [[ -s stdout.txt ]]; then echo "--- stdout"; cat stdout.txt; fi
    if [[ -s stderr.txt ]]; then echo "--- stderr"; cat stderr.txt; fi
    exit 1
}

# run ARGS...: runs tessera with a time limit ($limit_s, default 60 s), stdout/stderr captured,
# sets $rc.
limit_s=60
run() {
    timeout "$limit_s" "$tessera" "$@" >stdout.txt 2>stderr.txt
    rc=$?
    if [[ $rc -eq 124 ]]; then fail "tessera $* did not finish within $limit_s s"; fi
}

expect_rc() {
    [[ $rc -eq $1 ]] || fail "expected exit code $1, got $rc"
}

# expect_stderr_line REGEX: some line of stderr matches the (extended) regex.
expect_stderr_line() {
    grep -Eq -- "$1" stderr.txt || fail "no stderr line matches /$1/"
}

# expect_no_output STEM: neither STEM.exr, STEM.png, out.json nor any *.tmp-* exists.
expect_no_output() {
    local stem="$1"
    for f in "$stem.exr" "$stem.png" out.json; do
        [[ ! -e "$f" ]] || fail "bad input left an output file behind: $f"
    done
    local leftovers
    leftovers="$(find . -name '*.tmp-*' -print)"
    [[ -z "$leftovers" ]] || fail "temporary files left behind: $leftovers"
}

# A tiny scene: 16x16, 4 spp, a diffuse quad lit by a quad area light. Line numbers of the
# bad variants below refer to this layout, so keep it stable.
write_good_scene() {
    cat >"$1" <<'PBRT'
LookAt 0 0 -3  0 0 0  0 1 0
Camera "perspective" "float fov" [ 45 ]
Film "rgb" "integer xresolution" [ 16 ] "integer yresolution" [ 16 ]
    "string filename" [ "fromscene.exr" ]
Sampler "zsobol" "integer pixelsamples" [ 4 ]
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 4 4 4 ]
  Shape "trianglemesh" "point3 P" [ -0.5 1 -0.5  0.5 1 -0.5  0.5 1 0.5  -0.5 1 0.5 ]
      "integer indices" [ 0 1 2  0 2 3 ]
AttributeEnd
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "trianglemesh" "point3 P" [ -1 -1 1  1 -1 1  1 1 1  -1 1 1 ]
    "integer indices" [ 0 1 2  0 2 3 ]
PBRT
}

# Writes the good scene with line $2 replaced by $3.
write_scene_with_line() {
    write_good_scene "$1.orig"
    awk -v n="$2" -v s="$3" 'NR == n { print s; next } { print }' "$1.orig" >"$1"
    rm -f "$1.orig"
}

bad_render() {
    # bad_render SCENE: renders to out.exr with stats; expects exit 2 and no output.
    run render "$1" -o out.exr --stats out.json --spp 1 -q
    expect_rc 2
    expect_no_output out
}

case "$case_name" in
missing_scene)
    run render "$tmp/nope.pbrt" -o out.exr --stats out.json -q
    expect_rc 2
    expect_stderr_line "^$tmp/nope\\.pbrt:[0-9]+: "
    expect_no_output out
    ;;
syntax_error)
    # Line 12: a number expected, a word found.
    write_scene_with_line scene.pbrt 12 'Translate 0 0 oops'
    bad_render scene.pbrt
    expect_stderr_line '^scene\.pbrt:12: .*oops'
    ;;
unterminated_string)
    # The error names the line where the string starts.
    write_scene_with_line scene.pbrt 12 'Material "diffuse'
    bad_render scene.pbrt
    expect_stderr_line '^scene\.pbrt:12: .*unterminated string'
    ;;
unknown_directive)
    write_scene_with_line scene.pbrt 12 'Frobnicate "diffuse"'
    bad_render scene.pbrt
    expect_stderr_line "^scene\\.pbrt:12: .*Frobnicate"
    ;;
unknown_material)
    # An undefined named material: pbrt reports it at the shape that uses it (line 13).
    write_scene_with_line scene.pbrt 12 'NamedMaterial "nosuchmaterial"'
    bad_render scene.pbrt
    expect_stderr_line '^scene\.pbrt:13: .*nosuchmaterial'
    ;;
include_error)
    # An error in an included file names that file (as the including file wrote it) and its line.
    write_scene_with_line scene.pbrt 12 'Include "parts/extra.pbrt"'
    mkdir parts
    printf '# extra geometry\nShape "sphere" "float radius" [ 0.2 ]\nBogus 1\n' >parts/extra.pbrt
    bad_render scene.pbrt
    expect_stderr_line "^parts/extra\\.pbrt:3: .*Bogus"
    ;;
missing_ply)
    write_scene_with_line scene.pbrt 13 'Shape "plymesh" "string filename" [ "meshes/missing.ply" ]'
    # Line 14 held the rest of the replaced trianglemesh; make it a comment.
    sed -i '14s/^/# /' scene.pbrt
    bad_render scene.pbrt
    expect_stderr_line '^scene\.pbrt:13: .*missing\.ply'
    ;;
bad_resolution)
    write_good_scene scene.pbrt
    for r in abc 0x16 16x-4; do
        run render scene.pbrt -o out.exr --stats out.json --resolution "$r" -q
        expect_rc 2
        expect_stderr_line '--resolution'
        expect_no_output out
    done
    ;;
good_scene)
    write_good_scene scene.pbrt
    run render scene.pbrt -o out.exr --stats out.json --threads 2 -q
    expect_rc 0
    for f in out.exr out.png out.json; do [[ -s "$f" ]] || fail "$f was not written"; done
    leftovers="$(find . -name '*.tmp-*' -print)"
    [[ -z "$leftovers" ]] || fail "temporary files left behind: $leftovers"
    python3 - out.json <<'PY' || fail "stats JSON check failed"
import json, math, sys
s = json.load(open(sys.argv[1]))
missing = [k for k in ("wall_s", "samples", "rays", "spp", "nan_count", "threads") if k not in s]
assert not missing, f"missing keys {missing}"
assert s["spp"] == 4, s["spp"]
assert s["samples"] == 16 * 16 * 4, s["samples"]
assert s["rays"] >= s["samples"], (s["rays"], s["samples"])
assert s["nan_count"] == 0, s["nan_count"]
assert s["threads"] >= 1, s["threads"]
assert math.isfinite(s["wall_s"]) and s["wall_s"] >= 0, s["wall_s"]
assert s["catch_up_passes"] == 0, s["catch_up_passes"]  # every pixel at --spp after pass 0
PY
    # Without -o the scene's Film "filename" is used (relative to the current folder).
    run render scene.pbrt --spp 1 -q
    expect_rc 0
    [[ -s fromscene.exr && -s fromscene.png ]] || fail "Film \"filename\" was not used"
    # A scene that reads no image never loads OpenImageIO (its ~270 libraries cost 0.3 s at
    # start-up): the EXR and PNG are written with OpenEXR and libpng (docs/ARCHITECTURE.md).
    LD_DEBUG=files timeout 60 "$tessera" render scene.pbrt -o lean.exr --spp 1 -q \
        >stdout.txt 2>ld.txt
    rc=$?
    expect_rc 0
    [[ -s lean.exr && -s lean.png ]] || fail "lean.exr / lean.png were not written"
    grep -q 'file=.*libOpenImageIO' ld.txt && fail "a render without images loaded OpenImageIO"
    grep -q 'file=.*libembree' ld.txt || fail "LD_DEBUG=files did not list libraries"
    ;;
media_scene)
    # A scene with a medium (a fog sphere around the good scene's quad) runs the volumetric path
    # tracer under everything else unchanged: the default adaptive sampler, AOVs, the same bits
    # for any thread count (--deterministic), a checkpoint and its resume, and converge. The
    # stats name the medium and the code path.
    write_good_scene scene.pbrt
    cat >>scene.pbrt <<'PBRT'
MakeNamedMedium "fog" "string type" "homogeneous" "rgb sigma_s" [ 0.8 0.8 0.8 ]
    "rgb sigma_a" [ 0.1 0.1 0.1 ] "float g" [ 0.4 ]
AttributeBegin
  MediumInterface "fog" ""
  Material "interface"
  Shape "sphere" "float radius" [ 0.8 ]
AttributeEnd
PBRT
    sed 's/^Film "rgb"/Film "gbuffer"/' scene.pbrt >g.pbrt
    run render g.pbrt -o adaptive.exr --stats adaptive.json --time 1 -q
    expect_rc 0
    python3 - adaptive.json <<'PY' || fail "stats JSON check failed"
import json, sys
s = json.load(open(sys.argv[1]))
assert "media" in s["features"], s["features"]
assert s["code_path"].startswith("volumetric path tracer"), s["code_path"]
assert s["aovs"] == ["albedo", "normal", "depth"], s["aovs"]
assert s["specializations"]["used"] == "differentials,alpha", s["specializations"]
PY
    head -c 2048 adaptive.exr | grep -aq depth.Z || fail "adaptive.exr lacks the depth AOV"
    # --deterministic: the same bits for one thread and for two.
    run render g.pbrt -o one.exr --spp 16 --deterministic --threads 1 -q
    expect_rc 0
    run render g.pbrt -o two.exr --spp 16 --deterministic --threads 2 -q
    expect_rc 0
    run diff one.exr two.exr
    expect_rc 0
    awk '$1 == "MSE" { found = 1; for (i = 2; i <= NF; ++i) if ($i + 0 != 0) bad = 1 }
         END { exit !(found && !bad) }' stdout.txt || fail "1 and 2 threads differ"
    # A checkpoint resumes (to twice the samples) and keeps the AOVs.
    run render g.pbrt -o half.exr --spp 16 --sampler uniform --threads 2 -q \
        --checkpoint half.ckpt.exr
    expect_rc 0
    run render g.pbrt -o resumed.exr --spp 32 --sampler uniform --threads 2 -q \
        --resume half.ckpt.exr
    expect_rc 0
    head -c 2048 resumed.exr | grep -aq albedo.R || fail "resumed.exr lacks the albedo AOV"
    run converge scene.pbrt --sampler uniform --sampler adaptive --time 0.5 --snapshots 3 \
        --reference-spp 16 --cache-dir cache --threads 2 -o conv --no-report -q
    expect_rc 0
    [[ -s conv/convergence.csv ]] || fail "converge wrote no CSV"
    ;;
resume_adaptive)
    # A render too short to adapt (--spp 4: one pass) writes no prefix snapshots; resuming it
    # with the default sampler at a larger --spp must continue it (the film rebuilds what it
    # can of them), to an image like a direct render's.
    write_good_scene scene.pbrt
    run render scene.pbrt -o short.exr --resolution 64x64 --spp 4 --threads 2 -q \
        --checkpoint short.ckpt.exr
    expect_rc 0
    [[ -s short.ckpt.exr ]] || fail "no checkpoint written"
    run render scene.pbrt -o resumed.exr --resolution 64x64 --spp 64 --threads 2 -q \
        --resume short.ckpt.exr --stats resumed.json
    expect_rc 0
    run render scene.pbrt -o direct.exr --resolution 64x64 --spp 64 --threads 2 -q \
        --stats direct.json
    expect_rc 0
    python3 - resumed.json direct.json <<'PY' || fail "resumed render did not continue"
import json, sys
r, d = (json.load(open(f)) for f in sys.argv[1:3])
# It went on past the checkpoint's 4 samples a pixel, to about the direct render's count.
assert r["samples"] > 4 * 64 * 64 * 2, r["samples"]
assert 0.5 < r["samples"] / d["samples"] < 2.0, (r["samples"], d["samples"])
PY
    run diff resumed.exr direct.exr
    expect_rc 0
    # The two images estimate the same one: their means agree to 2%.
    awk '$1 == "mean(A)" { a = $NF } $1 == "mean(B)" { b = $NF }
         END { exit !(b > 0 && a / b > 0.98 && a / b < 1.02) }' stdout.txt ||
        fail "resumed and direct images differ: $(grep mean stdout.txt)"
    ;;
diff_same)
    write_good_scene scene.pbrt
    run render scene.pbrt -o a.exr -q
    expect_rc 0
    run diff a.exr a.exr
    expect_rc 0
    awk '$1 == "MSE" { found = 1; for (i = 2; i <= NF; ++i) if ($i + 0 != 0) bad = 1 }
         END { exit !(found && !bad) }' stdout.txt || fail "diff of an image with itself: MSE not 0"
    ;;
diff_size_mismatch)
    write_good_scene scene.pbrt
    run render scene.pbrt -o a.exr --no-png -q
    expect_rc 0
    run render scene.pbrt -o b.exr --no-png --resolution 8x8 -q
    expect_rc 0
    run diff a.exr b.exr
    expect_rc 2
    ;;
diff_missing_file)
    run diff nope-a.exr nope-b.exr
    expect_rc 2
    ;;
version)
    run --version
    expect_rc 0
    grep -Eq '^tessera [0-9]+\.[0-9]+' stdout.txt || fail "--version does not print the version"
    ;;
mpi_launch)
    # --version says whether MPI is built in. A build without it, launched as a rank of a job
    # of several (the launcher's environment), refuses instead of rendering the whole image on
    # every rank.
    run --version
    expect_rc 0
    grep -Eq '^MPI: ' stdout.txt || fail "--version does not say whether MPI is built in"
    if grep -q 'not built in' stdout.txt; then
        write_good_scene scene.pbrt
        OMPI_COMM_WORLD_SIZE=2 timeout 60 "$tessera" render scene.pbrt -o out.exr -q \
            >stdout.txt 2>stderr.txt
        rc=$?
        expect_rc 2
        expect_stderr_line "built without MPI"
        expect_no_output out
    fi
    ;;
unwritable_output)
    write_good_scene scene.pbrt
    # A render at this size would take minutes: the check must come before it.
    limit_s=15
    run render scene.pbrt -o /nonexistent/dir/x.exr --stats out.json \
        --resolution 4096x4096 --spp 4096 -q
    expect_rc 2
    expect_stderr_line '^/nonexistent/dir/x\.exr(:[0-9]+)?: '
    [[ ! -e out.json ]] || fail "stats were written although the render failed"
    ;;
unwritable_stats)
    # --stats into a folder that does not exist is bad input, found before rendering.
    write_good_scene scene.pbrt
    limit_s=15
    run render scene.pbrt -o out.exr --stats /nonexistent/dir/out.json \
        --resolution 4096x4096 --spp 4096 -q
    expect_rc 2
    expect_stderr_line '^/nonexistent/dir/out\.json(:[0-9]+)?: '
    expect_no_output out
    ;;
bad_ocio_config)
    # An OCIO config that cannot be read is bad input, found before rendering.
    write_good_scene scene.pbrt
    run render scene.pbrt -o out.exr --stats out.json --ocio-config "$tmp/missing.ocio" -q
    expect_rc 2
    expect_stderr_line 'missing\.ocio'
    expect_no_output out
    ;;
sigint)
    # Ctrl-C finishes the tiles in flight, then writes the image, a checkpoint and the stats,
    # and exits 0; --resume continues from that checkpoint.
    write_good_scene scene.pbrt
    "$tessera" render scene.pbrt -o out.exr --stats out.json --resolution 256x256 \
        --spp 1000000 --sampler uniform -q >stdout.txt 2>stderr.txt &
    pid=$!
    # A background job of a non-interactive shell starts with SIGINT ignored until tessera
    # installs its handler: on a loaded machine a single early signal was lost and the render
    # ran on until the ctest timeout. Repeat the signal until the process exits.
    sleep 1.5
    for _ in $(seq 1 100); do
        kill -INT "$pid" 2>/dev/null || break
        sleep 0.5
        kill -0 "$pid" 2>/dev/null || break
    done
    wait "$pid"
    rc=$?
    expect_rc 0
    for f in out.exr out.png out.json out.checkpoint.exr; do
        [[ -s "$f" ]] || fail "$f was not written after SIGINT"
    done
    python3 -c "import json,sys; s=json.load(open('out.json')); sys.exit(0 if s['cancelled'] else 1)" \
        || fail "stats do not say cancelled"
    run render scene.pbrt -o resumed.exr --resolution 256x256 --spp 4 --sampler uniform \
        --resume out.checkpoint.exr -q
    expect_rc 0
    [[ -s resumed.exr ]] || fail "resumed render wrote no image"
    ;;
samplers_list)
    run samplers
    expect_rc 0
    for name in uniform adaptive fixed jin kim fliptri flipquad suffern; do
        grep -Eq "^$name " stdout.txt || fail "tessera samplers does not list $name"
    done
    grep -Eq "tau_col=0.6" stdout.txt || fail "jin's tau_col default is not listed"
    ;;
bad_sampler_key)
    # An unknown key is an error naming the plugin and the key, before anything is rendered.
    write_good_scene scene.pbrt
    run render scene.pbrt -o out.exr --stats out.json --sampler jin:tau_bogus=1 -q
    expect_rc 2
    expect_stderr_line "sampler jin: unknown key \"tau_bogus\""
    expect_no_output out
    run render scene.pbrt -o out.exr --stats out.json --sampler fixed:spp=1000 -q
    expect_rc 2
    expect_stderr_line "sampler fixed: spp=1000 is outside"
    expect_no_output out
    run render scene.pbrt -o out.exr --stats out.json --sampler nosuch -q
    expect_rc 2
    expect_stderr_line 'unknown sampler "nosuch"'
    expect_no_output out
    run render scene.pbrt -o out.exr --stats out.json --sampler fixed --integrator nosuch -q
    expect_rc 2
    expect_stderr_line 'unknown integrator "nosuch"'
    expect_no_output out
    ;;
native_images)
    # A scene whose images are TGA, PFM or PNG renders without the image module (OpenImageIO;
    # renderer/util/native_image.h); an image of another format needs the module, and the error
    # says where it looked.
    examples="$(cd "$(dirname "${BASH_SOURCE[0]}")/../../examples" && pwd)"
    for s in textured environment; do
        TESSERA_IMAGE_MODULE=/nonexistent/libtessera_oiio.so \
            run render "$examples/$s/scene.pbrt" --spp 1 --resolution 32x24 -o "$s.exr" -q
        expect_rc 0
        [[ -s "$s.exr" && -s "$s.png" ]] || fail "$s: no EXR or PNG"
    done
    printf 'BM not really a bitmap' >tex.bmp
    write_scene_with_line scene.pbrt 12 \
        'Texture "t" "spectrum" "imagemap" "string filename" "tex.bmp" Material "diffuse" "texture reflectance" "t"'
    TESSERA_IMAGE_MODULE=/nonexistent/libtessera_oiio.so run render scene.pbrt -o out.exr --stats out.json -q
    expect_rc 2
    expect_stderr_line 'scene.pbrt:12: .*tex.bmp.*cannot load the image module'
    expect_no_output out
    ;;
no_specialize)
    # --no-specialize forces the general code paths: the same image, reported in --stats; a
    # bad name is an error naming the valid ones, before anything is rendered.
    write_good_scene scene.pbrt
    run render scene.pbrt -o spec.exr --stats spec.json --no-png -q
    expect_rc 0
    run render scene.pbrt -o gen.exr --stats gen.json --no-png -q --no-specialize
    expect_rc 0
    run render scene.pbrt -o one.exr --stats one.json --no-png -q --no-specialize=cull
    expect_rc 0
    python3 - spec.json gen.json one.json <<'PY' || fail "specialisation stats check failed"
import json, sys
spec, gen, one = (json.load(open(f)) for f in sys.argv[1:])
assert spec["specializations"]["forced_general"] == "none", spec["specializations"]
assert gen["specializations"]["used"] == "none", gen["specializations"]
assert one["specializations"]["forced_general"] == "cull", one["specializations"]
assert "cull" not in one["specializations"]["used"], one["specializations"]
assert spec["shadow_rays_avoided"] >= gen["shadow_rays_avoided"], (spec, gen)
assert "specialised:" in spec["code_path"], spec["code_path"]
PY
    run diff gen.exr spec.exr
    expect_rc 0
    grep -q '^MSE *0 *0 *0 *0$' stdout.txt || fail "general and specialised images differ"
    run render scene.pbrt -o out.exr --stats out.json -q --no-specialize=lambertian,bogus
    expect_rc 2
    expect_stderr_line 'unknown specialisation "bogus"'
    expect_no_output out
    ;;
bad_aov)
    # An unknown AOV name is an error before anything is rendered.
    write_good_scene scene.pbrt
    for a in bogus "albedo," "" "albedo,all" Depth; do
        run render scene.pbrt -o out.exr --stats out.json --aov "$a" -q
        expect_rc 2
        expect_stderr_line '^tessera: --aov: unknown AOV'
        expect_no_output out
    done
    ;;
aov_layers)
    # The EXR has the AOV layers asked for (--aov, else the Film type), the stats say which and
    # the film's real bytes per pixel; a resume keeps the checkpoint's AOVs.
    write_good_scene scene.pbrt
    # EXR channel names are plain text in the file header.
    has_layer() { head -c 2048 "$1" | grep -aq "$2"; }
    check_stats() {  # FILE AOVS-JSON BYTES
        python3 - "$1" "$2" "$3" <<'PY' || fail "stats JSON check failed: $*"
import json, sys
s = json.load(open(sys.argv[1]))
assert s["aovs"] == json.loads(sys.argv[2]), s["aovs"]
assert s["film_bytes_per_pixel"] == int(sys.argv[3]), s["film_bytes_per_pixel"]
PY
    }
    run render scene.pbrt -o none.exr --stats none.json -q
    expect_rc 0
    check_stats none.json '[]' 64
    for l in albedo.R normal.X depth.Z; do ! has_layer none.exr "$l" || fail "none.exr has $l"; done
    has_layer none.exr spp.Y || fail "none.exr lacks spp.Y"
    run render scene.pbrt -o some.exr --stats some.json --aov depth,normal -q
    expect_rc 0
    check_stats some.json '["normal", "depth"]' 80
    has_layer some.exr normal.X && has_layer some.exr depth.Z || fail "some.exr lacks a layer"
    ! has_layer some.exr albedo.R || fail "some.exr has albedo.R"
    sed 's/^Film "rgb"/Film "gbuffer"/' scene.pbrt >gbuffer.pbrt
    run render gbuffer.pbrt -o all.exr --stats all.json -q --checkpoint all.ckpt.exr
    expect_rc 0
    check_stats all.json '["albedo", "normal", "depth"]' 92
    ! grep -q 'warning' stderr.txt || fail "Film \"gbuffer\" warned"
    for l in albedo.R normal.X depth.Z; do has_layer all.exr "$l" || fail "all.exr lacks $l"; done
    run render gbuffer.pbrt -o none2.exr --stats none2.json --aov none -q
    expect_rc 0
    check_stats none2.json '[]' 64
    # Resuming takes the checkpoint's AOVs; asking for others is an error.
    run render scene.pbrt -o resumed.exr --stats resumed.json --spp 8 --resume all.ckpt.exr -q
    expect_rc 0
    check_stats resumed.json '["albedo", "normal", "depth"]' 92
    run render scene.pbrt -o out.exr --stats out.json --spp 8 --resume all.ckpt.exr --aov depth -q
    expect_rc 2
    expect_stderr_line '^--aov:0: the checkpoint all.ckpt.exr has the AOVs albedo,normal,depth'
    expect_no_output out
    ;;
realtime_frames)
    # A real-time sampler renders whole frames with the Whitted integrator and reports them.
    write_good_scene scene.pbrt
    run render scene.pbrt -o out.exr --stats out.json --sampler jin --frames 3 --orbit 20 -q
    expect_rc 0
    for f in out.exr out.png out.json; do [[ -s "$f" ]] || fail "$f was not written"; done
    python3 - out.json <<'PY' || fail "frame stats JSON check failed"
import json, math, sys
s = json.load(open(sys.argv[1]))
for k in ("frame_ms_median", "frame_ms_p95", "rays_per_pixel", "active_fraction"):
    assert k in s and math.isfinite(s[k]), k
assert s["frames"] == 3 and len(s["frame_ms"]) == 3, s["frames"]
assert s["integrator"] == "whitted", s["integrator"]
assert s["rays_per_pixel"] >= 1, s["rays_per_pixel"]
assert 0 <= s["active_fraction"] <= 1, s["active_fraction"]
assert "active_subpixels" in s["diagnostic_layers"], s["diagnostic_layers"]
# Per-stage medians over the frames without diagnostics, one per stage of the last frame.
names = [st["name"] for st in s["stages_last_frame"]]
assert [st["name"] for st in s["stages_ms_median"]] == names and names, s["stages_ms_median"]
assert all(math.isfinite(st["ms"]) and st["ms"] >= 0 for st in s["stages_ms_median"])
PY
    ;;
converge_good)
    # Two samplers for 0.6 s each against a rendered (and cached) reference: exit 0, the CSV,
    # the JSON and the images, the headline table on stdout, no temporaries.
    write_good_scene scene.pbrt
    run converge scene.pbrt --sampler uniform --sampler adaptive:error=0.01 --time 0.6 \
        --snapshots 4 --reference-spp 32 --cache-dir cache --threads 2 -o out --no-report -q
    expect_rc 0
    for f in out/convergence.csv out/convergence.json out/images/reference.png \
             out/images/0-uniform.exr out/images/1-adaptive-error-0.01.spp.pfm; do
        [[ -s "$f" ]] || fail "$f was not written"
    done
    grep -q '^time to reach relMSE-0.1% E' stdout.txt || fail "no headline table on stdout"
    grep -Eq '^adaptive:error=0.01 ' stdout.txt || fail "the table has no adaptive row"
    leftovers="$(find . -name '*.tmp-*' -print)"
    [[ -z "$leftovers" ]] || fail "temporary files left behind: $leftovers"
    python3 - out/convergence.json out/convergence.csv <<'PY' || fail "JSON/CSV check failed"
import csv, json, math, sys
j = json.load(open(sys.argv[1]))
rows = list(csv.DictReader(open(sys.argv[2])))
assert len(rows) == len(j["rows"]) >= 5, (len(rows), len(j["rows"]))
assert {r["sampler"] for r in rows} == {"uniform", "adaptive:error=0.01"}
for r in rows:
    for k in ("mse", "relmse", "rmse", "mae", "time_s", "mean_spp"):
        assert math.isfinite(float(r[k])), (k, r[k])
assert len(j["scene_hash"]) == 32 and j["hardware_threads"] >= 1
PY
    ;;
converge_cache)
    # The reference is rendered once, reused while the scene is unchanged, rebuilt after an edit.
    write_good_scene scene.pbrt
    args=(--sampler uniform --time 0.2 --snapshots 2 --reference-spp 16 --cache-dir cache
          --threads 2 --no-report)
    run converge scene.pbrt "${args[@]}" -o a
    expect_rc 0
    expect_stderr_line 'reference rendered and cached'
    run converge scene.pbrt "${args[@]}" -o b
    expect_rc 0
    expect_stderr_line 'reference reused from the cache'
    echo '# an edit' >>scene.pbrt
    run converge scene.pbrt "${args[@]}" -o c
    expect_rc 0
    expect_stderr_line 'reference rendered and cached'
    [[ $(find cache -name 'ref-*.exr' | wc -l) -eq 2 ]] || fail "expected 2 cached references"
    ;;
converge_missing_reference)
    write_good_scene scene.pbrt
    # --sampler before the scene takes one value: the scene is still the positional argument.
    run converge --sampler uniform scene.pbrt --reference nope.exr --time 1 -o out --no-report
    expect_rc 2
    expect_stderr_line '^nope\.exr:0: reference image not found'
    [[ ! -e out ]] || fail "the output folder was created for a bad reference"
    ;;
converge_reference_size)
    write_good_scene scene.pbrt
    run render scene.pbrt -o ref.exr --resolution 8x8 --no-png -q
    expect_rc 0
    run converge scene.pbrt --reference ref.exr --time 1 -o out --no-report
    expect_rc 2
    expect_stderr_line '^ref\.exr:0: the reference is 8x8 but the renders are 16x16'
    [[ ! -e out ]] || fail "the output folder was created for a bad reference"
    ;;
converge_reference_nan)
    # A 16x16 PFM reference with one NaN pixel.
    write_good_scene scene.pbrt
    python3 -c "
import struct
v = [0.5] * (16 * 16 * 3)
v[3 * (16 * 5 + 7)] = float('nan')
open('ref.pfm', 'wb').write(b'PF\n16 16\n-1.0\n' + struct.pack('<%df' % len(v), *v))"
    run converge scene.pbrt --reference ref.pfm --time 1 -o out --no-report
    expect_rc 2
    expect_stderr_line '^ref\.pfm:0: the reference has 1 non-finite values \(NaN or Inf\)'
    [[ ! -e out ]] || fail "the output folder was created for a bad reference"
    ;;
*)
    fail "unknown case"
    ;;
esac
echo "PASS [$case_name]"
