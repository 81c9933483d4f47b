#!/usr/bin/env python3
"""Adaptive vs uniform sampling at equal wall time, against a high-sample reference.

For each scene: render a reference (uniform, --ref-spp samples, cached by scene content and
settings), then the adaptive sampler with an error target and a time cap, then the uniform
sampler for exactly the adaptive run's wall time; print relMSE / MSE of both and their ratio.
Also prints the adaptive run's lock wait fraction, tree rebuild times and mean spp.

    scripts/bench_adaptive.py [--tessera build/tessera] [--res 240x180] [--time 20]
                              [--error 0.002] [--ref-spp 4096] [--threads 0] SCENE...
"""
import argparse
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"failed ({r.returncode}): {' '.join(cmd)}\n{r.stderr}")
    return r.stdout


def diff(tessera, a, ref):
    out = run([tessera, "diff", a, ref])
    metrics = {}
    for line in out.splitlines():
        parts = line.split()
        if parts and parts[0] in ("MSE", "relMSE", "RMSE", "PSNR"):
            metrics[parts[0]] = float(parts[-1])
    return metrics


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--tessera", default=os.path.join(os.path.dirname(__file__), "..", "build", "tessera"))
    ap.add_argument("--res", default="240x180")
    ap.add_argument("--time", type=float, default=20.0, help="cap on the adaptive run (s)")
    ap.add_argument("--error", default="0.001", help="adaptive error target(s), comma-separated")
    ap.add_argument("--max-spp", type=int, default=65536)
    ap.add_argument("--extra", default="", help="extra adaptive keys, e.g. min-extent=8")
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "tessera-bench-cache"))
    a = ap.parse_args()
    os.makedirs(a.cache, exist_ok=True)
    work = tempfile.mkdtemp(prefix="tessera-bench-")
    thr = ["--threads", str(a.threads)] if a.threads else []
    print(f"{'scene':<22} {'error':>8} {'time s':>7} {'spp a':>7} {'spp u':>7} "
          f"{'relMSE a':>10} {'relMSE u':>10} {'ratio':>6} {'MSE ratio':>9} "
          f"{'lock wait':>9} {'rebuild ms max/mean':>20}")
    for scene in a.scenes:
        with open(scene, "rb") as f:
            key = hashlib.sha256(f.read() + f"{a.res}|{a.ref_spp}".encode()).hexdigest()[:16]
        ref = os.path.join(a.cache, f"ref-{key}.exr")
        if not os.path.exists(ref):
            run([a.tessera, "render", scene, "--sampler", "uniform", "--spp", str(a.ref_spp),
                 "--resolution", a.res, "--no-png", "-q", "-o", ref] + thr)
        name = os.path.basename(os.path.dirname(os.path.abspath(scene)))
        for err in a.error.split(","):
            ad, ads = os.path.join(work, "a.exr"), os.path.join(work, "a.json")
            run([a.tessera, "render", scene, "--sampler", f"adaptive:error={err}" + (f",{a.extra}" if a.extra else ""),
                 "--spp", str(a.max_spp), "--time", str(a.time), "--resolution", a.res,
                 "--no-png", "-q", "-o", ad, "--stats", ads] + thr)
            sa = json.load(open(ads))
            un, uns = os.path.join(work, "u.exr"), os.path.join(work, "u.json")
            run([a.tessera, "render", scene, "--sampler", "uniform", "--spp", str(a.max_spp),
                 "--time", f"{sa['wall_s']:.3f}", "--resolution", a.res, "--no-png", "-q",
                 "-o", un, "--stats", uns] + thr)
            su = json.load(open(uns))
            ma, mu = diff(a.tessera, ad, ref), diff(a.tessera, un, ref)
            print(f"{name:<22} {err:>8} {sa['wall_s']:>7.2f} {sa['mean_spp']:>7.1f} "
                  f"{su['mean_spp']:>7.1f} {ma['relMSE']:>10.4g} {mu['relMSE']:>10.4g} "
                  f"{ma['relMSE'] / mu['relMSE']:>6.2f} {ma['MSE'] / mu['MSE']:>9.2f} "
                  f"{100 * sa['lock_wait_fraction']:>8.3f}% "
                  f"{sa['tree_rebuild_ms_max']:>9.2f}/{sa['tree_rebuild_ms_mean']:<9.2f}")


if __name__ == "__main__":
    main()
