"""Type stub of kincal, the Python package of the kincal calibration library.

Units everywhere: angles in degrees, lengths in millimetres; arrays are numpy float64.

This stub is the contract of the package's API (issue 32). Two parts:

* Bound now: ``__version__``, ``KincalError``, ``Robot``.
* Planned, declared here so that scripts and editors can be written against the names, but
  **not yet available**: ``identify``, ``Calibration``, ``compensate``, ``design``,
  ``campaign``, ``simulate``. They do not exist at run time (``AttributeError``) until
  they are bound; their docstrings say so. Signatures may still change before then.
"""

from collections.abc import Callable, Mapping, Sequence
from os import PathLike
from typing import Any, Literal, TypedDict, Union, final

import numpy as np
from numpy.typing import ArrayLike, NDArray

_Path = Union[str, PathLike[str]]

__all__ = ["KincalError", "Robot", "__version__"]

__version__: str
"""The package version, the kincal workspace's version (e.g. ``"0.1.0"``)."""

class KincalError(ValueError):
    """An error of kincal: a malformed or unreadable file, an invalid value or an array of the
    wrong shape. Its message is the library's and names the file, line and field, e.g.
    ``robot.json: field `joints[2].d_mm`: invalid type: string "abc", expected f64``."""

class ParameterRecord(TypedDict):
    """One entry of :attr:`Robot.parameters`."""

    name: str
    """Stable parameter name of docs/model.md §3: ``theta1``, ``d1``, ``beta2``, ``base_rz``,
    ``tool_x``, … (the same names as every kincal output)."""
    value: float
    """The value in display units (degrees or millimetres; see ``unit``)."""
    unit: str
    """``"deg"``, ``"mm"`` or the unit of an extended parameter (e.g. compliance)."""

@final
class Robot:
    """A robot model: the nominal or calibrated kinematics of a serial robot (a kincal robot
    file, docs/model.md §4). Immutable; angles in degrees, lengths in millimetres."""

    @staticmethod
    def load(path: _Path) -> Robot:
        """Reads a robot file (JSON, docs/model.md §4).

        Raises KincalError naming the file and the field when it cannot be read or is invalid.
        """

    @staticmethod
    def from_urdf(
        path: _Path,
        base: str,
        tip: str,
        *,
        tool_mm: tuple[float, float, float] = (0.0, 0.0, 0.0),
        name: str | None = None,
    ) -> Robot:
        """Converts the serial chain from link ``base`` to link ``tip`` of a plain URDF (xacro
        expanded first) into a robot, exactly, as ``kincal urdf import`` does (docs/urdf.md):
        ``base``'s frame becomes the measurement frame and the measured point is ``tool_mm`` in
        ``tip``'s frame; ``name`` defaults to the URDF's robot name.

        Raises KincalError naming the file and the element on an unreadable URDF, a missing
        link or a chain that is not serial and revolute.
        """

    def save(self, path: _Path) -> None:
        """Writes the robot file (JSON), atomically, as the kincal commands write theirs.

        Raises KincalError naming the file if it cannot be written.
        """

    def to_urdf(self, path: _Path, *, joint_names: Sequence[str] | None = None) -> None:
        """Writes the robot as a URDF, as ``kincal urdf export`` does: root link
        ``measurement`` (the measurement frame), one revolute joint per robot joint (named
        ``joint_names``, default the robot file's names or ``joint_1`` …), a fixed link
        ``tool`` at the measured point. ``Robot.from_urdf(path, "measurement", "tool")``
        reads it back.
        """

    @property
    def name(self) -> str:
        """The robot's name (from the robot file)."""

    @property
    def n_joints(self) -> int:
        """Number of joints N."""

    @property
    def n_params(self) -> int:
        """Number of entries in the parameter vector (``len(robot.parameters)``)."""

    @property
    def parameters(self) -> list[ParameterRecord]:
        """The parameter vector in the order of docs/model.md §3, as a list of records
        ``{"name", "value", "unit"}`` with values in display units (degrees, millimetres);
        ``pandas.DataFrame(robot.parameters)`` makes a table. A new list at each access."""

    def fk(self, q_deg: ArrayLike) -> NDArray[np.float64]:
        """Forward kinematics: the measured point (mm, in the measurement frame) for joint
        angles in degrees, shape ``(n, N)`` → ``(n, 3)``, or one pose ``(N,)`` → ``(3,)``.

        Any array-like of numbers is accepted (converted to float64). The same numbers as
        ``kincal predict``, to the bit. Raises KincalError on another shape or a non-finite
        angle. The GIL is released during the computation.
        """

    def __repr__(self) -> str: ...

