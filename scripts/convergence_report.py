#!/usr/bin/env python3
"""HTML report of `tessera converge` runs: error against time, equal-time crops, sample maps.

    scripts/convergence_report.py DIR                 # writes DIR/report.html
    scripts/convergence_report.py DIR... -o OUT       # one combined report: OUT/report.html

Each DIR is a `tessera converge -o DIR` folder (convergence.json, convergence.csv, images/).
The report shows, per run: the headline table (time to reach error E per sampler, from the
JSON), log-log plots of MSE, relMSE, robust relMSE and MAE against render time with one line per
sampler and its fitted slope (Monte Carlo: about -1 for MSE and relMSE, -1/2 for MAE), the
reference's estimated noise floor, the equal-time images of every sampler beside the reference
with two enlarged crops, the samples-per-pixel heat maps of the adaptive runs, and the final
snapshot's errors. Several DIRs make one page with a summary table first (scripts/bench_suite.py
uses that).

The robust relMSE ("relMSE-0.1%", `relmse_robust` in convergence.json) is relMSE with the 0.1%
of pixels of largest per-pixel relative error left out (sampling/image_metrics.h); it is shown
beside the plain relMSE wherever that is, because on scenes with rare bright paths the plain
relMSE of one render is decided by a few fireflies. It is the default headline metric of
`tessera converge`. Runs written before it existed (no `relmse_robust` in their rows) get the
report without it.

Needs matplotlib and numpy (Debian: python3-matplotlib, installed by scripts/setup.sh). When the
`python3` on PATH lacks them (a pyenv or venv interpreter), the script re-runs itself with the
system's /usr/bin/python3; if that lacks them too it says so and exits with code 3.
"""
import argparse
import csv
import html
import json
import math
import os
import sys

METRICS = [("mse", "MSE"), ("relmse", "relMSE"), ("mae", "MAE")]
# The robust relMSE (convergence.json key, label); runs of older tessera versions lack it.
ROBUST = ("relmse_robust", "relMSE-0.1%")
# Labels of the headline metric names (convergence.json "headline": {"metric": ...}).
HEADLINE_LABELS = {"mse": "MSE", "relmse": "relMSE", "relmse-robust": ROBUST[1],
                   "relmse_robust": ROBUST[1], "rmse": "RMSE", "mae": "MAE"}
EXIT_NO_MATPLOTLIB = 3


def import_plotting():
    """Returns (numpy, pyplot, colors) or exits with a clear message."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.colors as colors
        import matplotlib.pyplot as plt
        import numpy as np
        return np, plt, colors
    except ImportError as e:
        system = "/usr/bin/python3"
        if (os.path.exists(system) and not os.environ.get("TESSERA_REPORT_REEXEC")
                and os.path.realpath(sys.executable) != os.path.realpath(system)):
            os.environ["TESSERA_REPORT_REEXEC"] = "1"
            os.execv(system, [system, os.path.abspath(__file__)] + sys.argv[1:])
        sys.stderr.write(
            f"convergence_report: matplotlib and numpy are needed for the report ({e}).\n"
            "  Debian/Ubuntu: apt-get install python3-matplotlib (scripts/setup.sh installs it)\n")
        sys.exit(EXIT_NO_MATPLOTLIB)


# ------------------------------------------------------------------------------------------
# Data (no matplotlib needed: scripts/bench_suite.py imports these)
# ------------------------------------------------------------------------------------------

def load_run(run_dir):
    """The parsed convergence.json of a run folder, with 'dir' added."""
    with open(os.path.join(run_dir, "convergence.json")) as f:
        data = json.load(f)
    data["dir"] = run_dir
    return data


def sampler_rows(data, index):
    return [r for r in data["rows"] if r["sampler_index"] == index]


def usable(row):
    """Rows whose first pass had reached every pixel (the others stay out of fits)."""
    return row["coverage"] >= 1.0


def has_robust(data):
    """Whether every row of the run has the robust relMSE (not so for runs of older versions)."""
    return bool(data["rows"]) and all(ROBUST[0] in r for r in data["rows"])


def report_metrics(data):
    """The (key, label) pairs the run's plots show: METRICS, with the robust relMSE after the
    relMSE when the run has it."""
    out = []
    for m in METRICS:
        out.append(m)
        if m[0] == "relmse" and has_robust(data):
            out.append(ROBUST)
    return out


def headline_label(data):
    metric = data["headline"]["metric"]
    return HEADLINE_LABELS.get(metric, metric)


def fit_of(sampler, key):
    """The sampler's fit of metric key ({"slope": None, ...} when the JSON has none)."""
    return sampler["fit"].get(key) or {"slope": None, "intercept": None, "points": 0}


