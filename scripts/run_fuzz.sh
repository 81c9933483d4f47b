#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz/fuzz_*.cpp) with clang under ASan+UBSan and runs each
# for a bounded time; fails when a target crashes, leaks, hangs, runs out of memory, or throws
# anything but a SceneError.
#
#   scripts/run_fuzz.sh [SECONDS_PER_TARGET]      (default 20: about a minute and a half for the four)
#
# Targets: fuzz_pbrt (scene tokenizer, parser and builder), fuzz_ply (PLY reader),
# fuzz_obj (OBJ/MTL via tinyobjloader), fuzz_image (the native TGA, PFM and PNG readers: the first
# byte of an input picks the format, the rest is the file). Seeds: the example scenes, the broken-scene corpus
# (tests/broken) and tests/fuzz/seeds; the corpus a run grows is kept in
# $FUZZ_BUILD_DIR/corpus/<target> for the next run. A crashing input is written to
# $FUZZ_BUILD_DIR/artifacts/; copy it to tests/fuzz/regressions/<pbrt|ply|obj>/ (with a name
# that says what it found) once fixed, so that the normal test suite replays it
# (tests/renderer/test_fuzz_regressions.cpp).
#
# Environment: FUZZ_BUILD_DIR (default build-fuzz), JOBS (default 2), CXX_FUZZ (default clang++),
# FUZZ_TARGETS (default "fuzz_pbrt fuzz_ply fuzz_obj fuzz_image"), FUZZ_ARGS (extra libFuzzer flags, e.g.
# "-jobs=2 -workers=2"). Needs the Debian packages clang and libclang-rt-dev (libFuzzer and the
# sanitizer runtimes); scripts/setup.sh installs them.
set -uo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seconds="${1:-20}"
build="${FUZZ_BUILD_DIR:-$root/build-fuzz}"
jobs="${JOBS:-2}"
cxx="${CXX_FUZZ:-clang++}"
targets=(${FUZZ_TARGETS:-fuzz_pbrt fuzz_ply fuzz_obj fuzz_image})

command -v "$cxx" >/dev/null || { echo "run_fuzz: $cxx not found (apt-get install clang)" >&2; exit 2; }

echo "== fuzz: configure and build $build"
# A build folder already configured for fuzzing (scripts/run_sanitizers.sh asan with clang) is
# used as it is: only the fuzz targets are left to link.
if ! grep -qs '^TESSERA_FUZZ:BOOL=ON' "$build/CMakeCache.txt"; then
    cmake -S "$root" -B "$build" -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=Debug \
        -DCMAKE_CXX_FLAGS_DEBUG="-g -O1" -DTESSERA_SANITIZE=ON -DTESSERA_FUZZ=ON \
        -DTESSERA_BUILD_TESTS=OFF -DTESSERA_BUILD_BENCHMARKS=OFF >/dev/null || exit 1
fi
cmake --build "$build" -j "$jobs" --target "${targets[@]}" || exit 1

# The seeds of a target, copied into one folder of the build tree: libFuzzer is given only
# build-tree folders, so that nothing it does can write into the source tree.
seeds_for() {
    local kind="${1#fuzz_}" dir="$build/seeds/${1#fuzz_}"
    rm -rf "$dir" && mkdir -p "$dir"
    local sources=("$root"/tests/fuzz/seeds/"$kind"/* "$root"/tests/fuzz/regressions/"$kind"/*)
    case "$kind" in
    pbrt) sources+=("$root"/examples/*/*.pbrt "$root"/tests/broken/*.pbrt "$root"/tests/broken/inc/*) ;;
    ply) sources+=("$root"/tests/broken/meshes/*.ply) ;;
    obj) sources+=("$root"/tests/broken/meshes/*.obj) ;;
    esac
    local f
    for f in "${sources[@]}"; do
        [[ -f "$f" && "$(basename "$f")" != README.md ]] || continue
        cp "$f" "$dir/$(basename "$(dirname "$f")")_$(basename "$f")"
    done
    echo "$dir"
}

# halt_on_error: a UBSan finding is a crash to libFuzzer. new_delete_type_mismatch=0: see
# tests/CMakeLists.txt (OpenImageIO's TextureSystem::destroy).
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:new_delete_type_mismatch=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$root/tests/lsan.supp:print_suppressions=0}"

status=0
summary=()
for t in "${targets[@]}"; do
    corpus="$build/corpus/$t"
    artifacts="$build/artifacts"
    mkdir -p "$corpus" "$artifacts"
    dict=()
    [[ $t == fuzz_pbrt ]] && dict=(-dict="$root/tests/fuzz/pbrt.dict")
    [[ $t == fuzz_ply ]] && dict=(-dict="$root/tests/fuzz/ply.dict")
    seed_dir="$(seeds_for "$t")"
    echo "== fuzz: $t for ${seconds} s"
    log="$build/$t.log"
    # -timeout: one input taking 10 s is a hang; -rss_limit_mb: 2 GB is a runaway allocation;
    # -max_len: scenes and meshes of up to 16 KiB reach every parser state.
    (cd "$build" && "$build/fuzz/$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
        -max_len=16384 -print_final_stats=1 -artifact_prefix="$artifacts/$t-" \
        "${dict[@]}" ${FUZZ_ARGS:-} "$corpus" "$seed_dir") >"$log" 2>&1
    rc=$?
    execs="$(grep -Eo 'stat::number_of_executed_units: *[0-9]+' "$log" | grep -Eo '[0-9]+$' | tail -1)"
    cov="$(grep -Eo 'cov: [0-9]+' "$log" | tail -1)"
    if [[ $rc -ne 0 ]]; then
        status=1
        summary+=("$t: FAILED (exit $rc) after ${execs:-?} executions; see $log")
        echo "--- $t failed; the end of its log:"
        tail -n 60 "$log"
        ls -1 "$artifacts"/"$t"-* 2>/dev/null | sed 's/^/    crashing input: /'
    else
        summary+=("$t: ok, ${execs:-?} executions in ${seconds} s, ${cov:-cov ?}, corpus $(ls "$corpus" | wc -l) inputs")
    fi
done
printf '%s\n' "== fuzz summary" "${summary[@]}"
exit $status
