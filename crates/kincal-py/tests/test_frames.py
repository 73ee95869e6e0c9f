"""kincal.identify_frames (6-DoF and several targets per pose) against `kincal identify` on
a file with the same rows: the same calibrated robot to the bit, the same figures, errors as
exceptions naming the row."""

import json
import re

import numpy as np
import pytest

import kincal
from conftest import REPO, ROBOTS, read_csv, run_cli

SIX_DOF = REPO / "data" / "ur10-ipa" / "series-b-6dof.csv"


def six_dof():
    rows = read_csv(SIX_DOF)
    q = np.array([[float(r[f"q{i + 1}"]) for i in range(6)] for r in rows])
    p = np.array([[float(r[c]) for c in "xyz"] for r in rows])
    o = np.array([[float(r[c]) for c in ("qw", "qx", "qy", "qz")] for r in rows])
    return q, p, o


def without_time_and_names(summary):
    """The summary without what names the data (a file or the arrays), its lines and times."""
    s = re.sub(r"\d+\.\d ms", "T ms", summary)
    s = re.sub(r"line \d+", "line L", s)
    s = s.replace(str(SIX_DOF), "DATA").replace("identification arrays", "DATA")
    return [l for l in s.splitlines() if not l.startswith("→")]


def test_six_dof_equals_the_cli(tmp_path):
    out = tmp_path / "cli"
    stdout = run_cli("identify", "--robot", ROBOTS / "ur10.json", "--data", SIX_DOF,
                     "--every", 15, "--out", out)
    q, p, o = six_dof()
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    cal = kincal.identify_frames(robot, q, p, orientations_wxyz=o, every=15)
    cli_robot = kincal.Robot.load(out / "identified.json")
    assert cal.robot.parameters == cli_robot.parameters
    assert np.array_equal(cal.robot.fk(q), cli_robot.fk(q))
    assert without_time_and_names(cal.summary()) == without_time_and_names(stdout)
    v = cal.validation
    assert v["identified"]["n_poses"] == 1395
    assert f"{v['identified']['position_mean_mm']:.3f}" == "0.422"
    assert f"{v['identified']['orientation_mean_deg']:.4f}" == "0.0471"
    assert f"{v['start']['position_mean_mm']:.3f}" == "2.933"
    assert cal.fit_errors["identified"]["n_poses"] == 100
    # The flagged pose: line 862 of the file is data row 856 (6 comment and header lines).
    assert [o["row"] for o in cal.outliers] == [855]
    assert "base_rz" in cal.held
    names = [r["name"] for r in cal.parameters]
    assert len(names) == 30 and {"tool_rx", "tool_ry", "tool_rz"} <= set(names)
    cal.save(tmp_path / "py")
    assert sorted(f.name for f in (tmp_path / "py").iterdir()) == sorted(
        f.name for f in out.iterdir())
    # Deterministic.
    again = kincal.identify_frames(robot, q, p, orientations_wxyz=o, every=15)
    assert again.parameters == cal.parameters


def test_several_targets_per_pose_equal_the_cli(tmp_path):
    """Three reflectors per pose derived from the measured frame (p + R·o_k), as
    docs/calibrating-real-data.md's table does, without orientation."""
    q, p, o = six_dof()
    q, p, o = q[:300], p[:300], o[:300]
    offsets = {"A": (100.0, 0.0, 0.0), "B": (-50.0, 86.6, 0.0), "C": (-50.0, -86.6, 0.0)}

    def rot(w, x, y, z):
        return np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ])

    rows_q, rows_p, targets, ids = [], [], [], []
    for k in range(len(q)):
        for name, off in offsets.items():
            rows_q.append(q[k])
            rows_p.append(p[k] + rot(*o[k]) @ np.array(off))
            targets.append(name)
            ids.append(f"p{k}")
    rows_q, rows_p = np.array(rows_q), np.array(rows_p)
    data = tmp_path / "targets.csv"
    data.write_text("id,q1,q2,q3,q4,q5,q6,target,x,y,z\n" + "".join(
        ",".join([i, *(repr(float(v)) for v in qq), t, *(repr(float(v)) for v in pp)]) + "\n"
        for i, qq, t, pp in zip(ids, rows_q, targets, rows_p)))
    out = tmp_path / "cli"
    run_cli("identify", "--robot", ROBOTS / "ur10.json", "--data", data, "--every", 15,
            "--out", out)
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    cal = kincal.identify_frames(robot, rows_q, rows_p, targets=targets, pose_ids=ids, every=15)
    assert cal.robot.parameters == kincal.Robot.load(out / "identified.json").parameters
    # 20 identification poses, less those the robust screen excluded as gross errors.
    excluded = sum(o["excluded"] for o in cal.outliers)
    assert cal.fit_errors["identified"]["n_poses"] == 20 - excluded
    assert cal.validation["identified"]["position_mean_mm"] < 1.0


