"""kincal.identify, compensate, design, campaign and simulate against the kincal CLI on the
same data: identical numbers, errors as exceptions, determinism."""

import json
import re
import subprocess

import numpy as np
import pytest

import kincal
from conftest import REPO, ROBOTS, UR10_DATA, cli_command, read_csv, run_cli

SCENARIO = REPO / "scenarios" / "paper-kr1000.json"


def ur10_data():
    rows = read_csv(UR10_DATA)
    q = np.array([[float(r[f"q{i + 1}"]) for i in range(6)] for r in rows])
    p = np.array([[float(r[c]) for c in "xyz"] for r in rows])
    return q, p


@pytest.fixture(scope="module")
def readme_example(tmp_path_factory):
    """The README's UR10 example through the CLI and through the API."""
    out = tmp_path_factory.mktemp("cli") / "ur10-cal"
    stdout = run_cli(
        "identify", "--robot", ROBOTS / "ur10.json", "--data", UR10_DATA,
        "--every", 15, "--out", out,
    )
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    q, p = ur10_data()
    cal = kincal.identify(robot, q, p, every=15)
    return stdout, out, cal


def test_identify_gives_the_readmes_figures_and_the_clis(readme_example):
    stdout, out, cal = readme_example
    v = cal.validation
    assert v["n_poses"] == 1395
    # The README's figures, as the CLI prints them (3 decimals).
    assert (f"{v['after_mean_mm']:.3f}", f"{v['after_max_mm']:.3f}") == ("0.452", "1.766")
    assert (f"{v['before_mean_mm']:.3f}", f"{v['before_max_mm']:.3f}") == ("2.933", "5.011")
    line = next(l for l in stdout.splitlines() if l.startswith("validation:"))
    assert line.endswith(
        f"nominal (registered) mean {v['before_mean_mm']:.3f} mm, max {v['before_max_mm']:.3f} mm"
        f" → calibrated mean {v['after_mean_mm']:.3f} mm, max {v['after_max_mm']:.3f} mm"
    )
    # parameters.json holds shortest round-trip numbers: the API's are the same bits.
    table = json.loads((out / "parameters.json").read_text())
    assert table["rank"] == cal.rank == 27
    assert table["rms_mm"] == cal.rms_mm and table["sigma_hat_mm"] == cal.sigma_hat_mm
    assert table["rows"] == 100 and len(cal.identification_rows) == 100
    assert list(cal.identification_rows[:3]) == [0, 15, 30]
    keys = ["name", "unit", "free", "nominal", "start", "identified", "std_error", "identifiable"]
    assert [{k: r[k] for k in keys} for r in table["parameters"]] == cal.parameters
    # The calibrated robot is identified.json's, to the bit.
    cli_robot = kincal.Robot.load(out / "identified.json")
    assert cli_robot.parameters == cal.robot.parameters
    assert np.array_equal(cli_robot.fk(ur10_data()[0]), cal.predict(ur10_data()[0]))
    registered = kincal.Robot.load(out / "registered-nominal.json")
    assert registered.parameters == cal.registered_nominal.parameters


def test_calibration_arrays(readme_example):
    _, _, cal = readme_example
    q, p = ur10_data()
    rows = cal.identification_rows
    r = cal.residuals_mm
    assert r.shape == (100, 3) and r.dtype == np.float64
    # Residuals are measured − calibrated on the identification rows (fit.robot vs the
    # robot read back from identified.json: equal to rounding).
    assert np.allclose(r, p[rows] - cal.predict(q[rows]), atol=1e-9)
    assert np.sqrt((r**2).sum(axis=1).mean()) == pytest.approx(cal.rms_mm, rel=1e-12)
    cov = cal.covariance
    names = cal.covariance_parameters
    # The identifiable free parameters (the held redundant ones have no covariance).
    assert cov.shape == (len(names), len(names)) and 0 < len(names) <= cal.rank
    assert np.allclose(cov, cov.T)
    se = {x["name"]: x["std_error"] for x in cal.parameters}
    assert np.allclose(np.sqrt(np.diag(cov)), [se[n] for n in names], rtol=1e-12)
    # The CLI's outlier, line 857 of the file: data row 855 = identification row 57.
    assert cal.outliers == [57] and rows[57] == 855 and cal.registered
    assert "rank 27 of 35" in cal.summary()


