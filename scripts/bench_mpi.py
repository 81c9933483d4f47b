#!/usr/bin/env python3
"""Distributed rendering on MPI: efficiency and communication, side by side in one run.

    scripts/bench_mpi.py [--tessera build/tessera] [--reps 3] [--spp 64] [-o OUT]
                         [--scenes A.pbrt B.pbrt ...] [--hd-spp 16] [--hd-ranks 4]

1. Efficiency: per scene (the examples' Cornell box and, where ../shared/scenes is present, the
   Bitterli Cornell box and Bitterli scenes), the same render -- `--deterministic --spp N` at
   320x240, the default adaptive sampler, so that both take exactly the same samples and give
   the same image -- in one process with `--threads 2` and with `mpirun -np 2 --threads 1`.
   Efficiency = time of one process / time of two ranks (render wall time from the stats JSON,
   and the whole command, scene load included), the median of --reps runs each, interleaved.
   The images are checked bit-identical (idiff).
2. Communication at film resolution: 1920x1080 with --hd-ranks ranks (one thread each,
   oversubscribed on this machine), the default sampler, `--spp` --hd-spp: per rank the seconds
   inside the collectives as a share of its render time, split into the per-pass exchanges and
   the film's gather to rank 0 at the end, and apart from it the seconds it waited for slower
   ranks before them (a barrier first: load imbalance, and time slicing when the ranks
   oversubscribe the cores), the passes
   and the bytes a pass exchanges at most (per tile its index and 5 doubles with the relMSE
   metric; only tiles that changed travel).
3. The figures the README's scaling model uses: per-pass collective time and payload.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "scenes")
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_btl_tcp_if_include="lo", OMPI_MCA_oob_tcp_if_include="lo")


def default_scenes():
    s = [os.path.join(ROOT, "examples", "cornell-box", "scene.pbrt")]
    for rel in ["bitterli-cornell-box/pbrt-v4/scene-v4.pbrt", "bitterli/living-room-2/scene-v4.pbrt",
                "bitterli/material-testball/scene-v4.pbrt"]:
        p = os.path.join(SHARED, rel)
        if os.path.exists(p):
            s.append(p)
    return s


def run(cmd):
    t0 = time.monotonic()
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    dt = time.monotonic() - t0
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {r.returncode}: {r.stderr.strip()[-800:]}")
    return dt


def stats(path):
    with open(path) as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tessera", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--resolution", default="320x240")
    ap.add_argument("--scenes", nargs="*")
    ap.add_argument("--hd-spp", type=int, default=64)
    ap.add_argument("--hd-ranks", type=int, default=4)
    ap.add_argument("-o", "--out", default="bench-mpi")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    scenes = a.scenes or default_scenes()
    t = a.tessera

    print(f"1. efficiency: one process --threads 2 against mpirun -np 2 --threads 1, "
          f"--deterministic --spp {a.spp} at {a.resolution}, median of {a.reps}")
    print(f"{'scene':28} {'1 proc s':>9} {'2 ranks s':>10} {'eff (render)':>13} "
          f"{'eff (command)':>14} {'comm share':>11} {'waiting':>8} {'identical':>10}")
    effs = []
    for k, scene in enumerate(scenes):
        name = os.path.basename(os.path.dirname(scene))
        if name in ("pbrt-v4",):
            name = os.path.basename(os.path.dirname(os.path.dirname(scene)))
        common = [scene, "--resolution", a.resolution, "--spp", str(a.spp), "--deterministic",
                  "--seed", "1", "-q", "--no-png"]
        one_r, one_c, two_r, two_c, comm, wait = [], [], [], [], [], []
        for rep in range(a.reps):
            e1, j1 = os.path.join(a.out, f"one-{k}.exr"), os.path.join(a.out, f"one-{k}.json")
            one_c.append(run([t, "render", *common, "--threads", "2", "-o", e1, "--stats", j1]))
            one_r.append(stats(j1)["wall_s"])
            e2, j2 = os.path.join(a.out, f"two-{k}.exr"), os.path.join(a.out, f"two-{k}.json")
            two_c.append(run(["mpirun", "-np", "2", t, "render", *common, "--threads", "1",
                              "-o", e2, "--stats", j2]))
            s2 = stats(j2)
            two_r.append(s2["wall_s"])
            comm.append(s2["mpi"]["comm_fraction_max"])
            wait.append(s2["mpi"]["wait_fraction_max"])
        same = subprocess.run(["idiff", "-fail", "0", "-warn", "0", e1, e2],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE).returncode == 0
        m1, m2 = statistics.median(one_r), statistics.median(two_r)
        c1, c2 = statistics.median(one_c), statistics.median(two_c)
        effs.append(m1 / m2)
        print(f"{name:28} {m1:9.3f} {m2:10.3f} {m1 / m2:13.3f} {c1 / c2:14.3f} "
              f"{100 * statistics.median(comm):10.2f}% {100 * statistics.median(wait):7.2f}% "
              f"{'yes' if same else 'NO':>10}")
    print(f"median efficiency (render): {statistics.median(effs):.3f} (target >= 0.9)\n")

    n = a.hd_ranks
    print(f"2. communication at 1920x1080, mpirun -np {n} --threads 1 (oversubscribed: {n} ranks "
          f"on {os.cpu_count()} cores), default sampler, --spp {a.hd_spp}")
    j = os.path.join(a.out, "hd.json")
    run(["mpirun", "--oversubscribe", "-np", str(n), t, "render", scenes[0], "--resolution",
         "1920x1080", "--spp", str(a.hd_spp), "--threads", "1", "-o",
         os.path.join(a.out, "hd.exr"), "--stats", j, "-q", "--no-png"])
    s = stats(j)
    tiles = (1920 // 8) * (1080 // 8 + (1 if 1080 % 8 else 0))
    payload = tiles * 6 * 8
    print(f"{'rank':>5} {'samples':>11} {'wall s':>8} {'comm s':>8} {'share':>7} "
          f"{'of it: passes s':>16} {'film gather s':>14} {'waiting s':>10} {'share':>7}")
    for r in s["mpi"]["per_rank"]:
        print(f"{r['rank']:5d} {r['samples']:11d} {r['wall_s']:8.2f} {r['comm_s']:8.3f} "
              f"{100 * r['comm_s'] / r['wall_s']:6.2f}% {r['pass_comm_s']:16.3f} "
              f"{r['comm_s'] - r['pass_comm_s']:14.3f} {r['wait_s']:10.3f} "
              f"{100 * r['wait_s'] / r['wall_s']:6.2f}%")
    passes = s["passes"]
    print(f"passes {passes}, per pass each rank receives {payload / 1e6:.2f} MB of tile sums "
          f"({tiles} tiles x 6 doubles) at most; largest communication share "
          f"{100 * s['mpi']['comm_fraction_max']:.2f}% (target < 2%)")
    comm_min = min(r["pass_comm_s"] for r in s["mpi"]["per_rank"])
    print(f"3. scaling model input: per-pass collective time on the least-waiting rank "
          f"{1e3 * comm_min / max(1, passes):.2f} ms ({n} ranks, shared memory)")


if __name__ == "__main__":
    main()
