"""kincal: kinematic calibration of serial industrial robots (the Rust library, from Python).

Angles are in degrees and lengths in millimetres, as everywhere in kincal; arrays are numpy
float64. Errors of the library raise :class:`KincalError` (a ``ValueError``) with the
library's message, which names the file, line and field; a refusal by a plausibility check
raises its subclass :class:`Refused`, whose ``check`` is the ``allow=`` value that
overrides it.

:class:`Robot` (load, from_urdf, save, to_urdf, fk, parameters), :func:`identify` →
:class:`Calibration`, :func:`identify_frames` (6-DoF, several targets) →
:class:`FrameCalibration`, :func:`compensate`, :func:`compensate_cartesian`, :func:`design`, :func:`campaign`,
:func:`simulate`. See docs/python.md.
"""

from ._kincal import (
    Calibration,
    FrameCalibration,
    KincalError,
    Refused,
    Robot,
    __version__,
    campaign,
    compensate,
    compensate_cartesian,
    design,
    identify,
    identify_frames,
    simulate,
)

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
