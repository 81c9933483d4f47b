#!/usr/bin/env python3
"""Equal-time relMSE of samplers over several sequence seeds (the adaptive-against-uniform comparison of the README).

One `tessera converge` run per seed (every sampler for the same time budget, against one
reference), then per sampler: the final relMSE of each seed, its ratio to the first sampler's
relMSE with the same seed, and over the seeds the geometric mean and the range of the ratios and
the ratio of the mean relMSEs. A single run is not enough on scenes with caustics or small bright
lights: one firefly more or less in a pixel moves the image's relMSE by tens of per cent, and an
adaptive sampler, which stops pixels on what their samples showed so far, varies more from seed
to seed than uniform sampling does.

Usage: scripts/bench_adaptive_seeds.py SCENE [--seeds 3] [--time 20] [--resolution 240x180]
       [--reference REF.exr | --reference-spp 4096] [--sampler uniform --sampler adaptive ...]
       [--tessera build/tessera] [--out DIR] [--threads N]
The reference is rendered once (and cached by `tessera converge`) unless --reference is given;
it should have many more samples than any run it judges, or its own noise sets the floor.
"""
import argparse
import json
import math
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def final_rows(path):
    """Last snapshot row of every sampler, in sampler order."""
    with open(path) as f:
        d = json.load(f)
    last = {}
    for r in d["rows"]:
        last[r["sampler_index"]] = r
    return [last[i] for i in sorted(last)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--tessera", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--time", type=float, default=20)
    ap.add_argument("--resolution", default="240x180")
    ap.add_argument("--reference")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--sampler", action="append")
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--out", default="bench-adaptive-seeds")
    args = ap.parse_args()
    samplers = args.sampler or ["uniform", "adaptive"]
    per_seed = []  # per seed: list of (sampler, relmse, mean_spp)
    for k in range(args.seeds):
        seed = args.first_seed + k
        out = os.path.join(args.out, f"seed-{seed}")
        cmd = [args.tessera, "converge", args.scene, "-o", out, "--time", str(args.time),
               "--resolution", args.resolution, "--seed", str(seed), "--no-report", "-q"]
        cmd += ["--reference", args.reference] if args.reference else \
            ["--reference-spp", str(args.reference_spp)]
        if args.threads:
            cmd += ["--threads", str(args.threads)]
        for s in samplers:
            cmd += ["--sampler", s]
        print(f"seed {seed}: {' '.join(cmd)}", flush=True)
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        rows = final_rows(os.path.join(out, "convergence.json"))
        per_seed.append([(r["sampler"], r["relmse"]["total"], r["mean_spp"]) for r in rows])
        print("  " + "   ".join(f"{s}: relMSE {e:.4g} ({spp:.0f} spp)" for s, e, spp in per_seed[-1]),
              flush=True)

    base = samplers[0]
    print(f"\n{args.scene}, {args.resolution}, {args.time:g} s per sampler, {args.seeds} seeds; "
          f"ratios to {base} with the same seed")
    print(f"{'sampler':44s} {'mean relMSE':>12s} {'ratio of means':>15s} {'geo-mean ratio':>15s}"
          f" {'min ratio':>10s} {'max ratio':>10s}")
    n_s = len(per_seed[0])
    base_mean = sum(ps[0][1] for ps in per_seed) / len(per_seed)
    for i in range(n_s):
        name = per_seed[0][i][0]
        errs = [ps[i][1] for ps in per_seed]
        ratios = [ps[i][1] / ps[0][1] for ps in per_seed]
        mean = sum(errs) / len(errs)
        geo = math.exp(sum(math.log(r) for r in ratios) / len(ratios))
        print(f"{name[:44]:44s} {mean:12.4g} {mean / base_mean:15.3f} {geo:15.3f}"
              f" {min(ratios):10.3f} {max(ratios):10.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