def test_frame_errors_name_the_row():
    q, p, o = six_dof()
    q, p, o = q[:40], p[:40], o[:40].copy()
    robot = kincal.Robot.load(ROBOTS / "ur10.json")

    def refused(text, *args, **kw):
        with pytest.raises(kincal.KincalError) as e:
            kincal.identify_frames(robot, *args, **kw)
        assert text in str(e.value), str(e.value)

    refused("give orientations_wxyz or targets", q, p)
    refused("orientations_wxyz: expected shape (40, 4)", q, p, orientations_wxyz=o[:, :3])
    bad = o.copy()
    bad[6] *= 1.01
    refused("identification arrays", q, p, orientations_wxyz=bad)
    refused('identification arrays:7: column "qw"', q, p, orientations_wxyz=bad)
    refused("identification arrays: the identification data file has no data rows",
            q[:0], p[:0], orientations_wxyz=o[:0])
    refused('column "target"', q, p, targets=["A", "r 1"] * 20, pose_ids=[f"p{k}" for k in range(40)])
    refused('column "id"', q, p, targets=["A"] * 40, pose_ids=[""] * 40)
    refused("with targets every row needs a pose id", q, p, targets=["A"] * 40)
    refused("targets: expected 40 strings", q, p, targets=["A"] * 3, pose_ids=["x"] * 3)
    ids = [f"p{k // 2}" for k in range(40)]
    # Rows 0 and 1 are one pose but their joints differ.
    refused("same id are one pose", q, p, targets=["A", "B"] * 20, pose_ids=ids)
    refused("orientation_weight", q, p, orientations_wxyz=o, orientation_weight=0.0)
    refused("validate: expected", q, p, orientations_wxyz=o, validate=(q,))
    refused("unknown value", q, p, orientations_wxyz=o, schedule="fast")


@pytest.mark.parametrize("kind", ["frame", "targets"])
def test_simulate_gives_the_clis_frame_files_and_identify_frames_reads_them(kind, tmp_path):
    """A scenario measuring frames or three reflectors: kincal.simulate returns the rows
    `kincal simulate` writes (orientations; targets and pose ids), and identify_frames on
    them gives the CLI's calibrated robot on its files."""
    import json

    scenario = json.loads((REPO / "scenarios" / "noise-floor.json").read_text())
    scenario["robot"] = str(ROBOTS / "kr1000-titan.json")
    scenario["residual_budget"] = {"enabled": False}
    scenario["measurement"] = {"type": kind}
    file = tmp_path / "scenario.json"
    file.write_text(json.dumps(scenario))
    run_cli("simulate", file, "--out", tmp_path / "sim")
    sim = kincal.simulate(scenario)
    for part in ["identification", "validation"]:
        rows = read_csv(tmp_path / "sim" / f"{part}.csv")
        assert np.array_equal(
            sim[f"{part}_q_deg"], [[float(r[f"q{i + 1}"]) for i in range(6)] for r in rows])
        assert np.array_equal(sim[f"{part}_points_mm"], [[float(r[c]) for c in "xyz"] for r in rows])
        if kind == "frame":
            assert np.array_equal(sim[f"{part}_orientations_wxyz"],
                                  [[float(r[c]) for c in ("qw", "qx", "qy", "qz")] for r in rows])
            assert f"{part}_targets" not in sim
        else:
            assert sim[f"{part}_targets"] == [r["target"] for r in rows]
            assert sim[f"{part}_pose_ids"] == [r["id"] for r in rows]
            assert len(rows) == 150 and f"{part}_orientations_wxyz" not in sim
    run_cli("identify", "--robot", ROBOTS / "kr1000-titan.json",
            "--data", tmp_path / "sim" / "identification.csv",
            "--validate", tmp_path / "sim" / "validation.csv", "--out", tmp_path / "cal")
    robot = kincal.Robot.load(ROBOTS / "kr1000-titan.json")
    extra = lambda part: (
        {"orientations_wxyz": sim[f"{part}_orientations_wxyz"]} if kind == "frame"
        else {"targets": sim[f"{part}_targets"], "pose_ids": sim[f"{part}_pose_ids"]})
    v = extra("validation")
    cal = kincal.identify_frames(
        robot, sim["identification_q_deg"], sim["identification_points_mm"],
        validate=(sim["validation_q_deg"], sim["validation_points_mm"],
                  v.get("orientations_wxyz"), v.get("targets"), v.get("pose_ids")),
        **extra("identification"))
    assert cal.robot.parameters == kincal.Robot.load(tmp_path / "cal" / "identified.json").parameters
    after = cal.validation["identified"]["position_mean_mm"]
    assert after < 0.5 and after < cal.validation["start"]["position_mean_mm"]


