#!/usr/bin/env python3
"""The convergence benchmark suite: every example scene, uniform against adaptive sampling at
equal time, in one report.

    scripts/bench_suite.py [-o OUT] [--tessera build/tessera] [--quick] [--scenes a,b]
                           [--time S] [--threads N] [--cache-dir DIR] [--check]

For each scene of SUITE it runs `tessera converge` (each sampler for the same wall time, log-spaced
snapshots, errors against a cached high-sample reference) into OUT/<scene>/, then writes
OUT/report.html (scripts/convergence_report.py: summary table, then per scene the headline table,
error-versus-time plots with fitted slopes, equal-time crops and sample-count heat maps),
OUT/suite.csv (every row of every scene, with a `scene` column) and OUT/summary.txt (the headline
tables as tessera printed them, and per scene the final snapshot's relMSE and robust relMSE of
every sampler with their ratios to the first). Without --quick (and unless --no-realtime) it
then runs scripts/bench_realtime.py at 256x256 (every real-time plugin and fixed 1/4/8/9/16
against a stratified ground truth) into OUT/realtime/, writes OUT/suite-realtime.csv and appends
that table to the report.

Budget on 2 cores. Default: 10 s per sampler at about 13k pixels, references of 3072 spp; about
10 minutes when the reference cache is cold (the references are most of it), 2-3 minutes when
warm. --quick: 1 s per sampler at about 2k pixels (6 snapshots from 1/8 s), 1024-spp references,
about a minute on a cold cache; it checks (as --check does) that every report was produced and is
sane: all errors finite, the error of each sampler falling with time (MAE of the last snapshot
below the first complete one, negative MAE slope; convergence_report.sanity_problems), and
report.html present with its images. CI runs it (ctest test report_suite_quick, label `report`).

Errors are reported as relMSE and, beside it, the robust relMSE ("relMSE-0.1%": relMSE with the
0.1% of pixels of largest relative error left out, sampling/image_metrics.h), which is also
tessera converge's default headline metric: at equal time one firefly more or less decides the
plain relMSE of a render, the robust one follows the bulk of the pixels. In suite.csv its
columns (relmse_robust_r, _g, _b, relmse_robust) follow the relmse ones; results of a tessera
too old to write it simply lack them.

The reference of each scene is cached (tessera converge --cache-dir; default OUT/../converge-cache
relative to the output folder, i.e. shared between runs into the same parent folder).
"""
import argparse
import csv
import html
import os
import re
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import convergence_report  # noqa: E402  (data helpers only; plotting runs in a subprocess)

# One entry per example scene: resolution and reference samples per pixel, default and --quick.
# Resolutions keep each scene's aspect ratio at about 13k pixels (quick: about 2k).
SUITE = [
    # name            default res  ref spp   quick res  quick ref spp
    ("cornell-box",   "112x112",   3072,     "48x48",   1024),
    ("glossy-glass",  "144x96",    3072,     "54x36",   1024),
    ("textured",      "144x96",    3072,     "54x36",   1024),
    ("environment",   "144x96",    3072,     "54x36",   1024),
    ("uneven",        "128x96",    3072,     "48x36",   1024),
]
SAMPLERS = ["uniform", "adaptive"]
DEFAULT_TIME_S, QUICK_TIME_S = 10.0, 1.0
SNAPSHOTS, QUICK_SNAPSHOTS = 8, 6

# ----------------------------------------------------------------------------------------------
# The real-time sampler plugins (`tessera render --sampler jin|kim|fliptri|...`) render one frame
# at a fixed cost instead of converging over time, so they get an equal-cost table, not a curve:
# scripts/bench_realtime.py renders its scenes (examples/realtime, plus ../shared's Cornell box)
# with every plugin and fixed 1, 4, 8, 9, 16 against a stratified ground truth. The suite runs it
# at a small size (not with --quick) and adds its rows (kind "realtime") to suite.csv and its
# table to the report.
REALTIME_RES, REALTIME_FRAMES, REALTIME_GT_SPP = 256, 2, 64


def run_realtime(tessera, out_dir, threads):
    """Runs scripts/bench_realtime.py into OUT/realtime; returns its CSV rows."""
    rt_dir = os.path.join(out_dir, "realtime")
    cmd = [sys.executable, os.path.join(ROOT, "scripts", "bench_realtime.py"), "--tessera",
           tessera, "--resolution", str(REALTIME_RES), "--frames", str(REALTIME_FRAMES),
           "--gt-spp", str(REALTIME_GT_SPP), "--out", rt_dir]
    if threads:
        cmd += ["--threads", str(threads)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"bench_suite: failed ({r.returncode}): {' '.join(cmd)}\n{r.stderr}")
    print(r.stdout, flush=True)
    with open(os.path.join(rt_dir, "realtime.csv"), newline="") as f:
        return list(csv.DictReader(f)), r.stdout


