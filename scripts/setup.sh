#!/usr/bin/env bash
# Tessera's one-step set-up for a fresh Debian 12 machine (run as root, or with sudo available).
#
#   scripts/setup.sh render   install what rendering needs, build the tessera executable alone
#                             (Release), render the example scene
#   scripts/setup.sh test     install every dependency, build everything (Release: tessera, the
#                             tests, the benchmarks), run the whole test suite (with the quick
#                             convergence benchmark suite, ctest label report)
#   scripts/setup.sh build    install every dependency and build everything
#
# Environment: BUILD_DIR (default build), JOBS (default: number of cores), CTEST_ARGS (extra
# arguments for ctest, e.g. "-L unit"), SKIP_APT=1 to skip the package step, TSAN=0 to skip the
# ThreadSanitizer run of the scheduler tests that `test` does after the Release suite, ASAN=0
# to skip its ASan+UBSan run of the unit and command-line tests, FUZZ=0 to skip its bounded
# fuzz run (FUZZ_SECONDS per target, default 20; scripts/run_fuzz.sh).
set -euo pipefail

mode="${1:-render}"
case "$mode" in
  render|test|build) ;;
  *)
    echo "usage: scripts/setup.sh [render|test|build]" >&2
    exit 2
    ;;
esac
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
jobs="${JOBS:-$(nproc)}"

# What the tessera executable needs ...
packages=(
  build-essential cmake pkg-config
  libembree-dev libtbb-dev
  libopenimageio-dev openimageio-tools libopenexr-dev libopencolorio-dev
  libtinyobjloader-dev nlohmann-json3-dev libcli11-dev zlib1g-dev libpng-dev
  # Distributed rendering (`mpirun -np N tessera render`): CMake builds MPI in when it finds it.
  libopenmpi-dev openmpi-bin
)
# ... and what the tests, the benchmarks, the reports and the sanitizer/fuzz builds add.
if [[ "$mode" != "render" ]]; then
  packages+=(
    doctest-dev libbenchmark-dev libassimp-dev
    # scripts/convergence_report.py (tessera converge's report.html, the benchmark suite)
    python3 python3-numpy python3-matplotlib
    clang libclang-rt-dev
  )
fi

install_packages() {
  if [[ "${SKIP_APT:-0}" == "1" ]]; then return; fi
  local missing=()
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [[ ${#missing[@]} -eq 0 ]]; then
    echo "setup: all Debian packages present"
    return
  fi
  echo "setup: installing ${missing[*]}"
  local sudo=""
  if [[ $(id -u) -ne 0 ]]; then sudo="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

configure_and_build() {
  if [[ "$mode" == "render" ]]; then
    # Only the renderer: no doctest, no Google Benchmark, no test or benchmark targets.
    cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DTESSERA_BUILD_TESTS=OFF \
      -DTESSERA_BUILD_BENCHMARKS=OFF ${CMAKE_ARGS:-}
    cmake --build "$build" -j "$jobs" --target tessera
  else
    cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DTESSERA_BUILD_TESTS=ON \
      -DTESSERA_BUILD_BENCHMARKS=ON ${CMAKE_ARGS:-}
    cmake --build "$build" -j "$jobs"
  fi
}

# Wall time of each stage, for the CI log ("setup: <stage> done at <seconds> s").
stage_done() { echo "setup: $1 done at ${SECONDS} s"; }

install_packages
stage_done packages
configure_and_build
if [[ "$mode" == "render" ]]; then stage_done "Release build (tessera)"; else stage_done "Release build"; fi

case "$mode" in
  render)
    mkdir -p "$root/renders"
    "$build/tessera" render "$root/examples/cornell-box/scene.pbrt" \
      -o "$root/renders/cornell-box.exr" --stats "$root/renders/cornell-box.json"
    echo "setup: wrote renders/cornell-box.exr, renders/cornell-box.png and renders/cornell-box.json"
    ;;
  test)
    # Slow tests are labelled "slow" and run only when asked (CTEST_ARGS="-L slow").
    (cd "$build" && ctest --output-on-failure -j "$jobs" -LE slow ${CTEST_ARGS:-})
    stage_done "Release tests"
    # The scheduler owns every thread: its tests (label tsan) also run in a ThreadSanitizer
    # build of the layers below the renderer (quick: no Embree code). TSAN=0 skips it.
    if [[ "${TSAN:-1}" == "1" ]]; then
      JOBS="$jobs" TSAN_BUILD_DIR="${TSAN_BUILD_DIR:-$root/build-tsan}" \
        "$root/scripts/run_sanitizers.sh" tsan
      stage_done "TSan build and tests"
    fi
    # The unit and command-line tests (the broken-scene corpus among them) under ASan+UBSan,
    # built with clang; then each fuzz target for FUZZ_SECONDS from the same build.
    asan_dir="${ASAN_BUILD_DIR:-$root/build-asan}"
    if [[ "${ASAN:-1}" == "1" ]]; then
      JOBS="$jobs" ASAN_BUILD_DIR="$asan_dir" "$root/scripts/run_sanitizers.sh" asan
      stage_done "ASan+UBSan build and tests"
    fi
    if [[ "${FUZZ:-1}" == "1" ]]; then
      JOBS="$jobs" FUZZ_BUILD_DIR="$asan_dir" "$root/scripts/run_fuzz.sh" "${FUZZ_SECONDS:-20}"
      stage_done "fuzzing"
    fi
    ;;
  build) ;;
esac