def test_predict_returns_the_orientation_of_kincal_predict(tmp_path):
    """Issue 40 item 1: FrameCalibration.predict returns the points and the measured frame's
    orientation (unit quaternions w, x, y, z, w >= 0), the columns `kincal predict` writes
    for the same robot, to the bit; they agree with the file's orientations to the fit's
    residual. A robot without a tool orientation has none."""
    q, p, o = six_dof()
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    assert robot.fk_orientation(q) is None
    cal = kincal.identify_frames(robot, q, p, orientations_wxyz=o, every=15)
    points, wxyz = cal.predict(q)
    assert points.shape == (len(q), 3) and wxyz.shape == (len(q), 4)
    assert np.array_equal(points, cal.robot.fk(q))
    assert np.array_equal(wxyz, cal.robot.fk_orientation(q))
    assert np.all(np.abs(np.linalg.norm(wxyz, axis=1) - 1) < 1e-15) and np.all(wxyz[:, 0] >= 0)
    one_p, one_o = cal.predict(q[3])
    assert one_p.shape == (3,) and np.array_equal(one_o, wxyz[3])
    cal.save(tmp_path / "cal")
    run_cli("predict", "--robot", tmp_path / "cal" / "identified.json", "--joints", SIX_DOF,
            "--out", tmp_path / "p.csv")
    rows = read_csv(tmp_path / "p.csv")
    cli = np.array([[float(r[c]) for c in ("qw", "qx", "qy", "qz")] for r in rows])
    assert np.array_equal(cli, wxyz)
    o = o / np.linalg.norm(o, axis=1)[:, None]
    # The angle of conj(predicted)·measured: 2·atan2(|vector part|, |w|).
    w = np.sum(wxyz * o, axis=1)
    v = wxyz[:, :1] * o[:, 1:] - o[:, :1] * wxyz[:, 1:] - np.cross(wxyz[:, 1:], o[:, 1:])
    angle = np.degrees(2 * np.arctan2(np.linalg.norm(v, axis=1), np.abs(w)))
    # The fit's 100 poses and the 1395 validation poses: the identify figures.
    fit = cal.fit_errors["identified"]["orientation_mean_deg"]
    val = cal.validation["identified"]["orientation_mean_deg"]
    assert abs(angle.mean() - (100 * fit + 1395 * val) / 1495) < 1e-9
    assert 0.01 < angle.mean() < 0.05


