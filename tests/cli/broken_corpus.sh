#!/usr/bin/env bash
# Runs every input of the broken-scene corpus (tests/broken/, listed in tests/broken/expected.txt)
# through `tessera render` and checks the bad-input contract for each:
#
#   - exit code 2, and a stderr line "LOCATION: message" with the expected file:line and a
#     message matching the expected regex;
#   - no crash, no sanitizer report, no "internal error";
#   - bounded time (TIME_LIMIT_S each, default 20 s) and memory (the run is made under
#     `ulimit -v MEMORY_LIMIT_MB`, default 4096; skipped in sanitizer builds, whose shadow memory
#     needs terabytes of address space);
#   - no output left behind: no EXR, PNG, stats JSON, checkpoint or temporary file, and the corpus
#     folder unchanged.
#
#   tests/cli/broken_corpus.sh /path/to/tessera [CORPUS_DIR]
#
# Manifest lines: INPUT | LOCATION | MESSAGE_REGEX [| EXTRA ARGS]. INPUT is relative to the corpus
# folder (the command runs there, so messages name files as the corpus does); LOCATION is the
# exact "file:line" the error must start with; MESSAGE_REGEX is an extended regex matched against
# the rest of that line. Every top-level file of the corpus must be listed (the files in its
# subfolders are what the listed scenes include or load). A few inputs cannot live in git (a FIFO,
# an unreadable file) or are too large to keep there, and are made here, as are the
# command-line overrides. Prints one line per input and a total; exits 1 on any failure.
set -uo pipefail

tessera="${1:?usage: broken_corpus.sh TESSERA [CORPUS_DIR]}"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
corpus="${2:-$here/../broken}"
corpus="$(cd "$corpus" && pwd)"
tessera="$(cd "$(dirname "$tessera")" && pwd)/$(basename "$tessera")"
time_limit="${TIME_LIMIT_S:-20}"
mem_limit_mb="${MEMORY_LIMIT_MB:-4096}"
# Sanitizer builds reserve huge shadow mappings: no address-space limit there.
sanitized=0
if [[ -n "${ASAN_OPTIONS:-}${TSAN_OPTIONS:-}" ]] || nm -an "$tessera" 2>/dev/null | grep -q __asan_init; then
    sanitized=1
fi

tmp="$(mktemp -d "${TMPDIR:-/tmp}/tessera-broken-XXXXXX")"
trap 'chmod -R u+rw "$tmp" 2>/dev/null; rm -rf "$tmp"' EXIT
snapshot() { (cd "$corpus" && find . -print0 | sort -z | xargs -0 stat -c '%n %s %Y' 2>/dev/null | md5sum); }
before="$(snapshot)"

# The inputs run JOBS at a time (default: the number of cores); each run has its own folder
# under $tmp/runs and leaves its verdict in $tmp/runs/N/result, printed in order at the end.
jobs_max="${JOBS:-$(nproc)}"
total=0
declare -A listed

# check_one INPUT LOCATION REGEX [ARGS...]: runs one input from $run_dir (default: the corpus),
# in the background.
check_one() {
    total=$((total + 1))
    while (($(jobs -rp | wc -l) >= jobs_max)); do wait -n; done
    check_one_now "$total" "$@" &
}

check_one_now() {
    local n="$1" input="$2" location="$3" regex="$4"
    shift 4
    local work="$tmp/runs/$(printf '%04d' "$n")"
    local out="$work/out"
    mkdir -p "$out"
    local t0 t1 rc
    t0=$(date +%s%N)
    (
        cd "${run_dir:-$corpus}" || exit 99
        if [[ $sanitized -eq 0 ]]; then ulimit -v $((mem_limit_mb * 1024)); fi
        exec timeout -s KILL "$time_limit" "$tessera" render "$input" -o "$out/out.exr" \
            --stats "$out/out.json" --checkpoint "$out/out.ckpt.exr" --threads 2 -q "$@"
    ) >"$work/stdout.txt" 2>"$work/stderr.txt"
    rc=$?
    t1=$(date +%s%N)
    local ms=$(((t1 - t0) / 1000000))
    local why="" line=""
    if [[ $rc -eq 137 ]]; then
        why="killed after ${time_limit} s (or out of memory)"
    elif [[ $rc -ne 2 ]]; then
        why="exit code $rc, expected 2"
    elif grep -Eaq 'internal error|Sanitizer|runtime error:|out of memory' "$work/stderr.txt"; then
        why="crash, sanitizer report or internal error on stderr"
    else
        # The line that starts with LOCATION must carry the expected message.
        line="$(LC_ALL=C awk -v p="$location: " \
            'index($0, p) == 1 && index($0, ": warning: ") == 0 { print; exit }' "$work/stderr.txt")"
        if [[ -z "$line" || "${line#"$location: "}" == "$line" ]]; then
            why="no stderr line starts with \"$location: \""
        elif ! grep -Eaq -- "$regex" <<<"${line#"$location: "}"; then
            why="message \"${line#"$location: "}\" does not match /$regex/"
        fi
    fi
    local left
    left="$(find "$out" -mindepth 1 -print)"
    [[ -z "$why" && -n "$left" ]] && why="output left behind: $left"
    {
        if [[ -n "$why" ]]; then
            echo "FAIL $input: $why"
            sed 's/^/    stderr: /' "$work/stderr.txt" | head -n 8
        else
            printf 'ok   %-40s %5d ms  %s\n' "$input" "$ms" "$line"
        fi
    } >"$work/result"
    echo "$ms" >"$work/ms"
}

