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


class CalibrationError(InclinoError):
    """A calibration that cannot be used: singular, out of range, corrupt."""

    exit_code = 3
