"""Attitude engines: the firmware C (cffi), the NumPy golden model, the float reference,
and the checks that they agree."""