def test_save_writes_the_clis_files(readme_example, tmp_path):
    _, out, cal = readme_example
    cal.save(tmp_path / "api")
    names = lambda d: sorted(x.relative_to(d).as_posix() for x in d.rglob("*") if x.is_file())
    assert names(tmp_path / "api") == names(out)
    assert (tmp_path / "api" / "identified.json").read_text() != ""
    a = json.loads((tmp_path / "api" / "parameters.json").read_text())
    b = json.loads((out / "parameters.json").read_text())
    assert a["parameters"] == b["parameters"]
    # As the CLI's --out: a second save replaces the set as a whole and keeps the user's own
    # files; no lock or staging is left; a path that is not a directory is refused.
    (tmp_path / "api" / "notes.txt").write_text("mine")
    (tmp_path / "api" / "identified.json").write_text("stale")
    cal.save(tmp_path / "api")
    assert (tmp_path / "api" / "notes.txt").read_text() == "mine"
    assert (tmp_path / "api" / "identified.json").read_text() != "stale"
    assert names(tmp_path / "api") == sorted(names(out) + ["notes.txt"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["api"]
    (tmp_path / "file").write_text("x")
    with pytest.raises(kincal.KincalError, match="is a regular file, but an output directory"):
        cal.save(tmp_path / "file")
    assert (tmp_path / "file").read_text() == "x"


def test_identify_with_a_validation_set_equals_every(readme_example):
    _, _, cal = readme_example
    q, p = ur10_data()
    keep = np.arange(len(q)) % 15 == 0
    other = kincal.identify(
        kincal.Robot.load(ROBOTS / "ur10.json"), q[keep], p[keep], validate=(q[~keep], p[~keep])
    )
    assert other.validation == cal.validation
    assert other.parameters == cal.parameters


def test_identify_options(readme_example):
    q, p = ur10_data()
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    rej = kincal.identify(robot, q, p, every=15, reject_outliers=True)
    assert rej.rms_mm < readme_example[2].rms_mm
    cal = kincal.identify(robot, q[::15], p[::15], params="minimal", schedule="nielsen")
    assert sum(r["free"] for r in cal.parameters) == cal.rank
    cal = kincal.identify(robot, q[::15], p[::15], params=["theta2", "theta3", "base_dx",
        "base_dy", "base_dz", "base_rx", "base_ry", "base_rz"])
    assert sum(r["free"] for r in cal.parameters) == 8


def test_identify_prior_as_the_clis(readme_example, tmp_path):
    """prior= is --prior: "auto" (the default) leaves the well-excited README example to the
    data alone, "tolerance" gives the CLI's MAP fit, and a malformed value is refused."""
    q, p = ur10_data()
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    auto = readme_example[2]
    none = kincal.identify(robot, q, p, every=15, prior="none")
    assert [r["identified"] for r in none.parameters] == [
        r["identified"] for r in auto.parameters
    ]
    tol = kincal.identify(robot, q, p, every=15, prior="tolerance")
    out = tmp_path / "tol"
    run_cli(
        "identify", "--robot", ROBOTS / "ur10.json", "--data", UR10_DATA,
        "--every", 15, "--prior", "tolerance", "--out", out,
    )
    assert kincal.Robot.load(out / "identified.json").parameters == tol.robot.parameters
    assert tol.robot.parameters != auto.robot.parameters
    with pytest.raises(kincal.KincalError, match="prior"):
        kincal.identify(robot, q, p, every=15, prior="gaussian")


def test_compensate_equals_the_cli(readme_example, tmp_path):
    _, out, cal = readme_example
    q = ur10_data()[0][1:200:20]
    targets = tmp_path / "targets.csv"
    targets.write_text(
        "q1,q2,q3,q4,q5,q6\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in q)
    )
    run_cli(
        "compensate", "--robot", out / "identified.json", "--nominal",
        out / "registered-nominal.json", "--targets", targets, "--out", tmp_path / "c.csv",
    )
    rows = read_csv(tmp_path / "c.csv")
    q_cli = np.array([[float(r[f"q{i + 1}"]) for i in range(6)] for r in rows])
    q_api = kincal.compensate(cal, q)
    assert q_api.shape == (10, 6)
    assert np.array_equal(q_api, q_cli)
    assert np.array_equal(kincal.compensate(cal, q[3]), q_cli[3])
    # The compensated joints bring the calibrated robot onto the nominal's points.
    assert np.abs(cal.predict(q_api) - cal.registered_nominal.fk(q)).max() < 1e-6
    # No rows: said so (it said that no target is reachable).
    with pytest.raises(kincal.KincalError, match="q_deg: the targets file has no rows"):
        kincal.compensate(cal, np.zeros((0, 6)))


def test_design_equals_the_cli(tmp_path):
    q = ur10_data()[0][:300]
    cand = tmp_path / "cand.csv"
    cand.write_text(
        "q1,q2,q3,q4,q5,q6\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in q)
    )
    for criterion in ["d", "i"]:
        run_cli(
            "design", "--robot", ROBOTS / "ur10.json", "--candidates", cand, "--poses", 20,
            "--criterion", criterion, "--out", tmp_path / "plan.csv",
        )
        plan = read_csv(tmp_path / "plan.csv")
        q_plan = np.array([[float(r[f"q{i + 1}"]) for i in range(6)] for r in plan])
        idx = kincal.design(kincal.Robot.load(ROBOTS / "ur10.json"), q, 20, criterion=criterion)
        assert idx.dtype == np.int64 and len(idx) == 20
        assert np.array_equal(np.sort(q[idx], axis=0), np.sort(q_plan, axis=0))


def test_design_measure_equals_the_cli(tmp_path):
    """`measure=` is `--measure`: a 6-DoF frame per pose (the tool frame's unknowns join the
    robot's) chooses other poses than a point, the CLI's; targets without targets in the
    robot file are refused as the CLI refuses them."""
    q = ur10_data()[0][:300]
    cand = tmp_path / "cand.csv"
    cand.write_text(
        "q1,q2,q3,q4,q5,q6\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in q)
    )
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    point = kincal.design(robot, q, 10)
    frame = kincal.design(robot, q, 10, measure="frame")
    assert not np.array_equal(np.sort(point), np.sort(frame))
    run_cli(
        "design", "--robot", ROBOTS / "ur10.json", "--candidates", cand, "--poses", 10,
        "--measure", "frame", "--out", tmp_path / "plan.csv",
    )
    plan = read_csv(tmp_path / "plan.csv")
    q_plan = np.array([[float(r[f"q{i + 1}"]) for i in range(6)] for r in plan])
    assert np.array_equal(np.sort(q[frame], axis=0), np.sort(q_plan, axis=0))
    assert np.array_equal(kincal.design(robot, q, 10, measure="point"), point)
    refused = subprocess.run(
        cli_command() + ["design", "--robot", str(ROBOTS / "ur10.json"), "--candidates",
                         str(cand), "--poses", "8", "--measure", "targets",
                         "--out", str(tmp_path / "no.csv")],
        cwd=REPO, capture_output=True, text=True)
    assert refused.returncode != 0
    with pytest.raises(kincal.KincalError) as e:
        kincal.design(robot, q, 8, measure="targets")
    assert message(e).startswith("measure targets: ")
    assert message(e).split(": ", 1)[1].split(":")[0] in refused.stderr
    with pytest.raises(kincal.KincalError) as e:
        kincal.design(robot, q, 8, measure="frames")
    assert 'measure: unknown measurement "frames" (point, frame, targets)' == message(e)


def test_a_refusal_names_its_check_and_allow_retries_with_it():
    """`except kincal.Refused as e`: `e.check` is the check's name, the value of `allow=`
    that passes over it; retrying with each refusal's check reaches the next check, and
    other errors are plain KincalErrors."""
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    q, p = ur10_data()
    for args, kw, check in [
        ((np.radians(q), p), {}, "joint-units"),
        ((q, p / 1000), {}, "length-units"),
        ((q, p[:, [1, 0, 2]]), {}, "mirror"),
        ((q, p[:, [1, 0, 2]]), {"allow": "mirror"}, "parameters"),
        ((q, p), {"outlier_k": 1.0}, "outliers"),
    ]:
        with pytest.raises(kincal.Refused) as e:
            kincal.identify(robot, *args, every=15, **kw)
        assert isinstance(e.value, kincal.KincalError) and isinstance(e.value, ValueError)
        assert e.value.check == check, (kw, message(e))
        assert f'allow="{check}"' in message(e)
    # The retry the attribute is for: each refusal's check allowed in turn.
    allowed = []
    while True:
        try:
            retried = kincal.identify(robot, q, p / 1000, every=15, allow=allowed)
            break
        except kincal.Refused as e:
            assert e.check not in allowed
            allowed.append(e.check)
    # Metres taken as millimetres: then a robot of metre-size links cannot fit them, so its
    # parameters go far from the nominal; both allowed, the fit is returned.
    assert allowed == ["length-units", "parameters"]
    assert np.isfinite(retried.rms_mm)
    assert retried.parameters == kincal.identify(
        robot, q, p / 1000, every=15, allow=["parameters", "length-units"]).parameters
    for kw in [{"schedule": "fast"}, {"every": 0}, {"allow": "nope"}]:
        with pytest.raises(kincal.KincalError) as e:
            kincal.identify(robot, q, p, **kw)
        assert not isinstance(e.value, kincal.Refused), kw
        assert not hasattr(e.value, "check"), kw


@pytest.fixture(scope="module")
def cli_campaign(tmp_path_factory):
    out = tmp_path_factory.mktemp("campaign") / "c"
    run_cli("campaign", SCENARIO, "--trials", 4, "--no-iso", "--no-budget", "--threads", 2,
            "--quiet", "--out", out)
    return json.loads((out / "summary.json").read_text())


def test_campaign_summary_equals_the_clis(cli_campaign, monkeypatch):
    seen = []
    summary = kincal.campaign(SCENARIO, trials=4, iso=False, budget=False, threads=1,
                              progress=lambda done, total: seen.append((done, total)))
    assert summary == cli_campaign  # Table 4 and every other figure, on another thread count
    assert seen and seen[-1] == (4, 4)
    # The same scenario as a dict (a relative robot path is taken from the current directory).
    monkeypatch.chdir(SCENARIO.parent)
    as_dict = json.loads(SCENARIO.read_text())
    assert kincal.campaign(as_dict, trials=4, iso=False, budget=False) == cli_campaign


def test_campaign_seed_determinism(cli_campaign):
    a = kincal.campaign(SCENARIO, trials=3, iso=False, budget=False, seed=11, threads=2)
    b = kincal.campaign(SCENARIO, trials=3, iso=False, budget=False, seed=11, threads=1)
    c = kincal.campaign(SCENARIO, trials=3, iso=False, budget=False, seed=12, threads=2)
    assert a == b and a != c


def test_simulate_equals_the_cli(tmp_path):
    run_cli("simulate", SCENARIO, "--out", tmp_path, "--trial", 2)
    sim = kincal.simulate(SCENARIO, trial=2)
    for part in ["identification", "validation"]:
        rows = read_csv(tmp_path / f"{part}.csv")
        q = np.array([[float(r[f"q{i + 1}"]) for i in range(6)] for r in rows])
        p = np.array([[float(r[c]) for c in "xyz"] for r in rows])
        assert np.array_equal(sim[f"{part}_q_deg"], q)
        assert np.array_equal(sim[f"{part}_points_mm"], p)
    again = kincal.simulate(SCENARIO, trial=2)
    assert all(np.array_equal(sim[k], again[k]) for k in sim)
    other = kincal.simulate(SCENARIO, trial=2, seed=99)
    assert not np.array_equal(other["identification_points_mm"], sim["identification_points_mm"])


def message(excinfo):
    return str(excinfo.value)


def test_errors_are_kincal_errors_with_the_librarys_message():
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    q, p = ur10_data()
    q, p = q[:60].copy(), p[:60]
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q[:, :5], p)
    assert "q_deg: expected shape (n, 6)" in message(e)
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q, p[:59])
    assert "points_mm: expected shape (60, 3)" in message(e)
    bad = q.copy()
    bad[2, 1] = 400.0
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, bad, p)
    assert re.search(r'identification arrays:3: column "q2": joint value 400 deg is outside', message(e))
    bad = p.copy()
    bad[4, 2] = np.nan
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q, bad)
    assert 'identification arrays:5: column "z"' in message(e) and "not a finite" in message(e)
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q[:5], p[:5])
    assert "35 free parameters" in message(e) and "at least 12 rows" in message(e)
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q, p, params="paper,nonsense")
    assert "nonsense" in message(e)
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q, p, schedule="fast")
    assert 'schedule: unknown value "fast"' in message(e)
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q, p, every=0)
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q, p, outlier_k=-1.0)
    with pytest.raises(kincal.KincalError) as e:
        kincal.design(robot, q, 3, criterion="z")
    assert "unknown criterion" in message(e)
    with pytest.raises(kincal.KincalError) as e:
        kincal.campaign({"name": "x", "robot": "nope.json", "bogus": 1})
    assert "scenario dict" in message(e) and "bogus" in message(e)
    with pytest.raises(kincal.KincalError) as e:
        kincal.campaign(SCENARIO, trials=0)
    with pytest.raises(kincal.KincalError) as e:
        kincal.campaign(REPO / "no-such.json")
    assert "no-such.json" in message(e)
    with pytest.raises(ValueError):  # KincalError is a ValueError
        kincal.simulate(REPO / "no-such.json")


