#!/usr/bin/env bash
# Builds and tests Tessera under the sanitizers (the CI's ASan+UBSan and TSan jobs):
#
#   scripts/run_sanitizers.sh [asan|tsan|all]     (default: all)
#
#   asan: configure build-asan with -DTESSERA_SANITIZE=ON (AddressSanitizer + UBSan, Debug with
#         -O1), build, run the unit and command-line tests there (`ctest -L 'unit|cli'`: the
#         whole unit suite, the broken-scene corpus and the losing-nothing cases; the stat,
#         render and stress tests run in the Release build only, for time). UBSan findings fail
#         the test that hits them (UBSAN_OPTIONS=halt_on_error=1, set by tests/CMakeLists.txt).
#         With clang (the default when clang++ is installed; CXX_ASAN picks another compiler)
#         the build also gets -DTESSERA_FUZZ=ON, so that scripts/run_fuzz.sh can build its
#         libFuzzer targets from the same objects (FUZZ_BUILD_DIR=build-asan) instead of
#         compiling everything a third time; clang's -fsanitize=undefined also checks
#         float-to-int conversions, which gcc's does not.
#   tsan: configure build-tsan with -DTESSERA_TSAN=ON, build the scheduler tests
#         (tests/scheduler/test_*.cpp), run `ctest -L tsan` (the
#         scheduler owns all threads). Debian's libtbb is not
#         instrumented, so races reported inside TBB internals are false positives:
#         tests/tsan.supp suppresses those (TSAN_OPTIONS=suppressions=...); races in Tessera's
#         own code are still reported and fail the test.
#
# Environment: JOBS (default 2), ASAN_BUILD_DIR / TSAN_BUILD_DIR (default build-asan,
# build-tsan), CXX_ASAN (default clang++ if installed, else the default compiler),
# ASAN_LABELS (default 'unit|cli'), CTEST_ARGS (extra ctest arguments). Exits non-zero when a
# job fails.
set -uo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
mode="${1:-all}"
jobs="${JOBS:-2}"
asan_dir="${ASAN_BUILD_DIR:-$root/build-asan}"
tsan_dir="${TSAN_BUILD_DIR:-$root/build-tsan}"
status=0

run_asan() {
    echo "== ASan+UBSan: $asan_dir"
    local cxx="${CXX_ASAN:-}" extra=()
    if [[ -z "$cxx" ]] && command -v clang++ >/dev/null; then cxx=clang++; fi
    if [[ -n "$cxx" ]]; then
        extra+=(-DCMAKE_CXX_COMPILER="$cxx")
        [[ "$("$cxx" --version 2>/dev/null)" == *clang* ]] && extra+=(-DTESSERA_FUZZ=ON)
    fi
    cmake -S "$root" -B "$asan_dir" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-g -O1" \
        -DTESSERA_SANITIZE=ON -DTESSERA_BUILD_BENCHMARKS=OFF -DTESSERA_MPI=OFF "${extra[@]}" || return 1
    cmake --build "$asan_dir" -j "$jobs" || return 1
    # The sanitizer environment is set per test by tests/CMakeLists.txt; these are defaults for
    # anything run by hand from this shell.
    export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:new_delete_type_mismatch=0}"
    export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"
    (cd "$asan_dir" && ctest --output-on-failure -j "$jobs" -L "${ASAN_LABELS:-unit|cli}" ${CTEST_ARGS:-})
}

run_tsan() {
    echo "== TSan: $tsan_dir"
    cmake -S "$root" -B "$tsan_dir" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-g -O1" \
        -DTESSERA_TSAN=ON -DTESSERA_BUILD_BENCHMARKS=OFF -DTESSERA_MPI=OFF || return 1
    # Only the scheduler tests (label tsan, one per tests/scheduler/test_*.cpp) are built.
    local targets=()
    for f in "$root"/tests/scheduler/test_*.cpp; do targets+=("$(basename "$f" .cpp)"); done
    cmake --build "$tsan_dir" -j "$jobs" --target "${targets[@]}" || return 1
    export TSAN_OPTIONS="${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1:suppressions=$root/tests/tsan.supp}"
    (cd "$tsan_dir" && ctest --output-on-failure -j 1 -L tsan ${CTEST_ARGS:-})
}

case "$mode" in
    asan) run_asan || status=1 ;;
    tsan) run_tsan || status=1 ;;
    all)
        run_asan || status=1
        run_tsan || status=1
        ;;
    *)
        echo "usage: scripts/run_sanitizers.sh [asan|tsan|all]" >&2
        exit 2
        ;;
esac
if [[ $status -ne 0 ]]; then echo "run_sanitizers: FAILED" >&2; else echo "run_sanitizers: OK"; fi
exit $status
