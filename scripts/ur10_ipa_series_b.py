#!/usr/bin/env python3
"""Convert the published IPA UR10 series B to the kincal measurement file with orientation.

    python3 scripts/ur10_ipa_series_b.py [RAW.csv [OUT.csv]]

Defaults: data/ur10-ipa/raw/measurements_joint_configurations.csv ->
data/ur10-ipa/series-b-6dof.csv (paths relative to the repository root). Standard library
only; the output is byte-deterministic and canonical (reading it with the `measurements` crate
and writing it again gives the same bytes after the comment lines).

The raw file: `;`-separated, `,` decimal marks, CRLF lines. Per row: joints in radians
(`shoulder_pan_joint` ... `wrist_3_joint`), the T-Mac position in mm in the tracker frame
(`measurement_x/y/z`) and its orientation as intrinsic XYZ Euler angles in degrees
(`measurement_rx/ry/rz`, SciPy's `Rotation.from_euler('XYZ', ..., degrees=True)`), each
with the tracker's standard deviation (`measurement_std_*`).

The output (docs/model.md section 5), one row per raw row, in order:
  id        b0001 ... b1495, the raw row number
  q1..q6    degrees(joint radians), shortest round-trip form
  x,y,z     the raw position, mm
  qw..qz    the unit quaternion of R = Rx(rx) Ry(ry) Rz(rz), scalar first, qw >= 0
  sx,sy,sz  the raw position standard deviations, mm
  srx..srz  the orientation standard deviations about the tracker axes, degrees: the raw
            Euler-angle standard deviations propagated to first order to the rotation vector
            of the orientation error in the tracker frame, sqrt(diag(J diag(s^2) J^T)) with
            J = [e_x, Rx(rx) e_y, Rx(rx) Ry(ry) e_z] (the Euler angles' errors taken as
            independent, the correlations the propagation creates dropped)
"""

import math
import os
import sys
from decimal import Decimal

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RAW = os.path.join(ROOT, "data", "ur10-ipa", "raw", "measurements_joint_configurations.csv")
OUT = os.path.join(ROOT, "data", "ur10-ipa", "series-b-6dof.csv")

JOINTS = [
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
]

COMMENT = """\
UR10 (Fraunhofer IPA), series B, joint configurations, with the T-Mac's orientation.
Converted by scripts/ur10_ipa_series_b.py from raw/measurements_joint_configurations.csv
(MIT licence, LICENSE.md); see README.md. q1..q6 degrees; x,y,z mm, tracker frame;
qw,qx,qy,qz the T-Mac frame in the tracker frame (from intrinsic XYZ Euler angles);
sx,sy,sz mm; srx,sry,srz degrees, about the tracker axes."""


def number(text):
    """A raw field: `,` decimal mark."""
    return float(text.replace(",", "."))


def rust(v):
    """The number as Rust's `{}` prints an f64: shortest round-trip digits, never an exponent."""
    if v == 0.0:
        return "-0" if math.copysign(1.0, v) < 0 else "0"
    s = format(Decimal(repr(v)), "f")
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    return s


def qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def axis(k, deg):
    h = 0.5 * math.radians(deg)
    q = [math.cos(h), 0.0, 0.0, 0.0]
    q[1 + k] = math.sin(h)
    return tuple(q)


def quaternion_xyz(rx, ry, rz):
    """Intrinsic X-Y-Z: R = Rx(rx) Ry(ry) Rz(rz); scalar first, w >= 0."""
    q = qmul(qmul(axis(0, rx), axis(1, ry)), axis(2, rz))
    return tuple(-v for v in q) if q[0] < 0 else q


def sigma_about_axes(rx, ry, srx, sry, srz):
    """First-order standard deviations of the rotation vector about the tracker axes."""
    a, b = math.radians(rx), math.radians(ry)
    # Columns: e_x, Rx(a) e_y, Rx(a) Ry(b) e_z.
    cols = [
        (1.0, 0.0, 0.0),
        (0.0, math.cos(a), math.sin(a)),
        (math.sin(b), -math.sin(a) * math.cos(b), math.cos(a) * math.cos(b)),
    ]
    s = (srx, sry, srz)
    return tuple(math.sqrt(sum((cols[j][k] * s[j]) ** 2 for j in range(3))) for k in range(3))


def convert(raw_text):
    lines = raw_text.splitlines()
    header = lines[0].split(";")
    col = {name: i for i, name in enumerate(header)}
    out = [f"# {line}" for line in COMMENT.splitlines()]
    out.append("id,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz,sx,sy,sz,srx,sry,srz")
    for n, line in enumerate(lines[1:], start=1):
        f = line.split(";")
        if len(f) != len(header):
            raise SystemExit(f"raw line {n + 1}: {len(f)} fields, header has {len(header)}")
        v = lambda name: number(f[col[name]])  # noqa: E731
        q = [math.degrees(v(j)) for j in JOINTS]
        p = [v(f"measurement_{c}") for c in "xyz"]
        e = [v(f"measurement_r{c}") for c in "xyz"]
        sp = [v(f"measurement_std_{c}") for c in "xyz"]
        se = [v(f"measurement_std_r{c}") for c in "xyz"]
        quat = quaternion_xyz(*e)
        sr = sigma_about_axes(e[0], e[1], *se)
        values = q + p + list(quat) + sp + list(sr)
        out.append(",".join([f"b{n:04d}"] + [rust(x) for x in values]))
    return "\n".join(out) + "\n"


def main():
    raw = sys.argv[1] if len(sys.argv) > 1 else RAW
    dst = sys.argv[2] if len(sys.argv) > 2 else OUT
    with open(raw, encoding="utf-8", newline="") as fh:
        text = convert(fh.read())
    with open(dst, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
