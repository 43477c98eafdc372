"""Errors the CLI turns into one clear line and a documented exit status.

Exit statuses (README, docs/cli.md):
  0 success; 1 a check ran and failed (mismatches, targets missed);
  2 bad input (file, column, value, option); 3 calibration refused
  (out of range, singular); 4 probe or port problem.
"""


class InclinoError(Exception):
    exit_code = 1


class DataError(InclinoError):
    """Bad input data: unreadable file, missing column, non-number, NaN."""

    exit_code = 2


class MirroredAxesError(DataError):
    """A triad's axes mirrored in the data: the fit needs a reflection, or
    turned the field through 180 deg against the header's dip (calib.fit
    refuses both; `inclino diagnose` names the cause from the class)."""


class CalibrationError(InclinoError):
    """A calibration that cannot be used: singular, out of range, corrupt."""

    exit_code = 3


class UndeterminedError(DataError, CalibrationError):
    """The readings determine no calibration: their orientations leave the
    ellipsoid free, or they lie on no ellipsoid.  A singular fit (exit 3,
    as every other fit the orientations do not determine); a DataError too,
    so the checks that try an ellipsoid on the data as a first look go on
    without one."""

    exit_code = 3
