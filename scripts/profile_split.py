#!/usr/bin/env python3
"""Where a render's time goes, per scene: the share of CPU samples in ray intersection (Embree
and Tessera's own user geometry), shading (integrator, BSDFs, lights, camera), textures,
sampling (sample patterns, distributions), the film, the scheduler (tiles, region trees,
oneTBB), scene loading and the rest (libc, kernel).

    scripts/profile_split.py [--spp 16] [--resolution 192x144] [--threads 2] [--freq 2000]
                             [--tessera build/tessera] [SCENE ...]

Without scenes: every examples/*/*.pbrt and every ../shared/scenes scene, as
scripts/bench_builds.py. Each scene is rendered once under `perf record -e cpu-clock` (uniform
sampler, fixed spp); every sample's symbol is put into one category by its library and name
(CATEGORIES below, first match wins). Loading counts as far as its symbols tell (the parser,
mesh and image readers, MIP-map building); Embree's BVH build cannot be told from traversal in
a stripped library and counts as intersection, so renders should be long against the load
(Tessera's --stats load_s is printed beside). Needs perf (linux-perf); hardware counters are
not needed.
"""
import argparse
import collections
import json
import os
import re
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_builds import default_scenes  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# (category, library regex or None, symbol regex or None): the first rule whose library and
# symbol patterns both match (None matches anything) names a sample's category.
CATEGORIES = [
    ('load', None, r'pbrt_parser|Tokenizer|parse_|Parser|ply_|read_ply|load_|build_scene|'
                   r'MipMap::MipMap|resample_axis|prepare_image|native_image|TgaInput|PfmInput|'
                   r'PngInput|finish_mesh|obj_loader|tinyobj|loop_subdiv|SceneBuilder'),
    ('load', r'libpng|libz\.|libOpenImageIO|libOpenEXR|libImath|libIex', None),
    ('intersection', r'libembree', None),
    ('intersection', None, r'^rtc|Geometry::(intersect|occluded)|intersect_|_intersect|occluded|'
                           r'quadric|curve_|fill_hit|PacketRays'),
    ('textures', None, r'Texture|texture|MipMap|mipmap|bilinear|ewa|Ewa'),
    ('film', None, r'Film|film_|add_sample|flush|TileTally|Accumulator'),
    ('scheduler', r'libtbb', None),
    ('scheduler', None, r'sched::|Scheduler|RegionTree|region_tree|tbb::|Progressive|'
                        r'process_tile|run_pass|rebuild'),
    ('sampling', None, r'Sobol|sobol|owen|Owen|scramble|Sampler|sampler|sequence|Sequence|'
                       r'PiecewiseConstant|sample_continuous|sample_discrete|Distribution|'
                       r'hash|Hash|mix_bits|CameraSample|PixelSampler|get_1d|get_2d'),
    ('shading', r'tessera', None),
    ('other', None, None),
]
ORDER = ['intersection', 'shading', 'textures', 'sampling', 'film', 'scheduler', 'load', 'other']


def category(dso, sym):
    for name, lib_re, sym_re in CATEGORIES:
        if lib_re and not re.search(lib_re, dso):
            continue
        if sym_re and not re.search(sym_re, sym):
            continue
        return name
    return 'other'


def profile(args, scene, tmp):
    data = os.path.join(tmp, 'perf.data')
    stats = os.path.join(tmp, 'stats.json')
    cmd = ['perf', 'record', '-q', '-e', 'cpu-clock', '-F', str(args.freq), '-o', data, '--',
           args.tessera, 'render', scene, '--sampler', 'uniform', '--spp', str(args.spp),
           '--resolution', args.resolution, '--threads', str(args.threads), '-q', '--no-png',
           '-o', os.path.join(tmp, 'out.exr'), '--stats', stats]
    subprocess.run(cmd, check=True, capture_output=True, cwd=os.path.dirname(scene))
    rep = subprocess.run(['perf', 'report', '-i', data, '--no-children', '--sort', 'dso,sym',
                          '-g', 'none', '--stdio', '--percent-limit', '0'],
                         check=True, capture_output=True, text=True).stdout
    shares = collections.Counter()
    for line in rep.splitlines():
        m = re.match(r'\s*([\d.]+)%\s+(\S+)\s+\[[.k]\]\s+(.*)$', line)
        if not m:
            continue
        pct, dso, sym = float(m.group(1)), m.group(2), m.group(3).strip()
        shares[category(dso, sym) if dso != '[kernel.kallsyms]' else 'other'] += pct
    with open(stats) as f:
        s = json.load(f)
    return shares, float(s['load_s']), float(s['wall_s'])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('scenes', nargs='*')
    ap.add_argument('--spp', type=int, default=16)
    ap.add_argument('--resolution', default='192x144')
    ap.add_argument('--threads', type=int, default=2)
    ap.add_argument('--freq', type=int, default=2000)
    ap.add_argument('--tessera', default=os.path.join(ROOT, 'build', 'tessera'))
    args = ap.parse_intermixed_args()
    args.tessera = os.path.abspath(args.tessera)
    scenes = [os.path.abspath(s) for s in (args.scenes or default_scenes())]
    tmp = tempfile.mkdtemp(prefix='tessera-profile-split-')
    print('| scene | load s | render s | ' + ' | '.join(ORDER) + ' |')
    print('|---|---|---|' + '---|' * len(ORDER), flush=True)
    for scene in scenes:
        shares, load_s, wall_s = profile(args, scene, tmp)
        total = sum(shares.values()) or 1.0
        name = os.path.relpath(scene, ROOT)
        cells = [f'{100 * shares[c] / total:.0f}%' for c in ORDER]
        print(f'| {name} | {load_s:.2f} | {wall_s:.2f} | ' + ' | '.join(cells) + ' |',
              flush=True)


if __name__ == '__main__':
    main()