def sanity_problems(data):
    """What is wrong with a run's numbers, as readable strings (empty: sane). Checks that every
    sampler has rows, that every error is finite, and that its error falls with time: MAE at the
    last usable snapshot below the first, and a negative fitted MAE slope. (MAE, not MSE: at the
    few samples of a quick run one firefly can lift the MSE of a later snapshot above an earlier
    one, while MAE follows the bulk of the pixels.) Where the rows have the robust relMSE it must
    be finite and not above the plain relMSE of the same snapshot (leaving out the pixels of
    largest error cannot raise the mean)."""
    problems = []
    name = os.path.basename(os.path.normpath(data.get("dir", "?")))
    for s in data["samplers"]:
        rows = sampler_rows(data, s["index"])
        label = f"{name}: {s['spec']}"
        if not rows:
            problems.append(f"{label}: no snapshots")
            continue
        for r in rows:
            for key, _ in METRICS + [("rmse", "RMSE")]:
                v = r[key]["total"]
                if v is None or not math.isfinite(v) or v < 0:
                    problems.append(f"{label}: snapshot {r['snapshot']}: {key} = {v}")
            if ROBUST[0] in r:
                v, plain = r[ROBUST[0]]["total"], r["relmse"]["total"]
                if v is None or not math.isfinite(v) or v < 0:
                    problems.append(f"{label}: snapshot {r['snapshot']}: {ROBUST[0]} = {v}")
                elif plain is not None and math.isfinite(plain) and v > plain * (1 + 1e-9):
                    problems.append(f"{label}: snapshot {r['snapshot']}: {ROBUST[0]} {v:.6g} "
                                    f"is above relmse {plain:.6g}")
        good = [r for r in rows if usable(r)]
        if len(good) < 2:
            problems.append(f"{label}: fewer than two snapshots with every pixel sampled")
            continue
        first, last = good[0]["mae"]["total"], good[-1]["mae"]["total"]
        if not (last < first):
            problems.append(f"{label}: MAE does not fall with time ({first:.4g} -> {last:.4g})")
        slope = s["fit"]["mae"]["slope"]
        if slope is None or not slope < 0:
            problems.append(f"{label}: fitted MAE slope {slope} is not negative")
        if not (good[-1]["time_s"] > good[0]["time_s"]):
            problems.append(f"{label}: render time does not grow between snapshots")
    return problems


def crossing_text(c):
    if c["kind"] == "before_first":
        return f"&le;{c['time_s']:.3g}"
    if c["kind"] == "not_reached":
        return f"&gt;{c['time_s']:.3g}"
    return f"{c['time_s']:.3g}"


def speedups(data):
    """Per sampler: time of the first sampler / its time at the lowest headline level."""
    out = []
    samplers = data["samplers"]
    for s in samplers:
        a = samplers[0]["time_to_error"][-1] if samplers[0]["time_to_error"] else None
        b = s["time_to_error"][-1] if s["time_to_error"] else None
        if a and b and a["kind"] == "reached" and b["kind"] == "reached" and b["time_s"] > 0:
            out.append(a["time_s"] / b["time_s"])
        else:
            out.append(None)
    return out


# ------------------------------------------------------------------------------------------
# Images
# ------------------------------------------------------------------------------------------

def read_pfm(np, path):
    """A PFM image as a float array (rows top to bottom)."""
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = (int(v) for v in f.readline().split())
        scale = float(f.readline())
        channels = 3 if kind == b"PF" else 1
        data = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4", count=w * h * channels)
    shape = (h, w, 3) if channels == 3 else (h, w)
    return np.flipud(data.reshape(shape))


def read_png(plt, path):
    return plt.imread(path)[..., :3]


