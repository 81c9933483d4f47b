#!/usr/bin/env python3
"""Time to equal error against Blender Cycles on Bitterli's Cornell box, side by side in one run.

    scripts/bench_cycles.py [--size 256] [--cycles-spp 64] [--seeds 3] [--threads 2]
                            [--sampler uniform --sampler adaptive ...] [--tessera build/tessera]

The comparison of ../shared/tools/cycles/README.md: Cycles (the harness render_cycles.py there:
Lambertian, box filter of one pixel, no denoiser, no clamping, all bounce limits 64) renders
the box at --size x --size with --cycles-spp samples for each seed; its error is the mean over
the seeds of the relMSE (mean of (a - r)^2 / (r^2 + 0.01)) against Tungsten's reference
(../shared/scenes/bitterli-cornell-box/reference/TungstenRender.exr, box-downsampled), and its
time the median of the harness's render_wall_s (scene sync, BVH and render; Blender's start-up
left out). Tessera renders the pbrt-v4 file of the same box (its triangle filter replaced by a
box of radius 0.5, the same pixel footprint as Cycles') for a ladder of spp budgets per
sampler and seed; its time is the stats JSON's load_s + wall_s (parse, BVH and render; the
process start left out), its error the same relMSE. The time Tessera needs for Cycles' error is
interpolated log-log between the two ladder budgets around it; the figure is that time over
Cycles' time. Also prints the robust relMSE (the 0.1% largest per-pixel errors left out).
Needs `blender` (apt-get install blender: Blender 3.4, CPU Cycles with Embree), oiiotool and
numpy; ../shared must be present.
"""
import argparse
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import image_error  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), 'shared')
BOX = os.path.join(SHARED, 'scenes', 'bitterli-cornell-box')
CYCLES = os.path.join(SHARED, 'tools', 'cycles')


def box_downsample(img, size):
    h, w, c = img.shape
    if h % size or w % size:
        raise SystemExit(f'bench_cycles: reference {w}x{h} is not a multiple of {size}')
    fy, fx = h // size, w // size
    return img.reshape(size, fy, size, fx, c).mean(axis=(1, 3))


def errors(img, ref):
    return image_error.rel_mse(img, ref), image_error.rel_mse_robust(img, ref)


def cycles_run(args, seed, out):
    cmd = ['blender', '-b', '--factory-startup', '--python',
           os.path.join(CYCLES, 'render_cycles.py'), '--',
           '--obj', os.path.join(CYCLES, 'cornell.obj'),
           '--camera', os.path.join(CYCLES, 'camera.txt'),
           '--width', str(args.size), '--height', str(args.size), '--spp', str(args.cycles_spp),
           '--max-depth', '64', '--seed', str(seed), '--threads', str(args.threads), '--out', out]
    r = subprocess.run(cmd, capture_output=True, text=True)
    line = next((l for l in r.stdout.splitlines() if l.startswith('{"tool": "render_cycles"')),
                None)
    if r.returncode != 0 or line is None:
        raise SystemExit(f'bench_cycles: Cycles failed:\n{r.stdout[-2000:]}\n{r.stderr[-2000:]}')
    return json.loads(line)['render_wall_s']


def box_filter_scene(tmp):
    """The pbrt-v4 file with its pixel filter replaced by a box of radius 0.5."""
    src = os.path.join(BOX, 'pbrt-v4', 'scene-v4.pbrt')
    with open(src) as f:
        text = f.read()
    new, n = re.subn(r'PixelFilter\s+"triangle"\s*"float xradius"\s*\[\s*1\s*\]\s*'
                     r'"float yradius"\s*\[\s*1\s*\]',
                     'PixelFilter "box" "float xradius" [ 0.5 ] "float yradius" [ 0.5 ]', text)
    if n != 1:
        raise SystemExit(f'bench_cycles: {src}: no triangle PixelFilter of radius 1 to replace')
    out = os.path.join(tmp, 'cornell-box-boxfilter.pbrt')
    with open(out, 'w') as f:
        f.write(new)
    return out


