#!/usr/bin/env python3
"""The adaptive scheduler's own costs at film resolution, and its determinism.

    scripts/bench_scheduler.py [--scene examples/cornell-box/scene.pbrt] [--resolution 1920x1080]
                               [--time 20] [--threads 2] [--tessera build/tessera] [-o OUT]

1. Costs: one `tessera render --time T` per sampler (the default `adaptive`, `adaptive:dammertz=1`
   with refinement, `uniform`) at the resolution; from the stats JSON the lock wait as a fraction
   of thread time, the tree rebuild time per quadrant (mean and max, milliseconds), rebuilds,
   samples and tiles skipped.
2. Determinism: `--deterministic --spp 64` renders of the scene at 160x120 with 1, 2 and 3
   threads per sampler; the EXRs' beauty and sample counts must be bit-identical (exit 1 if not).
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import image_error as ie  # noqa: E402

SAMPLERS = ["adaptive", "adaptive:dammertz=1,refine=1", "uniform"]


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {r.returncode}: {r.stderr.strip()[-600:]}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default=os.path.join(ROOT, "examples", "cornell-box", "scene.pbrt"))
    ap.add_argument("--resolution", default="1920x1080")
    ap.add_argument("--time", type=float, default=20)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--tessera", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("-o", "--out", default="bench-scheduler")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    print(f"{os.path.relpath(a.scene, ROOT)} at {a.resolution}, --time {a.time:g}, "
          f"{a.threads} threads")
    print(f"{'sampler':32} {'lock wait':>10} {'rebuild ms mean':>16} {'max':>8} {'rebuilds':>9} "
          f"{'Msamples':>9} {'tiles skipped':>14}")
    for k, smp in enumerate(SAMPLERS):
        js = os.path.join(a.out, f"cost-{k}.json")
        run([a.tessera, "render", a.scene, "--sampler", smp, "--resolution", a.resolution,
             "--time", str(a.time), "--spp", "1000000", "--threads", str(a.threads),
             "-o", os.path.join(a.out, f"cost-{k}.exr"), "--stats", js, "-q", "--no-png"])
        with open(js) as f:
            s = json.load(f)
        print(f"{smp:32} {100 * s['lock_wait_fraction']:9.4f}% {s['tree_rebuild_ms_mean']:16.3f} "
              f"{s['tree_rebuild_ms_max']:8.3f} {s['rebuilds']:9d} {s['samples'] / 1e6:9.1f} "
              f"{s['tiles_skipped']:14d}")
    print("\ndeterministic, --spp 64 at 160x120: bit-identical for 1, 2 and 3 threads?")
    ok = True
    for k, smp in enumerate(SAMPLERS):
        imgs = []
        for t in (1, 2, 3):
            exr = os.path.join(a.out, f"det-{k}-{t}.exr")
            run([a.tessera, "render", a.scene, "--sampler", smp, "--resolution", "160x120",
                 "--spp", "64", "--deterministic", "--threads", str(t), "-o", exr, "-q",
                 "--no-png"])
            imgs.append((ie.read_exr(exr), ie.read_exr(exr, "spp.Y")))
        same = all(np.array_equal(imgs[0][0], i[0]) and np.array_equal(imgs[0][1], i[1])
                   for i in imgs[1:])
        ok = ok and same
        print(f"  {smp:32} {'identical' if same else 'DIFFERENT'}")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
