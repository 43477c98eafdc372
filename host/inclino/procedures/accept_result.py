"""The result of an acceptance run (`inclino accept -o`): a dataclass
with to_json/load, and the error arrays the plots draw.

Its own module so that the acceptance procedure (accept.py) and the plots
(plots.py) both import it and neither imports the other.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from inclino.errors import DataError
from inclino.formats.jsonout import dumps


@dataclass
class AcceptResult:
    grid: str
    probe_serial: int
    before: str  # what the before column is
    after: str
    declination_deg: float
    points: list = field(default_factory=list)
    stats: dict = field(default_factory=dict)
    surveys_checked: int = 0
    survey_mismatches: list = field(default_factory=list)
    limits: dict = field(default_factory=dict)
    passed: bool = False
    reasons: list = field(default_factory=list)
    download: dict | None = None
    before_cal: dict = field(default_factory=dict)  # float coefficients (dequantised), for the plots
    after_cal: dict = field(default_factory=dict)
    circles: list = field(default_factory=list)  # raw dataset rows of the horizontal circles
    world: dict = field(default_factory=dict)
    elapsed_s: float = 0.0

    def to_json(self) -> str:
        return dumps(asdict(self))

    @staticmethod
    def load(path: str) -> "AcceptResult":
        from inclino.formats import safeio

        d = safeio.load_json(path, "accept result")  # bounded: size, nesting, numbers
        if not isinstance(d, dict):
            raise DataError(f"{path} is not an accept result (inclino accept -o)")
        try:
            return AcceptResult(**d)
        except (ValueError, TypeError) as e:
            raise DataError(f"{path} is not an accept result (inclino accept -o): {str(e)[:80]}") from None

    # arrays over the points
    def errors(self, which: str):
        """(set_inc, set_azi, inc error, azi error (nan where undefined))."""
        si = np.array([p["set_inc"] for p in self.points], float)
        sa = np.array([p["set_azi"] for p in self.points], float)
        ei = np.array([p[which]["inc_err"] for p in self.points], float)
        ea = np.array([np.nan if p[which]["azi_err"] is None else p[which]["azi_err"] for p in self.points], float)
        return si, sa, ei, ea
