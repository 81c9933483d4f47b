#!/usr/bin/env python3
"""What each specialised code path saves (renderer/scene/specialize.h): time per sample and image difference,
specialised against the general path forced with --no-specialize, side by side in one run.

For every scene: the default render (every specialisation that applies), the general path
(--no-specialize, all forced off), and each applicable specialisation forced off alone
(--no-specialize=NAME: what that one saves on top of the others). Runs are interleaved
round-robin over --rounds rounds so that machine noise hits every variant alike; the table
shows the median and the best time per sample, the ratio general / specialised on the medians,
and whether the image is identical to the default render (MSE from `tessera diff`).

Usage: scripts/bench_specialize.py [--tessera build/tessera] [--rounds 5] [--spp 32]
       [--resolution 256x256] [--threads 1] [--csv out.csv]
Exits 1 when some image differs from the specialised render's (they must be identical).
Scenes from ../shared/scenes are used when present (skipped with a message otherwise).
"""
import argparse
import csv
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "scenes")

SCENES = [
    ("diffuse-box", os.path.join(ROOT, "examples/specialize/diffuse-box.pbrt")),
    ("bitterli-cornell", os.path.join(SHARED, "bitterli-cornell-box/pbrt-v4/scene-v4.pbrt")),
    ("mcguire-cornell-obj", os.path.join(SHARED, "mcguire-cornellbox-obj/CornellBox-Original.obj")),
    ("cornell-box (textured, glass, metal)", os.path.join(ROOT, "examples/cornell-box/scene.pbrt")),
    ("glossy-glass", os.path.join(ROOT, "examples/glossy-glass/scene.pbrt")),
    ("environment", os.path.join(ROOT, "examples/environment/scene.pbrt")),
]


def render(args, scene, out_dir, tag, extra, spp=None):
    exr = os.path.join(out_dir, tag + ".exr")
    stats = os.path.join(out_dir, tag + ".json")
    cmd = [args.tessera, "render", scene, "-o", exr, "--no-png", "-q", "--sampler", "uniform",
           "--spp", str(spp or args.spp), "--resolution", args.resolution, "--threads",
           str(args.threads), "--stats", stats] + extra
    subprocess.run(cmd, check=True)
    with open(stats) as f:
        j = json.load(f)
    return exr, j


def mse(args, a, b):
    out = subprocess.run([args.tessera, "diff", a, b], check=True, capture_output=True,
                         text=True).stdout
    m = re.search(r"^MSE\s+\S+\s+\S+\s+\S+\s+(\S+)", out, re.M)
    return float(m.group(1)) if m else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tessera", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--resolution", default="256x256")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--csv", default="")
    args = ap.parse_args()

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, scene in SCENES:
            if not os.path.exists(scene):
                print(f"skipped {name}: {scene} not found (../shared is not in a user's clone)")
                continue
            # Which specialisations apply: from a short probe render.
            _, probe = render(args, scene, tmp, "probe", [], spp=1)
            applicable = probe["specializations"]["applicable"]
            applicable = [] if applicable == "none" else applicable.split(",")
            variants = [("specialised", [])]
            variants.append(("general (--no-specialize)", ["--no-specialize"]))
            for s in applicable:
                variants.append((f"without {s}", [f"--no-specialize={s}"]))
            times = {v: [] for v, _ in variants}
            info = {}
            for r in range(args.rounds):
                for v, extra in variants:
                    tag = re.sub(r"[^a-z0-9]+", "_", f"{name}_{v}_{r}")
                    exr, j = render(args, scene, tmp, tag, extra)
                    times[v].append(j["time_per_phase"]["render_thread_s"] / j["samples"] * 1e6)
                    info[v] = (exr, j)
            base_exr, base_j = info["specialised"]
            base = statistics.median(times["specialised"])
            for v, _ in variants:
                exr, j = info[v]
                med = statistics.median(times[v])
                err = 0.0 if v == "specialised" else mse(args, exr, base_exr)
                rows.append({
                    "scene": name,
                    "variant": v,
                    "used": j["specializations"]["used"],
                    "us_per_sample_median": round(med, 3),
                    "us_per_sample_best": round(min(times[v]), 3),
                    "ratio_vs_specialised": round(med / base, 3),
                    "shadow_rays_avoided_per_sample": round(j["shadow_rays_avoided"] / j["samples"], 3),
                    "rays_per_sample": round(j["rays"] / j["samples"], 3),
                    "image_mse_vs_specialised": err,
                })

    cols = ["scene", "variant", "used", "us_per_sample_median", "us_per_sample_best",
            "ratio_vs_specialised", "rays_per_sample", "shadow_rays_avoided_per_sample",
            "image_mse_vs_specialised"]
    widths = [max(len(c), *(len(str(r[c])) for r in rows)) for c in cols] if rows else []
    print(f"# bench_specialize: {args.resolution}, {args.spp} spp, {args.threads} thread(s), "
          f"{args.rounds} interleaved rounds; time per sample = render thread time / samples")
    print("  ".join(c.ljust(w) for c, w in zip(cols, widths)))
    for r in rows:
        print("  ".join(str(r[c]).ljust(w) for c, w in zip(cols, widths)))
    for r in rows:
        if r["variant"].startswith("general"):
            print(f"{r['scene']}: general path / specialised = {r['ratio_vs_specialised']:.3f}x "
                  f"(target >= 1.2 on a diffuse-only scene lit by one area light), image "
                  f"{'identical' if r['image_mse_vs_specialised'] == 0 else 'MSE %g' % r['image_mse_vs_specialised']}")
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=cols)
            w.writeheader()
            w.writerows(rows)
    # Every specialisation promises the general path's image bit for bit.
    differ = [r for r in rows if r["image_mse_vs_specialised"] != 0]
    for r in differ:
        print(f"ERROR: {r['scene']}, {r['variant']}: image differs from the specialised one "
              f"(MSE {r['image_mse_vs_specialised']})", file=sys.stderr)
    return 1 if differ or not rows else 0


if __name__ == "__main__":
    sys.exit(main())
