#!/usr/bin/env bash
# Distributed rendering under mpirun (docs/ARCHITECTURE.md, "Distributed rendering"), one case
# per ctest (label "mpi"; registered only when Tessera is built with MPI and mpirun exists):
#
#   tests/cli/mpi_render.sh /path/to/tessera SCENE CASE
#
# Ranks run on this machine (loopback, --oversubscribe: more ranks than cores). As root,
# OpenMPI needs OMPI_ALLOW_RUN_AS_ROOT(_CONFIRM), set here. Images are compared with idiff
# (OpenImageIO) at zero tolerance over every channel of the EXR (beauty, spp, error): bit for
# bit. Prints "PASS" or "FAIL: why" and exits 0 / 1.
set -uo pipefail

tessera="${1:?usage: mpi_render.sh TESSERA SCENE CASE}"
scene="${2:?usage: mpi_render.sh TESSERA SCENE CASE}"
case_name="${3:?usage: mpi_render.sh TESSERA SCENE CASE}"
tessera="$(cd "$(dirname "$tessera")" && pwd)/$(basename "$tessera")"
scene="$(cd "$(dirname "$scene")" && pwd)/$(basename "$scene")"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# Loopback only: no network interface probing beyond the local one.
export OMPI_MCA_btl_tcp_if_include=lo OMPI_MCA_oob_tcp_if_include=lo

tmp="$(mktemp -d "${TMPDIR:-/tmp}/tessera-mpi-XXXXXX")"
trap 'rm -rf "$tmp"' EXIT
cd "$tmp" || exit 1

fail() {
    echo "FAIL [$case_name]: $*"
    for f in *.log; do [[ -s "$f" ]] && { echo "--- $f"; tail -20 "$f"; }; done
    exit 1
}

# mpi N LOG ARGS...: tessera render with N ranks (60 s limit); sets $rc.
mpi() {
    local n="$1" log="$2"
    shift 2
    timeout 60 mpirun --oversubscribe -np "$n" "$tessera" render "$@" >"$log" 2>&1
    rc=$?
    [[ $rc -ne 124 ]] || fail "mpirun -np $n did not finish within 60 s"
}

# one LOG ARGS...: tessera render in one process; sets $rc.
one() {
    local log="$1"
    shift
    timeout 60 "$tessera" render "$@" >"$log" 2>&1
    rc=$?
}

same() {  # same A B: bit-identical images
    idiff -fail 0 -warn 0 "$1" "$2" >idiff.log 2>&1 || fail "$1 and $2 differ: $(tail -3 idiff.log)"
}

json() {  # json FILE EXPR: a value of the stats JSON (python3)
    python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print($2)" "$1"
}

# rank_pids [RANK]: the pids of this test's tessera ranks (their environment names
# OMPI_COMM_WORLD_RANK: not mpirun, not timeout, not another build's render), or of one rank.
rank_pids() {
    local p
    for p in $(pgrep -f "$tessera render"); do
        tr '\0' '\n' <"/proc/$p/environ" 2>/dev/null |
            grep -qx "OMPI_COMM_WORLD_RANK=${1:-[0-9]*}" && echo "$p"
    done
}

# A small render: 64x48, a few passes.
common=(--resolution 64x48 --seed 3 -q)

case "$case_name" in
deterministic)
    # Deterministic images for 1-4 ranks (and 1 or 2 threads each) equal the single-process
    # render, uniform and adaptive (spp budget, and refining under an spp cap).
    for sampler in uniform adaptive adaptive:refine=1; do
        one single.log "$scene" "${common[@]}" --spp 24 --sampler "$sampler" --deterministic \
            --threads 2 -o single.exr --stats single.json
        [[ $rc -eq 0 ]] || fail "single-process render failed ($rc)"
        for n in 1 2 3 4; do
            threads=$((n % 2 + 1))
            mpi "$n" "mpi$n.log" "$scene" "${common[@]}" --spp 24 --sampler "$sampler" \
                --deterministic --threads "$threads" -o "mpi$n.exr" --stats "mpi$n.json"
            [[ $rc -eq 0 ]] || fail "mpirun -np $n ($sampler) exited $rc"
            same single.exr "mpi$n.exr"
            [[ "$(json "mpi$n.json" "j['samples']")" == "$(json single.json "j['samples']")" ]] ||
                fail "$sampler, $n ranks: sample totals differ"
            # Every sample was taken by exactly one rank: the per-rank samples add up (one
            # rank is a plain single-process render: no per-rank rows).
            [[ $n -eq 1 ]] || [[ "$(json "mpi$n.json" "sum(r['samples'] for r in j['mpi']['per_rank'])")" == \
               "$(json single.json "j['samples']")" ]] || fail "$sampler, $n ranks: per-rank samples do not add up"
            [[ "$(json "mpi$n.json" "j['mpi']['ranks']")" == "$n" ]] || fail "ranks not reported"
        done
    done
    ;;
resume)
    # N passes on 2 ranks, a checkpoint, the rest on 3 ranks (and on 1) == all passes straight.
    one straight.log "$scene" "${common[@]}" --spp 64 --deterministic -o straight.exr
    [[ $rc -eq 0 ]] || fail "straight render failed"
    mpi 2 first.log "$scene" "${common[@]}" --spp 64 --deterministic --threads 1 \
        --max-passes 2 -o part.exr --checkpoint part.ckpt.exr
    [[ $rc -eq 0 && -s part.ckpt.exr ]] || fail "first part failed ($rc)"
    mpi 3 second.log "$scene" "${common[@]}" --spp 64 --deterministic --threads 1 \
        --resume part.ckpt.exr -o resumed3.exr
    [[ $rc -eq 0 ]] || fail "resume on 3 ranks failed ($rc)"
    same straight.exr resumed3.exr
    one third.log "$scene" "${common[@]}" --spp 64 --deterministic --resume part.ckpt.exr \
        -o resumed1.exr
    [[ $rc -eq 0 ]] || fail "single-process resume failed ($rc)"
    same straight.exr resumed1.exr
    ;;
