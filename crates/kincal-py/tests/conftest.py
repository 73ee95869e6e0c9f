"""Shared helpers of the Python tests: the repository's paths and the kincal CLI to compare with."""

import csv
import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
ROBOTS = REPO / "scenarios" / "robots"
UR10_DATA = REPO / "data" / "ur10-ipa" / "series-b-joint-configurations.csv"
URDF_FIXTURES = REPO / "crates" / "urdf" / "tests" / "fixtures"


def _binary(env_var, name):
    """The command running a repository binary: $env_var, else target/{release,debug}/name,
    else `cargo run` (which builds it)."""
    if os.environ.get(env_var):
        return [os.environ[env_var]]
    for profile in ("release", "debug"):
        exe = REPO / "target" / profile / name
        if exe.is_file():
            return [str(exe)]
    if shutil.which("cargo") is None:
        pytest.fail(f"no {name} binary: set {env_var} or build it (cargo build -p {name})")
    return ["cargo", "run", "--quiet", "--package", name, "--"]


def cli_command(binary="kincal"):
    """The command that runs the kincal CLI (or `xtask`), as a list."""
    return _binary("KINCAL_BIN" if binary == "kincal" else "KINCAL_XTASK_BIN", binary)


def run_cli(*args, binary="kincal"):
    """Runs the kincal CLI (or `xtask`) from the repository root; returns its stdout."""
    cmd = cli_command(binary)
    out = subprocess.run(
        cmd + [str(a) for a in args], cwd=REPO, capture_output=True, text=True
    )
    assert out.returncode == 0, f"{cmd + list(args)} failed:\n{out.stderr}"
    return out.stdout


def read_csv(path):
    """Rows of a kincal CSV (comment lines start with #) as dicts of strings."""
    with open(path, newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))