# ---------------------------------------------------------------------------------------------
# Planned API (issue 32): declared as the contract, NOT YET AVAILABLE at run time.
# ---------------------------------------------------------------------------------------------

class CalibrationParameter(TypedDict):
    """One entry of :attr:`Calibration.parameters` (planned)."""

    name: str
    unit: str
    nominal: float
    identified: float
    std_error: float | None

class ValidationSummary(TypedDict):
    """:attr:`Calibration.validation` (planned): 3-D errors on the validation poses, mm."""

    n_poses: int
    before_mean_mm: float
    before_max_mm: float
    after_mean_mm: float
    after_max_mm: float

class Calibration:
    """Not yet available (planned, issue 32): the result of :func:`identify`."""

    @property
    def robot(self) -> Robot:
        """Not yet available. The calibrated robot (``identified.json``)."""

    def predict(self, q_deg: ArrayLike) -> NDArray[np.float64]:
        """Not yet available. Points ``(n, 3)`` of the calibrated robot in the measurement
        frame."""

    @property
    def residuals_mm(self) -> NDArray[np.float64]:
        """Not yet available. Residuals ``(n, 3)`` on the identification poses."""

    @property
    def parameters(self) -> list[CalibrationParameter]:
        """Not yet available. Every parameter: name, unit, nominal, identified, std_error."""

    @property
    def rank(self) -> int:
        """Not yet available. Rank of the identification Jacobian."""

    @property
    def covariance(self) -> NDArray[np.float64]:
        """Not yet available. Covariance of the identified parameters (display units)."""

    @property
    def validation(self) -> ValidationSummary | None:
        """Not yet available. Before/after mean and max on ``validate=`` poses, if given."""

    def save(self, directory: _Path) -> None:
        """Not yet available. Writes the files of ``kincal identify --out``."""

def identify(
    robot: Robot,
    q_deg: ArrayLike,
    points_mm: ArrayLike,
    *,
    params: str | Sequence[str] = "paper",
    validate: tuple[ArrayLike, ArrayLike] | None = None,
    reject_outliers: bool = False,
    **options: Any,
) -> Calibration:
    """Not yet available (planned, issue 32). Identifies the robot's parameters from measured
    points ``(n, 3)`` at joints ``(n, N)``, as ``kincal identify`` does."""

def compensate(calibration: Calibration, q_deg: ArrayLike) -> NDArray[np.float64]:
    """Not yet available (planned, issue 32). The joints ``(n, N)`` that make the calibrated
    robot reach the nominal robot's points at ``q_deg``, as ``kincal compensate`` does."""

def design(
    robot: Robot,
    candidates_q_deg: ArrayLike,
    n: int,
    *,
    criterion: Literal["d", "a", "e", "i", "o1", "o3", "o5"] = "d",
    workspace_q_deg: ArrayLike | None = None,
) -> NDArray[np.int64]:
    """Not yet available (planned, issue 32). Indices of the ``n`` candidate poses a design
    criterion chooses, as ``kincal design`` does."""

def campaign(
    scenario: _Path | Mapping[str, Any],
    *,
    trials: int | None = None,
    threads: int | None = None,
    seed: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """Not yet available (planned, issue 32). Runs a Monte Carlo campaign of a scenario (a
    file or a dict) and returns its summary, as ``kincal campaign`` writes it."""

def simulate(
    scenario: _Path | Mapping[str, Any],
    *,
    seed: int | None = None,
    trial: int = 0,
) -> dict[str, NDArray[np.float64]]:
    """Not yet available (planned, issue 32; signature provisional). A simulated measurement
    set of a scenario's virtual robot, as arrays (joints, points), as ``kincal simulate``
    writes it."""