def test_units_and_plausibility_checks_as_the_cli(readme_example, tmp_path):
    """Radians, metres and a mirrored frame are refused as the CLI refuses them, naming the
    override; declared units give the CLI's numbers to the bit."""
    _, out, cal = readme_example
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    q, p = ur10_data()
    # The radians file the CLI reads holds shortest round-trip numbers: the same bits.
    q_rad = np.radians(q)
    data = tmp_path / "radians.csv"
    data.write_text("q1,q2,q3,q4,q5,q6,x,y,z\n" + "".join(
        ",".join(repr(float(v)) for v in (*qr, *pr)) + "\n" for qr, pr in zip(q_rad, p)))
    cli_out = tmp_path / "rad"
    run_cli("identify", "--robot", ROBOTS / "ur10.json", "--data", data, "--every", 15,
            "--joint-units", "rad", "--out", cli_out)
    table = json.loads((cli_out / "parameters.json").read_text())
    declared = kincal.identify(robot, q_rad, p, every=15, joint_units="rad")
    keys = ["name", "unit", "free", "nominal", "start", "identified", "std_error", "identifiable"]
    assert [{k: r[k] for k in keys} for r in table["parameters"]] == declared.parameters
    assert f"{declared.validation['after_mean_mm']:.3f}" == "0.452"
    # Undeclared radians: the CLI's refusal and the API's give the same evidence.
    refused = subprocess.run(
        cli_command() + ["identify", "--robot", str(ROBOTS / "ur10.json"), "--data", str(data),
                         "--every", "15", "--out", str(tmp_path / "no")],
        cwd=REPO, capture_output=True, text=True)
    assert refused.returncode != 0 and not (tmp_path / "no").exists()
    evidence = re.search(r"every joint value is within ±2π \(largest \|q\| = [0-9.]+\)",
                         refused.stderr).group(0)
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q_rad, p, every=15)
    # The CLI names its options, Python its keywords.
    assert "declare it (--joint-units rad)" in refused.stderr
    assert "(--allow joint-units)" in refused.stderr
    assert evidence in message(e) and 'allow="joint-units"' in message(e)
    assert 'declare it (joint_units="rad")' in message(e) and "--" not in message(e)
    # Degrees declared radians.
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q, p, every=15, joint_units="rad")
    assert "declared radians" in message(e) and "beyond one turn" in message(e)
    # Metres: refused, or declared and equal to millimetres.
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q, p / 1000, every=15)
    assert "look like metres" in message(e) and 'allow="length-units"' in message(e)
    assert 'length_units="m"' in message(e)
    # Centimetres: refused naming them, or declared and equal to millimetres.
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q, p / 10, every=15)
    assert "look like centimetres" in message(e) and 'length_units="cm"' in message(e)
    centimetres = kincal.identify(robot, q, p / 10, every=15, length_units="cm")
    assert centimetres.validation["after_mean_mm"] == pytest.approx(
        cal.validation["after_mean_mm"], rel=1e-9)
    metres = kincal.identify(robot, q, p / 1000, every=15, length_units="m")
    assert metres.validation["after_mean_mm"] == pytest.approx(
        cal.validation["after_mean_mm"], rel=1e-9)
    # A mirrored frame: refused naming `allow="mirror"`; allowed, the fit is refused anyway
    # (no rotation maps a reflection: the parameters go far from the nominal).
    mirrored = p[:, [1, 0, 2]]
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q, mirrored, every=15)
    assert "left-handed" in message(e) and 'allow="mirror"' in message(e)
    with pytest.raises(kincal.KincalError) as e:
        kincal.identify(robot, q, mirrored, every=15, allow=["mirror"])
    assert "far beyond manufacturing errors" in message(e)
    for kw, text in [({"allow": "nope"}, "unknown check `nope`"),
                     ({"allow": 3}, "allow: expected"),
                     ({"joint_units": "grad"}, 'joint_units: unknown value "grad"'),
                     ({"length_units": "ft"}, 'length_units: unknown value "ft"')]:
        with pytest.raises(kincal.KincalError) as e:
            kincal.identify(robot, q, p, every=15, **kw)
        assert text in message(e), kw


