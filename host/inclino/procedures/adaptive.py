"""`inclino acquire --procedure adaptive`: a calibration run that chooses
its poses for what this probe still needs and stops when the predicted
acceptance reaches the target (docs/calibration.md, "Adaptive runs").

After each reading the Fisher information of joint's parameters (and, with
a chamber, of the temperature terms) at the current estimate gives the
predicted accuracy on the acceptance grid (calib.design, the covariance the
fit will report); the next pose is the candidate the turntable can reach
that lowers it most per second of bench time (its move, timed by the
table's motion model, plus the reading).  The fit (calib.fit, joint) runs
as the readings come in and its report's prediction is what the run stops
on:

* target reached: the predicted acceptance azimuth and inclination RMS
  (the report's `prediction_acceptance_grid`: coefficients, reading noise,
  input resolution, linear-model bias) at or below the targets, after at
  least `min_poses` poses (diagnose needs 16 readings); with a chamber also
  the predicted ratio at the range's ends to t_ref at or below
  `target_ratio`;
* more poses stop helping: the best next pose lowered the predicted RMS by
  less than `plateau` (relative) for `patience` poses running;
* the pose limit `max_poses`.

The first two wait for the run to stay diagnosable: every static effect
`inclino diagnose` tests (scale nonlinearity, turntable offsets and axis
errors) with a signature at least `diagnose_share` times what the
multi-position procedure gives (procedures.diagnosable, whose part of the
criterion the design adds to its own).

Targets by default ("auto"): the calibration's share of the acceptance
(its coefficient term) at most AUTO_COEF_SHARE of the acceptance's own
floor (reading noise, resolution and the linear model's bias at the run's
averaging): target = floor sqrt(1 + AUTO_COEF_SHARE^2), 12 % over what no
calibration can remove.

With `--temperatures LO,HI` the chamber ramps continuously (procedures/ramp:
the air to LO - margin, reversed when the lag model says the probe will
still reach LO, then to HI + margin until the probe reads HI, then held):
no soak.  The poses are chosen the same way, with the temperature terms in
the information and "stay" as a candidate (hold the pose while the chamber
moves, read again when the probe's temperature has changed by STAY_DELTA_C);
the run stops once the probe has been through the range and the targets
hold.  Every row records the probe's own temperature (TEMP_OUT): the fit
never sees the chamber's or the emulator's.

Who turns the table: the emulator's turntable (--bench, unattended) or a
person (each pose announced with the predicted accuracy so far and a
progress bar toward the target).
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from inclino.errors import DataError
from inclino.procedures.acquire import COLUMNS, AcquireResult, _RowWriter, recording, run_header
from inclino.procedures.poses import Step, wrap_deg
from inclino.procedures.readings import Tolerance, mean_row, read_stable

AUTO_COEF_SHARE = 0.5
MIN_FIT_ROWS = 10  # rows before the first joint fit (joint needs 8; 31 parameters)
STAY_DELTA_C = 1.0  # with a chamber: hold a pose until the probe's temperature has moved this much
FULL_EVERY = 8  # poses between calib.fit's refits at room temperature
FULL_EVERY_RAMP = 30  # through a chamber: calib.fit of the rows near t_ref (the floor), every ... poses
LINEARISE_EVERY_RAMP = 10
CONFIRM_AGAIN = 3  # poses before a stop the fit did not confirm is tried again
CONFIRM_AGAIN_RAMP = 10
NEAR_REF_C = 5.0  # degC: the rows a chamber run's floor and linearisation are fitted on
READ_S = {16: 0.09, 64: 0.34}  # seconds per reading at the probe's averaging (docs/firmware-app.md: ~5 ms a sample)


@dataclass
class AdaptivePlan:
    target_azi_deg: float | None = None  # None: auto (module docstring)
    target_inc_deg: float | None = None
    target_ratio: float = 1.1  # chamber: predicted RMS at the range's ends over that at t_ref
    min_poses: int = 16
    max_poses: int = 150
    plateau: float = 0.002
    patience: int = 8
    average: int | None = None  # samples per reading: 16 at room temperature, 64 through a chamber
    accept_average: int = 16  # the acceptance the prediction is for (`inclino accept` at the probe's default)
    diagnose_share: float = 0.5  # procedures.diagnosable: each static effect's signature >= this x multi-position's (0: off)
    table_rate_deg_s: float = 10.0  # the turntable's motion model (world.TurntableMotion): the moves' cost
    table_settle_s: float = 3.0
    inc_step_deg: float = 15.0
    azi_step_deg: float = 30.0
    tf_step_deg: float = 30.0
    ramp: object = None  # procedures.ramp.RampPlan: through a chamber

    def check(self) -> None:
        for name, v in (("--target-azi-deg", self.target_azi_deg), ("--target-inc-deg", self.target_inc_deg)):
            if v is not None and not (math.isfinite(v) and v > 0):
                raise DataError(f"{name} must be > 0 deg, got {v:g}")
        if not (math.isfinite(self.target_ratio) and self.target_ratio >= 1.0):
            raise DataError(f"--target-ratio must be >= 1, got {self.target_ratio:g}")
        if int(self.min_poses) != self.min_poses or not 8 <= self.min_poses <= 1000:
            raise DataError("--min-poses must be an integer within 8-1000")
        if int(self.max_poses) != self.max_poses or not self.min_poses <= self.max_poses <= 5000:
            raise DataError("--max-poses must be an integer within --min-poses and 5000")
        if not (math.isfinite(self.diagnose_share) and 0.0 <= self.diagnose_share <= 2.0):
            raise DataError(f"--diagnose-share must be within 0-2, got {self.diagnose_share:g}")
        if not (0.0 < self.plateau < 1.0) or int(self.patience) != self.patience or self.patience < 1:
            raise DataError("the plateau rule wants 0 < plateau < 1 and patience >= 1")
        if self.average is not None and (int(self.average) != self.average or not 1 <= self.average <= 64):
            raise DataError("--average must be within 1-64 samples")
        if int(self.accept_average) != self.accept_average or not 1 <= self.accept_average <= 64:
            raise DataError("--accept-average must be within 1-64 samples")
        for name, v, lo in (("--table-rate", self.table_rate_deg_s, 0.0), ("--table-settle", self.table_settle_s, -1e-9)):
            if not (math.isfinite(v) and v > lo):
                raise DataError(f"{name} must be {'> 0' if lo == 0 else '>= 0'}, got {v:g}")
        for name, v in (("inclination", self.inc_step_deg), ("azimuth", self.azi_step_deg),
                        ("toolface", self.tf_step_deg)):
            if not 1.0 <= v <= 90.0:
                raise DataError(f"the candidates' {name} step must be within 1-90 deg")
        if self.ramp is not None:
            self.ramp.check()

    def samples(self) -> int:
        return int(self.average) if self.average is not None else (64 if self.ramp is not None else 16)


@dataclass
class AdaptiveResult(AcquireResult):
    stop_reason: str = ""
    targets: dict = field(default_factory=dict)
    prediction: dict = field(default_factory=dict)  # the fit's report at the stop (prediction_acceptance_grid ...)
    bench_s: float = 0.0  # the bench's time: the emulator's active clock (or wall time with a person)
    planning_s: float = 0.0  # the host's computing between readings (wall time)
    trace: list = field(default_factory=list)  # per pose: bench time, pose, temperature, predicted RMS
    ramp: dict = field(default_factory=dict)  # with a chamber: phases, turns, the fitted lag
    diagnosable: dict = field(default_factory=dict)  # each static effect's signature over multi-position's, at the stop

    def to_dict(self) -> dict:
        return asdict(self)


class _Clock:
    """The bench's time: the emulator's active clock (`status`: emulated time
    less the time it idled waiting for the host) and its clock (the chamber's
    time base); with a person, wall time for both."""

    def __init__(self, table):
        self.table = table
        self.emulated = bool(getattr(table, "unattended", False)) and hasattr(table, "call")
        self.t0_wall = time.monotonic()

    def read(self) -> tuple[float, float]:
        """(bench seconds, time base seconds)."""
        if self.emulated:
            st = self.table.call("status")
            return float(st.get("active_s", st["t"])), float(st["t"])
        t = time.monotonic() - self.t0_wall
        return t, t


class _Run:
    """One adaptive run: the rows so far, the estimate, the design."""

    def __init__(self, plan: AdaptivePlan, meta: dict):
        from inclino.calib import design
        from inclino.model.world import TurntableMotion

        self.plan = plan
        self.meta = meta
        self.design_mod = design
        self.motion = TurntableMotion(plan.table_rate_deg_s, plan.table_settle_s)
        self.cand = design.candidate_poses(plan.inc_step_deg, plan.azi_step_deg, plan.tf_step_deg)
        self.rows: list[dict] = []
        self.thermal = plan.ramp is not None
        self.order = 2 if self.thermal else 0
        self.read_s = 3 * READ_S.get(plan.samples(), plan.samples() * 0.0052 + 0.01)
        self.est = None
        self.floor = None  # (azimuth, inclination) deg: the acceptance terms no calibration removes
        self.report = None
        self.prediction = None  # acceptance_prediction of the last calib.fit
        self.cal = None
        self.design = None
        self.history: list[float] = []  # the predicted azimuth RMS after each pose
        self.best_drop: list[float] = []
        self.planning_s = 0.0
        self.fits = 0
        self.diag = None
        if plan.diagnose_share > 0:
            from inclino.procedures.diagnosable import Floor

            self.diag = Floor(self.cand, plan.diagnose_share)
        self.cur_index = None  # the candidate the table stands at
        self.last_full = 0
        self.next_confirm = 0

    # ---------------------------------------------------------------- the world
    def world(self, first_row: dict | None = None) -> dict:
        m = self.meta
        F, dip = m.get("field_nT"), m.get("dip_deg")
        if (F is None or dip is None) and first_row is not None:  # from the first reading, for the design only
            a = np.array([first_row[c] for c in ("ax_g", "ay_g", "az_g")])
            b = np.array([first_row[c] for c in ("mx_nT", "my_nT", "mz_nT")])
            F = F if F is not None else float(np.linalg.norm(b))
            dip = dip if dip is not None else float(np.degrees(np.arcsin(np.clip(a @ b / (np.linalg.norm(a)
                                                                                   * np.linalg.norm(b)), -1, 1))))
        return {"field_nT": float(F if F is not None else 50000.0), "dip_deg": float(dip if dip is not None else 60.0),
                "declination_deg": float(m.get("declination_deg", 0.0)), "gravity_g": float(m.get("gravity_g", 1.0))}

    def dataset(self, rows=None):
        from inclino.formats.dataset import META_KEYS, RawDataset

        rows = self.rows if rows is None else rows
        cols = {c: np.array([r[c] for r in rows], float) for c in COLUMNS if c in rows[0]}
        return RawDataset(cols, {k: v for k, v in self.meta.items() if k in META_KEYS})

    def poses(self, rows=None):
        rows = self.rows if rows is None else rows
        return tuple(np.array([r[c] for r in rows], float) for c in ("inc_deg", "azi_deg", "tf_deg"))

    # ---------------------------------------------------------------- targets
    def targets(self) -> tuple[float, float]:
        """(azimuth, inclination) targets on the predicted acceptance RMS."""
        k = math.sqrt(1.0 + AUTO_COEF_SHARE ** 2)
        fa, fi = self.floor if self.floor is not None else (None, None)
        ta = self.plan.target_azi_deg if self.plan.target_azi_deg is not None else (k * fa if fa else None)
        ti = self.plan.target_inc_deg if self.plan.target_inc_deg is not None else (k * fi if fi else None)
        return ta, ti

    def taus(self) -> tuple[float, float]:
        """The coefficient share each target leaves (the design's weights);
        before the first fit, or a target below the floor, a tenth of it."""
        ta, ti = self.targets()
        fa, fi = self.floor if self.floor is not None else (0.0, 0.0)
        out = []
        for t, f, default in ((ta, fa, 0.015), (ti, fi, 0.0015)):
            if t is None:
                out.append(default)
            else:
                out.append(math.sqrt(t * t - f * f) if t > 1.05 * f else 0.3 * t)
        return out[0], out[1]

    # ---------------------------------------------------------------- estimate and design
    def temps_of_interest(self):
        if not self.thermal:
            return None
        r = self.plan.ramp
        return (r.lo_c, self.est.t_ref_c, r.hi_c)

    def rebuild(self, prior: bool) -> None:
        """The design at the current estimate: every row's information, the
        weights, the candidates' Jacobians (at t_ref; with a chamber they are
        recomputed at each reading's temperature)."""
        d = self.design_mod
        est = self.est
        info = d.prior_information(est.order) if prior else np.zeros((est.n_params, est.n_params))
        if not prior and est.order:  # the temperature terms keep a weak prior until the range determines them
            info[d.N_JOINT:, d.N_JOINT:] = d.prior_information(est.order)[d.N_JOINT:, d.N_JOINT:]
        ta, ti = self.taus()
        temps = self.temps_of_interest()
        if self.thermal:
            self.W_ends = d.attitude_weights(est, temps, per_temperature=True)
            Wa = sum(w[0] for w in self.W_ends) / len(temps)
            Wi = sum(w[1] for w in self.W_ends) / len(temps)
        else:
            Wa, Wi = d.attitude_weights(est)
        self.W = (Wa, Wi)
        self.design = d.Design(info, [(Wa, ta), (Wi, ti)])
        if self.rows:
            T = np.array([r["temp_c"] for r in self.rows]) if self.thermal else None
            self.design.add(d.row_jacobians(est, self.poses(), T))
        self.Jc = d.RowJacobians(est, self.cand)

    def start(self) -> None:
        w = self.world(self.rows[0] if self.rows else None)
        self.est = self.design_mod.Estimate.nominal(w["field_nT"], w["dip_deg"], w["declination_deg"],
                                                    w["gravity_g"], order=self.order)
        self.rebuild(prior=True)

    def linearise(self) -> bool:
        """A joint fit (the nonlinear model) of the rows near t_ref: the new
        linearisation point and s^2.  False while joint cannot fit yet."""
        from inclino.calib import joint
        from inclino.errors import CalibrationError

        rows = self.near_ref_rows() if self.thermal else self.rows
        if len(rows) < MIN_FIT_ROWS:
            return False
        ds = self.dataset(rows)
        try:
            with np.errstate(all="ignore"):
                cal, info = joint.fit(ds, nonlinear=True, noise="nominal")  # the estimate only: fast
        except (CalibrationError, DataError, np.linalg.LinAlgError, ValueError):
            return False
        self.fits += 1
        w = self.world()
        order, t_ref, theta = self.est.order, self.est.t_ref_c, self.est.theta
        self.est = self.design_mod.Estimate.from_fit(cal, info, w, joint.SIGMA_ACC, joint.SIGMA_MAG,
                                                     joint.SIGMA_POSE_DEG)
        self.est.order, self.est.t_ref_c = order, t_ref
        self.est.theta = theta if len(theta) == 12 * order else np.zeros(12 * order)
        return True

    def near_ref_rows(self) -> list:
        t0 = self.est.t_ref_c if self.est is not None else 25.0
        return [r for r in self.rows if abs(r["temp_c"] - t0) <= NEAR_REF_C]

    def full_fit(self, near_ref: bool = False) -> bool:
        """calib.fit as `inclino calibrate` runs it (joint; with the
        temperature terms through a chamber): its report's prediction is what
        the run stops on; the floor and the estimate follow it.  near_ref:
        joint alone on the rows within NEAR_REF_C of t_ref (a chamber run's
        floor and estimate while it ramps)."""
        from inclino.calib import fit, joint
        from inclino.errors import CalibrationError

        rows = self.near_ref_rows() if near_ref else self.rows
        if len(rows) < MIN_FIT_ROWS:
            return False
        ds = self.dataset(rows)
        try:
            cal, rep = fit(ds, "joint", temperature="on" if (self.thermal and not near_ref) else "off")
        except (CalibrationError, DataError, np.linalg.LinAlgError, ValueError):
            return False
        self.fits += 1
        pa = acceptance_prediction(cal, rep, self.plan.samples(), self.plan.accept_average, self.world())
        if not pa:
            return False
        self.cal, self.report, self.prediction = cal, rep, pa
        ta, ti = pa["terms_azi_rms_deg"], pa["terms_inc_rms_deg"]
        self.floor = (math.sqrt(max(pa["azi_rms_deg"] ** 2 - ta.get("coefficients", 0.0) ** 2, 0.0)),
                      math.sqrt(max(pa["inc_rms_deg"] ** 2 - ti.get("coefficients", 0.0) ** 2, 0.0)))
        w = self.world()
        info = {"dip_deg": float(rep.uncertainty.get("dip_deg", w["dip_deg"])),
                "s2": float(rep.residuals.get("s2", 1.0))}
        if rep.uncertainty.get("nonlinear_model"):
            info["nonlinear"] = rep.uncertainty["nonlinear_model"]
        w = self.world()
        theta, t_ref = (self.est.theta, self.est.t_ref_c) if self.est is not None else (None, 25.0)
        self.est = self.design_mod.Estimate.from_fit(cal, info, w, joint.SIGMA_ACC, joint.SIGMA_MAG,
                                                     joint.SIGMA_POSE_DEG, order=self.order)
        if near_ref:  # keep the temperature terms' linearisation point
            self.est.t_ref_c = t_ref
            if theta is not None and len(theta) == 12 * self.order:
                self.est.theta = theta
        return True

    def refresh(self, span: float) -> None:
        """The fits while the run goes: calib.fit (the report's floor and
        s^2) first and every FULL_EVERY poses (with a chamber once the run
        spans 10 degC, then every FULL_EVERY_RAMP), and between them joint's
        nonlinear fit for the linearisation point.  The design keeps its
        prior until the first calib.fit succeeds."""
        n = len(self.rows)
        if n < MIN_FIT_ROWS:
            return
        if self.thermal:
            # the floor from calib.fit of the rows near t_ref (room temperature), the
            # linearisation from joint's; the temperature fit only at the stop
            if (self.floor is None or n - self.last_full >= FULL_EVERY_RAMP) and self.full_fit(near_ref=True):
                self.last_full = n
                self.rebuild(prior=False)
            elif n % LINEARISE_EVERY_RAMP == 0 and self.linearise():
                self.rebuild(prior=self.floor is None)
            return
        if (self.floor is None or n - self.last_full >= FULL_EVERY) and self.full_fit():
            self.last_full = n
            self.rebuild(prior=False)
        elif self.linearise():
            self.rebuild(prior=self.floor is None)

    # ---------------------------------------------------------------- predictions
    def predicted(self) -> tuple:
        """(azimuth, inclination) predicted acceptance RMS at t_ref from the
        design (the floor from the last fit; None before it)."""
        if self.floor is None:
            return None, None
        if self.thermal:
            Va, Vi = self._variances_at(1)
        else:
            Va, Vi = self.design.variances()
        return math.sqrt(self.floor[0] ** 2 + Va), math.sqrt(self.floor[1] ** 2 + Vi)

    def _variances_at(self, k: int):
        C = self.design.cov
        Wa, Wi = self.W_ends[k]
        return float(np.trace(C @ Wa)), float(np.trace(C @ Wi))

    def predicted_ratios(self) -> dict:
        """With a chamber: predicted RMS at the range's ends over that at
        t_ref (the same reading noise at every temperature)."""
        if not self.thermal or self.floor is None:
            return {}
        fa, fi = self.floor
        v0 = self._variances_at(1)
        out = {}
        for k, t in ((0, self.plan.ramp.lo_c), (2, self.plan.ramp.hi_c)):
            v = self._variances_at(k)
            out[f"{t:g}"] = {"azi": math.sqrt((fa ** 2 + v[0]) / max(fa ** 2 + v0[0], 1e-30)),
                             "inc": math.sqrt((fi ** 2 + v[1]) / max(fi ** 2 + v0[1], 1e-30))}
        return out

    def targets_met(self, pa: tuple, ratios: dict) -> bool:
        ta, ti = self.targets()
        if pa[0] is None or ta is None or ti is None:
            return False
        ok = pa[0] <= ta and pa[1] <= ti
        if self.thermal:
            ok = ok and all(max(r["azi"], r["inc"]) <= self.plan.target_ratio for r in ratios.values())
        return ok

    # ---------------------------------------------------------------- the next pose
    def choose(self, cur, temp_next: float | None, stay_cost_s: float | None):
        """(index into the candidates or -1 for "stay", the relative drop of
        the predicted acceptance RMS, azimuth or inclination whichever is
        larger, that reading is expected to bring; inf before the floor is
        known)."""
        d = self.design_mod
        Jc = self.Jc.at(None if not self.thermal else np.full(len(self.cand[0]), temp_next))
        g = self.design.gains(Jc)
        if self.diag is not None:
            g = g + self.diag.gains()
        cost = self.motion.duration(cur, self.cand) + self.read_s
        same = self.motion.turn_deg(cur, self.cand) < 1e-6
        score = np.where(same, -np.inf, g / cost)
        j = int(np.argmax(score))
        best, J_best = j, Jc[j:j + 1]
        if stay_cost_s is not None:  # hold the pose while the chamber moves
            Js = d.row_jacobians(self.est, tuple(np.array([c]) for c in cur), np.array([temp_next]))
            if float(self.design.gains(Js)[0]) / stay_cost_s > score[j]:
                best, J_best = -1, Js
        return best, self.relative_drop(J_best)

    def relative_drop(self, J) -> float:
        if self.floor is None:
            return math.inf
        before = self.predicted()
        if self.thermal:
            d = self.design_mod.Design(self.design.info, [(self.W_ends[1][0], 1.0), (self.W_ends[1][1], 1.0)])
        else:
            d = self.design_mod.Design(self.design.info, [(self.W[0], 1.0), (self.W[1], 1.0)])
        Va, Vi = d.variances_after(J)
        after = (math.sqrt(self.floor[0] ** 2 + Va), math.sqrt(self.floor[1] ** 2 + Vi))
        return max((b - a) / b for b, a in zip(before, after) if b > 0)

    def add_row(self, row: dict, j: int | None = None) -> None:
        """j: the candidate pose read (None: the table held its pose)."""
        if j is not None:
            self.cur_index = j
        if self.diag is not None and self.cur_index is not None:
            self.diag.add(self.cur_index)
        self.rows.append(row)
        T = np.array([row["temp_c"]]) if self.thermal else None
        self.design.add(self.design_mod.row_jacobians(self.est, self.poses([row]), T))


def acceptance_prediction(cal, rep, n_run: int, n_accept: int, world: dict) -> dict | None:
    """The fit report's acceptance prediction (calib.predict: coefficients,
    reading noise, input resolution, linear-model bias on the Li grid at
    toolfaces 0/120/240; its readings "as the run's") for an acceptance read
    at n_accept samples per reading: the report's noise per reading (readings
    of n_run samples) scaled by sqrt(n_run / n_accept), everything else as
    the report has it.  The report's own `prediction_acceptance_grid` when
    the two averagings agree."""
    u = rep.uncertainty
    pa = u.get("prediction_acceptance_grid")
    if n_run == n_accept or not pa:
        return pa
    from inclino.calib.predict import predict

    if "covariance" not in u:
        return None
    f = math.sqrt(n_run / n_accept)
    sg = pa.get("sigmas") or {}
    kw = {}
    if sg.get("pose_deg") is not None:  # the run's fitted pose error, when the report has one
        kw["sigma_pose_deg"] = sg["pose_deg"]
    dip = float(u.get("dip_deg", world["dip_deg"]))
    p = predict(cal, np.asarray(u["covariance"]), world, dip, np.asarray(sg["acc_g"], float) * f,
                np.asarray(sg["mag_nT"], float) * f, n_avg=1, nonlinear=u.get("nonlinear_model"),
                resolution_n=n_accept, **kw)
    out = p.to_dict()
    out["readings"] = f"at {n_accept} samples per reading: the report's noise per reading x sqrt({n_run}/{n_accept})"
    return out


# ---------------------------------------------------------------- the run
def acquire_adaptive(link, out_path: str, table, plan: AdaptivePlan | None = None, *, tol: Tolerance | None = None,
                     max_reads: int = 30, world: dict | None = None, quiet: bool = False,
                     sleep=time.sleep) -> AdaptiveResult:
    """Take an adaptive run (module docstring) on `table` and write it to
    out_path as a raw dataset."""
    from inclino.progress import bar as progress_bar
    from inclino.procedures import acquire_temp

    plan = plan or AdaptivePlan()
    tol = tol or Tolerance()
    tol.check()
    plan.check()
    t0 = time.monotonic()
    average = plan.samples()
    ident, meta = run_header(link, table, world, average)
    who = f"bench {table.spec}" if table.unattended else "operator"
    ramp = plan.ramp
    meta["source"] = (f"inclino acquire adaptive ("
                      + (f"chamber ramp {ramp.lo_c:g} to {ramp.hi_c:g} degC at {ramp.rate_c_per_min:g} degC/min; "
                         if ramp is not None else "")
                      + f"{who}; probe {ident.product} fw {'.'.join(map(str, ident.fw_version))}, "
                      f"{tol.reads} reads within {tol.acc_mg:g} mg / {tol.mag_nT:g} nT)")
    res = AdaptiveResult(out_path, "adaptive", 0, ident.serial, meta)
    out = _RowWriter(out_path, meta)
    bar = progress_bar(100, "adaptive: toward the target", unit="%", quiet=quiet, leave=False,
                       bar_format="{desc}: {percentage:3.0f}%|{bar}|{postfix}")

    def say(m):
        bar.write(m, file=sys.stderr)

    if not table.unattended and getattr(table, "default_say", False):
        table.say = say  # a person at the turntable: told above the progress bar
    tell = table.say if not table.unattended else None
    clock = _Clock(table)
    run = _Run(plan, meta)
    chamber = acquire_temp._Chamber(table, sleep) if ramp is not None else None
    with recording(out, bar, res, t0), acquire_temp._default_average_after(link, ramp is not None
                                                                          and plan.average is None):
        _loop(link, table, run, res, out, bar, tell, clock, chamber, tol, max_reads)
    res.planning_s = run.planning_s
    return res


def _loop(link, table, run: _Run, res: AdaptiveResult, out, bar, tell, clock, chamber, tol, max_reads) -> None:
    plan = run.plan
    bench0, tb0 = clock.read()
    cur = (0.0, 0.0, 0.0)  # the table's pose before the run: taken as home
    thermal = chamber is not None
    ramp_state = _RampState(plan.ramp, tb0) if thermal else None
    if thermal:
        chamber.set(ramp_state.air_target(), plan.ramp.rate_c_per_min)
        ramp_state.program(tb0, plan.ramp.rate_c_per_min)
    first_pred = None
    run_planning = 0.0
    k = 0
    while True:
        k += 1
        tp0 = time.monotonic()
        if run.design is None:
            run.start()
        temp_next = ramp_state.next_temp() if thermal else None
        stay_cost = ramp_state.stay_cost(run.read_s) if (thermal and run.rows) else None
        j, drop = run.choose(cur, temp_next, stay_cost)
        run.best_drop.append(drop)
        run_planning += time.monotonic() - tp0
        if j < 0:
            st = Step(*cur, f"pose {k}: hold while the chamber moves")
            wait_s = ramp_state.stay_wait(run.read_s)
            if wait_s > 0:
                chamber.wait(wait_s / 60.0)
        else:
            st = Step(float(run.cand[0][j]), float(run.cand[1][j]), float(run.cand[2][j]), f"adaptive pose {k}")
            if tell is not None:
                pa = run.history[-1] if run.history else None
                ta, _ = run.targets()
                tell(f"  next: pose {k}" + (f"; predicted acceptance azimuth RMS {pa:.4f} deg" if pa else "")
                     + (f" (target {ta:.4f})" if ta else ""))
            table.move(st, k, plan.max_poses)
            cur = (st.inc, st.azi, st.tf)
        win = read_stable(link, tol, max_reads if table.unattended else None)
        res.reads += len(win)
        row = {**mean_row(win), "inc_deg": cur[0], "azi_deg": wrap_deg(cur[1]), "tf_deg": wrap_deg(cur[2])}
        out.write(row, win)
        bench, tb = clock.read()
        tp0 = time.monotonic()
        if thermal:
            ramp_state.observe(tb, row["temp_c"])
            turn = ramp_state.step(tb)
            if turn is not None:
                chamber.set(turn, plan.ramp.rate_c_per_min)
                ramp_state.program(tb, plan.ramp.rate_c_per_min)
        run.add_row(row, j if j >= 0 else None)
        run.refresh(ramp_state.span() if thermal else 0.0)
        pa, pi = run.predicted()
        ratios = run.predicted_ratios()
        if pa is not None:
            run.history.append(pa)
            first_pred = first_pred or pa
        ta, ti = run.targets()
        res.trace.append({"pose": k, "bench_s": bench - bench0, "inc_deg": cur[0], "azi_deg": cur[1],
                          "tf_deg": cur[2], "temp_c": row["temp_c"], "stay": j < 0,
                          "predicted_azi_deg": pa, "predicted_inc_deg": pi,
                          "predicted_ratio": ratios or None, "target_azi_deg": ta, "target_inc_deg": ti})
        if pa is not None and ta:
            frac = 1.0 if pa <= ta else max(0.0, math.log(first_pred / pa) / max(math.log(first_pred / ta), 1e-9))
            bar.n = int(100 * min(frac, 1.0))
            bar.set_postfix_str(f"pose {k}, predicted azimuth {pa:.4f} -> {ta:.4f} deg", refresh=False)
            bar.update(0)  # shown at the bar's own pace (on a terminal; every PERIOD off one)
        # the stopping rule
        reason = None
        covered = (ramp_state.covered() if thermal else True) and (run.diag is None or run.diag.met())
        if covered and len(run.rows) >= max(plan.min_poses, run.next_confirm) and run.targets_met((pa, pi), ratios):
            run.next_confirm = len(run.rows) + (CONFIRM_AGAIN_RAMP if thermal else CONFIRM_AGAIN)
            if run.full_fit():  # confirm on the fit `inclino calibrate` runs
                run.rebuild(prior=False)
                pa, pi = run.predicted()
                ratios = run.predicted_ratios()
                pr = run.prediction
                if run.targets_met((pr["azi_rms_deg"], pr["inc_rms_deg"]), ratios):
                    reason = "target reached"
        if reason is None and covered and len(run.rows) >= plan.min_poses and len(run.best_drop) >= plan.patience \
                and max(run.best_drop[-plan.patience:]) < plan.plateau:
            reason = f"more poses stop helping (each of the last {plan.patience} lowered the prediction < " \
                     f"{100 * plan.plateau:g} %)"
        if reason is None and len(run.rows) >= plan.max_poses:
            reason = f"the pose limit ({plan.max_poses})"
        run_planning += time.monotonic() - tp0
        if reason is not None:
            break
    if reason != "target reached":
        run.full_fit()
        if run.design is not None and run.est is not None:
            run.rebuild(prior=False)
    run.planning_s = run_planning
    res.stop_reason = reason
    bench, _ = clock.read()
    res.bench_s = bench - bench0
    ta, ti = run.targets()
    res.targets = {"azi_deg": ta, "inc_deg": ti, "auto": plan.target_azi_deg is None,
                   "coef_share": AUTO_COEF_SHARE if plan.target_azi_deg is None else None,
                   "ratio": plan.target_ratio if thermal else None}
    if run.report is not None:
        u = run.report.uncertainty
        res.prediction = {"acceptance_grid": run.prediction, "accept_average": plan.accept_average,
                          "calibration_grid": {"azi_rms_deg": u.get("predicted_azi_rms_deg"),
                                               "inc_rms_deg": u.get("predicted_inc_rms_deg")},
                          "ratios": run.predicted_ratios() or None, "fit_passed": bool(run.report.passed)}
    if thermal:
        res.ramp = ramp_state.summary()
        if run.cal is not None and getattr(run.cal, "temperature", None):
            from inclino.calib import templag

            res.ramp["sensor_lag"] = templag.estimate(run.dataset(), run.cal)
    if run.diag is not None:
        res.diagnosable = {"share": plan.diagnose_share, "met": run.diag.met(), "ratios": run.diag.ratios()}
    res.notes.append({"poses": len(run.rows), "fits": run.fits, "stop": reason})
    if tell is not None:
        pa = res.prediction.get("acceptance_grid", {}) or {}
        tell(f"  stopped after {len(run.rows)} poses: {reason}; predicted acceptance azimuth RMS "
             f"{pa.get('azi_rms_deg', float('nan')):.4f} deg, inclination {pa.get('inc_rms_deg', float('nan')):.4f}")


class _RampState:
    """The chamber's side of a ramped run (procedures.ramp): phase, the
    programmed air, the probe's temperatures and the fitted lag."""

    def __init__(self, rp, t0: float):
        from inclino.procedures import ramp

        self.rp = rp
        self.ramp = ramp
        self.air = ramp.AirProfile.start(t0, 25.0)
        self.phase = "cool"
        self.times: list[float] = []
        self.temps: list[float] = []
        self.tau = rp.tau_guess_s
        self.tau_rms = float("nan")
        self.turns: list[dict] = []
        self.reached_lo = False
        self.reached_hi = False
        self.air_set = None

    def air_target(self) -> float:
        rp = self.rp
        return {"cool": rp.lo_c - rp.air_margin_c, "heat": rp.hi_c + rp.air_margin_c, "hold": rp.hi_c}[self.phase]

    def program(self, t: float, rate: float) -> None:
        self.air_set = self.air_target()
        self.air.set(t, self.air_set, rate)

    def observe(self, t: float, temp: float) -> None:
        if not self.times:  # the air starts where the probe is (a chamber at room temperature)
            self.air = self.ramp.AirProfile.start(t - 1e-6, temp)
            self.air.set(t - 1e-6, self.air_set, self.rp.rate_c_per_min)
        self.times.append(t)
        self.temps.append(temp)
        if len(self.times) % 5 == 0:
            self.tau, self.tau_rms = self.ramp.fit_tau(self.air, self.times, self.temps, self.rp.tau_guess_s)
        if temp <= self.rp.lo_c:
            self.reached_lo = True
        if self.reached_lo and temp >= self.rp.hi_c:
            self.reached_hi = True

    def probe_now(self, t: float) -> float:
        if len(self.times) < 2:
            return self.temps[-1] if self.temps else 25.0
        return float(self.air.probe([t], self.tau, self.times[-1], self.temps[-1])[0])

    def step(self, t: float):
        """The air's new target when the run turns the chamber, else None."""
        rp = self.rp
        tp = self.probe_now(t)
        tc = self.air.at(t)
        if self.phase == "cool":
            if self.reached_lo or (tp > tc and self.ramp.turning_point(tc, tp, rp.rate_c_per_min, self.tau)
                                   <= rp.lo_c - rp.overshoot_c):
                self.phase = "heat"
                self.turns.append({"t_s": t, "to": "heat", "probe_c": tp, "air_c": tc, "tau_s": self.tau})
                return self.air_target()
        elif self.phase == "heat" and self.reached_hi:
            self.phase = "hold"
            self.turns.append({"t_s": t, "to": "hold", "probe_c": tp, "air_c": tc, "tau_s": self.tau})
            return self.air_target()
        return None

    def covered(self) -> bool:
        return self.reached_lo and self.reached_hi

    def span(self) -> float:
        return (max(self.temps) - min(self.temps)) if self.temps else 0.0

    def rate_now(self) -> float:
        """The probe's temperature rate now (degC/s) from the lag model."""
        if len(self.times) < 2:
            return 0.0
        t = self.times[-1]
        return (self.probe_now(t + 30.0) - self.probe_now(t)) / 30.0

    def next_temp(self) -> float:
        return self.temps[-1] if self.temps else 25.0

    def stay_wait(self, read_s: float) -> float:
        r = abs(self.rate_now())
        return min(STAY_DELTA_C / r, 600.0) if r > 1e-6 else 60.0

    def stay_cost(self, read_s: float) -> float:
        return self.stay_wait(read_s) + read_s

    def summary(self) -> dict:
        return {"plan": asdict(self.rp), "phase": self.phase, "turns": self.turns, "tau_fitted_s": self.tau,
                "tau_fit_rms_c": self.tau_rms, "probe_range_c": [min(self.temps), max(self.temps)]
                if self.temps else None, "air_pieces": self.air.pieces}