def add_realtime(out_dir, rows, text):
    """Appends the real-time rows to suite.csv and a table to report.html."""
    with open(os.path.join(out_dir, "suite-realtime.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["kind"] + list(rows[0]))
        w.writeheader()
        for row in rows:
            w.writerow({"kind": "realtime", **row})
    cells = "".join(
        f"<tr><td>{html.escape(r['scene'])}</td><td>{html.escape(r['sampler'])}</td>"
        f"<td>{float(r['psnr']):.2f}</td><td>{float(r['rays_per_pixel']):.2f}</td>"
        f"<td>{float(r['frame_ms_median']):.1f}</td>"
        f"<td>{100 * float(r['active_fraction']):.1f}% {html.escape(r['active_unit'])}</td></tr>"
        for r in rows)
    section = (f"<h2>Real-time samplers against fixed N ({REALTIME_RES}x{REALTIME_RES}, "
               f"ground truth fixed:spp={REALTIME_GT_SPP})</h2>\n<table border='1'>"
               "<tr><th>scene</th><th>sampler</th><th>PSNR dB</th><th>rays/px</th>"
               f"<th>ms/frame</th><th>active</th></tr>{cells}</table>\n"
               f"<pre>{html.escape(text)}</pre>\n")
    report = os.path.join(out_dir, "report.html")
    page = open(report).read()
    page = page.replace("</body>", section + "</body>") if "</body>" in page else page + section
    with open(report, "w") as f:
        f.write(page)
# ----------------------------------------------------------------------------------------------


def run_converge(tessera, scene_path, out_dir, res, ref_spp, time_s, threads, cache_dir, quick):
    cmd = [tessera, "converge", scene_path, "-o", out_dir, "--time", str(time_s),
           "--snapshots", str(QUICK_SNAPSHOTS if quick else SNAPSHOTS), "--resolution", res,
           "--reference-spp", str(ref_spp), "--cache-dir", cache_dir, "--no-report", "-q"]
    if quick:
        # Snapshots of a few milliseconds measure start-up jitter, not convergence.
        cmd += ["--first-snapshot", str(time_s / 8)]
    for s in SAMPLERS:
        cmd += ["--sampler", s]
    if threads:
        cmd += ["--threads", str(threads)]
    t0 = time.monotonic()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"bench_suite: failed ({r.returncode}): {' '.join(cmd)}\n{r.stderr}")
    return r.stdout, time.monotonic() - t0


ROBUST_COLUMNS = ["relmse_robust_r", "relmse_robust_g", "relmse_robust_b", "relmse_robust"]


def suite_columns(columns):
    """convergence.csv's columns in suite.csv's order: the robust relMSE right after relmse."""
    rest = [c for c in columns if c not in ROBUST_COLUMNS]
    robust = [c for c in ROBUST_COLUMNS if c in columns]
    if robust and "relmse" in rest:
        at = rest.index("relmse") + 1
        return rest[:at] + robust + rest[at:]
    return rest + robust


def write_suite_csv(out_dir, names):
    path = os.path.join(out_dir, "suite.csv")
    rows, columns = [], []
    for name in names:
        with open(os.path.join(out_dir, name, "convergence.csv"), newline="") as src:
            reader = csv.DictReader(src)
            columns += [c for c in reader.fieldnames if c not in columns]
            rows += [{"scene": name, "kind": "progressive", **row} for row in reader]
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=["scene", "kind"] + suite_columns(columns),
                                restval="")
        writer.writeheader()
        writer.writerows(rows)
    return path


def final_errors_text(run_dir):
    """The final snapshot's relMSE and robust relMSE per sampler, and their ratios to the first
    sampler's, as a text table (for summary.txt and the console)."""
    data = convergence_report.load_run(run_dir)
    robust = convergence_report.has_robust(data)
    finals = []
    for s in data["samplers"]:
        rows = convergence_report.sampler_rows(data, s["index"])
        if rows:
            finals.append((s["spec"], rows[-1]))
    if not finals:
        return "final snapshot: no rows\n"
    width = max(8, max(len(spec) for spec, _ in finals))
    rl = convergence_report.ROBUST[1]
    head = f"{'sampler':{width}s} {'time s':>7s} {'mean spp':>9s} {'relMSE':>10s} {'ratio':>7s}"
    if robust:
        head += f" {rl:>12s} {'ratio':>7s}"
    lines = [f"\nfinal snapshot (ratios to {finals[0][0]})", head]

    def ratio(v, base):
        return f"{v / base:7.3f}" if v is not None and base else f"{'-':>7s}"

    base = finals[0][1]
    for spec, r in finals:
        rel = r["relmse"]["total"]
        line = (f"{spec:{width}s} {r['time_s']:7.2f} {r['mean_spp']:9.1f} {rel:10.4g} "
                f"{ratio(rel, base['relmse']['total'])}")
        if robust:
            rob = r[convergence_report.ROBUST[0]]["total"]
            line += (f" {rob:12.4g} "
                     f"{ratio(rob, base[convergence_report.ROBUST[0]]['total'])}")
        lines.append(line)
    return "\n".join(lines) + "\n"


