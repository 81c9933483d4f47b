#!/usr/bin/env python3
"""Scene load time (parse, meshes, textures, BVH) of Tessera against pbrt-v4 on the same files,
side by side in one run.

    scripts/bench_load.py [--rounds 5] [--threads 2] [--before OLD_TESSERA] [--pbrt PBRT]
                          [SCENE.pbrt ...]

Without scenes: every pbrt-v4 scene of ../shared/scenes (the Bitterli set and its Cornell box)
and every examples/*/scene.pbrt. Each round runs, per scene, every program once as a whole
process rendering 1 sample of a 16x16 block (Tessera: --resolution 16x16 --spp 1; pbrt-v4:
--spp 1 --pixelbounds 0,16,0,16, the same scene at its own resolution), so that the process's
wall time is its start-up and scene load; the order of the programs alternates between rounds.
Prints per scene the median wall time and the peak memory (MiB, getrusage) of each program,
Tessera's own load_s from --stats, and Tessera / pbrt-v4, then the largest scene's figures
(by the size of its folder) and the median ratio. --before adds a second Tessera build
(e.g. the commit before a change) to the same run.
"""
import argparse
import glob
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), 'shared')


def default_scenes():
    scenes = sorted(glob.glob(os.path.join(SHARED, 'scenes', 'bitterli', '*', 'scene-v4.pbrt')))
    scenes += sorted(glob.glob(os.path.join(SHARED, 'scenes', 'bitterli-cornell-box', 'pbrt-v4',
                                            'scene-v4.pbrt')))
    scenes += sorted(glob.glob(os.path.join(ROOT, 'examples', '*', 'scene.pbrt')))
    return scenes


def folder_bytes(scene):
    total = 0
    for d, _, files in os.walk(os.path.dirname(scene)):
        for f in files:
            total += os.path.getsize(os.path.join(d, f))
    return total


def run_measured(cmd, cwd):
    """(wall s, peak RSS MiB) of one child, from wait4's rusage."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    err = p.stderr.read()
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode != 0:
        raise RuntimeError(f'{" ".join(cmd)} failed ({p.returncode}): '
                           f'{err.decode(errors="replace")[-400:]}')
    return wall, ru.ru_maxrss / 1024.0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('scenes', nargs='*')
    ap.add_argument('--rounds', type=int, default=5)
    ap.add_argument('--threads', type=int, default=2)
    ap.add_argument('--tessera', default=os.path.join(ROOT, 'build', 'tessera'))
    ap.add_argument('--before', help='a second Tessera binary measured in the same run')
    ap.add_argument('--pbrt', default=os.path.join(SHARED, 'tools', 'pbrt-v4', 'bin', 'pbrt'))
    args = ap.parse_args()
    scenes = [os.path.abspath(s) for s in (args.scenes or default_scenes())]
    if not scenes:
        sys.exit('bench_load: no scenes (../shared/scenes not found and none given)')
    have_pbrt = os.access(args.pbrt, os.X_OK)
    if not have_pbrt:
        print(f'bench_load: no pbrt-v4 at {args.pbrt}: Tessera only', file=sys.stderr)
    progs = [('tessera', args.tessera)]
    if args.before:
        progs.append(('before', os.path.abspath(args.before)))
    if have_pbrt:
        progs.append(('pbrt', args.pbrt))

    tmp = tempfile.mkdtemp(prefix='tessera-bench-load-')
    rows = []
    for scene in scenes:
        cwd = os.path.dirname(scene)
        name = os.path.relpath(scene, SHARED if scene.startswith(SHARED) else ROOT)
        walls = {p: [] for p, _ in progs}
        mem = {p: 0.0 for p, _ in progs}
        load_s = []
        for r in range(args.rounds):
            order = progs if r % 2 == 0 else list(reversed(progs))
            for label, binary in order:
                if label == 'pbrt':
                    cmd = [binary, '--quiet', '--nthreads', str(args.threads), '--spp', '1',
                           '--pixelbounds', '0,16,0,16', '--outfile',
                           os.path.join(tmp, 'pbrt.exr'), scene]
                else:
                    stats = os.path.join(tmp, f'{label}.json')
                    cmd = [binary, 'render', scene, '--sampler', 'uniform', '--spp', '1',
                           '--resolution', '16x16', '--threads', str(args.threads), '--quiet',
                           '--no-png', '-o', os.path.join(tmp, f'{label}.exr'), '--stats', stats]
                wall, rss = run_measured(cmd, cwd)
                walls[label].append(wall)
                mem[label] = max(mem[label], rss)
                if label == 'tessera':
                    with open(stats) as f:
                        load_s.append(float(json.load(f)['load_s']))
        med = {p: statistics.median(v) for p, v in walls.items()}
        rows.append((name, folder_bytes(scene), med, mem, statistics.median(load_s)))
        cols = '  '.join(f'{p} {med[p]:.3f} s {mem[p]:.0f} MiB' for p, _ in progs)
        ratio = f'  tessera/pbrt {med["tessera"] / med["pbrt"]:.2f}' if have_pbrt else ''
        print(f'{name}: {cols}  (tessera load_s {rows[-1][4]:.3f}){ratio}', flush=True)

    print()
    hdr = ['scene', 'MiB on disk'] + [f'{p} s' for p, _ in progs] + [f'{p} MiB' for p, _ in progs]
    hdr += ['tessera load_s'] + (['tessera / pbrt'] if have_pbrt else [])
    if args.before:
        hdr.append('tessera / before')
    print('| ' + ' | '.join(hdr) + ' |')
    print('|' + '---|' * len(hdr))
    for name, size, med, mem, ls in rows:
        cells = [name, f'{size / 2**20:.0f}'] + [f'{med[p]:.3f}' for p, _ in progs]
        cells += [f'{mem[p]:.0f}' for p, _ in progs] + [f'{ls:.3f}']
        if have_pbrt:
            cells.append(f'{med["tessera"] / med["pbrt"]:.2f}')
        if args.before:
            cells.append(f'{med["tessera"] / med["before"]:.2f}')
        print('| ' + ' | '.join(cells) + ' |')
    if have_pbrt:
        ratios = [m['tessera'] / m['pbrt'] for _, _, m, _, _ in rows]
        big = max(rows, key=lambda r: r[1])
        print(f'\nmedian tessera/pbrt {statistics.median(ratios):.2f} over {len(rows)} scenes; '
              f'largest scene {big[0]} ({big[1] / 2**20:.0f} MiB): tessera '
              f'{big[2]["tessera"]:.3f} s, pbrt-v4 {big[2]["pbrt"]:.3f} s, '
              f'ratio {big[2]["tessera"] / big[2]["pbrt"]:.2f}')


if __name__ == '__main__':
    main()
