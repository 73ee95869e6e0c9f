#!/usr/bin/env python3
"""Independent URDF forward kinematics for the tests of crates/urdf (docs/urdf.md).

Loads a URDF with yourdfpy (a URDF library nobody in this project wrote), sets the joints of
each row of a pose file and writes the point `--tool-mm` of the tip link in the base link's
frame, in mm.

    python scripts/urdf_reference.py FILE.urdf BASE_LINK TIP_LINK POSES.csv OUT.csv [--tool-mm x,y,z]

POSES.csv: a header of joint names, then one row of joint values in radians per pose.
OUT.csv: header x_mm,y_mm,z_mm, one row per pose, numbers as Python's repr (round-trip exact).
"""

import argparse
import csv
import sys

import numpy as np
import yourdfpy


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("urdf")
    ap.add_argument("base")
    ap.add_argument("tip")
    ap.add_argument("poses")
    ap.add_argument("out")
    ap.add_argument("--tool-mm", default="0,0,0")
    a = ap.parse_args()
    tool_m = np.array([float(v) for v in a.tool_mm.split(",")] + [1000.0]) / 1000.0
    robot = yourdfpy.URDF.load(
        a.urdf,
        build_scene_graph=True,
        build_collision_scene_graph=False,
        load_meshes=False,
        load_collision_meshes=False,
    )
    with open(a.poses, newline="") as f:
        rows = list(csv.reader(f))
    names, poses = rows[0], rows[1:]
    unknown = [n for n in names if n not in robot.actuated_joint_names]
    if unknown:
        print(f"{a.urdf}: no actuated joints {unknown}", file=sys.stderr)
        return 1
    with open(a.out, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["x_mm", "y_mm", "z_mm"])
        for row in poses:
            robot.update_cfg({n: float(v) for n, v in zip(names, row)})
            t = robot.get_transform(frame_to=a.tip, frame_from=a.base)
            p = (t @ tool_m)[:3] * 1000.0
            w.writerow([repr(float(v)) for v in p])
    return 0


if __name__ == "__main__":
    sys.exit(main())
