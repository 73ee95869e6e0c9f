#!/usr/bin/env python3
"""Independent reference for the controller writers' rotation conversions (issue 40).

SciPy's Rotation turns a fixed set of rotations into a unit quaternion (scalar first,
w >= 0), KUKA's A, B, C (intrinsic ZYX Euler angles, degrees) and a UR rotation vector
(axis * angle, radians), one CSV row each:

    label,qw,qx,qy,qz,a_deg,b_deg,c_deg,rx,ry,rz

The set: 200 random rotations (numpy's default_rng(40)), and the cases a conversion gets
wrong first: the identity, half turns about the axes and a diagonal, rotations within 1e-6
rad of a half turn, gimbal lock (B = +-90 deg, where SciPy sets the third angle C to 0) and
B within 1e-4 deg of it, and angles at +-180 deg.

    python3 scripts/rotation_reference.py OUT.csv

crates/controller/tests/fixtures/rotation_reference.csv is this script's output (SciPy
1.17.1); crates/controller/tests/rotation.rs reads it, and its ignored test runs this
script again and compares the numbers (`.ci/run`, in the Python package's venv).
"""

import sys
import warnings

import numpy as np
from scipy.spatial.transform import Rotation


def cases():
    yield "identity", Rotation.identity()
    for axis, name in [((1, 0, 0), "x"), ((0, 1, 0), "y"), ((0, 0, 1), "z"), ((1, 1, 1), "xyz")]:
        a = np.array(axis, dtype=float) / np.linalg.norm(axis)
        yield f"half-turn-{name}", Rotation.from_rotvec(np.pi * a)
        yield f"near-half-turn-{name}", Rotation.from_rotvec((np.pi - 1e-6) * a)
    for abc in [(30, 90, 0), (-120, -90, 0), (10, 90, 25), (45, 89.9999, -30), (-60, -89.9999, 170),
                (180, 0, 0), (-180, 45, 180), (179.99, -10, -179.99), (0, 0, 180)]:
        yield "abc(" + " ".join(f"{v:g}" for v in abc) + ")", Rotation.from_euler("ZYX", abc, degrees=True)
    rng = np.random.default_rng(40)
    for k in range(200):
        yield f"random-{k}", Rotation.from_quat(rng.normal(size=4))


def main(out):
    rows = ["label,qw,qx,qy,qz,a_deg,b_deg,c_deg,rx,ry,rz"]
    for label, r in cases():
        x, y, z, w = r.as_quat()
        if w < 0:
            x, y, z, w = -x, -y, -z, -w
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # gimbal lock: SciPy warns, sets C = 0
            abc = r.as_euler("ZYX", degrees=True)
        rv = r.as_rotvec()
        values = [w, x, y, z, *abc, *rv]
        rows.append(label + "," + ",".join(repr(float(v)) for v in values))
    with open(out, "w", encoding="utf-8") as f:
        f.write("\n".join(rows) + "\n")


if __name__ == "__main__":
    main(sys.argv[1])
