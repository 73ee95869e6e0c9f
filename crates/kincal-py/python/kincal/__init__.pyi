"""Type stub of kincal, the Python package of the kincal calibration library.

Units everywhere: angles in degrees, lengths in millimetres; arrays are numpy float64.

This stub is the contract of the package's API (issue 32): ``Robot``, ``identify`` →
``Calibration``, ``compensate``, ``compensate_cartesian``, ``design``, ``campaign``, ``simulate``, ``KincalError``,
``Refused``.
mypy's stubtest checks it against the compiled module.
"""

from collections.abc import Callable, Mapping, Sequence
from os import PathLike
from typing import Any, Literal, NotRequired, TypedDict, Union, final

import numpy as np
from numpy.typing import ArrayLike, NDArray

_Path = Union[str, PathLike[str]]

__all__ = [
    "Calibration",
    "FrameCalibration",
    "KincalError",
    "Refused",
    "Robot",
    "__version__",
    "campaign",
    "compensate",
    "compensate_cartesian",
    "design",
    "identify",
    "identify_frames",
    "simulate",
]

__version__: str
"""The package version, the kincal workspace's version (e.g. ``"0.1.0"``)."""

class KincalError(ValueError):
    """An error of kincal: a malformed or unreadable file, an invalid value or an array of the
    wrong shape. Its message is the library's and names the file, line and field, e.g.
    ``robot.json: field `joints[2].d_mm`: invalid type: string "abc", expected f64``."""