def test_identify_releases_the_gil_and_is_deterministic_across_threads():
    import threading

    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    q, p = ur10_data()
    results = [None] * 4

    def work(k):
        results[k] = kincal.identify(robot, q, p, every=15).parameters

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(r == results[0] for r in results)


def test_a_robot_file_of_implausible_numbers_is_refused_naming_the_field(tmp_path):
    """Issue 38: θ1 = 2⁶⁴ parses as a number but is no robot's; the field is named."""
    robot = json.loads((ROBOTS / "ur10.json").read_text())
    robot["joints"][0]["theta_deg"] = 2.0**64
    path = tmp_path / "robot.json"
    path.write_text(json.dumps(robot))
    with pytest.raises(kincal.KincalError) as e:
        kincal.Robot.load(path)
    assert "joints[0].theta_deg = 1.8446744073709552e19°" in message(e)


def _interrupt_after(seconds):
    """Sends SIGINT to this process after `seconds` (from another thread, as Ctrl-C would
    arrive); returns a list that gets the monotonic time of the signal."""
    import os
    import signal
    import threading
    import time

    sent = []

    def fire():
        time.sleep(seconds)
        sent.append(time.monotonic())
        os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=fire, daemon=True).start()
    return sent


def test_ctrl_c_interrupts_a_campaign_within_a_second():
    import time

    # 10,000 trials with the ISO test and the budget: about a minute on 2 threads (300 take
    # 2.5 s on the 2-core CI machine), so the signal at 1 s lands in the trials.
    sent = _interrupt_after(1.0)
    started = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        kincal.campaign(SCENARIO, trials=10000, threads=2)
    raised = time.monotonic()
    assert sent, f"the campaign ended before the signal ({raised - started:.1f} s)"
    latency = raised - sent[0]
    print(f"Ctrl-C latency: {latency * 1e3:.0f} ms")
    assert latency <= 1.0, f"KeyboardInterrupt {latency:.2f} s after the signal"
    # The interpreter is usable and the next campaign runs normally.
    assert kincal.campaign(SCENARIO, trials=2, iso=False, budget=False)["trials"] == 2


