#!/usr/bin/env python3
"""Benchmark of the attribute specialisation in the real-time modes (renderer/scene/specialize.h).

For each scene and plugin: `tessera render --sampler S --frames F --threads T` with the
Whitted integrator collecting only what the plugin reads and the scene can have (reduced) and
with `--no-specialize` (full collection, the general path), interleaved A B A B (the machine is
noisy), RUNS runs each. Prints the median frame time of each mode (the median over runs of the
stats' frame_ms_median), the ratio full / reduced (> 1: the reduced collection is faster), the
attribute groups collected, and the shadow rays traced and avoided (totals over the frames; the
same in both modes, checked).

Usage: scripts/bench_attributes.py [--tessera build/tessera] [--resolution 512x512]
       [--frames 8] [--threads 1] [--runs 2] [--out bench-attributes]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES = [("cornell-mirror", "examples/realtime/cornell-mirror.pbrt"),
          ("cornell-box", "examples/cornell-box/scene.pbrt")]
SAMPLERS = ["fixed:spp=1", "fixed:spp=4", "jin", "kim", "fliptri", "suffern"]


def render(args, scene, sampler, specialize, tag):
    stats = os.path.join(args.out, f"{tag}.json")
    cmd = [args.tessera, "render", os.path.join(ROOT, scene), "--sampler", sampler,
           "--frames", str(args.frames), "--resolution", args.resolution,
           "--threads", str(args.threads), "-o", os.path.join(args.out, f"{tag}.exr"),
           "--no-png", "--stats", stats, "-q"]
    if not specialize:
        cmd.append("--no-specialize")
    subprocess.run(cmd, check=True)
    with open(stats) as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tessera", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--resolution", default="512x512")
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--out", default="bench-attributes")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)

    print(f"# {args.resolution}, {args.frames} frames, {args.threads} thread(s), "
          f"{args.runs} interleaved runs per mode; ms = median of frame_ms_median")
    header = (f"{'scene':<15} {'sampler':<12} {'reduced ms':>10} {'full ms':>9} {'full/red':>8} "
              f"{'collected (reduced)':<26} {'shadow rays':>12} {'avoided':>11} {'avoided %':>9}")
    print(header)
    print("-" * len(header))
    ok = True
    for scene_name, scene in SCENES:
        for sampler in SAMPLERS:
            times = {True: [], False: []}
            last = {}
            for run in range(args.runs):
                for specialize in (True, False):  # A B A B
                    tag = f"{scene_name}-{sampler.replace(':', '_').replace('=', '')}-" \
                          f"{'red' if specialize else 'full'}-{run}"
                    j = render(args, scene, sampler, specialize, tag)
                    times[specialize].append(j["frame_ms_median"])
                    last[specialize] = j
            red, full = statistics.median(times[True]), statistics.median(times[False])
            a, b = last[True], last[False]
            if (a["shadow_rays"], a["shadow_rays_avoided"], a["rays"]) != \
                    (b["shadow_rays"], b["shadow_rays_avoided"], b["rays"]):
                print(f"error: {scene_name} {sampler}: ray counts differ between the modes",
                      file=sys.stderr)
                ok = False
            total = a["shadow_rays"] + a["shadow_rays_avoided"]
            pct = 100.0 * a["shadow_rays_avoided"] / total if total else 0.0
            print(f"{scene_name:<15} {sampler:<12} {red:>10.1f} {full:>9.1f} {full / red:>8.3f} "
                  f"{a['attributes_collected']:<26} {a['shadow_rays']:>12} "
                  f"{a['shadow_rays_avoided']:>11} {pct:>8.1f}%", flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
