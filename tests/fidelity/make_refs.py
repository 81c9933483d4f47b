#!/usr/bin/env python3
"""Renders the fidelity references with pbrt-v4: each scene of tests/fidelity/scenes twice,
with seeds 1 and 2, into tests/fidelity/refs/NAME.seed1.exr and NAME.seed2.exr (half-float
EXR, pbrt-v4's own output). Two independent renders let the test estimate the references'
noise per pixel: for the mean m = (a + b) / 2, E[(a - b)^2] / 4 = Var(m).

    tests/fidelity/make_refs.py [--spp 2048] [--threads 2] [--pbrt PATH] [NAME ...]

Without names every scene is rendered; with names only those (a scene file's name without
.pbrt). Names in SHARED_SCENES are public scenes of ../shared/scenes, rendered from a copy
with the resolution given there (scripts/compare_pbrt.py scaled_scene: a mirror folder whose
other entries link to the originals); only on request, by name. pbrt-v4 comes from ../shared/tools/pbrt-v4/bin/pbrt beside the repository unless
--pbrt is given. refs/manifest.json records each reference's spp, seeds and render time.
"""
import argparse
import json
import os
import re
import subprocess
import tempfile
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(HERE, 'scenes')
REFS = os.path.join(HERE, 'refs')
DEFAULT_PBRT = os.path.normpath(os.path.join(HERE, '..', '..', '..', 'shared', 'tools',
                                             'pbrt-v4', 'bin', 'pbrt'))
PBRT_COMMIT = '5f7a606'  # ../shared/tools/pbrt-v4/README.md
SHARED = os.path.normpath(os.path.join(HERE, '..', '..', '..', 'shared'))
# Public scenes the fidelity test checks when ../shared is present (fidelity_render.cpp
# kSharedScenes): name -> (path under ../shared, x resolution, y resolution).
SHARED_SCENES = {
    'shared-staircase2': ('scenes/bitterli/staircase2/scene-v4.pbrt', 128, 128),
}


def scene_path(name, work_dir):
    """The scene file to render for `name`, and the folder to render it in."""
    if name not in SHARED_SCENES:
        return os.path.join(SCENES, name + '.pbrt'), SCENES
    sys.path.insert(0, os.path.join(HERE, '..', '..', 'scripts'))
    from compare_pbrt import scaled_scene
    rel, w, _ = SHARED_SCENES[name]
    src = os.path.join(SHARED, rel)
    if not os.path.exists(src):
        raise SystemExit(f'make_refs: {src} not found')
    text = open(src).read()
    xres = int(re.search(r'"integer\s+xresolution"\s*\[?\s*(\d+)', text).group(1))
    path, _, _ = scaled_scene(src, os.path.join(work_dir, name), w / xres)
    return path, os.path.dirname(path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--spp', type=int, default=2048, help='samples per pixel per seed')
    ap.add_argument('--threads', type=int, default=2)
    ap.add_argument('--pbrt', default=DEFAULT_PBRT)
    ap.add_argument('names', nargs='*')
    args = ap.parse_args()
    if not os.access(args.pbrt, os.X_OK):
        print(f'make_refs: pbrt-v4 not found at {args.pbrt} (give --pbrt)', file=sys.stderr)
        return 2
    names = args.names or sorted(f[:-5] for f in os.listdir(SCENES) if f.endswith('.pbrt'))
    os.makedirs(REFS, exist_ok=True)
    manifest_path = os.path.join(REFS, 'manifest.json')
    manifest = {}
    if os.path.exists(manifest_path):
        with open(manifest_path) as f:
            manifest = json.load(f)
    work_dir = tempfile.mkdtemp(prefix='make_refs.')
    for name in names:
        scene, cwd = scene_path(name, work_dir)
        if not os.path.exists(scene):
            print(f'make_refs: no scene {scene}', file=sys.stderr)
            return 2
        seconds = []
        for seed in (1, 2):
            out = os.path.join(REFS, f'{name}.seed{seed}.exr')
            tmp = out + '.tmp.exr'
            t0 = time.time()
            # Run in the scenes folder: pbrt-v4 resolves relative paths against the scene
            # file's folder, and writes nothing else there with --outfile.
            r = subprocess.run([args.pbrt, '--spp', str(args.spp), '--seed', str(seed),
                                '--nthreads', str(args.threads), '--quiet', '--outfile', tmp,
                                scene], cwd=cwd, capture_output=True, text=True)
            if r.returncode != 0:
                print(f'make_refs: pbrt-v4 failed on {name}:\n{r.stdout}{r.stderr}',
                      file=sys.stderr)
                if os.path.exists(tmp):
                    os.remove(tmp)
                return 1
            os.replace(tmp, out)
            seconds.append(round(time.time() - t0, 1))
        manifest[name] = {'spp_per_seed': args.spp, 'seeds': [1, 2], 'seconds': seconds,
                          'pbrt': PBRT_COMMIT, 'threads': args.threads}
        print(f'{name}: {seconds[0]} s + {seconds[1]} s', flush=True)
        with open(manifest_path + '.tmp', 'w') as f:
            json.dump(manifest, f, indent=1, sort_keys=True)
            f.write('\n')
        os.replace(manifest_path + '.tmp', manifest_path)
    return 0


if __name__ == '__main__':
    sys.exit(main())
