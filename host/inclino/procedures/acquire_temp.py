"""`inclino acquire --procedure temperature`: a calibration run through a
thermal chamber, for the temperature terms (docs/calibration.md).

At each chamber set point in turn (--temperatures, default -5,25,55 degC):

1. the ramp and soak: the chamber is set (a ramp at --ramp-rate degC/min)
   and, every --interval-min minutes until the probe has settled, the probe is
   read at a few poses (the first --ramp-poses of RAMP_POSES): a bench visits
   all of them at every interval (its turntable turns inside the chamber), a
   person's probe holds one of them (the k-th set point's, in turn) through
   the whole ramp and soak, as a fixture in a closed chamber does;
2. settled: the probe's own temperature reading is within --soak-band of the
   set point and has changed by at most --soak-tol over the last
   --soak-window-min minutes (a bench also waits for its air to reach the set
   point); a bench gives up after --max-soak-min minutes (exit 4);
3. the pose set (--poses: twelve-position or multi-position, the static
   procedures of `inclino acquire`) is taken at the set point, each position
   with the usual stability check.

Every reading averages ThermalPlan.average = 64 samples (SET_AVERAGE; --average
overrides it) instead of the probe's default 16: the temperature terms rest
on the readings at each set point, and with 16 the chamber run's sensor
noise, not the model, made what the terms leave at -5 and 55 degC (the
noise-free grid error 1.7-1.8x the 25 degC figure, median; and one probe in
about 40 beyond the 1.2x target, docs/calibration.md).  Four times the
samples cost 0.24 s more per reading on a probe (a sample every ~5 ms,
docs/firmware-app.md): about 5 minutes over the run's ~400 rows of three
readings, against the soaks' hours.  The probe is set back to its
default 16 at the end, so that a later `inclino accept` reads as it does
after a restart.

Every row records the probe's temperature (temp_c, the mean of the readings
of that row), so the fit uses the temperature each reading was taken at, not
the set point.  Unattended on the emulator (--bench): the chamber is set with
the control channel's `chamber` command and the waits are `advance`
requests (emulated time runs ahead; an hour of chamber time takes seconds).
Guided for a person: each set point and pose is announced on stderr, Enter
confirms, and the waits are real time.
"""
from __future__ import annotations

import contextlib
import math
import sys
import time
from dataclasses import dataclass

from inclino.procedures.acquire import AcquireResult, _RowWriter, procedure_steps, recording, run_header
from inclino.procedures.poses import Step, wrap_deg
from inclino.procedures.readings import Unsettled, mean_row, progress_bar, read_stable
from inclino.errors import DataError

# Poses held through the ramps: each sensor axis down and up in turn, at
# different azimuths so that the field too points several ways in the body.
RAMP_POSES = (
    Step(0.0, 0.0, 0.0, "ramp pose 1 (Z down)"),
    Step(90.0, 90.0, 0.0, "ramp pose 2"),
    Step(90.0, 180.0, 90.0, "ramp pose 3"),
    Step(180.0, 270.0, 0.0, "ramp pose 4 (Z up)"),
    Step(90.0, 0.0, 180.0, "ramp pose 5"),
    Step(90.0, 270.0, 270.0, "ramp pose 6"),
)
POSE_SETS = ("twelve-position", "multi-position")
TEMP_RANGE_C = (-40.0, 125.0)  # the ADIS16210's operating range


