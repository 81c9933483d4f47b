#!/usr/bin/env python3
"""Render time of two Tessera builds on the same scenes, side by side in one run: what a change
costs (or saves) where it should change nothing.

    scripts/bench_builds.py BEFORE_BINARY AFTER_BINARY [--rounds 5] [--spp 16]
                            [--resolution 192x192] [--threads 2] [--skip-media] [SCENE ...]

Without scenes: every examples/*/*.pbrt and every ../shared/scenes scene (when present). Each
scene renders with both binaries (uniform sampler, --deterministic, fixed spp), interleaved
before/after over --rounds rounds so that machine noise hits both alike; the render time is
the stats JSON's `wall_s` (the render; scene loading left out). Prints per scene the median
render time of each build and after/before, then the median ratio over the scenes. --skip-media leaves out
scenes with MakeNamedMedium (which the builds may render differently on purpose).
"""
import argparse
import glob
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), 'shared', 'scenes')


def default_scenes():
    scenes = sorted(glob.glob(os.path.join(ROOT, 'examples', '*', '*.pbrt')))
    if os.path.isdir(SHARED):
        for d, _, files in sorted(os.walk(SHARED)):
            for f in sorted(files):
                if f == 'scene-v4.pbrt' or f.endswith('.obj') or f == 'bunny.ply':
                    scenes.append(os.path.join(d, f))
    return scenes


def has_media(path):
    if not path.endswith('.pbrt'):
        return False
    with open(path, errors='replace') as f:
        return 'MakeNamedMedium' in f.read()


def render_s(binary, scene, args, tmp, seed=None, out=None):
    """Render seconds (stats wall_s) of a uniform render at args.spp, args.resolution and
    args.threads; --deterministic unless a seed is given (scripts/bench_efficiency.py)."""
    stats = os.path.join(tmp, 'stats.json')
    cmd = [binary, 'render', scene, '-o', out or os.path.join(tmp, 'out.exr'), '--no-png', '-q',
           '--sampler', 'uniform', '--spp', str(args.spp), '--resolution',
           args.resolution, '--threads', str(args.threads), '--stats', stats]
    cmd += ['--deterministic'] if seed is None else ['--seed', str(seed)]
    subprocess.run(cmd, check=True, capture_output=True, cwd=os.path.dirname(scene))
    with open(stats) as f:
        return float(json.load(f)['wall_s'])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('before')
    ap.add_argument('after')
    ap.add_argument('scenes', nargs='*')
    ap.add_argument('--rounds', type=int, default=5)
    ap.add_argument('--spp', type=int, default=16)
    ap.add_argument('--resolution', default='192x192')
    ap.add_argument('--threads', type=int, default=2)
    ap.add_argument('--skip-media', action='store_true')
    args = ap.parse_args()
    args.before, args.after = os.path.abspath(args.before), os.path.abspath(args.after)
    scenes = [os.path.abspath(s) for s in args.scenes] or default_scenes()
    if args.skip_media:
        scenes = [s for s in scenes if not has_media(s)]
    ratios = []
    print('scene\tbefore s\tafter s\tafter/before', flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            t = {'before': [], 'after': []}
            for _ in range(args.rounds):
                for side in ('before', 'after'):
                    t[side].append(render_s(getattr(args, side), scene, args, tmp))
            b, a = statistics.median(t['before']), statistics.median(t['after'])
            ratios.append(a / b)
            name = os.path.relpath(scene, os.path.dirname(ROOT))
            print(f'{name}\t{b:.4f}\t{a:.4f}\t{a / b:.4f}', flush=True)
    if ratios:
        print(f'median after/before over {len(ratios)} scenes: {statistics.median(ratios):.4f} '
              f'(min {min(ratios):.4f}, max {max(ratios):.4f})')
    return 0


if __name__ == '__main__':
    sys.exit(main())