time_budget)
    # --time ends every rank: the job ends near the budget, out of time, every rank rendered.
    start=$(date +%s.%N)
    mpi 3 time.log "$scene" --resolution 128x96 --spp 1000000 --time 2 --threads 1 \
        -o timed.exr --stats timed.json -q
    end=$(date +%s.%N)
    [[ $rc -eq 0 ]] || fail "timed render exited $rc"
    [[ "$(json timed.json "j['out_of_time']")" == "True" ]] || fail "not out of time"
    python3 -c "import sys; t=$end-$start; sys.exit(0 if t < 12 else 1)" ||
        fail "a 2 s budget took $(python3 -c "print($end-$start)") s"
    [[ "$(json timed.json "min(r['samples'] for r in j['mpi']['per_rank']) > 0")" == "True" ]] ||
        fail "a rank took no sample"
    [[ -s timed.exr ]] || fail "no image"
    ;;
interrupt)
    # SIGTERM to every rank (what a batch system's cancel sends; mpirun's Ctrl-C sends it too,
    # but kills the ranks 1 s later, a race on a loaded machine): the image and a checkpoint
    # are written, mpirun exits 0, and the checkpoint resumes on another number of ranks.
    timeout 60 mpirun --oversubscribe -np 2 "$tessera" render "$scene" --resolution 128x96 \
        --spp 1000000 --time 40 --threads 1 -o int.exr -q >int.log 2>&1 &
    pid=$!
    # Signal once both ranks catch SIGTERM (bit 15 of SigCgt: the render's handler is
    # installed) and have rendered a moment.
    ranks=()
    for _ in $(seq 300); do
        ranks=()
        for p in $(rank_pids); do
            mask=$(awk '/^SigCgt:/ {print $2}' "/proc/$p/status" 2>/dev/null)
            [[ -n "$mask" ]] && (( (16#$mask >> 14) & 1 )) && ranks+=("$p")
        done
        (( ${#ranks[@]} >= 2 )) && break
        sleep 0.1
    done
    (( ${#ranks[@]} >= 2 )) || fail "the ranks did not start rendering"
    sleep 2
    kill -TERM "${ranks[@]}"
    wait "$pid"
    rc=$?
    [[ $rc -eq 0 ]] || fail "mpirun exited $rc after SIGTERM to the ranks"
    [[ -s int.exr && -s int.checkpoint.exr ]] || fail "no image or checkpoint after SIGTERM"
    mpi 3 resume.log "$scene" --resolution 128x96 --spp 1000000 --time 1 --threads 1 \
        --resume int.checkpoint.exr -o resumed.exr
    [[ $rc -eq 0 && -s resumed.exr ]] || fail "resume of the interrupted render failed ($rc)"
    ;;
rank_dies)
    # A rank killed mid-render fails the job with mpirun's message naming the rank; the last
    # periodic checkpoint (written atomically by rank 0) stays valid and resumes.
    timeout 60 mpirun --oversubscribe -np 2 "$tessera" render "$scene" --resolution 128x96 \
        --spp 1000000 --time 40 --threads 1 --checkpoint-every 1 -o dies.exr -q >dies.log 2>&1 &
    pid=$!
    for _ in $(seq 100); do [[ -s dies.checkpoint.exr ]] && break; sleep 0.1; done
    sleep 1.5
    victim=$(rank_pids 1)
    [[ -n "$victim" ]] || fail "rank 1 not found"
    kill -9 "$victim"
    wait "$pid"
    rc=$?
    [[ $rc -ne 0 ]] || fail "mpirun exited 0 after a rank died"
    grep -Eiq "rank 1" dies.log || fail "mpirun's message does not name rank 1"
    [[ -s dies.checkpoint.exr ]] || fail "no checkpoint"
    one resume.log "$scene" --resolution 128x96 --spp 1000000 --time 1 \
        --resume dies.checkpoint.exr -o resumed.exr
    [[ $rc -eq 0 && -s resumed.exr ]] || fail "the last checkpoint does not resume ($rc)"
    ;;
not_render)
    # Only `render` runs on several ranks.
    timeout 60 mpirun --oversubscribe -np 2 "$tessera" samplers >conv.log 2>&1
    rc=$?
    [[ $rc -ne 0 ]] || fail "samplers under mpirun -np 2 exited 0"
    grep -q "only \`tessera render\` runs on several MPI ranks" conv.log || fail "no clear message"
    ;;
bad_scene)
    # Bad input on every rank: "file:line: message" and a non-zero exit, no output.
    printf 'WorldBegin\nShape "nonsense"\n' >bad.pbrt
    mpi 2 bad.log bad.pbrt -o bad.exr
    [[ $rc -ne 0 ]] || fail "a bad scene exited 0"
    grep -Eq "bad\.pbrt:2: " bad.log || fail "no file:line message"
    [[ ! -e bad.exr ]] || fail "an image was written"
    ;;
*)
    echo "FAIL: unknown case $case_name"
    exit 1
    ;;
esac
echo PASS
