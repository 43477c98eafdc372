"""The chamber's air and the probe's temperature during a continuous ramp
(`inclino acquire --procedure adaptive --temperatures LO,HI`,
inclino.procedures.adaptive; docs/calibration.md, "The ramp model").

The air follows the profile the procedure programs: from each command on,
a linear ramp at the commanded rate to the set point, then the set point
(the chamber reports its air temperature; a person's chamber is taken to
follow its programme).  The probe lags the air by a first-order time
constant tau (its heat capacity over its conductance to the air):

    dTp/dt = (Tc(t) - Tp) / tau

solved exactly on each linear piece of the air (t_k, Tc_k, slope r_k):

    Tp(t) = Tc(t) - r_k tau + (Tp_k - Tc_k + r_k tau) exp(-(t - t_k) / tau)

tau is not assumed: it is fitted to the probe's own temperature readings
(TEMP_OUT, the `temp_c` of every reading) against the programmed air by
least squares over log tau (with the probe's starting temperature), once
the probe has moved MIN_SPAN_FOR_TAU_C; until then the plan's guess stands.

When to turn the air: with the air ramping back at rate r from Tc0 while the
probe is at Tp0 (the probe still moving away from it), the probe keeps going
until the air crosses it, and turns at

    Tp_turn = Tc0 + r tau ln(1 + (Tp0 - Tc0) / (r tau))        (r tau > 0, signs per direction)

so the procedure reverses the air as soon as that turning point reaches the
range's end: the probe then spans the range without a soak and without
waiting longer at the cold end than the lag requires.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

MIN_SPAN_FOR_TAU_C = 3.0  # degC the probe must have moved before tau is fitted
TAU_RANGE_S = (30.0, 20000.0)


@dataclass
class AirProfile:
    """The programmed air: pieces (t_s, Tc_s, slope degC/s)."""
    pieces: list = field(default_factory=list)

    @classmethod
    def start(cls, t_s: float, temp_c: float) -> "AirProfile":
        return cls([(float(t_s), float(temp_c), 0.0)])

    def at(self, t: float) -> float:
        tk, ck, rk = self._piece(t)
        return ck + rk * (t - tk)

    def _piece(self, t: float):
        k = len(self.pieces) - 1
        while k > 0 and self.pieces[k][0] > t:
            k -= 1
        return self.pieces[k]

    def set(self, t_s: float, setpoint_c: float, rate_c_per_min: float) -> None:
        """From t_s, ramp to setpoint_c at rate_c_per_min, then hold."""
        t_s = float(t_s)
        tc = self.at(t_s)
        self.pieces = [p for p in self.pieces if p[0] < t_s] or [self.pieces[0]]
        if rate_c_per_min <= 0 or setpoint_c == tc:
            self.pieces.append((t_s, float(setpoint_c), 0.0))
            return
        r = math.copysign(rate_c_per_min / 60.0, setpoint_c - tc)
        self.pieces.append((t_s, tc, r))
        self.pieces.append((t_s + (setpoint_c - tc) / r, float(setpoint_c), 0.0))

    def probe(self, t, tau: float, t0: float, tp0: float):
        """The probe's temperature at times t (array) for lag tau, starting at
        tp0 at t0 (t >= t0)."""
        t = np.atleast_1d(np.asarray(t, float))
        # the air's pieces from t0 on, with the probe's temperature at each start
        starts = [t0] + [p[0] for p in self.pieces if p[0] > t0]
        tp = [tp0]
        for a, b in zip(starts[:-1], starts[1:]):
            tp.append(self._advance(a, tp[-1], b, tau))
        out = np.empty(len(t))
        idx = np.searchsorted(np.asarray(starts), t, side="right") - 1
        for j, ti in enumerate(t):
            k = max(int(idx[j]), 0)
            out[j] = self._advance(starts[k], tp[k], ti, tau)
        return out

    def _advance(self, ta: float, tpa: float, tb: float, tau: float) -> float:
        """Probe temperature at tb from tpa at ta, within one air piece."""
        tk, ck, rk = self._piece(ta)
        ca = ck + rk * (ta - tk)
        dt = tb - ta
        if tau <= 0:
            return ca + rk * dt
        return ca + rk * dt - rk * tau + (tpa - ca + rk * tau) * math.exp(-dt / tau)


def fit_tau(profile: AirProfile, t, temp, tau_guess: float) -> tuple[float, float]:
    """(tau, rms of the fit in degC): the lag that makes the programmed air
    explain the probe's readings `temp` at times `t` (the first reading's
    time and temperature start the probe); the guess when the readings have
    not moved MIN_SPAN_FOR_TAU_C."""
    t = np.asarray(t, float)
    temp = np.asarray(temp, float)
    if len(t) < 5 or np.ptp(temp) < MIN_SPAN_FOR_TAU_C:
        return float(tau_guess), float("nan")

    def cost(lt):
        tau = math.exp(lt)
        # the starting temperature is the best constant offset of the whole
        # run's first reading: a single TEMP_OUT count would bias tau
        m = profile.probe(t, tau, t[0], temp[0])
        return float(np.mean((m - temp) ** 2))

    lo, hi = math.log(TAU_RANGE_S[0]), math.log(TAU_RANGE_S[1])
    grid = np.linspace(lo, hi, 40)
    c = [cost(g) for g in grid]
    k = int(np.argmin(c))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    gr = (math.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = b - gr * (b - a), a + gr * (b - a)
    f1, f2 = cost(x1), cost(x2)
    for _ in range(40):
        if f1 < f2:
            b, x2, f2 = x2, x1, f1
            x1 = b - gr * (b - a)
            f1 = cost(x1)
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + gr * (b - a)
            f2 = cost(x2)
    lt = (a + b) / 2.0
    return math.exp(lt), math.sqrt(cost(lt))


def turning_point(tc0: float, tp0: float, rate_c_per_min: float, tau: float) -> float:
    """The probe's extreme temperature when the air, at tc0 with the probe at
    tp0, starts ramping back towards the probe at rate_c_per_min (the probe
    keeps moving away until the air crosses it)."""
    r = rate_c_per_min / 60.0
    gap = tp0 - tc0  # > 0: the probe above the air (cooling), the air turns up
    if gap == 0.0:
        return tp0
    s = math.copysign(1.0, gap)
    rt = r * tau
    if rt <= 0:
        return tc0
    return tc0 + s * rt * math.log1p(abs(gap) / rt)


@dataclass
class RampPlan:
    """A continuous ramp through LO..HI: the air to LO - margin, turned when
    the probe's turning point reaches LO - overshoot, then to HI + margin until
    the probe reaches HI, then held at HI."""
    lo_c: float = -5.0
    hi_c: float = 55.0
    rate_c_per_min: float = 5.0
    air_margin_c: float = 20.0
    overshoot_c: float = 0.5
    tau_guess_s: float = 900.0

    def check(self) -> None:
        from inclino.errors import DataError

        for name, v in (("the range's ends", self.lo_c), ("the range's ends", self.hi_c)):
            if not (math.isfinite(v) and -40.0 <= v <= 125.0):
                raise DataError(f"{name} must be within -40 to 125 degC (the ADIS16210's range), got {v:g}")
        if not self.hi_c - self.lo_c >= 10.0:
            raise DataError(f"--temperatures LO,HI must span at least 10 degC (the temperature terms need it), "
                            f"got {self.lo_c:g},{self.hi_c:g}")
        if not (math.isfinite(self.rate_c_per_min) and 0.0 < self.rate_c_per_min <= 30.0):
            raise DataError(f"--ramp-rate must be within (0, 30] degC/min, got {self.rate_c_per_min:g}")
        if not (math.isfinite(self.air_margin_c) and 0.0 <= self.air_margin_c <= 60.0):
            raise DataError(f"--air-margin must be within 0-60 degC, got {self.air_margin_c:g}")
        if not (math.isfinite(self.tau_guess_s) and TAU_RANGE_S[0] <= self.tau_guess_s <= TAU_RANGE_S[1]):
            raise DataError(f"--probe-tau must be within {TAU_RANGE_S[0]:g}-{TAU_RANGE_S[1]:g} s")
        if self.lo_c - self.air_margin_c < -70.0 or self.hi_c + self.air_margin_c > 180.0:
            raise DataError("the air's limits (the range's ends -/+ --air-margin) must stay within the chamber's "
                            "-70 to 180 degC")


def simulate(plan: RampPlan, tau_s: float, start_c: float = 25.0, step_s: float = 10.0) -> dict:
    """The ramp's timing by the lag model alone (a probe of lag tau_s,
    starting at start_c with the air): when the run turns the air, when the
    probe reaches HI, how far it overshoots LO.  What the ramp rate and the
    air margin buy, without an emulator."""
    air = AirProfile.start(0.0, start_c)
    air.set(0.0, plan.lo_c - plan.air_margin_c, plan.rate_c_per_min)
    t, turn, lowest = 0.0, None, start_c
    while t < 86400.0:
        t += step_s
        tp = float(air.probe([t], tau_s, 0.0, start_c)[0])
        lowest = min(lowest, tp)
        if turn is None and turning_point(air.at(t), tp, plan.rate_c_per_min, tau_s) <= plan.lo_c - plan.overshoot_c:
            turn = t
            air.set(t, plan.hi_c + plan.air_margin_c, plan.rate_c_per_min)
        elif turn is not None and tp >= plan.hi_c:
            break
    return {"rate_c_per_min": plan.rate_c_per_min, "turn_min": (turn or float("nan")) / 60.0,
            "done_min": t / 60.0, "probe_min_c": lowest}