def test_a_raising_progress_callback_stops_the_campaign_at_once():
    import time

    class Stop(Exception):
        pass

    calls = []

    def progress(done, total):
        calls.append((done, total))
        raise Stop("from the callback")

    started = time.monotonic()
    with pytest.raises(Stop, match="from the callback"):
        kincal.campaign(SCENARIO, trials=10000, threads=2, progress=progress)
    assert len(calls) == 1
    assert time.monotonic() - started < 5.0


def test_threads_are_capped_like_the_clis_with_a_warning():
    import os

    with pytest.warns(UserWarning, match=r"threads=100000 capped at \d+ \(4 per core"):
        s = kincal.campaign(SCENARIO, trials=2, iso=False, budget=False, threads=100000)
    assert s["trials"] == 2
    cores = len(os.sched_getaffinity(0))
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kincal.campaign(SCENARIO, trials=2, iso=False, budget=False, threads=4 * cores)


def test_criterion_is_checked_as_the_cli_checks_it():
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    q, p = ur10_data()
    # As `--criterion z` (not a criterion) and `--criterion a` without `--select` are.
    for criterion, expect in [("z", "criterion: unknown criterion"), ("a", "only with select")]:
        with pytest.raises(kincal.KincalError, match=expect):
            kincal.identify(robot, q, p, criterion=criterion)