def worst_window(np, err, size):
    """Top-left corner of the size x size window with the largest summed error."""
    h, w = err.shape
    size_y, size_x = min(size, h), min(size, w)
    s = np.zeros((h + 1, w + 1))
    s[1:, 1:] = np.cumsum(np.cumsum(err, axis=0), axis=1)
    sums = (s[size_y:, size_x:] - s[:-size_y, size_x:] - s[size_y:, :-size_x]
            + s[:-size_y, :-size_x])
    y, x = np.unravel_index(np.argmax(sums), sums.shape)
    return int(y), int(x), size_y, size_x


# ------------------------------------------------------------------------------------------
# Figures
# ------------------------------------------------------------------------------------------

def plot_errors(np, plt, data, out_png):
    """One log-log panel per metric of report_metrics (with the robust relMSE: four)."""
    metrics = report_metrics(data)
    width = 5.2 if len(metrics) <= 3 else 4.5
    fig, axes = plt.subplots(1, len(metrics), figsize=(width * len(metrics), 4.4))
    cmap = plt.get_cmap("tab10")
    for ax, (key, label) in zip(axes, metrics):
        for s in data["samplers"]:
            rows = sampler_rows(data, s["index"])
            color = cmap(s["index"] % 10)
            t = [r["time_s"] for r in rows if r[key]["total"]]
            e = [r[key]["total"] for r in rows if r[key]["total"]]
            full = [usable(r) for r in rows if r[key]["total"]]
            fit = fit_of(s, key)
            name = s["spec"]
            if fit["slope"] is not None:
                name += f"  (slope {fit['slope']:.2f})"
            ax.plot(t, e, "-", color=color, label=name, lw=1.5)
            ax.plot([x for x, f in zip(t, full) if f], [y for y, f in zip(e, full) if f], "o",
                    color=color, ms=4)
            ax.plot([x for x, f in zip(t, full) if not f], [y for y, f in zip(e, full) if not f],
                    "o", mfc="none", color=color, ms=4)
            if fit["slope"] is not None:
                ft = [r["time_s"] for r in rows if usable(r)]
                xs = np.geomspace(min(ft), max(ft), 20)
                ax.plot(xs, 10 ** fit["intercept"] * xs ** fit["slope"], ":", color=color, lw=1)
        floor = data["reference"].get("noise_" + key)
        floor_label = "reference noise (estimate)"
        if not floor and key == ROBUST[0]:
            # No robust estimate of the reference's noise: its plain relMSE one, for scale.
            floor = data["reference"].get("noise_relmse")
            floor_label = "reference noise, plain relMSE (estimate)"
        if floor:
            ax.axhline(floor, color="0.5", ls="--", lw=1, label=floor_label)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("render time (s)")
        ax.set_ylabel(label)
        ax.set_title(f"{label}{' (robust)' if key == ROBUST[0] else ''} against time")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("hollow markers: first pass not finished (left out of the fits); dotted: fits",
                 fontsize=8)
    fig.tight_layout()
    fig.savefig(out_png, dpi=90)
    plt.close(fig)