def tessera_run(args, scene, sampler, spp, seed, tmp):
    exr = os.path.join(tmp, 't.exr')
    stats = os.path.join(tmp, 't.json')
    cmd = [args.tessera, 'render', scene, '--sampler', sampler, '--spp', str(spp), '--seed',
           str(seed), '--resolution', f'{args.size}x{args.size}', '--threads', str(args.threads),
           '-q', '--no-png', '-o', exr, '--stats', stats]
    subprocess.run(cmd, check=True, capture_output=True)
    with open(stats) as f:
        s = json.load(f)
    return float(s['load_s']) + float(s['wall_s']), exr


def time_to_error(ladder, target):
    """Log-log interpolation of time at `target` error over [(time, error)] points."""
    pts = sorted(ladder)
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if e0 >= target >= e1 and e0 > e1:
            a = (math.log(e0) - math.log(target)) / (math.log(e0) - math.log(e1))
            return math.exp(math.log(t0) + a * (math.log(t1) - math.log(t0)))
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--size', type=int, default=256)
    ap.add_argument('--cycles-spp', type=int, default=64)
    ap.add_argument('--seeds', type=int, default=3)
    ap.add_argument('--threads', type=int, default=2)
    ap.add_argument('--sampler', action='append')
    ap.add_argument('--spp-ladder', default='4,8,16,32,64,128')
    ap.add_argument('--tessera', default=os.path.join(ROOT, 'build', 'tessera'))
    args = ap.parse_args()
    samplers = args.sampler or ['uniform', 'adaptive']
    ladder = [int(v) for v in args.spp_ladder.split(',')]
    if not os.path.isdir(BOX) or not os.path.isdir(CYCLES):
        sys.exit('bench_cycles: ../shared/scenes/bitterli-cornell-box or ../shared/tools/cycles '
                 'not found')
    if subprocess.run(['which', 'blender'], capture_output=True).returncode != 0:
        sys.exit('bench_cycles: blender not found (apt-get install blender)')

    ref = box_downsample(image_error.read_exr(os.path.join(BOX, 'reference', 'TungstenRender.exr')),
                         args.size)
    tmp = tempfile.mkdtemp(prefix='tessera-bench-cycles-')
    seeds = list(range(11, 11 + args.seeds))
    c_times, c_err, c_rob = [], [], []
    for seed in seeds:
        out = os.path.join(tmp, f'cycles-{seed}.exr')
        c_times.append(cycles_run(args, seed, out))
        e, r = errors(image_error.read_exr(out), ref)
        c_err.append(e)
        c_rob.append(r)
        print(f'cycles seed {seed}: {c_times[-1]:.3f} s relMSE {e:.5g} robust {r:.5g}', flush=True)
    t_cycles = statistics.median(c_times)
    e_cycles = statistics.mean(c_err)
    print(f'cycles {args.cycles_spp} spp: median {t_cycles:.3f} s, relMSE {e_cycles:.5g} '
          f'(seeds {min(c_err):.5g}-{max(c_err):.5g}), robust {statistics.mean(c_rob):.5g}\n')

    scene = box_filter_scene(tmp)
    rows = []
    for sampler in samplers:
        points = []
        for spp in ladder:
            ts, es, rs = [], [], []
            for seed in seeds:
                t, exr = tessera_run(args, scene, sampler, spp, seed, tmp)
                e, r = errors(image_error.read_exr(exr), ref)
                ts.append(t)
                es.append(e)
                rs.append(r)
            t, e = statistics.median(ts), statistics.mean(es)
            points.append((t, e))
            print(f'tessera {sampler} {spp} spp: {t:.3f} s relMSE {e:.5g} '
                  f'(seeds {min(es):.5g}-{max(es):.5g}) robust {statistics.mean(rs):.5g}',
                  flush=True)
        t_eq = time_to_error(points, e_cycles)
        rows.append((sampler, t_eq))
        print()
    print(f'| renderer | time to relMSE {e_cycles:.4g} (s) | / Cycles |')
    print('|---|---|---|')
    print(f'| Cycles {args.cycles_spp} spp | {t_cycles:.3f} | 1 |')
    for sampler, t_eq in rows:
        if t_eq is None:
            print(f'| Tessera {sampler} | outside the ladder | - |')
        else:
            print(f'| Tessera {sampler} | {t_eq:.3f} | {t_eq / t_cycles:.2f} |')


if __name__ == '__main__':
    main()
