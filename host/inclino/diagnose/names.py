"""The names the diagnosis speaks in: the library's effects, the triads,
axes and channels of a raw dataset.  One place, imported by the package's
__init__ (without loading SciPy), core, forward and robust.
"""
from __future__ import annotations

EFFECT_NAMES = ("temperature-bias", "temperature-scale", "scale-nonlinearity",
                "turntable-inclination-offset", "turntable-azimuth-offset", "field-drift", "sample-skew",
                "turntable-azimuth-axis-tilt", "turntable-inclination-axis-skew", "rig-field")
RIG_AXES = ("azi", "inc", "tf")  # the turntable axes a rig field can move with (effects.RigField)
TRIADS = ("acc", "mag")
AXES = ("x", "y", "z")
CHANNELS = ("acc_x", "acc_y", "acc_z", "mag_x", "mag_y", "mag_z")
TRIAD_UNITS = {"acc": "g", "mag": "nT"}
