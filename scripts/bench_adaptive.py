#!/usr/bin/env python3
"""Adaptive against uniform sampling on every scene: equal time, equal spp, the oracle bound.

    scripts/bench_adaptive.py [-o OUT] [--tessera build/tessera] [--seeds 5] [--time S]
                              [--pixels 20000] [--reference-spp 2048] [--threads 2]
                              [--spp-seeds 3] [--scenes SUBSTR,...] [--extra SCENE ...]
                              [--sampler adaptive] [--cache-dir DIR]

Scenes: every scene under ../shared/scenes (the Bitterli set, both Cornell boxes, the bunny; the
folder is skipped with a message when it is missing) and every example, plus --extra files. Each
renders at about --pixels pixels with its own aspect ratio. Per scene:

- equal time: one `tessera converge` per seed (uniform and the adaptive sampler for the same
  time each: --time, or per scene the time uniform sampling needs for --auto-spp (128) samples
  per pixel, measured by a short render, within --min-time and --max-time (2-10 s) log-spaced snapshots) against one cached uniform reference of --reference-spp
  samples; per seed the ratio adaptive / uniform of the final relMSE and of the robust relMSE
  (the 0.1% largest per-pixel errors left out, sampling/image_metrics.h), reported as the mean
  and range over the seeds, both with the reference's own noise (converge's estimate) subtracted;
  and the time the adaptive run needed to reach uniform's final robust error (log-log
  interpolation between snapshots; beyond the last snapshot extrapolated as error ~ 1/time,
  marked with '>'), as a fraction of the budget;
- equal spp (--spp-seeds seeds): `tessera render --spp N` with each sampler, N the uniform run's
  samples per pixel at the time budget (a multiple of 16): the render time ratio, the robust error
  ratio, and their product, the time the adaptive render would need for uniform's error if its
  error falls as 1/time ("time to uniform's error");
- the oracle bound: per-pixel relative variance a_p = n (mean over the seeds of the uniform runs'
  per-pixel relative squared error), the largest 0.1% clipped; samples n_p ~ sqrt(a_p) minimise
  sum a_p / n_p for a fixed total, and give (mean sqrt a)^2 / mean a times uniform's relMSE
  ("oracle"; per 8x8 tile: "oracle-tile"). The per-pixel a_p come from a few noisy seeds, so the
  oracle is somewhat optimistic (Jensen);
- what of it is knowable, and what samples cost: "oracle, cross-validated" allocates by one
  uniform seed's per-pixel error (3x3 mean) and judges the allocation on the other seeds' errors
  (what an estimate from one budget's samples could reach, in samples); "allocation" judges the
  adaptive run's own final spp map the same way (seed k against the uniform seeds other than k);
  "samples/s" is its sample rate against uniform's at equal time (its samples go where they cost
  more). At equal time the ratio is about allocation / samples/s, less whatever the sampler gains
  by reacting to the paths it actually drew (a firefly it samples down), which no allocation fixed
  in advance can;
- concentration: the share of uniform's robust relMSE held by its 10% worst pixels (a scene is
  "concentrated" when it is over half);
- the error estimate against the truth: an adaptive `tessera render` writes its per-pixel relMSE
  estimate (the EXR's `error` layer); summed over 8x8 tiles, the median ratio estimate / true
  error and the correlation of their logarithms;
- `--error E` with E = uniform's final robust relMSE: the robust relMSE reached / E, and the
  render time against the uniform run's;
- seams: the robust relMSE ratio of the images box-filtered to 8x8 tiles against the full
  resolution ratio (block-wise bias of the stopping decisions would raise the first).

Writes OUT/bench.json and OUT/bench.md (the table) and prints the table. Needs numpy and oiiotool
(scripts/image_error.py).
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import image_error as ie  # noqa: E402


def scene_list(args):
    shared = os.path.normpath(os.path.join(ROOT, "..", "shared", "scenes"))
    scenes = []
    if os.path.isdir(shared):
        for dirpath, _, files in sorted(os.walk(shared)):
            depth = os.path.relpath(dirpath, shared).count(os.sep)
            if depth > 2:
                continue
            for f in sorted(files):
                if f == "scene-v4.pbrt" or f.endswith(".obj") or f == "bunny.ply":
                    scenes.append(os.path.join(dirpath, f))
    else:
        print(f"bench_adaptive: {shared} is missing: the examples only", file=sys.stderr)
    ex = os.path.join(ROOT, "examples")
    for dirpath, _, files in sorted(os.walk(ex)):
        for f in sorted(files):
            if f.endswith(".pbrt"):
                scenes.append(os.path.join(dirpath, f))
    scenes += args.extra or []
    if args.scenes:
        keys = args.scenes.split(",")
        scenes = [s for s in scenes if any(k in s for k in keys)]
    return scenes


def scene_name(path):
    rel = os.path.relpath(path, os.path.join(ROOT, ".."))
    rel = re.sub(r"^(shared/scenes/|main/|[^/]+/examples/)", "", rel)
    rel = rel.replace("/pbrt-v4/scene-v4.pbrt", "").replace("/scene-v4.pbrt", "")
    rel = rel.replace("/scene.pbrt", "")
    return re.sub(r"\.(pbrt|obj|ply)$", "", rel).replace("bitterli/", "")


def resolution(path, pixels):
    w, h = 1280, 720
    if path.endswith(".pbrt"):
        text = open(path, errors="replace").read()
        mx = re.search(r'"integer\s+xresolution"\s*\[?\s*(\d+)', text)
        my = re.search(r'"integer\s+yresolution"\s*\[?\s*(\d+)', text)
        if mx and my:
            w, h = int(mx.group(1)), int(my.group(1))
    elif path.endswith(".obj") or path.endswith(".ply"):
        w, h = 1, 1  # Tessera's default view is square
    aspect = w / h
    rw = max(16, int(round(math.sqrt(pixels * aspect))))
    rh = max(16, int(round(rw / aspect)))
    return rw, rh


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {r.returncode}: {r.stderr.strip()[-600:]}")
    return r


def final_rows(conv):
    last = {}
    for r in conv["rows"]:
        last[r["sampler_index"]] = r
    return [last[i] for i in sorted(last)]


def time_to_reach(rows, level):
    """Seconds an adaptive run needed to reach `level` (robust relMSE): log-log interpolation
    between snapshots; past the last one, error ~ 1/time (returns (t, extrapolated))."""
    pts = [(r["time_s"], r["relmse_robust"]["total"]) for r in rows if r["coverage"] >= 1]
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if e0 > level >= e1 and e0 > 0 and e1 > 0 and t0 > 0:
            f = (math.log(level) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0))), False
    if pts and pts[0][1] <= level:
        return pts[0][0], False
    t, e = pts[-1]
    return t * e / level, True


def stats_of(v):
    v = [x for x in v if x is not None and math.isfinite(x)]
    if not v:
        return None
    return {"mean": float(np.mean(v)), "min": float(min(v)), "max": float(max(v)),
            "values": [float(x) for x in v]}


def box3(x):
    """3x3 mean (edges repeated)."""
    p = np.pad(x, 1, mode="edge")
    h, w = x.shape
    return sum(p[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)) / 9.0


def allocation_ratio(n, err):
    """relMSE of the per-pixel sample map n (any scale), at the same total samples, against
    uniform sampling, for per-pixel errors `err` of uniform sampling (a pixel's error ~ 1/n)."""
    n = n / n.mean()
    return float(np.mean(np.where(err > 0, err / np.maximum(n, 1e-12), 0.0)) / err.mean())


def bench_scene(path, args, out):
    name = scene_name(path)
    w, h = resolution(path, args.pixels)
    sdir = os.path.join(out, re.sub(r"[^A-Za-z0-9_.-]", "_", name))
    os.makedirs(sdir, exist_ok=True)
    tess = args.tessera
    res = f"{w}x{h}"
    common = ["--resolution", res, "--threads", str(args.threads)]
    budget = args.time
    if budget is None:
        # The time uniform sampling needs for about --auto-spp samples per pixel (from a short
        # uniform render's rate), within [--min-time, --max-time]: a budget of a few samples per
        # pixel leaves an adaptive sampler nothing to decide after its uniform first pass.
        js = os.path.join(sdir, "rate.json")
        run([tess, "render", path, "--sampler", "uniform", "--spp", "16", "-o",
             os.path.join(sdir, "rate.exr"), "--stats", js, "-q", "--no-png"] + common)
        with open(js) as f:
            st = json.load(f)
        rate = st["samples"] / max(st["wall_s"], 1e-6)
        budget = min(args.max_time, max(args.min_time, args.auto_spp * w * h / rate))
        budget = round(budget, 1)
    conv, ref_path = [], None
    for k in range(args.seeds):
        seed = args.first_seed + k
        d = os.path.join(sdir, f"seed-{seed}")
        cmd = [tess, "converge", path, "-o", d, "--time", str(budget), "--seed", str(seed),
               "--sampler", "uniform", "--sampler", args.sampler, "--no-report", "-q"] + common
        cmd += ["--reference", ref_path] if ref_path else \
            ["--reference-spp", str(args.reference_spp), "--cache-dir", args.cache_dir]
        run(cmd)
        with open(os.path.join(d, "convergence.json")) as f:
            c = json.load(f)
        c["_dir"] = d
        conv.append(c)
        if ref_path is None:
            ref_path = c["reference"]["path"]
            if not os.path.isabs(ref_path):
                ref_path = os.path.join(d, ref_path)
    noise = conv[0]["reference"].get("noise_relmse") or 0.0
    ref = ie.read_exr(ref_path)

    # Equal time.
    ratio, ratio_robust, t_reach, extrap = [], [], [], False
    u_imgs, a_imgs, u_spp = [], [], []
    for c in conv:
        u, a = final_rows(c)
        eu = u["relmse"]["total"] - noise
        ea = a["relmse"]["total"] - noise
        ru = u["relmse_robust"]["total"] - noise
        ra = a["relmse_robust"]["total"] - noise
        ratio.append(ea / eu if eu > 0 else None)
        ratio_robust.append(ra / ru if ru > 0 else None)
        arows = [r for r in c["rows"] if r["sampler_index"] == 1]
        t, ex = time_to_reach(arows, u["relmse_robust"]["total"])
        t_reach.append(t / u["time_s"])
        extrap = extrap or ex
        imgs = [s["images"] for s in c["samplers"]]
        u_imgs.append(ie.read_exr(os.path.join(c["_dir"], imgs[0]["exr"])))
        a_imgs.append(ie.read_exr(os.path.join(c["_dir"], imgs[1]["exr"])))
        u_spp.append(u["mean_spp"])

    # Oracle and concentration from the uniform runs.
    per_pixel = np.mean([ie.pixel_rel_errors(im, ref) for im in u_imgs], axis=0)
    a_p = per_pixel * float(np.mean(u_spp))
    a_p = np.minimum(a_p, np.quantile(a_p, 1 - ie.DROP))
    oracle = float(np.sqrt(a_p).mean() ** 2 / a_p.mean()) if a_p.mean() > 0 else 1.0
    a_t = ie.block_mean(a_p[..., None], 8)[..., 0]
    oracle_tile = float(np.sqrt(a_t).mean() ** 2 / a_t.mean()) if a_t.mean() > 0 else 1.0
    srt = np.sort(a_p.ravel())[::-1]
    share10 = float(srt[: max(1, len(srt) // 10)].sum() / srt.sum()) if srt.sum() > 0 else 0.0

    # How much of the oracle's gain is knowable, and what the samples cost. The oracle divides
    # by the same noisy a_p it allocates by (optimistic), and counts samples, not time. An
    # allocation by one uniform seed's per-pixel error (3x3 mean), judged on the other seeds'
    # errors ("cross-validated"), is what an estimate from one budget's samples could reach.
    # The sampler's own final spp map (seed k) is judged on the uniform seeds other than k
    # (seed k's uniform run shares its first samples) the same way: its allocation in samples
    # at uniform's total. Its samples per second against uniform's is the rest of the equal-time
    # ratio (a pixel's samples cost more where the error is: layered materials, paths that do
    # not miss).
    errs = [ie.pixel_rel_errors(im, ref) for im in u_imgs]
    cv, alloc, rate = [], [], []
    for k in range(len(errs)):
        if len(errs) < 2:
            break
        others = np.mean([e for j, e in enumerate(errs) if j != k], axis=0)
        others = np.minimum(others, np.quantile(others, 1 - ie.DROP))
        cv.append(allocation_ratio(np.sqrt(box3(errs[k])), others))
        n = ie.read_exr(os.path.join(conv[k]["_dir"], conv[k]["samplers"][1]["images"]["exr"]),
                        "spp.Y")[..., 0].astype(np.float64)
        alloc.append(allocation_ratio(n, others))
    for c in conv:
        u, a = final_rows(c)
        if u["time_s"] > 0 and a["time_s"] > 0 and u["mean_spp"] > 0:
            rate.append((a["mean_spp"] / a["time_s"]) / (u["mean_spp"] / u["time_s"]))

    # Seams: robust ratio at 8x8 tiles against full resolution (mean over the seeds).
    ref8 = ie.block_mean(ref, 8)
    tile_ratio = [ie.rel_mse_robust(ie.block_mean(a, 8), ref8) /
                  max(ie.rel_mse_robust(ie.block_mean(u, 8), ref8), 1e-30)
                  for a, u in zip(a_imgs, u_imgs)]
    full_ratio = [ie.rel_mse_robust(a, ref) / max(ie.rel_mse_robust(u, ref), 1e-30)
                  for a, u in zip(a_imgs, u_imgs)]

    # Equal spp.
    n = max(16, int(np.mean(u_spp)) // 16 * 16)
    spp_rows = []
    for k in range(min(args.spp_seeds, args.seeds)):
        seed = args.first_seed + k
        row = {}
        for label, smp in (("uniform", "uniform"), ("adaptive", args.sampler)):
            exr = os.path.join(sdir, f"spp-{label}-{seed}.exr")
            js = os.path.join(sdir, f"spp-{label}-{seed}.json")
            run([tess, "render", path, "--sampler", smp, "--spp", str(n), "--seed", str(seed),
                 "-o", exr, "--stats", js, "-q", "--no-png"] + common)
            with open(js) as f:
                st = json.load(f)
            img = ie.read_exr(exr)
            row[label] = {"wall_s": st["wall_s"], "samples": st["samples"],
                          "relmse_robust": ie.rel_mse_robust(img, ref) - noise}
        tr = row["adaptive"]["wall_s"] / row["uniform"]["wall_s"]
        er = row["adaptive"]["relmse_robust"] / max(row["uniform"]["relmse_robust"], 1e-30)
        row.update({"time_ratio": tr, "error_ratio": er, "time_to_uniform_error": tr * er})
        spp_rows.append(row)

    # The error estimate against the truth (seed 1, an adaptive render with its error layer).
    exr = os.path.join(sdir, "estimate.exr")
    run([tess, "render", path, "--sampler", args.sampler, "--time", str(budget),
         "--spp", "1000000", "--seed", str(args.first_seed), "-o", exr, "-q", "--no-png"] + common)
    img = ie.read_exr(exr)
    est = ie.read_exr(exr, "error.Y")[..., 0].astype(np.float64)
    true = ie.pixel_rel_errors(img, ref)
    bt = ie.block_mean(true[..., None], 8)[..., 0]
    be = ie.block_mean(np.nan_to_num(est, posinf=0)[..., None], 8)[..., 0]
    ok = (bt > 0) & (be > 0)
    est_ratio = float(np.median(be[ok] / bt[ok])) if ok.any() else None
    est_corr = float(np.corrcoef(np.log(be[ok]), np.log(bt[ok]))[0, 1]) if ok.sum() > 2 else None

    # --error E means what converge measures: render to uniform's final robust relMSE.
    target = float(np.mean([final_rows(c)[0]["relmse_robust"]["total"] for c in conv]))
    exr = os.path.join(sdir, "error-target.exr")
    js = os.path.join(sdir, "error-target.json")
    run([tess, "render", path, "--sampler", args.sampler, "--error", f"{target:.6g}",
         "--spp", "1000000", "--seed", str(args.first_seed), "-o", exr, "--stats", js, "-q",
         "--no-png"] + common)
    with open(js) as f:
        et = json.load(f)
    img = ie.read_exr(exr)
    error_mode = {"target": target, "relmse_robust": ie.rel_mse_robust(img, ref),
                  "relmse": ie.rel_mse(img, ref), "wall_s": et["wall_s"],
                  "estimate": et["error_estimate"], "converged": et["converged"],
                  "uniform_time_s": float(np.mean([final_rows(c)[0]["time_s"] for c in conv]))}

    return {
        "error_mode": error_mode,
        "scene": name, "path": os.path.relpath(path, ROOT), "resolution": res,
        "time_s": budget,
        "reference_spp": args.reference_spp, "reference_noise_relmse": noise,
        "uniform_spp": float(np.mean(u_spp)),
        "ratio_relmse": stats_of(ratio), "ratio_robust": stats_of(ratio_robust),
        "time_to_uniform_error": stats_of(t_reach), "time_extrapolated": extrap,
        "oracle": oracle, "oracle_tile": oracle_tile, "share_10pct": share10,
        "oracle_cross_validated": stats_of(cv), "allocation": stats_of(alloc),
        "samples_per_s_ratio": stats_of(rate),
        "concentrated": share10 > 0.5,
        "seam_tile_ratio": float(np.mean(tile_ratio)), "seam_full_ratio": float(np.mean(full_ratio)),
        "spp_budget": n, "spp": spp_rows,
        "spp_time_to_uniform_error": stats_of([r["time_to_uniform_error"] for r in spp_rows]),
        "spp_time_ratio": stats_of([r["time_ratio"] for r in spp_rows]),
        "spp_error_ratio": stats_of([r["error_ratio"] for r in spp_rows]),
        "estimate_over_true": est_ratio, "estimate_log_corr": est_corr,
    }


def fmt(s, digits=2):
    if s is None:
        return "n/a"
    return f"{s['mean']:.{digits}f} [{s['min']:.{digits}f}, {s['max']:.{digits}f}]"


def table(results, args):
    lines = [
        f"Equal time ({'%g s' % args.time if args.time else 'per scene: uniform ~%g spp, %g-%g s' % (args.auto_spp, args.min_time, args.max_time)}; "
        f"{args.threads} threads), {args.seeds} seeds, ~{args.pixels} "
        f"pixels, references {args.reference_spp} spp; sampler `{args.sampler}` / uniform "
        "(mean [min, max] over seeds; reference noise subtracted).", "",
        "| scene | res | time | uniform spp | robust relMSE ratio | relMSE ratio | time to uniform's "
        "error | oracle (tile) | oracle, cross-validated | allocation | samples/s | 10% share | "
        "spp budget: time x error | est/true, log corr | seam: tile / full | --error E: reached "
        "/ E, time |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        if "error" in r:
            lines.append(f"| {r['scene']} | failed: {r['error']} |")
            continue
        lines.append(
            f"| {r['scene']} | {r['resolution']} | {r['time_s']:g} s | {r['uniform_spp']:.0f} | "
            f"{fmt(r['ratio_robust'])} | {fmt(r['ratio_relmse'])} | "
            f"{'>' if r['time_extrapolated'] else ''}{fmt(r['time_to_uniform_error'])} | "
            f"{r['oracle']:.2f} ({r['oracle_tile']:.2f}) | "
            f"{fmt(r.get('oracle_cross_validated'))} | {fmt(r.get('allocation'))} | "
            f"{fmt(r.get('samples_per_s_ratio'))} | {r['share_10pct']:.2f}"
            f"{' *' if r['concentrated'] else ''} | "
            f"{fmt(r['spp_time_to_uniform_error'])} (N={r['spp_budget']}) | "
            f"{(r['estimate_over_true'] or float('nan')):.2f}, "
            f"{(r['estimate_log_corr'] or float('nan')):.2f} | "
            f"{r['seam_tile_ratio']:.2f} / {r['seam_full_ratio']:.2f} | "
            f"{r['error_mode']['relmse_robust'] / r['error_mode']['target']:.2f}, "
            f"{r['error_mode']['wall_s'] / r['error_mode']['uniform_time_s']:.2f}x |")
    ok = [r for r in results if "error" not in r]

    def med(key):
        v = [r[key]["mean"] for r in ok if r.get(key)]
        return f"{np.median(v):.3f}" if v else "n/a"

    if ok:
        rr = [r["ratio_robust"]["mean"] for r in ok]
        conc = [r["ratio_robust"]["mean"] for r in ok if r["concentrated"]]
        worse = [r["scene"] for r in ok if r["ratio_robust"]["min"] > 1.0]
        spp = [r["spp_time_to_uniform_error"]["mean"] for r in ok if r["spp_time_to_uniform_error"]]
        lines += ["", f"median robust ratio {np.median(rr):.3f} over {len(ok)} scenes; "
                  f"concentrated scenes (*): max {max(conc) if conc else float('nan'):.3f}; "
                  f"worse than uniform on every seed: {', '.join(worse) or 'none'}; "
                  f"median spp-budget time to uniform's error {np.median(spp) if spp else float('nan'):.3f}; "
                  f"median oracle {np.median([r['oracle'] for r in ok]):.3f}; "
                  f"median cross-validated oracle {med('oracle_cross_validated')}; "
                  f"median allocation {med('allocation')}; "
                  f"median samples/s ratio {med('samples_per_s_ratio')}"]
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("-o", "--out", default="bench-adaptive")
    ap.add_argument("--tessera", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--spp-seeds", type=int, default=3)
    ap.add_argument("--time", type=float, help="seconds per sampler (default: automatic)")
    ap.add_argument("--auto-spp", type=float, default=128)
    ap.add_argument("--min-time", type=float, default=2)
    ap.add_argument("--max-time", type=float, default=10)
    ap.add_argument("--pixels", type=int, default=20000)
    ap.add_argument("--reference-spp", type=int, default=2048)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--sampler", default="adaptive")
    ap.add_argument("--scenes", help="comma list of substrings of the scene paths")
    ap.add_argument("--extra", action="append", help="another scene file (repeatable)")
    ap.add_argument("--cache-dir", help="reference cache (default OUT/../converge-cache)")
    args = ap.parse_args()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    if not args.cache_dir:
        args.cache_dir = os.path.join(os.path.dirname(out), "converge-cache")
    results = []
    for path in scene_list(args):
        print(f"bench_adaptive: {scene_name(path)} ...", file=sys.stderr, flush=True)
        try:
            results.append(bench_scene(path, args, out))
        except (RuntimeError, OSError, ValueError, KeyError) as e:
            results.append({"scene": scene_name(path), "error": str(e)[-300:]})
        with open(os.path.join(out, "bench.json"), "w") as f:
            json.dump({"settings": vars(args), "scenes": results}, f, indent=1)
    text = table(results, args)
    with open(os.path.join(out, "bench.md"), "w") as f:
        f.write(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