class Refused(KincalError):
    """A refusal by a plausibility check: the data or the result look wrong (joints that look
    like radians, points that look like metres or inches, a mirrored measurement frame,
    outliers, identified parameters far from the nominal, validation worse than before, a
    URDF whose reach is not a robot arm's). The message says why and names the override;
    ``check`` is the check's name, which is also the value of ``allow=`` that overrides it::

        try:
            cal = kincal.identify(robot, q, p)
        except kincal.Refused as e:
            cal = kincal.identify(robot, q, p, allow=e.check)
    """

    check: Literal[
        "joint-units", "length-units", "mirror", "outliers", "parameters", "validation"
    ]
    """The check that refused: ``joint-units``, ``length-units``, ``mirror``, ``outliers``,
    ``parameters`` or ``validation``."""

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

        Raises KincalError naming the file and the field when it cannot be read or is invalid,
        including numbers that are no robot's: an angle beyond ±360° or a length beyond
        ±100 m (``joints[0].theta_deg = 1.8446744073709552e19°``).
        """

    @staticmethod
    def from_urdf(
        path: _Path,
        base: str,
        tip: str,
        *,
        tool_mm: tuple[float, float, float] = (0.0, 0.0, 0.0),
        name: str | None = None,
        allow: str | Sequence[str] | None = None,
    ) -> Robot:
        """Converts the serial chain from link ``base`` to link ``tip`` of a plain URDF (xacro
        expanded first) into a robot, exactly, as ``kincal urdf import`` does (docs/urdf.md):
        ``base``'s frame becomes the measurement frame and the measured point is ``tool_mm`` in
        ``tip``'s frame; ``name`` defaults to the URDF's robot name. A robot whose reach is
        outside 20 mm … 50 m (a URDF written in millimetres) is refused (:class:`Refused`,
        ``check == "length-units"``) unless ``allow`` names ``"length-units"`` (``--allow
        length-units``).

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
    def joint_types(self) -> list[str]:
        """The type of each joint, base to flange: ``"revolute"`` or ``"prismatic"`` (a
        prismatic joint's values and limits are millimetres where a revolute joint's are
        degrees)."""

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
        angle, and MemoryError, before copying anything, on more rows than this machine's
        available memory holds (a broadcast array costs numpy nothing but its full size
        here; docs/scale.md). The GIL is released during the computation.
        """

    def fk_orientation(self, q_deg: ArrayLike) -> NDArray[np.float64] | None:
        """The measured frame's orientation (in the measurement frame) for joint angles in
        degrees, as unit quaternions ``w, x, y, z`` (scalar first, ``w ≥ 0``), shape
        ``(n, N)`` → ``(n, 4)``, or ``(N,)`` → ``(4,)``: the flange rotation times the tool
        orientation ``tool_rotation_deg`` (docs/model.md §5), the columns ``qw, qx, qy, qz``
        of ``kincal predict``, to the bit. ``None`` for a robot without a tool orientation
        (a point calibration). Arguments and errors as :meth:`fk`."""

    def __repr__(self) -> str: ...

class CalibrationParameter(TypedDict):
    """One entry of :attr:`Calibration.parameters`: a row of ``parameters.json``."""

    name: str
    unit: str
    free: bool
    """Whether the parameter was identified (else held at its start value)."""
    nominal: float
    """Value in the nominal robot."""
    start: float
    """Value the fit started from (the nominal after base registration)."""
    identified: float
    """Value of the calibrated robot."""
    std_error: float | None
    """Standard error, for identifiable parameters (``None`` otherwise)."""
    identifiable: bool
    """In the identifiable (minimal) subset at the solution."""

class ResidualFold(TypedDict):
    """One fold of :attr:`ResidualModelSummary.folds`: held-out 3-D errors, mm."""

    fold: int
    train_poses: int
    held_out_poses: int
    geometry_mean_mm: float
    geometry_p95_mm: float
    geometry_max_mm: float
    hybrid_mean_mm: float
    hybrid_p95_mm: float
    hybrid_max_mm: float

class ResidualModelSummary(TypedDict):
    """:attr:`Calibration.residual_model`: the k-fold cross-validation of the learned
    residual model on the identification rows and the gate's decision (``used``: the mean
    and the p95 gains both exceed their fold-to-fold scatter)."""

    used: bool
    folds: list[ResidualFold]
    mean_gain_mm: tuple[float, float]
    p95_gain_mm: tuple[float, float]
    coverage_1sd: float
    coverage_2sd: float
    orientation: NotRequired[OrientationResidualSummary]
    """6-DoF data (:attr:`FrameCalibration.residual_model`): the orientation part."""

class OrientationResidualFold(TypedDict):
    """One fold of :attr:`OrientationResidualSummary.folds`: held-out angle errors, degrees."""

    fold: int
    train_poses: int
    held_out_poses: int
    geometry_mean_deg: float
    geometry_p95_deg: float
    geometry_max_deg: float
    hybrid_mean_deg: float
    hybrid_p95_deg: float
    hybrid_max_deg: float

class OrientationResidualSummary(TypedDict):
    """The orientation part of a 6-DoF calibration's residual model, cross-validated on the
    same folds as the position part (angles in degrees); ``used``: applied (the position
    part was kept and this part passes the same gate)."""

    used: bool
    folds: list[OrientationResidualFold]
    mean_gain_deg: tuple[float, float]
    p95_gain_deg: tuple[float, float]
    coverage_1sd: float
    coverage_2sd: float

class ValidationSummary(TypedDict):
    """:attr:`Calibration.validation`: 3-D errors on the validation poses, mm; before = the
    nominal after registration, after = the calibrated robot."""

    n_poses: int
    before_mean_mm: float
    before_max_mm: float
    before_rms_mm: float
    before_p95_mm: float
    after_mean_mm: float
    after_max_mm: float
    after_rms_mm: float
    after_p95_mm: float

@final
class Calibration:
    """The result of :func:`identify`: the calibration ``kincal identify`` computes on the
    same rows. Immutable."""

    @property
    def robot(self) -> Robot:
        """The calibrated robot as ``identified.json`` holds it (the same numbers as
        ``Robot.load("OUT/identified.json")``)."""

    @property
    def registered_nominal(self) -> Robot:
        """The nominal robot in the data's frame (``registered-nominal.json``): the targets
        of compensation."""

    def predict(
        self, q_deg: ArrayLike, *, geometry_only: bool = False
    ) -> NDArray[np.float64]:
        """Points ``(n, 3)`` (mm, the measurement frame) of the calibrated robot at joints
        ``(n, N)`` in degrees (``(N,)`` → ``(3,)``): ``calibration.robot.fk(q_deg)``, plus
        the learned residual model's mean when ``identify(..., residual_model="gp")`` kept
        one, as ``kincal predict`` adds it; ``geometry_only=True`` leaves the model out."""

    def predict_sd(self, q_deg: ArrayLike) -> NDArray[np.float64] | None:
        """The learned residual model's predictive standard deviation ``(n, 3)`` (mm, per
        axis; ``(N,)`` → ``(3,)``) at joints in degrees, as ``kincal predict --with-sd``
        writes it; ``None`` without a model (not asked for, or declined by the gate)."""

    @property
    def residual_model(self) -> ResidualModelSummary | None:
        """The residual model's cross-validation and the gate's decision
        (``identify(..., residual_model="gp")``, ``docs/residual-model.md``); ``None`` when
        no model was asked for."""

    @property
    def residuals_mm(self) -> NDArray[np.float64]:
        """Residuals measured − calibrated ``(n, 3)`` (mm) on the identification rows
        (:attr:`identification_rows`, outliers included)."""

    @property
    def identification_rows(self) -> NDArray[np.int64]:
        """0-based indices into the ``q_deg`` given to :func:`identify` of the rows that
        identified (all, or those an ``every``/``select`` split chose)."""

    @property
    def parameters(self) -> list[CalibrationParameter]:
        """Every parameter (docs/model.md §3 order): name, unit, free, nominal, start,
        identified, std_error, identifiable, display units — the rows of
        ``parameters.json``; ``pandas.DataFrame(cal.parameters)`` makes the table."""

    @property
    def rank(self) -> int:
        """Numerical rank of the identification Jacobian at the solution."""

    @property
    def covariance(self) -> NDArray[np.float64] | None:
        """Covariance ``(r, r)`` of the identifiable free parameters (display units), rows
        and columns named by :attr:`covariance_parameters`; ``None`` without degrees of
        freedom."""

    @property
    def covariance_parameters(self) -> list[str]:
        """Names of the rows and columns of :attr:`covariance`."""

    @property
    def rms_mm(self) -> float:
        """RMS 3-D point error of the final fit on the rows it used, mm."""

    @property
    def sigma_hat_mm(self) -> float | None:
        """σ̂, the fit's residual scale (mm per axis)."""

    @property
    def outliers(self) -> list[int]:
        """Indices into :attr:`identification_rows` of the rows the outlier screen flagged."""

    @property
    def measurement_scale(self) -> float | None:
        """The measurements' scale factor ``fit_scale=True`` identified (the points were
        divided by it before identifying), or None (not asked, or not significant)."""

    @property
    def excluded(self) -> list[int]:
        """Indices into :attr:`identification_rows` of the rows the robust screen excluded
        from the final fit (the gross errors by default; every flagged row with
        ``reject_outliers=True``; none with ``keep_outliers=True``)."""

    @property
    def registered(self) -> bool:
        """Whether the measurement frame was registered onto the robot base first."""

    @property
    def validation(self) -> ValidationSummary | None:
        """3-D errors on the validation rows (``validate=`` or held out by a split), before
        and after: mean, max, RMS, p95 (mm); ``None`` without validation rows."""

    @property
    def library_ms(self) -> float:
        """Wall time (ms) of the library call inside :func:`identify`, timed in Rust: the
        cost of the identification without the binding's conversions and checks."""

    def summary(self) -> str:
        """The console summary ``kincal identify`` prints."""

    def save(self, directory: _Path) -> None:
        """Writes the files of ``kincal identify --out`` into ``directory`` as the CLI does:
        under the directory's lock, the set replacing the previous one as a whole (your own
        files kept); a path that is not a directory raises KincalError."""

    def __repr__(self) -> str: ...