def test_sizes_that_cannot_fit_are_refused_before_allocation():
    # Broadcast arrays: numpy allocates 6 values, the rows are 10^12 (the 10^9 rows
    # aborted the interpreter with "memory allocation of 48000000000 bytes failed").
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    huge = np.broadcast_to(np.zeros(6), (10**12, 6))
    with pytest.raises(MemoryError) as e:
        robot.fk(huge)
    assert re.search(r"q_deg: rows: 1000000000000 would need about .* of memory", message(e))
    with pytest.raises(MemoryError):
        kincal.identify(robot, huge, np.broadcast_to(np.zeros(3), (10**12, 3)))
    # design: more candidates than the CLI's limit (10^6) is a KincalError at once (10^8
    # candidates were OOM-killed at 23.7 GB).
    with pytest.raises(kincal.KincalError) as e:
        kincal.design(robot, np.broadcast_to(np.zeros(6), (10**8, 6)), 20)
    assert "candidates_q_deg: poses: 100000000 is more than the limit of 1000000" in message(e)
    # Within the memory: still computed.
    assert robot.fk(np.broadcast_to(np.zeros(6), (1000, 6))).shape == (1000, 3)


def test_ctrl_c_interrupts_a_design_within_a_second():
    import time

    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    # 300,000 candidates: about 20 s of selection on the 2-core CI machine (10^5 take 7 s).
    q = np.random.default_rng(1).uniform(-170.0, 170.0, (300_000, 6))
    sent = _interrupt_after(2.0)
    started = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        kincal.design(robot, q, 30)
    raised = time.monotonic()
    assert sent, f"the design ended before the signal ({raised - started:.1f} s)"
    latency = raised - sent[0]
    print(f"Ctrl-C latency (design): {latency * 1e3:.0f} ms")
    assert latency <= 1.0, f"KeyboardInterrupt {latency:.2f} s after the signal"


def test_a_scaled_tracker_is_refused_and_fit_scale_identifies_it():
    """Issue 38: points 2 % too large are refused by the scale check (naming
    ``fit_scale=True``); ``fit_scale=True`` identifies the factor and divides the points by
    it, as ``--fit-scale`` does."""
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    q, p = ur10_data()
    with pytest.raises(kincal.Refused) as e:
        kincal.identify(robot, q, p * 1.02, every=15)
    assert e.value.check == "scale"
    assert "fit_scale=True" in message(e) and "scaled by 1.02" in message(e)
    cal = kincal.identify(robot, q, p * 1.02, every=15, fit_scale=True)
    assert abs(cal.measurement_scale / 1.02 - 1) < 0.002
    assert abs(cal.validation["after_mean_mm"] - 0.452) < 0.01
    assert kincal.identify(robot, q, p, every=15).measurement_scale is None


