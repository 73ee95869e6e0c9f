"""Hybrid calibration on the shipped UR10 data (data/ur10-ipa): kincal identifies the
geometry, a scikit-learn Gaussian process learns what the geometry leaves (the residuals) from
the joint angles, and both are scored on poses neither model saw.

    python -m venv venv && venv/bin/pip install ./crates/kincal-py scikit-learn
    venv/bin/python crates/kincal-py/examples/hybrid_gp.py            # from the repository root

Protocol (K-fold cross-validation over the 1,495 poses, shuffled with a fixed seed): in each
fold, the training poses are the other K-1 folds; of them, `n_train` poses (the first
n_train of the shuffled training poses) identify the geometry (kincal.identify, the
README's options: paper parameters, registration, Levenberg) and the same poses train the
GP on their residuals (measured − calibrated, mm). The held-out fold is predicted by the
calibrated robot alone and by the calibrated robot + the GP's mean. Nothing of the held-out
fold is used to fit or to choose anything (the GP's hyper-parameters are fitted by maximum
likelihood on the training poses only).
"""

import argparse
import csv
import time
import warnings
from pathlib import Path

import numpy as np
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

import kincal

REPO = Path(__file__).resolve().parents[3]
DATA = REPO / "data" / "ur10-ipa" / "series-b-joint-configurations.csv"
ROBOT = REPO / "scenarios" / "robots" / "ur10.json"


def load():
    with open(DATA, newline="") as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    q = np.array([[float(r[f"q{i + 1}"]) for i in range(6)] for r in rows])
    p = np.array([[float(r[c]) for c in "xyz"] for r in rows])
    return q, p


def features(q_deg):
    """The GP's inputs: the joint angles in radians (q6 does not move the measured point
    much; the anisotropic kernel learns that)."""
    return np.radians(q_deg)


def gp_model():
    kernel = ConstantKernel(1.0, (1e-3, 1e2)) * RBF(
        length_scale=np.ones(6), length_scale_bounds=(1e-2, 1e2)
    ) + WhiteKernel(0.05, (1e-4, 1.0))
    return GaussianProcessRegressor(kernel=kernel, normalize_y=True, random_state=0)


def stats(e):
    n = np.linalg.norm(e, axis=1)
    return n.mean(), np.sqrt((n**2).mean()), np.percentile(n, 95), n.max()


def main():
    # A length scale at its upper bound means "this joint barely matters" (q6 does not move the
    # measured point); scikit-learn warns about it at every fit.
    warnings.filterwarnings("ignore", category=ConvergenceWarning)
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--train", type=int, nargs="+", default=[100, 400],
                    help="training poses per fold (geometry and GP)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    q, p = load()
    robot = kincal.Robot.load(ROBOT)
    order = np.random.default_rng(args.seed).permutation(len(q))
    folds = np.array_split(order, args.folds)
    started = time.perf_counter()
    print(f"{len(q)} poses, {args.folds}-fold cross-validation (seed {args.seed}); "
          "3-D error on the held-out poses, mm")
    header = "| training poses | model | mean | RMS | p95 | max |"
    table = [header, "|---:|---|---:|---:|---:|---:|"]
    for n_train in args.train:
        errors = {"geometry (kincal)": [], "geometry + GP": []}
        for k, test in enumerate(folds):
            train = np.concatenate([f for j, f in enumerate(folds) if j != k])[:n_train]
            cal = kincal.identify(robot, q[train], p[train])
            gp = gp_model().fit(features(q[train]), cal.residuals_mm)
            geometric = p[test] - cal.predict(q[test])
            errors["geometry (kincal)"].append(geometric)
            errors["geometry + GP"].append(geometric - gp.predict(features(q[test])))
        for model, e in errors.items():
            mean, rms, p95, mx = stats(np.concatenate(e))
            table.append(f"| {n_train} | {model} | {mean:.3f} | {rms:.3f} | {p95:.3f} | {mx:.3f} |")
    print("\n".join(table))
    print(f"({time.perf_counter() - started:.1f} s)")


if __name__ == "__main__":
    main()