def report_problems(out_dir, names):
    """Sanity of the produced reports (see the module doc)."""
    problems = []
    report = os.path.join(out_dir, "report.html")
    if not os.path.isfile(report):
        return [f"{report} was not written"]
    page = open(report).read()
    for src in re.findall(r"<img src='([^']+)'", page):
        if not os.path.isfile(os.path.join(out_dir, src)):
            problems.append(f"report.html shows a missing image: {src}")
    for name in names:
        if name not in page:
            problems.append(f"report.html has no section for {name}")
        problems += convergence_report.sanity_problems(
            convergence_report.load_run(os.path.join(out_dir, name)))
    return problems


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-o", "--output", default=os.path.join(ROOT, "renders", "suite"),
                    help="output folder (default renders/suite)")
    ap.add_argument("--tessera", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--quick", action="store_true",
                    help="about one minute, small images; implies --check")
    ap.add_argument("--scenes", help="comma-separated subset of: "
                    + ", ".join(s[0] for s in SUITE))
    ap.add_argument("--time", type=float, help="seconds per sampler (default 10, quick 1)")
    ap.add_argument("--threads", type=int, default=0, help="worker threads (default: all)")
    ap.add_argument("--cache-dir", help="reference cache (default: <OUT>/../converge-cache)")
    ap.add_argument("--no-realtime", action="store_true",
                    help="skip the real-time plugins' table (never run with --quick)")
    ap.add_argument("--check", action="store_true",
                    help="fail unless every report is produced and sane")
    a = ap.parse_args()

    if not os.access(a.tessera, os.X_OK):
        sys.exit(f"bench_suite: {a.tessera} is not an executable (build first, or --tessera)")
    wanted = a.scenes.split(",") if a.scenes else [s[0] for s in SUITE]
    unknown = set(wanted) - {s[0] for s in SUITE}
    if unknown:
        sys.exit(f"bench_suite: unknown scene(s): {', '.join(sorted(unknown))}")
    out_dir = os.path.abspath(a.output)
    os.makedirs(out_dir, exist_ok=True)
    cache_dir = a.cache_dir or os.path.join(os.path.dirname(out_dir), "converge-cache")
    time_s = a.time or (QUICK_TIME_S if a.quick else DEFAULT_TIME_S)
    check = a.check or a.quick

    t_start = time.monotonic()
    names, summary = [], []
    for name, res, ref_spp, quick_res, quick_ref_spp in SUITE:
        if name not in wanted:
            continue
        scene_path = os.path.join(ROOT, "examples", name, "scene.pbrt")
        run_dir = os.path.join(out_dir, name)
        res, ref_spp = (quick_res, quick_ref_spp) if a.quick else (res, ref_spp)
        stdout, secs = run_converge(a.tessera, scene_path, run_dir, res, ref_spp, time_s,
                                    a.threads, cache_dir, a.quick)
        names.append(name)
        block = (f"== {name} ({res}, {secs:.0f} s with the reference)\n{stdout}"
                 f"{final_errors_text(run_dir)}")
        summary.append(block)
        print(block, flush=True)

    with open(os.path.join(out_dir, "summary.txt"), "w") as f:
        f.write("\n".join(summary))
    csv_path = write_suite_csv(out_dir, names)
    report = subprocess.run([sys.executable, os.path.join(ROOT, "scripts",
                                                          "convergence_report.py")]
                            + [os.path.join(out_dir, n) for n in names]
                            + ["-o", out_dir, "--title",
                               "Tessera benchmark suite" + (" (quick)" if a.quick else "")])
    if report.returncode != 0:
        sys.exit(f"bench_suite: the report failed (exit {report.returncode})")
    if not a.quick and not a.no_realtime:
        rt_rows, rt_text = run_realtime(a.tessera, out_dir, a.threads)
        add_realtime(out_dir, rt_rows, rt_text)
    print(f"bench_suite: wrote {os.path.join(out_dir, 'report.html')}, {csv_path} "
          f"in {time.monotonic() - t_start:.0f} s")
    if check:
        problems = report_problems(out_dir, names)
        for p in problems:
            print(f"bench_suite: check failed: {p}", file=sys.stderr)
        if problems:
            return 1
        print(f"bench_suite: check passed: {len(names)} reports, errors finite and falling")
    return 0


if __name__ == "__main__":
    sys.exit(main())