def test_ctrl_c_interrupts_an_identification_on_large_data_within_a_second():
    """Issue 39: one identification cannot stop between chunks; Ctrl-C raises at once and
    it finishes in the background, its result dropped. 600,000 rows (the UR10 recording
    tiled) take about 2 s in the library; the signal comes at 0.2 s."""
    import time

    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    q, p = ur10_data()
    reps = 600_000 // len(q) + 1
    q, p = np.tile(q, (reps, 1)), np.tile(p, (reps, 1))
    sent = _interrupt_after(0.2)
    started = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        kincal.identify(robot, q, p)
    raised = time.monotonic()
    assert sent, f"the identification ended before the signal ({raised - started:.1f} s)"
    latency = raised - sent[0]
    print(f"Ctrl-C latency (identify): {latency * 1e3:.0f} ms")
    assert latency <= 1.0, f"KeyboardInterrupt {latency:.2f} s after the signal"


@pytest.fixture(scope="module")
def gp_calibration():
    """The UR10 recording's ``every=5`` split with ``residual_model="gp"`` (the GP's
    cross-validation costs seconds: fitted once for the module), and without it."""
    robot = kincal.Robot.load(ROBOTS / "ur10.json")
    q, p = ur10_data()
    cal = kincal.identify(robot, q, p, every=5, residual_model="gp")
    plain = kincal.identify(robot, q, p, every=5)
    return robot, q, p, cal, plain


def test_the_residual_model_is_kept_by_the_gate_and_predicts_held_out_poses_better(
    gp_calibration,
):
    """Issue 41: ``residual_model="gp"`` runs ``--residual-model gp``'s cross-validation and
    gate; on the UR10's 299 identification rows (``every=5``) the gate keeps the model, and
    ``predict`` with it is closer to the 1,196 held-out measurements than the geometry
    (``docs/residual-model.md``: 0.426 → 0.334 mm), with ``predict_sd`` covering them near
    the Gaussian 68 % / 95 %. Without the option nothing changes."""
    robot, q, p, cal, plain = gp_calibration
    summary = cal.residual_model
    assert summary["used"] is True and len(summary["folds"]) == 5
    assert summary["mean_gain_mm"][0] > summary["mean_gain_mm"][1]
    assert summary["p95_gain_mm"][0] > summary["p95_gain_mm"][1]
    held = np.setdiff1d(np.arange(len(q)), cal.identification_rows)
    geometry = np.linalg.norm(cal.predict(q[held], geometry_only=True) - p[held], axis=1)
    hybrid = np.linalg.norm(cal.predict(q[held]) - p[held], axis=1)
    assert abs(geometry.mean() - 0.426) < 0.002, geometry.mean()
    assert abs(hybrid.mean() - 0.334) < 0.002, hybrid.mean()
    assert np.array_equal(cal.predict(q[held], geometry_only=True), cal.robot.fk(q[held]))
    sd = cal.predict_sd(q[held])
    assert sd.shape == (len(held), 3) and (sd > 0).all()
    z = np.abs(cal.predict(q[held]) - p[held]) / sd
    assert 0.6 < (z <= 1).mean() < 0.8 and 0.9 < (z <= 2).mean() < 0.98
    assert cal.predict_sd(q[0]).shape == (3,)
    assert plain.residual_model is None and plain.predict_sd(q[0]) is None
    assert np.array_equal(plain.predict(q[held]), cal.predict(q[held], geometry_only=True))
    with pytest.raises(ValueError, match="residual_model"):
        kincal.identify(robot, q, p, every=5, residual_model="nn")


# `calibrate::residual::FIXED_POINT_TOL_MM`: the fixed point of a compensation with the model
# stops when r(q) changes by less than this, a tenth of the IK's position tolerance; so
# `FK_geom(q) + r(q)` is on the target to the IK's tolerance (10x) plus that last change.
FIXED_POINT_TOL_MM = 1e-7
COMPENSATED_TOL_MM = 10 * FIXED_POINT_TOL_MM + FIXED_POINT_TOL_MM