while IFS= read -r raw || [[ -n "$raw" ]]; do
    [[ -z "${raw// /}" || "$raw" == \#* ]] && continue
    # Split on " | " (the regex itself may use '|' without spaces).
    IFS=$'\x1f' read -r input location regex args <<<"${raw// | /$'\x1f'}"
    listed["$input"]=1
    read -r -a extra <<<"${args:-}"
    check_one "$input" "$location" "$regex" "${extra[@]}"
done <"$corpus/expected.txt"

failures=0
# Every top-level file of the corpus is an input and must be in the manifest.
while IFS= read -r f; do
    f="${f#./}"
    [[ "$f" == expected.txt || "$f" == README.md ]] && continue
    if [[ -z "${listed[$f]:-}" ]]; then
        failures=$((failures + 1))
        echo "FAIL $f: not listed in expected.txt"
    fi
done < <(cd "$corpus" && find . -maxdepth 1 -type f -print | sort)

# Inputs that git cannot hold, made in a scratch folder.
run_dir="$tmp/made"
mkdir -p "$run_dir"
printf 'WorldBegin\nShape "sphere"\n' >"$run_dir/good.pbrt"
mkfifo "$run_dir/fifo.pbrt"
check_one fifo.pbrt "fifo.pbrt:0" "not a regular file"
printf 'WorldBegin\nInclude "fifo.pbrt"\n' >"$run_dir/include_fifo.pbrt"
check_one include_fifo.pbrt "include_fifo.pbrt:2" "not a regular file"
mkdir -p "$run_dir/dir.pbrt"
check_one dir.pbrt "dir.pbrt:0" "directory"
check_one no_such_scene.pbrt "no_such_scene.pbrt:0" "cannot open"
# Two large inputs, generated rather than stored: 70000 nested AttributeBegin (the limit is
# 65536), and Loop subdivision of 32769 triangles at 8 levels (x65536: over 2^31 triangles).
{ printf 'WorldBegin\n'; for ((i = 0; i < 70000; ++i)); do echo AttributeBegin; done; } \
    >"$run_dir/nesting_too_deep.pbrt"
check_one nesting_too_deep.pbrt "nesting_too_deep.pbrt:65538" "AttributeBegin nested more than 65536 deep"
{
    printf 'WorldBegin\nShape "loopsubdiv" "integer levels" [ 8 ] "point3 P" [ 0 0 0  1 0 0  0 1 0 ]\n'
    printf '  "integer indices" ['
    for ((i = 0; i < 32769; ++i)); do printf ' 0 1 2'; done
    printf ' ]\n'
} >"$run_dir/loopsubdiv_explosion.pbrt"
check_one loopsubdiv_explosion.pbrt "loopsubdiv_explosion.pbrt:2" \
    "loopsubdiv with 8 levels: [0-9]+ triangles, more than the maximum"
check_one good.pbrt "--resolution:0" "larger than the maximum" --resolution 70000x16
check_one good.pbrt "--resolution:0" "needs about .* of memory" --resolution 32768x32768
check_one good.pbrt "--spp:0" "larger than the maximum" --spp 2000000000
if [[ $(id -u) -ne 0 ]]; then
    # root reads anything: only meaningful for other users.
    cp "$run_dir/good.pbrt" "$run_dir/unreadable.pbrt"
    chmod 000 "$run_dir/unreadable.pbrt"
    check_one unreadable.pbrt "unreadable.pbrt:0" "cannot"
fi

wait
max_ms=0
for work in "$tmp"/runs/*; do
    cat "$work/result" 2>/dev/null || { echo "FAIL: no result in $work"; failures=$((failures + 1)); continue; }
    grep -q '^FAIL' "$work/result" && failures=$((failures + 1))
    ms="$(cat "$work/ms")"
    ((ms > max_ms)) && max_ms=$ms
done
after="$(snapshot)"
if [[ "$before" != "$after" ]]; then
    failures=$((failures + 1))
    echo "FAIL: the corpus folder changed during the run"
fi
echo "broken corpus: $total inputs, $failures failures, slowest $max_ms ms" \
    "(memory limit: $([[ $sanitized -eq 0 ]] && echo "${mem_limit_mb} MiB" || echo "none, sanitizer build"))"
[[ $failures -eq 0 ]]