@dataclass
class ThermalPlan:
    setpoints: tuple = (-5.0, 25.0, 55.0)  # degC, in order
    poses: str = "twelve-position"  # the pose set at each set point
    ramp_rate: float = 1.0  # degC/min
    interval_min: float = 2.0  # minutes between readings while ramping and soaking
    ramp_poses: int = 4  # of RAMP_POSES
    soak_band: float = 1.0  # degC from the set point
    soak_tol: float = 0.5  # degC of change over soak_window_min
    soak_window_min: float = 10.0
    max_soak_min: float = 240.0  # bench: give up after this long at one set point
    average: int = 64  # samples per reading (SET_AVERAGE) unless --average says otherwise (module docstring)

    def check(self) -> None:
        def fin(name, v, lo, hi, lo_open=False):
            v = float(v)
            if not math.isfinite(v) or v > hi or (v <= lo if lo_open else v < lo):
                raise DataError(f"{name} must be within {'(' if lo_open else '['}{lo:g}, {hi:g}], got {v:g}")

        if not self.setpoints:
            raise DataError("--temperatures needs at least one set point")
        for t in self.setpoints:
            fin("each of --temperatures", t, *TEMP_RANGE_C)
        if self.poses not in POSE_SETS:
            raise DataError(f"--poses must be one of {', '.join(POSE_SETS)}")
        fin("--ramp-rate", self.ramp_rate, 0.0, 30.0, True)
        fin("--interval-min", self.interval_min, 0.0, 60.0, True)
        if not 1 <= int(self.ramp_poses) <= len(RAMP_POSES) or int(self.ramp_poses) != self.ramp_poses:
            raise DataError(f"--ramp-poses must be within 1-{len(RAMP_POSES)}")
        fin("--soak-band", self.soak_band, 0.0, 20.0, True)
        fin("--soak-tol", self.soak_tol, 0.0, 20.0, True)
        fin("--soak-window-min", self.soak_window_min, 0.0, 600.0, True)
        fin("--max-soak-min", self.max_soak_min, 0.0, 10000.0, True)
        if int(self.average) != self.average or not 1 <= int(self.average) <= 64:
            raise DataError("--average must be within 1-64 samples")


def parse_temperatures(text: str) -> tuple:
    try:
        vals = tuple(float(x) for x in str(text).split(",") if x.strip())
    except ValueError:
        raise DataError(f"--temperatures wants comma-separated degC, got {text!r}")
    return vals


def settled(history: list, setpoint: float, plan: ThermalPlan) -> bool:
    """history: (minutes, probe temperature) of the readings at this set
    point.  Settled when the last is within soak_band of the set point and
    the readings of the last soak_window minutes (which must span it) vary by
    at most soak_tol."""
    if not history:
        return False
    t_last, temp_last = history[-1]
    if abs(temp_last - setpoint) > plan.soak_band:
        return False
    if t_last - history[0][0] < plan.soak_window_min:
        return False
    win = [T for (t, T) in history if t >= t_last - plan.soak_window_min]
    return max(win) - min(win) <= plan.soak_tol


class _Chamber:
    """The chamber's side of a table: set a set point, wait."""

    def __init__(self, table, sleep=time.sleep):
        self.table = table
        self.sleep = sleep

    def set(self, sp: float, rate: float) -> None:
        if self.table.unattended:
            self.table.call("chamber", setpoint_c=float(sp), rate_c_per_min=float(rate))
        else:
            self.table.ask(f"set the chamber to {sp:g} degC (ramp {rate:g} degC/min) and start it; press Enter "
                           "('q' to stop)")

    def wait(self, minutes: float) -> None:
        if self.table.unattended:
            self.table.call("advance", s=float(minutes) * 60.0)
        else:
            self.sleep(float(minutes) * 60.0)

    def air_at(self, sp: float) -> bool:
        """The bench's air has reached the set point (a person's chamber: assumed)."""
        if not self.table.unattended:
            return True
        st = self.table.call("chamber")
        return abs(float(st["chamber_c"]) - sp) < 1e-6


PROBE_DEFAULT_AVERAGE = 16  # firmware/include/inclino/probe.h PROBE_N_DEFAULT


@contextlib.contextmanager
def _default_average_after(link, restore: bool):
    """Set the probe back to its default averaging when the block ends
    (also on an error, as far as the link still answers)."""
    try:
        yield
    except BaseException:
        if restore:
            try:
                link.set_average(PROBE_DEFAULT_AVERAGE)
            except Exception:  # the error already under way is the one to report
                pass
        raise
    if restore:
        link.set_average(PROBE_DEFAULT_AVERAGE)