def test_compensate_applies_the_kept_residual_model_as_the_cli(gp_calibration, tmp_path):
    """Issue 41: ``compensate`` of a Calibration whose residual model was kept solves
    ``FK_geom(q) + r(q) = target`` as ``kincal compensate`` does: ``predict(q)`` (with the
    model's mean) is on the registered nominal's points to the fixed point's tolerance,
    where the geometric joints miss by the model's correction; ``geometry_only=True`` gives
    the geometric joints (those of a calibration without the model), as ``--geometry-only``;
    both equal the CLI's on the saved calibration, to the bit."""
    _, q, _, cal, plain = gp_calibration
    assert cal.residual_model["used"] is True
    commanded = q[1:200:20]
    target = cal.registered_nominal.fk(commanded)
    q_model = kincal.compensate(cal, commanded)
    q_geometry = kincal.compensate(cal, commanded, geometry_only=True)
    miss_model = np.linalg.norm(cal.predict(q_model) - target, axis=1).max()
    miss_geometry = np.linalg.norm(cal.predict(q_geometry, geometry_only=True) - target, axis=1)
    miss_geometry_with_model = np.linalg.norm(cal.predict(q_geometry) - target, axis=1)
    moved = np.abs(q_model - q_geometry).max()
    print(
        f"compensate with the model: max |predict(q) - target| {miss_model:.2e} mm "
        f"(geometric joints: {miss_geometry.max():.2e} mm geometry-only, "
        f"{miss_geometry_with_model.max():.3f} mm with the model); joints moved by the "
        f"model up to {moved:.4f} deg"
    )
    assert miss_model < COMPENSATED_TOL_MM
    assert miss_geometry.max() < COMPENSATED_TOL_MM
    # The model's correction is tenths of a millimetre: the geometric joints miss by it.
    assert miss_geometry_with_model.max() > 1e4 * COMPENSATED_TOL_MM
    assert moved > 1e-3
    assert np.array_equal(kincal.compensate(cal, commanded[3]), q_model[3])
    # geometry_only=True is the compensation of the same geometry without a model.
    assert np.array_equal(kincal.compensate(plain, commanded), q_geometry)
    assert np.array_equal(kincal.compensate(plain, commanded, geometry_only=True), q_geometry)
    # The CLI on the saved calibration (identified.json names the model).
    cal.save(tmp_path / "cal")
    targets = tmp_path / "targets.csv"
    targets.write_text(
        "q1,q2,q3,q4,q5,q6\n"
        + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in commanded)
    )
    for flags, expected in (([], q_model), (["--geometry-only"], q_geometry)):
        out = tmp_path / f"c{len(flags)}.csv"
        run_cli(
            "compensate", "--robot", tmp_path / "cal" / "identified.json", "--nominal",
            tmp_path / "cal" / "registered-nominal.json", "--targets", targets, "--out", out,
            *flags,
        )
        rows = read_csv(out)
        q_cli = np.array([[float(r[f"q{i + 1}"]) for i in range(6)] for r in rows])
        assert np.array_equal(q_cli, expected), flags


def test_compensate_cartesian_applies_the_kept_residual_model_as_the_cli(
    gp_calibration, tmp_path
):
    """Cartesian targets (positions in the measurement frame) with the kept model: the
    calibrated solve puts ``predict(q)`` on each position to the fixed point's tolerance;
    ``geometry_only=True`` gives the geometric joints; both equal ``kincal compensate``'s on
    a targets file without joint columns."""
    _, q, _, cal, plain = gp_calibration
    positions = cal.registered_nominal.fk(q[100:106])
    start = list(q[100])
    q_model, p_model, _ = kincal.compensate_cartesian(
        cal, positions, frame="measurement", start_q_deg=start
    )
    q_geometry, p_geometry, o_geometry = kincal.compensate_cartesian(
        cal, positions, frame="measurement", start_q_deg=start, geometry_only=True
    )
    miss_model = np.linalg.norm(cal.predict(q_model) - positions, axis=1).max()
    miss_geometry = np.linalg.norm(cal.predict(q_geometry, geometry_only=True) - positions, axis=1)
    moved = np.abs(q_model - q_geometry).max()
    print(
        f"compensate_cartesian with the model: max |predict(q) - target| {miss_model:.2e} mm "
        f"(geometry-only {miss_geometry.max():.2e} mm); joints moved by the model up to "
        f"{moved:.4f} deg, corrected targets by {np.abs(p_model - p_geometry).max():.4f} mm"
    )
    assert miss_model < COMPENSATED_TOL_MM
    assert miss_geometry.max() < COMPENSATED_TOL_MM
    assert moved > 1e-3
    # geometry_only=True is the compensation of the same geometry without a model.
    q_plain, p_plain, o_plain = kincal.compensate_cartesian(
        plain, positions, frame="measurement", start_q_deg=start
    )
    assert np.array_equal(q_plain, q_geometry) and np.array_equal(p_plain, p_geometry)
    assert np.array_equal(o_plain, o_geometry)
    targets = tmp_path / "targets.csv"
    targets.write_text(
        "x,y,z\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in positions)
    )
    cal.save(tmp_path / "cal")
    for flags, expected in (([], q_model), (["--geometry-only"], q_geometry)):
        out = tmp_path / f"c{len(flags)}.csv"
        run_cli(
            "compensate", "--robot", tmp_path / "cal" / "identified.json", "--nominal",
            tmp_path / "cal" / "registered-nominal.json", "--targets", targets, "--out", out,
            "--frame", "measurement", "--start-joints=" + ",".join(repr(float(v)) for v in start),
            *flags,
        )
        rows = read_csv(out)
        q_cli = np.array([[float(r[f"q{i + 1}"]) for i in range(6)] for r in rows])
        assert np.array_equal(q_cli, expected), flags
