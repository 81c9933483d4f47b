#!/usr/bin/env python3
"""Equal-time relMSE of samplers over several sequence seeds (the adaptive-against-uniform comparison of the README).

One `tessera converge` run per seed (every sampler for the same time budget, against one
reference), then per sampler and for two metrics, the robust relMSE ("relMSE-0.1%": relMSE with
the 0.1% of pixels of largest per-pixel relative error left out, sampling/image_metrics.h) and
the plain relMSE: the final error of each seed and its ratio to the first sampler's error with
the same seed, and over the seeds the mean error, the ratio of the mean errors, and the mean,
geometric mean and range (min-max) of the per-seed ratios.

The robust relMSE is the headline (first table; also tessera converge's default --metric):
the plain relMSE of one render is decided by single fireflies. On scenes with caustics or small
bright lights one firefly more or less in a pixel moves the image's relMSE by tens of per cent,
so its ratios say more about which seed drew the fireflies than about the sampler. Even so a
single run is not enough: an adaptive sampler, which stops pixels on what their samples showed
so far, varies more from seed to seed than uniform sampling does, which is what the range of
the ratios shows. Results of a tessera too old to write the robust relMSE get the plain table
only.

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


# The metrics of the tables, headline first: (convergence.json key, label).
METRICS = [("relmse_robust", "relMSE-0.1%"), ("relmse", "relMSE")]


def row_result(r):
    """(sampler, {metric key: final error, None where the row lacks it}, mean spp) of a row."""
    errs = {key: (r[key]["total"] if key in r else None) for key, _ in METRICS}
    return r["sampler"], errs, r["mean_spp"]


def seed_line(results):
    """One seed's errors and their ratios to the first sampler's, for the progress output."""
    base = results[0][1]
    parts = []
    for name, errs, spp in results:
        cells = []
        for key, label in METRICS:
            e = errs[key]
            if e is not None:
                cells.append(f"{label} {e:.4g} ({e / base[key]:.3f}x)" if base[key]
                             else f"{label} {e:.4g}")
        parts.append(f"{name}: " + ", ".join(cells) + f", {spp:.0f} spp")
    return "  " + "\n  ".join(parts)


def metric_table(per_seed, key, label):
    """The over-seeds table of one metric; None when a run lacks the metric (or the first
    sampler's error, the ratios' denominator, is 0)."""
    if any(errs[key] is None for ps in per_seed for _, errs, _ in ps) or \
            any(not ps[0][1][key] for ps in per_seed):
        return None
    n_s = len(per_seed[0])
    lines = [f"{label}:",
             f"{'sampler':44s} {'mean error':>11s} {'ratio of means':>15s} {'mean ratio':>11s}"
             f" {'geo-mean ratio':>15s} {'ratio range':>17s}"]
    base_mean = sum(ps[0][1][key] for ps in per_seed) / len(per_seed)
    for i in range(n_s):
        name = per_seed[0][i][0]
        errs = [ps[i][1][key] for ps in per_seed]
        ratios = [ps[i][1][key] / ps[0][1][key] for ps in per_seed]
        mean = sum(errs) / len(errs)
        mean_ratio = sum(ratios) / len(ratios)
        geo = math.exp(sum(math.log(r) for r in ratios) / len(ratios)) \
            if all(r > 0 for r in ratios) else 0.0
        span = f"{min(ratios):.3f}-{max(ratios):.3f}"
        lines.append(f"{name[:44]:44s} {mean:11.4g} {mean / base_mean:15.3f} {mean_ratio:11.3f}"
                     f" {geo:15.3f} {span:>17s}")
    return "\n".join(lines)


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
    per_seed = []  # per seed: list of (sampler, {metric: error}, mean_spp)
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
        per_seed.append([row_result(r) for r in rows])
        print(seed_line(per_seed[-1]), flush=True)

    base = samplers[0]
    print(f"\n{args.scene}, {args.resolution}, {args.time:g} s per sampler, {args.seeds} seeds; "
          f"ratios to {base} with the same seed (below 1: better than {base})")
    for key, label in METRICS:
        table = metric_table(per_seed, key, label + (" (headline)" if key == METRICS[0][0]
                                                     else ""))
        if table is None:
            print(f"\n{label}: not in every run (a tessera without it?), left out")
        else:
            print("\n" + table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
