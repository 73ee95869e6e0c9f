"""Timings of the Python package against the Rust library and the CLI (docs/python.md).

    python crates/kincal-py/bench/timings.py [--repeat 30] [--trials 4000] [--rounds 4] [--threads 2]

Run with a release build of the package (`pip install ./crates/kincal-py`) and of the CLI
(`cargo build --release -p kincal`, found as $KINCAL_BIN or target/release/kincal).

1. `kincal.identify` on the README's UR10 example (1,495 rows, every 15th identifies, the
   others validate): the median wall time of the Python call against the median of the
   library call inside it (`Calibration.library_ms`, timed in Rust around
   `calibrate::calibrate` on the same data); the difference is the binding's overhead
   (array conversion, the rows' checks, building the result).
2. A campaign (scenarios/paper-kr1000.json, ISO test and residual budget off): trials/s of
   `kincal.campaign` against `kincal campaign` (its timing.json, and its process wall
   time), on the same thread count, in alternating order.
"""

import argparse
import csv
import json
import os
import platform
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import kincal

REPO = Path(__file__).resolve().parents[3]
DATA = REPO / "data" / "ur10-ipa" / "series-b-joint-configurations.csv"
ROBOT = REPO / "scenarios" / "robots" / "ur10.json"
SCENARIO = REPO / "scenarios" / "paper-kr1000.json"


def load():
    with open(DATA, newline="") as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    q = np.array([[float(r[f"q{i + 1}"]) for i in range(6)] for r in rows])
    p = np.array([[float(r[c]) for c in "xyz"] for r in rows])
    return q, p


def cli():
    exe = os.environ.get("KINCAL_BIN") or str(REPO / "target" / "release" / "kincal")
    if not Path(exe).is_file():
        raise SystemExit(f"no release CLI at {exe}: cargo build --release -p kincal")
    return exe


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=30)
    ap.add_argument("--trials", type=int, default=4000)
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.1f}; Python {platform.python_version()}, kincal {kincal.__version__}")

    q, p = load()
    robot = kincal.Robot.load(ROBOT)
    kincal.identify(robot, q, p, every=15)  # warm-up
    wall, lib = [], []
    for _ in range(args.repeat):
        t = time.perf_counter()
        cal = kincal.identify(robot, q, p, every=15)
        wall.append((time.perf_counter() - t) * 1e3)
        lib.append(cal.library_ms)
    v = cal.validation
    w, l = statistics.median(wall), statistics.median(lib)
    print(f"identify (UR10, every 15th of 1495 rows; validation {v['after_mean_mm']:.3f} / "
          f"{v['after_max_mm']:.3f} mm), median of {args.repeat}: Python call {w:.2f} ms, "
          f"library call {l:.2f} ms, overhead {w - l:.2f} ms ({100 * (w - l) / l:.1f} %)")

    exe = cli()
    py_rate, cli_rate, cli_lib_rate = [], [], []
    for round_ in range(args.rounds):
        # Alternate the order, so that neither side always runs on a cold cache.
        for side in (("cli", "py") if round_ % 2 == 0 else ("py", "cli")):
            if side == "cli":
                with tempfile.TemporaryDirectory() as tmp:
                    t = time.perf_counter()
                    subprocess.run([exe, "campaign", str(SCENARIO), "--trials", str(args.trials),
                                    "--threads", str(args.threads), "--no-iso", "--no-budget",
                                    "--quiet", "--out", f"{tmp}/c"], check=True, capture_output=True)
                    cli_wall = time.perf_counter() - t
                    cli_lib = json.loads(Path(f"{tmp}/c/timing.json").read_text())
                    cli_summary = json.loads(Path(f"{tmp}/c/summary.json").read_text())
                cli_rate.append(args.trials / cli_wall)
                cli_lib_rate.append(cli_lib["trials_per_second"])
            else:
                t = time.perf_counter()
                summary = kincal.campaign(SCENARIO, trials=args.trials, threads=args.threads,
                                          iso=False, budget=False)
                py_rate.append(args.trials / (time.perf_counter() - t))
        assert summary == cli_summary, "the summaries differ"
    fmt = lambda xs: " / ".join(f"{x:.0f}" for x in xs)
    print(f"campaign (paper-kr1000, {args.trials} trials, {args.threads} threads, no ISO, no "
          f"budget; the same summary), trials/s in {args.rounds} rounds: Python {fmt(py_rate)} "
          f"(median {statistics.median(py_rate):.0f}); CLI process {fmt(cli_rate)} (median "
          f"{statistics.median(cli_rate):.0f}); CLI timing.json {fmt(cli_lib_rate)} (median "
          f"{statistics.median(cli_lib_rate):.0f})")

if __name__ == "__main__":
    main()