def plot_crops(np, plt, data, out_png):
    run = data["dir"]
    ref = read_png(plt, os.path.join(run, data["reference"]["png"]))
    imgs = [read_png(plt, os.path.join(run, s["images"]["png"])) for s in data["samplers"]]
    h, w = ref.shape[:2]
    size = max(8, min(h, w) // 4)
    # Crop A: where the first sampler is worst; crop B: where the last one is worst outside
    # crop A (the window may not overlap A by more than half its size).
    wins = []
    for img in (imgs[0], imgs[-1]):
        err = ((img - ref) ** 2).sum(axis=2)
        for (y, x, sy, sx) in wins:
            err[max(0, y - sy // 2):y + sy + sy // 2, max(0, x - sx // 2):x + sx + sx // 2] = 0
        wins.append(worst_window(np, err, size))
    cols = [("reference", ref)] + [
        (f"{s['spec']}\n{s['final_time_s']:.3g} s", img) for s, img in zip(data["samplers"], imgs)]
    fig, axes = plt.subplots(3, len(cols), figsize=(2.6 * len(cols), 7.6), squeeze=False)
    for c, (title, img) in enumerate(cols):
        axes[0][c].imshow(img, interpolation="nearest")
        axes[0][c].set_title(title, fontsize=8)
        for r, (y, x, sy, sx) in enumerate(wins):
            axes[0][c].add_patch(plt.Rectangle((x - 0.5, y - 0.5), sx, sy, fill=False,
                                               ec="yc"[r], lw=1))
            axes[r + 1][c].imshow(img[y:y + sy, x:x + sx], interpolation="nearest")
            axes[r + 1][c].set_title(f"crop {'AB'[r]}", fontsize=7, color="k")
        for ax in axes[:, c]:
            ax.set_xticks([])
            ax.set_yticks([])
    fig.tight_layout()
    fig.savefig(out_png, dpi=90)
    plt.close(fig)


def plot_heatmaps(np, plt, colors, data, out_png):
    adaptive = [s for s in data["samplers"] if s["images"].get("adaptive")]
    if not adaptive:
        return False
    fig, axes = plt.subplots(1, len(adaptive), figsize=(4.6 * len(adaptive), 3.9), squeeze=False)
    for ax, s in zip(axes[0], adaptive):
        spp = read_pfm(np, os.path.join(data["dir"], s["images"]["spp_pfm"]))
        lo = max(1.0, float(spp.min()))
        hi = max(lo * 1.01, float(spp.max()))
        im = ax.imshow(np.maximum(spp, lo), cmap="viridis", interpolation="nearest",
                       norm=colors.LogNorm(vmin=lo, vmax=hi))
        ax.set_title(f"{s['spec']}\nsamples per pixel (mean {spp.mean():.1f})", fontsize=8)
        ax.set_xticks([])
        ax.set_yticks([])
        fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
    fig.tight_layout()
    fig.savefig(out_png, dpi=90)
    plt.close(fig)
    return True


# ------------------------------------------------------------------------------------------
# HTML
# ------------------------------------------------------------------------------------------

CSS = """body{font-family:sans-serif;max-width:1400px;margin:1em auto;color:#222}
table{border-collapse:collapse;margin:.5em 0 1em}td,th{border:1px solid #bbb;padding:2px 8px;
text-align:right;font-size:13px}th{background:#eee}td.l,th.l{text-align:left}
img{max-width:100%}.note{color:#666;font-size:12px}h2{border-top:2px solid #ccc;padding-top:.5em}
"""


def esc(s):
    return html.escape(str(s))


def headline_html(data):
    levels = data["headline"]["levels"]
    metric = headline_label(data)
    out = [f"<table><tr><th class=l>time (s) to reach {metric} E</th>"]
    out += [f"<th>E = {lv:.3g}</th>" for lv in levels]
    out.append("<th>speed-up at the lowest E</th></tr>")
    for s, sp in zip(data["samplers"], speedups(data)):
        out.append(f"<tr><td class=l>{esc(s['spec'])}</td>")
        out += [f"<td>{crossing_text(c)}</td>" for c in s["time_to_error"]]
        out.append(f"<td>{'-' if sp is None else f'{sp:.2f}x'}</td></tr>")
    out.append("</table>")
    return "".join(out)


def final_table_html(data):
    robust = has_robust(data)
    rl = ROBUST[1]
    out = ["<table><tr><th class=l>sampler</th><th>time s</th><th>mean spp</th><th>Mrays</th>"
           "<th>MSE</th><th>relMSE</th>" + (f"<th>{rl}</th>" if robust else "")
           + "<th>RMSE</th><th>PSNR dB</th><th>MAE</th><th>slope MSE</th><th>slope relMSE</th>"
           + (f"<th>slope {rl}</th>" if robust else "") + "<th>slope MAE</th></tr>"]
    for s in data["samplers"]:
        rows = sampler_rows(data, s["index"])
        if not rows:
            continue
        r = rows[-1]

        def g(key):
            v = r[key]["total"]
            return "-" if v is None else f"{v:.4g}"

        def sl(key):
            v = fit_of(s, key)["slope"]
            return "-" if v is None else f"{v:.2f}"

        out.append(f"<tr><td class=l>{esc(s['description'])}</td><td>{r['time_s']:.3g}</td>"
                   f"<td>{r['mean_spp']:.1f}</td><td>{r['rays'] / 1e6:.1f}</td>"
                   f"<td>{g('mse')}</td><td>{g('relmse')}</td>"
                   + (f"<td>{g(ROBUST[0])}</td>" if robust else "")
                   + f"<td>{g('rmse')}</td><td>{g('psnr')}</td><td>{g('mae')}</td>"
                   f"<td>{sl('mse')}</td><td>{sl('relmse')}</td>"
                   + (f"<td>{sl(ROBUST[0])}</td>" if robust else "")
                   + f"<td>{sl('mae')}</td></tr>")
    out.append("</table>")
    return "".join(out)


def run_section(np, plt, colors, data, out_dir, heading):
    """Writes the run's figures into its own folder; returns the HTML section (image paths
    relative to out_dir)."""
    run = data["dir"]
    figs = {"errors": os.path.join(run, "report_errors.png"),
            "crops": os.path.join(run, "report_crops.png"),
            "spp": os.path.join(run, "report_spp.png")}
    plot_errors(np, plt, data, figs["errors"])
    plot_crops(np, plt, data, figs["crops"])
    has_spp = plot_heatmaps(np, plt, colors, data, figs["spp"])
    rel = {k: os.path.relpath(v, out_dir) for k, v in figs.items()}
    st = data["settings"]
    ref = data["reference"]
    noise = ref.get("noise_relmse")
    ref_text = (f"{esc(ref['path'])} ({'reused from the cache' if ref['cached'] else 'rendered'}"
                f"{', ' + str(ref['spp']) + ' spp' if ref.get('spp') else ''}"
                f"{f', estimated noise relMSE {noise:.3g}' if noise else ''})")
    parts = [
        f"<h2>{esc(heading)}</h2>",
        f"<p class=note>scene {esc(data['scene'])} (content hash {esc(data['scene_hash'][:12])}), "
        f"{st['width']}x{st['height']}, max depth {st['max_depth']}, seed {st['seed']}, "
        f"{st['time_s']:.3g} s per sampler, {st['snapshots']} snapshots from "
        f"{st['first_snapshot_s']:.3g} s, {data['threads']} threads of "
        f"{data['hardware_threads']}, Tessera {esc(data['tessera_version'])}.<br>"
        f"reference: {ref_text}.<br>data: "
        f"<a href='{esc(os.path.relpath(os.path.join(run, 'convergence.csv'), out_dir))}'>"
        f"convergence.csv</a>, "
        f"<a href='{esc(os.path.relpath(os.path.join(run, 'convergence.json'), out_dir))}'>"
        f"convergence.json</a></p>",
        headline_html(data),
        f"<img src='{esc(rel['errors'])}' alt='error against time'>",
        "<h3>Equal time: final images and crops</h3>",
        f"<img src='{esc(rel['crops'])}' alt='equal-time crops'>",
    ]
    if has_spp:
        parts += ["<h3>Samples per pixel of the adaptive runs</h3>",
                  f"<img src='{esc(rel['spp'])}' alt='sample-count heat maps'>"]
    parts += ["<h3>Final snapshot</h3>", final_table_html(data)]
    if has_robust(data):
        parts.append(f"<p class=note>{ROBUST[1]}: relMSE with the 0.1% of pixels of largest "
                     "relative error left out (robust to single fireflies).</p>")
    return "\n".join(parts)


def summary_html(runs):
    """One row per scene and sampler: final errors (relMSE, and the robust relMSE where any run
    has it), the MSE slope, and the time to the lowest headline level."""
    robust = any(has_robust(d) for d in runs)
    rl = ROBUST[1]
    labels = {headline_label(d) for d in runs}
    # The headline metric in the header when all runs share it, else in every cell.
    head_metric = labels.pop() if len(labels) == 1 else None
    out = ["<table><tr><th class=l>scene</th><th class=l>sampler</th><th>time s</th>"
           "<th>mean spp</th><th>relMSE</th><th>relMSE / first</th>"
           + (f"<th>{rl}</th><th>{rl} / first</th>" if robust else "")
           + "<th>slope MSE</th>" + (f"<th>slope {rl}</th>" if robust else "")
           + f"<th>E (headline{' ' + head_metric if head_metric else ''})</th>"
           "<th>time to E s</th><th>speed-up</th></tr>"]
    for data in runs:
        name = os.path.basename(os.path.normpath(data["dir"]))
        levels = data["headline"]["levels"]
        run_robust = has_robust(data)
        first_rows = sampler_rows(data, data["samplers"][0]["index"]) if data["samplers"] else []
        first_plain = first_rows[-1]["relmse"]["total"] if first_rows else None
        first_robust = (first_rows[-1][ROBUST[0]]["total"]
                        if run_robust and first_rows else None)
        for s, sp in zip(data["samplers"], speedups(data)):
            rows = sampler_rows(data, s["index"])
            slope = s["fit"]["mse"]["slope"]
            cross = s["time_to_error"][-1] if s["time_to_error"] else None
            cells = [esc(name), esc(s["spec"])]
            if rows:
                r = rows[-1]
                plain = r["relmse"]["total"]
                cells += [f"{r['time_s']:.3g}", f"{r['mean_spp']:.1f}", f"{plain:.4g}",
                          f"{plain / first_plain:.3f}" if first_plain else "-"]
            else:
                cells += ["-", "-", "-", "-"]
            if robust:
                v = rows[-1][ROBUST[0]]["total"] if rows and run_robust else None
                ratio = v / first_robust if v is not None and first_robust else None
                rs = fit_of(s, ROBUST[0])["slope"] if run_robust else None
                cells += ["-" if v is None else f"{v:.4g}",
                          "-" if ratio is None else f"{ratio:.3f}"]
            cells += ["-" if slope is None else f"{slope:.2f}"]
            if robust:
                cells += ["-" if rs is None else f"{rs:.2f}"]
            level = f"{levels[-1]:.3g}" if levels else "-"
            if levels and not head_metric:
                level = f"{esc(headline_label(data))} {level}"
            cells += [level,
                      crossing_text(cross) if cross else "-",
                      "-" if sp is None else f"{sp:.2f}x"]
            out.append("<tr>" + "".join(
                f"<td{' class=l' if i < 2 else ''}>{c}</td>" for i, c in enumerate(cells))
                + "</tr>")
    out.append("</table>")
    return "".join(out)


def write_report(run_dirs, out_dir, title):
    np, plt, colors = import_plotting()
    runs = [load_run(d) for d in run_dirs]
    os.makedirs(out_dir, exist_ok=True)
    body = []
    if len(runs) > 1:
        body += ["<h2>Summary</h2>",
                 "<p class=note>time to reach the lowest headline error level of each scene; "
                 "speed-up against the first sampler of the scene. Errors of the final "
                 f"snapshot, with their ratios to the first sampler of the scene; "
                 f"{ROBUST[1]}: relMSE with the 0.1% of pixels of largest relative error left "
                 "out (where the runs have it).</p>", summary_html(runs)]
    for data in runs:
        # The run folder's name (the suite names them after the scenes), and the scene file.
        scene = os.path.normpath(data["scene"])
        heading = (os.path.basename(os.path.normpath(data["dir"])) + ": "
                   + os.path.join(os.path.basename(os.path.dirname(scene)),
                                  os.path.basename(scene)))
        body.append(run_section(np, plt, colors, data, out_dir, heading))
    page = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{esc(title)}</title>"
            f"<style>{CSS}</style></head><body><h1>{esc(title)}</h1>\n"
            + "\n".join(body) + "\n</body></html>\n")
    path = os.path.join(out_dir, "report.html")
    tmp = path + f".tmp-{os.getpid()}"
    with open(tmp, "w") as f:
        f.write(page)
    os.replace(tmp, path)
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", help="tessera converge output folders")
    ap.add_argument("-o", "--output", help="folder of the report (default: the single DIR)")
    ap.add_argument("--title", default="Tessera convergence report")
    ap.add_argument("--check", action="store_true",
                    help="also fail (exit 1) when a run's errors are not finite or not falling")
    a = ap.parse_args()
    if len(a.runs) > 1 and not a.output:
        ap.error("several run folders need -o OUT")
    for d in a.runs:
        if not os.path.isfile(os.path.join(d, "convergence.json")):
            sys.stderr.write(f"convergence_report: {d}: no convergence.json (not a tessera "
                             "converge folder)\n")
            return 2
    path = write_report(a.runs, a.output or a.runs[0], a.title)
    print(f"convergence_report: wrote {path}")
    if a.check:
        problems = [p for d in a.runs for p in sanity_problems(load_run(d))]
        for p in problems:
            sys.stderr.write(f"convergence_report: check failed: {p}\n")
        return 1 if problems else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
