#!/usr/bin/env python3
"""Time to equal error of two Tessera builds on the same scenes, side by side in one run: what a
change to sampling or to the integrator does to efficiency, not only to speed.

    scripts/bench_efficiency.py BEFORE_BINARY AFTER_BINARY [--pairs 2] [--spp 32]
                                [--resolution 160x120] [--threads 2] [SCENE ...]

Without scenes: every examples/*/*.pbrt and every ../shared/scenes scene (when present), as
scripts/bench_builds.py. Each build renders each scene (uniform sampler, fixed spp) with seeds
1 .. 2 x --pairs, the builds interleaved seed by seed; a build's error on a scene is the mean
over the seed pairs (1, 2), (3, 4), ... of the robust relMSE between the two images (relMSE
without the 0.1% largest per-pixel errors: twice the variance of one image, with no reference
needed), its time the sum of the stats JSON's wall_s (the render). Prints per scene the error
and time ratios after/before and the efficiency gain (before error x time) / (after error x
time): above 1, the after build reaches a given error sooner. Then the median gain.
"""
import argparse
import os
import statistics
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import image_error  # noqa: E402
from bench_builds import default_scenes, render_s  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('before')
    ap.add_argument('after')
    ap.add_argument('scenes', nargs='*')
    ap.add_argument('--pairs', type=int, default=2)
    ap.add_argument('--spp', type=int, default=32)
    ap.add_argument('--resolution', default='160x120')
    ap.add_argument('--threads', type=int, default=2)
    args = ap.parse_intermixed_args()
    builds = {'before': os.path.abspath(args.before), 'after': os.path.abspath(args.after)}
    scenes = [os.path.abspath(s) for s in (args.scenes or default_scenes())]
    tmp = tempfile.mkdtemp(prefix='tessera-bench-efficiency-')
    print(f'| scene | error after/before | time after/before | efficiency gain |')
    print('|---|---|---|---|', flush=True)
    gains = []
    for scene in scenes:
        times = {b: 0.0 for b in builds}
        imgs = {b: [] for b in builds}
        for seed in range(1, 2 * args.pairs + 1):
            for b, binary in builds.items():
                out = os.path.join(tmp, f'{b}-{seed}.exr')
                times[b] += render_s(binary, scene, args, tmp, seed=seed, out=out)
                imgs[b].append(image_error.read_exr(out))
        err = {b: statistics.mean(image_error.rel_mse_robust(v[2 * k], v[2 * k + 1])
                                  for k in range(args.pairs))
               for b, v in imgs.items()}
        gain = (err['before'] * times['before']) / (err['after'] * times['after'])
        gains.append(gain)
        name = os.path.relpath(scene, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        print(f'| {name} | {err["after"] / err["before"]:.3f} | '
              f'{times["after"] / times["before"]:.3f} | {gain:.3f} |', flush=True)
    print(f'\nmedian efficiency gain {statistics.median(gains):.3f} over {len(gains)} scenes '
          f'(min {min(gains):.3f}, max {max(gains):.3f})')


if __name__ == '__main__':
    main()