def acquire_temperature(link, out_path: str, table, plan: ThermalPlan, *, tol=None, max_reads: int = 30,
                        world: dict | None = None, quiet: bool = False, average: int | None = None,
                        sleep=time.sleep) -> AcquireResult:
    """Take the thermal run (module docstring) on `table` (a turntable:
    turntable.ManualTurntable or turntable_emulated.EmulatedTurntable) and write it to out_path as a raw dataset."""
    from inclino.procedures.readings import Tolerance

    tol = tol or Tolerance()
    tol.check()
    plan.check()
    poses = procedure_steps(plan.poses)
    ramp = RAMP_POSES[:int(plan.ramp_poses)]
    t0 = time.monotonic()
    plan_avg = average is None  # the plan's averaging: the probe goes back to its default at the end
    average = int(plan.average) if average is None else average
    ident, meta = run_header(link, table, world, average)
    who = f"bench {table.spec}" if table.unattended else "operator"
    sps = ",".join(f"{t:g}" for t in plan.setpoints)
    meta["source"] = (f"inclino acquire temperature (set points {sps} degC, {plan.poses} at each, "
                      f"{len(ramp)} ramp poses every {plan.interval_min:g} min, ramp {plan.ramp_rate:g} degC/min; "
                      f"{who}; probe {ident.product} fw {'.'.join(map(str, ident.fw_version))}, "
                      f"{tol.reads} reads within {tol.acc_mg:g} mg / {tol.mag_nT:g} nT)")
    res = AcquireResult(out_path, "temperature", 0, ident.serial, meta)
    out = _RowWriter(out_path, meta)
    bar = progress_bar(len(plan.setpoints) * len(poses), "temperature", quiet)

    def say(m):  # above the progress bar, on stderr
        bar.write(m, file=sys.stderr)

    if not table.unattended and getattr(table, "default_say", False):
        table.say = say
    tell = table.say if not table.unattended else (None if quiet else say)
    chamber = _Chamber(table, sleep)
    with recording(out, bar, res, t0), _default_average_after(link, plan_avg):
        for k, sp in enumerate(plan.setpoints):
            held = [ramp[k % len(ramp)]] if not table.unattended else list(ramp)
            if not table.unattended:
                table.move(held[0], k + 1, len(plan.setpoints))
            chamber.set(sp, plan.ramp_rate)
            history, minutes = [], 0.0
            while True:
                temps = []
                for st in held:
                    if table.unattended:
                        table.move(st, 0, 0)
                    win = read_stable(link, tol, max_reads if table.unattended else None)
                    res.reads += len(win)
                    row = mean_row(win)
                    out.write({**row, "inc_deg": st.inc, "azi_deg": wrap_deg(st.azi), "tf_deg": wrap_deg(st.tf)})
                    temps.append(row["temp_c"])
                history.append((minutes, sum(temps) / len(temps)))
                if tell is not None:
                    tell(f"  set point {sp:g} degC: probe at {history[-1][1]:.2f} degC after {minutes:g} min")
                if settled(history, sp, plan) and chamber.air_at(sp):
                    break
                if table.unattended and minutes >= plan.max_soak_min:
                    raise Unsettled(f"set point {sp:g} degC: the probe did not settle in {plan.max_soak_min:g} min "
                                    f"(at {history[-1][1]:.2f} degC; band {plan.soak_band:g} degC, "
                                    f"{plan.soak_tol:g} degC over {plan.soak_window_min:g} min)")
                chamber.wait(plan.interval_min)
                minutes += plan.interval_min
            res.notes.append({"setpoint_c": sp, "soak_min": minutes, "probe_c": history[-1][1]})
            for i, st in enumerate(poses, start=1):
                table.move(Step(st.inc, st.azi, st.tf, f"{sp:g} degC: {st.label}"), i, len(poses))
                win = read_stable(link, tol, max_reads if table.unattended else None)
                res.reads += len(win)
                out.write({**mean_row(win), "inc_deg": st.inc, "azi_deg": st.azi, "tf_deg": st.tf}, win)
                bar.update(1)
    return res


__all__ = ["RAMP_POSES", "ThermalPlan", "acquire_temperature", "parse_temperatures", "settled"]


# ---------------------------------------------------------------- CLI