def test_compensate_cartesian_targets_of_a_frame_calibration():
    """Cartesian targets with orientation on the UR10's 6-DoF calibration (issue 40): the
    calibrated robot's TCP at the joints to command is on the targets (given again in the
    measurement frame they give back the same joints); a FrameCalibration compensates joint
    targets too; a quaternion that is not of unit norm names its row."""
    q, p, o = six_dof()
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    cal = kincal.identify_frames(robot, q, p, orientations_wxyz=o, every=15)
    rows = read_csv(REPO / "data" / "ur10-ipa" / "cartesian-targets.csv")
    tp = np.array([[float(r[c]) for c in "xyz"] for r in rows])
    to = np.array([[float(r[c]) for c in ("qw", "qx", "qy", "qz")] for r in rows])
    start = [-166, -129, 121, -172, -4, 0]
    qc, cp, co = kincal.compensate_cartesian(cal, tp, to, start_q_deg=start)
    assert qc.shape == (15, 6) and cp.shape == (15, 3) and co.shape == (15, 4)
    assert np.allclose(np.linalg.norm(co, axis=1), 1.0)
    # The corrected targets are near the targets (the calibration moves by millimetres).
    assert np.max(np.linalg.norm(cp - tp, axis=1)) < 10.0
    # The calibrated TCP at the joints, in the measurement frame, as targets: the same joints.
    mp, mo = cal.robot.fk(qc), cal.robot.fk_orientation(qc)
    again, _, _ = kincal.compensate_cartesian(cal, mp, mo, frame="measurement", start_q_deg=start)
    assert np.max(np.abs(again - qc)) < 1e-6
    assert kincal.compensate(cal, q[::100]).shape == (15, 6)
    # A FrameCalibration has no residual model: geometry_only changes nothing.
    assert np.array_equal(
        kincal.compensate(cal, q[::100], geometry_only=True), kincal.compensate(cal, q[::100])
    )
    bad = to.copy()
    bad[4] *= 1.01
    with pytest.raises(kincal.KincalError, match='target arrays:5: column "qw"'):
        kincal.compensate_cartesian(cal, tp, bad, start_q_deg=start)


def test_six_dof_residual_model_equals_the_cli(tmp_path):
    """Issue 41 on 6-DoF data: identify_frames(..., residual_model="gp") keeps the model of
    `kincal identify --residual-model gp` on the same rows — the same residual-model.json
    numbers, position and orientation parts applied on the UR10's every=5 split — and
    FrameCalibration.predict is `kincal predict` with it, to the bit (geometry_only: the
    robot alone). compensate brings the hybrid onto the nominal's points."""
    q, p, o = six_dof()
    out = tmp_path / "cli"
    run_cli("identify", "--robot", ROBOTS / "ur10.json", "--data", SIX_DOF, "--every", 5,
            "--residual-model", "gp", "--out", out)
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    cal = kincal.identify_frames(robot, q, p, orientations_wxyz=o, every=5, residual_model="gp")
    r = cal.residual_model
    assert r["used"] and r["orientation"]["used"]
    assert len(r["folds"]) == 5 and len(r["orientation"]["folds"]) == 5
    gain, scatter = r["orientation"]["mean_gain_deg"]
    assert gain > scatter > 0
    cal.save(tmp_path / "py")
    # The same model; only the calibration run it names differs (the data's source is the
    # arrays here, the file there).
    files = [json.loads((d / "residual-model.json").read_text()) for d in (tmp_path / "py", out)]
    assert files[0].pop("fitted_for") != files[1].pop("fitted_for")
    assert files[0] == files[1] and files[0]["format"] == "kincal-residual-model/2"
    run_cli("predict", "--robot", out / "identified.json", "--joints", SIX_DOF,
            "--out", tmp_path / "p.csv")
    rows = read_csv(tmp_path / "p.csv")
    cli_p = np.array([[float(r[c]) for c in "xyz"] for r in rows])
    cli_o = np.array([[float(r[c]) for c in ("qw", "qx", "qy", "qz")] for r in rows])
    points, wxyz = cal.predict(q)
    assert np.array_equal(points, cli_p) and np.array_equal(wxyz, cli_o)
    geo_p, geo_o = cal.predict(q, geometry_only=True)
    assert np.array_equal(geo_p, cal.robot.fk(q))
    assert np.array_equal(geo_o, cal.robot.fk_orientation(q))
    # The model moves the prediction by tenths of a millimetre and hundredths of a degree.
    assert 0.05 < np.mean(np.linalg.norm(points - geo_p, axis=1)) < 1.0
    assert cal.predict_sd(q).shape == (len(q), 3)
    # Compensation with the model: the hybrid at the joints found is on the registered
    # nominal's points (to the fixed point's and the IK's tolerances); without, it is not.
    targets = q[1::150]
    qc = kincal.compensate(cal, targets)
    reached = cal.predict(qc)[0]
    nominal = cal.registered_nominal.fk(targets)
    assert np.max(np.linalg.norm(reached - nominal, axis=1)) < 1e-5
    qg = kincal.compensate(cal, targets, geometry_only=True)
    assert np.max(np.linalg.norm(cal.predict(qg)[0] - nominal, axis=1)) > 0.05