def identify(
    robot: Robot,
    q_deg: ArrayLike,
    points_mm: ArrayLike,
    *,
    params: str | Sequence[str] | None = None,
    validate: tuple[ArrayLike, ArrayLike] | None = None,
    reject_outliers: bool = False,
    keep_outliers: bool = False,
    every: int | None = None,
    offset: int = 0,
    select: int | None = None,
    criterion: str = "d",
    schedule: str = "levenberg",
    redundant: str = "hold",
    registration: str = "auto",
    outlier_k: float = 3.0,
    worst: int = 10,
    joint_units: Literal["deg", "rad"] = "deg",
    length_units: Literal["mm", "m", "cm", "in"] = "mm",
    allow: str | Sequence[str] | None = None,
    prior: str = "auto",
    fit_scale: bool = False,
    residual_model: Literal["none", "gp"] = "none",
    residual_folds: int = 5,
) -> Calibration:
    """Identifies the robot's parameters from measured points ``(n, 3)`` (mm) at joints
    ``(n, N)`` (degrees), as ``kincal identify`` does on a file with the same rows; the
    options are the CLI's flags: ``params`` (``None`` = ``"paper"``; ``"minimal"``, names,
    ``"paper+compliance"``; or a list of names), ``validate=(q_deg, points_mm)``,
    ``every``/``offset`` or ``select``/``criterion`` (hold-out splits; ``criterion`` is
    checked whether or not ``select`` is given, and one other than ``"d"`` needs it, as
    ``--criterion`` needs ``--select``), ``schedule``
    (levenberg, marquardt, nielsen), ``redundant`` (hold, damp), ``registration`` (auto,
    always, never), ``reject_outliers`` (drop every flagged row; by default the robust
    screen drops the gross errors alone), ``keep_outliers`` (keep every row), ``outlier_k``, ``worst``, ``prior`` (``--prior``:
    ``"auto"``, ``"none"``, ``"tolerance"`` or ``"tolerance,NAME=SD,..."``), ``fit_scale``
    (``--fit-scale``: identify the measurements' scale factor instead of refusing a scaled
    tracker; ``Calibration.measurement_scale`` gives it), ``residual_model`` and
    ``residual_folds`` (``--residual-model gp``, ``--residual-folds``: the learned residual
    model, kept only when cross-validation says it helps; ``Calibration.residual_model``,
    ``predict`` and ``predict_sd`` use it).

    ``joint_units`` and ``length_units`` declare the arrays' units (``--joint-units``,
    ``--length-units``: converted to degrees and millimetres, the joint limits checked in
    the arrays' units).

    The rows get the checks of a file: joint count, joint limits of the robot file, finite
    values (errors name ``identification arrays:ROW``, rows counted from 1). Then the
    plausibility checks of ``kincal identify``: joints that look like radians, points that
    look like metres or inches, a mirrored measurement frame, outliers, identified
    parameters far from the nominal, validation worse than before. Each raises
    :class:`Refused` (a KincalError), saying why and naming its override in ``e.check``:
    ``allow="mirror"`` (or a list of check names: ``joint-units``, ``length-units``,
    ``mirror``, ``outliers``, ``scale``, ``parameters``, ``validation``) is ``--allow``. Other errors
    raise KincalError with the library's message. The GIL is released during the work.
    """

