"""kincal: kinematic calibration of serial industrial robots (the Rust library, from Python).

Angles are in degrees and lengths in millimetres, as everywhere in kincal; arrays are numpy
float64. Errors of the library raise :class:`KincalError` (a ``ValueError``) with the
library's message, which names the file, line and field.

Bound now: :class:`Robot` (load, from_urdf, save, to_urdf, fk, parameters). Not yet bound
(declared in the stub ``__init__.pyi`` as the planned API, absent at run time): identify,
Calibration, compensate, design, campaign, simulate. See docs/python.md.
"""

from ._kincal import KincalError, Robot, __version__

__all__ = ["KincalError", "Robot", "__version__"]
