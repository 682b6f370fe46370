"""The cost of driving remembrane from Python, measured against the engine.

    python python/examples/overhead.py [--blocks 40] [--block 200] [--runs 3]

On the bundled RBC scene (642 vertices) it measures, in one process:

* the per-call overhead of `step()`: the time of `step(0)` calls;
* `step(1)` called k times against one `step(k)`;
* a Python force term that returns zeros, and one that computes a gravity
  field with numpy, against the same scene without it: the cost a Python
  term adds per tick;
* `Simulation.run()` against `remembrane run` (the CLI binary) on the whole
  scene (5×10^4 iterations), wall time.

The machine is noisy, so the comparisons are paired: two simulations of
the same scene advance in alternating blocks of ticks, and the median of
the per-block differences is reported. Performance is measured here and in
benches/, never asserted in tests.
"""

import argparse
import json
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import remembrane as rm

REPO = Path(__file__).resolve().parents[2]
RBC = REPO / "scenes" / "red_blood_cell.ron"


def zeros(x):
    return 0.0, np.zeros_like(x)


def gravity(x):
    f = np.zeros_like(x)
    f[:, 2] = -0.01
    return 0.01 * float(x[:, 2].sum()), f


def simulation(term=None):
    sim = rm.Simulation(rm.Scene.load(RBC))
    if term is not None:
        sim.add_force_term("python", term)
    sim.step(1)  # build the schedule
    return sim


def timed(f):
    t = time.perf_counter()
    f()
    return time.perf_counter() - t


def paired(a, b, advance_a, advance_b, blocks, block):
    """Median and quartiles of (b − a) per tick (µs) over alternating blocks,
    and the median of a per tick."""
    diffs, base = [], []
    for _ in range(blocks):
        ta = timed(lambda: advance_a(a, block))
        tb = timed(lambda: advance_b(b, block))
        diffs.append((tb - ta) / block * 1e6)
        base.append(ta / block * 1e6)
    q = statistics.quantiles(diffs, n=4)
    return statistics.median(base), statistics.median(diffs), q[0], q[2]


def steps(sim, k):
    sim.step(k)


def single_steps(sim, k):
    for _ in range(k):
        sim.step(1)


def run_wall(use_cli, binary):
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "run"
        t = time.perf_counter()
        if use_cli:
            subprocess.run([str(binary), "run", str(RBC), "--out", str(out), "--quiet"], check=True)
        else:
            rm.Simulation(rm.Scene.load(RBC)).run(out=out, progress=False)
        wall = time.perf_counter() - t
        summary = json.loads((out / "summary.json").read_text())
    return wall, summary["iterations"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=40)
    ap.add_argument("--block", type=int, default=200, help="ticks per block")
    ap.add_argument("--runs", type=int, default=3, help="whole runs of CLI and Python each")
    ap.add_argument("--cli", default=str(REPO / "target" / "release" / "remembrane"))
    args = ap.parse_args()

    sim = simulation()
    calls = 20000
    per_call = timed(lambda: [sim.step(0) for _ in range(calls)]) / calls * 1e6
    print(f"RBC, 642 vertices; paired blocks of {args.block} ticks × {args.blocks}\n")
    print("| comparison | baseline µs/tick | added µs/tick (median) | quartiles |")
    print("|---|---:|---:|---:|")
    print(f"| `step(0)` call, no tick | — | {per_call:.2f} per call | — |")
    rows = [
        ("`step(1)` ×k vs `step(k)`", simulation(), simulation(), steps, single_steps),
        ("Python term returning zeros", simulation(), simulation(zeros), steps, steps),
        ("Python gravity term (numpy)", simulation(), simulation(gravity), steps, steps),
    ]
    for name, a, b, fa, fb in rows:
        base, med, q1, q3 = paired(a, b, fa, fb, args.blocks, args.block)
        print(f"| {name} | {base:.1f} | {med:+.2f} | {q1:+.2f} … {q3:+.2f} |")
    if Path(args.cli).exists():
        walls = {True: [], False: []}
        for _ in range(args.runs):
            for use_cli in (True, False):
                walls[use_cli].append(run_wall(use_cli, args.cli))
        cli = statistics.median(w for w, _ in walls[True])
        py = statistics.median(w for w, _ in walls[False])
        n = walls[True][0][1]
        print(
            f"\nWhole scene ({n} iterations), median of {args.runs}: CLI {cli:.2f} s, "
            f"Simulation.run {py:.2f} s ({(py / cli - 1) * 100:+.1f} %)"
        )


if __name__ == "__main__":
    main()