class FrameParameter(TypedDict):
    """One entry of :attr:`FrameCalibration.parameters`: an unknown of the 6-DoF fit (the
    table of ``report.md``)."""

    name: str
    unit: str
    start: float
    identified: float
    std_error: float

class FrameErrors(TypedDict):
    """Position (mm) and orientation (degrees) errors of a model on a set of poses."""

    n_poses: int
    position_mean_mm: float
    position_max_mm: float
    orientation_mean_deg: float
    orientation_max_deg: float

class FrameErrorsBeforeAfter(TypedDict):
    """Errors of the start model (registered nominal, closed-form tool frame) and of the
    identified one."""

    start: FrameErrors
    identified: FrameErrors

class FrameOutlier(TypedDict):
    """A pose the outlier screen flagged."""

    row: int
    """0-based index of the pose's first row in the arrays given."""
    ratio: float
    position_mm: float
    orientation_deg: float | None
    excluded: bool
    """Whether the pose was dropped from the final fit (a gross error by default)."""

@final
class FrameCalibration:
    """The result of :func:`identify_frames`: the 6-DoF / multi-target calibration
    ``kincal identify`` computes on a file with the same rows. Immutable."""

    @property
    def measurement_scale(self) -> float | None:
        """The measurements' scale factor ``fit_scale=True`` identified, or None."""

    @property
    def robot(self) -> Robot:
        """The calibrated robot with its tool frame (``identified.json``)."""

    @property
    def registered_nominal(self) -> Robot:
        """The nominal robot in the data's measurement frame (``registered-nominal.json``):
        the nominal controller's model of compensation."""

    def predict(
        self, q_deg: ArrayLike, *, geometry_only: bool = False
    ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """The calibrated robot's prediction at joints ``(n, N)`` in degrees (or ``(N,)``):
        ``(points_mm, orientations_wxyz)``, the points ``(n, 3)`` (mm, the measurement frame)
        and the measured frame's orientation ``(n, 4)`` (unit quaternions, scalar first,
        ``w ≥ 0``; ``None`` when no orientation was measured) — ``kincal predict``'s
        ``x, y, z`` and ``qw, qx, qy, qz``: ``(robot.fk(q_deg), robot.fk_orientation(q_deg))``.
        With a residual model that ``identify_frames(..., residual_model="gp")`` kept, the
        points add its mean and the orientations turn by its orientation part's mean (where
        that part is applied), as ``kincal predict``; ``geometry_only=True`` leaves it out."""

    def predict_sd(self, q_deg: ArrayLike) -> NDArray[np.float64] | None:
        """The learned residual model's predictive standard deviation of the points
        ``(n, 3)`` (mm, per axis; ``(N,)`` → ``(3,)``), as ``kincal predict --with-sd``
        writes ``sx, sy, sz``; ``None`` without a kept model."""

    @property
    def residual_model(self) -> ResidualModelSummary | None:
        """The residual model's cross-validation and the gate's decision
        (``identify_frames(..., residual_model="gp")``, ``docs/residual-model.md``), with
        ``orientation`` for the orientation part of 6-DoF data; ``None`` when no model was
        asked for."""

    @property
    def parameters(self) -> list[FrameParameter]:
        """The fit's unknowns: name, unit, start, identified, std_error (display units)."""

    @property
    def held(self) -> list[str]:
        """Candidates held at their start values (confounded with the tool frame or with
        kept parameters)."""

    @property
    def fit_errors(self) -> FrameErrorsBeforeAfter:
        """Position and orientation errors on the identification poses."""

    @property
    def validation(self) -> FrameErrorsBeforeAfter | None:
        """Position and orientation errors on the validation poses; ``None`` without them."""

    @property
    def outliers(self) -> list[FrameOutlier]:
        """The poses the outlier screen flagged, largest ratio first."""

    @property
    def sigma_hat(self) -> float:
        """σ̂ of the weighted fit."""

    @property
    def library_ms(self) -> float:
        """Wall time (ms) of the library call inside :func:`identify_frames`."""

    def summary(self) -> str:
        """The console summary ``kincal identify`` prints."""

    def save(self, directory: _Path) -> None:
        """Writes the files of ``kincal identify --out`` into ``directory`` as the CLI does:
        under the directory's lock, the set replacing the previous one as a whole (your own
        files kept); a path that is not a directory raises KincalError."""

    def __repr__(self) -> str: ...

def identify_frames(
    robot: Robot,
    q_deg: ArrayLike,
    points_mm: ArrayLike,
    *,
    orientations_wxyz: ArrayLike | None = None,
    targets: Sequence[str] | None = None,
    pose_ids: Sequence[str] | None = None,
    orientation_weight: float | None = None,
    params: str | Sequence[str] | None = None,
    validate: tuple[Any, ...] | None = None,
    reject_outliers: bool = False,
    keep_outliers: bool = False,
    every: int | None = None,
    offset: int = 0,
    select: int | None = None,
    criterion: str = "d",
    schedule: str = "levenberg",
    redundant: str = "hold",
    registration: str = "auto",
    outlier_k: float = 3.0,
    worst: int = 10,
    joint_units: Literal["deg", "rad"] = "deg",
    length_units: Literal["mm", "m", "cm", "in"] = "mm",
    allow: str | Sequence[str] | None = None,
    prior: str = "auto",
    fit_scale: bool = False,
    residual_model: Literal["none", "gp"] = "none",
    residual_folds: int = 5,
) -> FrameCalibration:
    """Identifies the robot and its tool frame from 6-DoF measurements and/or several
    targets per pose, as ``kincal identify`` does on a file with ``qw,qx,qy,qz`` or
    ``target`` columns (docs/model.md §5, §6.4): ``orientations_wxyz`` ``(n, 4)`` unit
    quaternions of the probe (scalar first, in the measurement frame); ``targets`` ``(n,)``
    target names with ``pose_ids`` ``(n,)`` (the rows with the same id are one pose, with
    equal joints). ``orientation_weight`` is ``--orientation-weight`` (mm per degree, default
    5); ``validate=(q_deg, points_mm[, orientations_wxyz[, targets[, pose_ids]]])``. The
    other options, the checks (:class:`Refused`) and ``allow`` are :func:`identify`'s;
    ``residual_model="gp"`` cross-validates the learned residual model on 6-DoF data
    (position and orientation parts, ``FrameCalibration.residual_model``; several targets per
    pose are refused). Raises KincalError with the library's message. The GIL is released
    during the work."""

def compensate(
    calibration: Calibration | FrameCalibration,
    q_deg: ArrayLike,
    *,
    geometry_only: bool = False,
) -> NDArray[np.float64]:
    """The joints ``(n, N)`` (degrees) that make the calibrated robot reach the points the
    registered nominal robot reaches at ``q_deg``, as ``kincal compensate`` with the
    calibration's ``identified.json`` and ``registered-nominal.json``; ``(N,)`` → ``(N,)``.
    With a residual model that ``identify(..., residual_model="gp")`` (or ``identify_frames``)
    kept, the joints bring the geometry plus the model's mean onto each target (``calibration.predict(q)`` reaches
    it; ``docs/residual-model.md``); ``geometry_only=True`` leaves the model out, as
    ``--geometry-only``. Raises KincalError listing the unreachable rows."""

def compensate_cartesian(
    calibration: Calibration | FrameCalibration,
    positions_mm: ArrayLike,
    orientations_wxyz: ArrayLike | None = None,
    *,
    frame: Literal["base", "measurement"] = "base",
    start_q_deg: Sequence[float] | None = None,
    geometry_only: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Cartesian targets, as ``kincal compensate`` with a targets file without joint columns:
    TCP positions ``(n, 3)`` (mm) and optionally orientations ``(n, 4)`` (unit quaternions,
    scalar first), in the robot's base frame (``frame="base"``, the registered nominal's
    base: the controller's) or the measurement frame. Each target is solved on the nominal
    model from the previous one's solution (the first from ``start_q_deg``, default each
    joint's 0 within its limits), then on the calibrated model from there (with the
    orientation when the calibration has one; else the orientation is left to the nominal
    model). Returns ``(q_deg, positions_mm, orientations_wxyz)``: the joints to command
    ``(n, N)`` and the corrected targets ``(n, 3)``, ``(n, 4)`` — the nominal model's
    forward kinematics at those joints in the base frame, for a controller that runs the
    nominal model. With a residual model that ``identify(..., residual_model="gp")`` kept,
    the calibrated solve brings the geometry plus the model's mean onto each target position
    (and the orientation part of a 6-DoF calibration's model onto its orientation);
    ``geometry_only=True`` leaves it out, as
    ``--geometry-only``. Raises KincalError listing the unreachable rows."""

def design(
    robot: Robot,
    candidates_q_deg: ArrayLike,
    n: int,
    *,
    criterion: str = "d",
    workspace_q_deg: ArrayLike | None = None,
    params: str | Sequence[str] | None = None,
    seed: int = 1,
    restarts: int = 0,
    measure: Literal["point", "frame", "targets"] = "point",
) -> NDArray[np.int64]:
    """Indices into ``candidates_q_deg`` of the ``n`` poses a design criterion chooses
    (``"d"``, ``"a"``, ``"e"``, ``"i"``, ``"o1"``, ``"o3"``, ``"o5"``; ``params`` ``None``
    = ``"minimal"``), each pose measuring ``measure``: ``"point"`` (one reflector),
    ``"frame"`` (a 6-DoF probe: the tool frame's unknowns join the robot's) or
    ``"targets"`` (every target of the robot file's ``targets``), as ``kincal design
    --candidates --measure`` does (docs/design.md). More than 10⁶ candidates raise
    KincalError, fewer that do not fit in memory MemoryError, before anything is copied
    (the limits of ``kincal design``, docs/scale.md). The GIL is released during the work;
    Ctrl-C raises KeyboardInterrupt within a second (the selection stops at its next
    step)."""

def campaign(
    scenario: _Path | Mapping[str, Any],
    *,
    trials: int | None = None,
    threads: int | None = None,
    seed: int | None = None,
    progress: Callable[[int, int], object] | None = None,
    iso: bool = True,
    budget: bool = True,
) -> dict[str, Any]:
    """Runs a Monte Carlo campaign of a scenario (a file, or a dict of its fields whose
    relative ``robot`` path is taken from the current directory) and returns its summary:
    the contents of ``summary.json`` of ``kincal campaign`` with the same options
    (``iso=False`` is ``--no-iso``, ``budget=False`` ``--no-budget``). Nothing is written.
    ``progress(done, total)`` is called on the calling thread about every 0.05 s. The same
    seed gives the same summary on any thread count; ``threads`` above 4 per core is capped
    with a UserWarning, as ``--threads`` is. The GIL is released during the work, and the
    calling thread checks for signals every 0.05 s: Ctrl-C raises KeyboardInterrupt once
    the trials in progress finish (well within a second), and an exception raised by
    ``progress`` stops the run the same way and is raised as it was."""

def simulate(
    scenario: _Path | Mapping[str, Any],
    *,
    seed: int | None = None,
    trial: int = 0,
) -> dict[str, Any]:
    """A simulated measurement set of trial ``trial`` of a scenario's virtual robot, as
    ``kincal simulate`` writes it: ``{"identification_q_deg", "identification_points_mm",
    "validation_q_deg", "validation_points_mm"}`` (float64 arrays). A scenario whose
    ``measurement`` is ``frame`` adds ``"{set}_orientations_wxyz"`` ``(n, 4)``; one with
    ``targets`` has a row per reflector and adds ``"{set}_targets"`` and
    ``"{set}_pose_ids"`` (lists of strings): the arguments of :func:`identify_frames`."""
