"""`inclino acquire`: take a calibration run from the probe, position by
position, and write it as a raw dataset (docs/dataset.md).

    inclino acquire --port P --procedure twelve-position|multi-position|continuous -o RUN.csv
                    [--bench HOST:PORT]

Procedures (pose lists from inclino.calib.runs, our conventions):

* twelve-position -- Li 2021 Table 1, the twelve positions (li2021, joint).
* multi-position -- Li's twelve, Ren 2014's ten positions and three circles
  (body x, y, z down, turned about the vertical every 30 deg), and --points
  quasi-uniform orientations (default 36): every static method (joint,
  ren2014, li2021) can fit the run.
* continuous -- Guo 2009: two full toolface rotations at inclinations d1 and
  d1 + 90 deg (--d1, default 30) at one azimuth (--azimuth, default 2),
  read while the toolface turns, with the probe's timestamps (guo2009,
  joint).
* temperature -- through a thermal chamber: at each set point of
  --temperatures a few poses read through the ramp and soak, then the
  --poses set (inclino.procedures.acquire_temp; joint --temperature-terms).
* adaptive -- poses chosen one at a time for what the probe still needs,
  until the predicted acceptance reaches the target; with
  --chamber-range-c through a continuous chamber ramp
  (inclino.procedures.adaptive; joint, with --temperature-terms).

Who turns the table:

* an operator (no --bench): every position is announced (the turntable's
  inclination, azimuth, toolface and which way each body axis then points);
  the operator sets it and presses Enter.  For the continuous procedure the
  operator sets inclination and azimuth, presses Enter and turns the
  toolface slowly through a full turn; the toolface of each reading is the
  probe's own gravity toolface from the raw accelerometer (its error is the
  uncalibrated accelerometer's bias and misalignment: up to 0.52 deg at 30
  deg inclination on the emulator's typical probe, inside the +-1 deg Guo's
  method is simulated with).
* the emulator's turntable (--bench HOST:PORT, `inclino emulate` prints the
  port): moved over its control channel, unattended.  The control channel
  only has static moves, so the continuous rotation is a toolface step every
  --step deg (default 10) with one reading at each.

Stability check (static positions): readings (SURVEY_RAW: the probe's
averaged raw counts and the survey of the same acquisition, with the
probe's time) are taken until --reads consecutive ones (default 3) agree
within the tolerance on every axis: max - min <= --tol-acc-mg (default 1.0
mg = 16 ADIS16210 counts) and <= --tol-mag-nt (default 20 nT).  A typical
probe at rest scatters by ~0.4 mg and ~3 nT between readings; a probe still
swinging on the table by far more.  The row written is the mean of those
readings (sensor columns in nominal units: counts x 2^-14 g, counts x 1 nT),
its time the mean of theirs.  The bench gives up on a position after
--max-reads readings (exit 4); an operator is told the probe is still moving
and the readings go on.

The file is written to RUN.csv.part as the run goes and renamed to RUN.csv
at the end (a run stopped part-way leaves its rows in RUN.csv.part); header lines carry the probe serial, the field when known (the
bench reports its field; an operator may give --field/--dip/--declination),
the date and the source.

Exit statuses: 0 written; 2 bad option; 4 port, probe or bench problem.
"""
from __future__ import annotations

import contextlib
import math
import os
import sys
import time
from dataclasses import dataclass, field

from inclino.errors import DataError, InclinoError
from inclino.engines.reference import ACC_LSB_G, MAG_LSB_NT  # noqa: F401 (one place for the sensor scales)
from inclino.procedures.poses import Step, wrap_deg
from inclino.procedures.readings import (Tolerance, Unsettled, gravity_toolface, mean_row, progress_bar, read_once,
                                         read_stable, set_average)

PROCEDURES = ("twelve-position", "multi-position", "continuous", "temperature", "adaptive")
COLUMNS = ("t_s", "inc_deg", "azi_deg", "tf_deg", "temp_c", "ax_g", "ay_g", "az_g", "mx_nT", "my_nT", "mz_nT",
           "utc_s")
# header keys that must match when a run is resumed (the probe, its firmware and calibration, the procedure)
RESUME_KEYS = ("probe_serial", "firmware", "calibration_crc", "calibration_sequence", "samples_averaged", "source")


# ---------------------------------------------------------------- poses
def procedure_steps(name: str, points: int = 36, d1: float = 30.0, azimuth: float = 2.0,
                    step_deg: float = 10.0, circle_step_deg: float = 30.0) -> list[Step]:
    import numpy as np

    from inclino.calib import li2021, runs

    if name == "twelve-position":
        return [Step(*map(float, li2021.POSITIONS[p]), f"Li 2021 Table 1 position {p}") for p in range(1, 13)]
    if name == "multi-position":
        if points < 0:
            raise DataError("--points must be >= 0")
        steps = procedure_steps("twelve-position")
        I, A, T = runs.ren2014(circle_step_deg)
        n_circle = len(np.arange(0.0, 360.0, circle_step_deg))
        names = ([f"Ren 2014 position {k + 1}" for k in range(10)]
                 + [f"Ren 2014 circle, {ax} down, {j + 1}/{n_circle}" for ax in "XYZ" for j in range(n_circle)])
        steps += [Step(float(i), float(a), float(t), nm) for i, a, t, nm in zip(I, A, T, names)]
        if points:
            I, A, T = runs.multi_position(points)
            steps += [Step(float(i), float(a), float(t), f"orientation {k + 1}/{points}")
                      for k, (i, a, t) in enumerate(zip(I, A, T))]
        return [Step(s.inc, wrap_deg(s.azi), wrap_deg(s.tf), s.label, s.rotation) for s in steps]
    if name == "continuous":
        if not 0.0 <= d1 <= 90.0:
            raise DataError("--d1 must be within 0-90 deg (the second rotation is at d1 + 90)")
        if not 0.0 < step_deg <= 60.0:
            raise DataError("--step must be within (0, 60] deg (Guo's fit needs >= 6 readings per turn)")
        r = np.arange(0.0, 360.0 - 1e-9, step_deg)
        return [Step(d, wrap_deg(azimuth), float(t), f"rotation {k + 1} at inclination {d:g}", k + 1)
                for k, d in enumerate((d1, d1 + 90.0)) for t in r]
    raise DataError(f"unknown procedure {name!r} (one of {', '.join(PROCEDURES)})")


# ---------------------------------------------------------------- the run
@dataclass
class AcquireResult:
    path: str
    procedure: str
    rows: int
    probe_serial: int
    meta: dict
    reads: int = 0
    unsettled_windows: int = 0
    elapsed_s: float = 0.0
    notes: list = field(default_factory=list)


def run_header(link, table, world, average):
    """Set the probe's averaging, identify it and build a run file's header:
    the world (given values first, then the turntable's), the probe's serial,
    firmware and active calibration, the start of the run (UTC, ISO 8601)
    and the sensor samples the probe averages per reading (asked of the
    probe: one survey's sample count, whether or not --average set it)."""
    from inclino.formats.survey_log import utc_iso

    set_average(link, average)
    ident = link.identify()
    meta = {k: v for k, v in (world or {}).items() if v is not None}
    meta.update({k: v for k, v in table.world().items() if k not in meta})
    meta["probe_serial"] = ident.serial
    meta["firmware"] = ".".join(map(str, ident.fw_version))
    meta["calibration_crc"] = f"{ident.cal_crc:04X}"
    meta["calibration_sequence"] = ident.cal_sequence
    meta["start_utc"] = utc_iso(time.time())
    meta["date"] = meta["start_utc"][:10]
    meta["samples_averaged"] = int(average) if average is not None else int(link.survey().count)
    return ident, meta


@contextlib.contextmanager
def recording(out, bar, res, t0):
    """The rows written inside go to the output file only when the block
    ends normally (`out.commit()`); on any exception, Ctrl-C and `q`
    included, the rows so far stay in RUN.csv.part and the exception says
    so (and how to continue).  Fills res.rows and res.elapsed_s."""
    try:
        yield
    except KeyboardInterrupt as e:
        bar.close()
        raise KeyboardInterrupt("; ".join(x for x in (str(e), out.abort()) if x)) from None
    except InclinoError as e:
        bar.close()
        e.args = (f"{e}; {out.abort()}",)
        raise
    except BaseException:
        out.abort()
        bar.close()
        raise
    bar.close()
    out.commit()
    res.rows = out.rows
    res.elapsed_s = time.monotonic() - t0


class _RowWriter:
    """RUN.csv.part, written and flushed row by row; renamed to RUN.csv at
    the end.  A .part is never overwritten: `resume` (its path) continues it
    when its header is this run's; without it an existing .part is refused."""

    def __init__(self, path: str, meta: dict, resume: str | None = None):
        from inclino.formats import safeio
        from inclino.formats.dataset import META_KEYS
        from inclino.formats.survey_log import parse_utc

        safeio.check_output(path)
        self.path = path
        self.part = path + ".part"
        self.rows = 0
        self.noise = _Noise()
        self.notes: list[str] = []   # what resuming did to the .part, said before the first move
        if resume is not None:
            old_meta, old_rows, cut = _read_part(resume)
            def key(k, m):  # the procedure, not who turned the table, must match
                v = str(m.get(k, ""))
                return v.split(" (")[0] if k == "source" else v

            diff = [f"{k} {key(k, old_meta)} in the file, {key(k, meta)} now" for k in RESUME_KEYS
                    if key(k, old_meta) != key(k, meta)]
            if diff:
                raise DataError(f"{resume}: not this run ({'; '.join(diff)}): not resumed")
            self.rows = old_rows
            meta.clear()
            meta.update(old_meta)
            self.start = parse_utc(old_meta["start_utc"], resume)
            if cut is not None:  # the run stopped while writing its last row: drop it, take that pose again
                os.truncate(resume, cut)
                self.notes.append(f"{resume}: its last row was cut short (the run stopped while writing it): "
                                  f"dropped; pose {old_rows + 1} is taken again")
            mode = "a"
        else:
            if os.path.exists(self.part):
                _, n, _ = _read_part(self.part, check=False)
                raise DataError(f"{self.part} exists ({n} rows an earlier run kept): continue it with --resume "
                                f"{self.part}, or remove it to start again")
            self.start = parse_utc(meta["start_utc"], path)
            mode = "w"
        self.f = safeio.open_log(self.part, mode)  # the output rules: never an input or another output
        if mode == "w":
            for k in META_KEYS:
                if k in meta and meta[k] is not None:
                    self.f.write(f"# {k}={meta[k]}\n")
            self.f.write("# utc_s=seconds since start_utc (host clock when the row was taken)\n")
            self.f.write(",".join(COLUMNS) + "\n")
            self.f.flush()

    def write(self, row: dict, window=None) -> None:
        row = {**row, "utc_s": time.time() - self.start}
        self.f.write(",".join(repr(float(row[c])) for c in COLUMNS) + "\n")
        self.f.flush()
        self.rows += 1
        if window is not None:
            self.noise.add(window)

    def commit(self) -> None:
        """The finished run goes to the output path through inclino.formats.safeio
        (atomic, never over a device or through a replaced symlink, the
        target's permissions kept), with the reading noise measured over the
        run in its header; the .part file is then removed."""
        from inclino.formats import safeio

        self.f.close()
        try:
            with open(self.part, encoding="utf-8") as src:
                lines = src.read().splitlines(keepends=True)
        except OSError as e:
            raise DataError(f"cannot read back {self.part}: {e.strerror}") from None
        head = [ln for ln in lines if ln.startswith("#")]
        body = lines[len(head):]
        head = [ln for ln in head if not ln.startswith(("# reading_noise", "# readings_per_row"))] + self.noise.lines()
        safeio.write_output(self.path, "".join(head + body))
        os.unlink(self.part)

    def abort(self) -> str:
        """Close the .part; what it kept, and how to continue."""
        try:
            self.f.close()
        except OSError:  # pragma: no cover
            pass
        if self.rows == 0:
            with contextlib.suppress(OSError):
                os.unlink(self.part)
            return "no row taken, nothing kept"
        return (f"{self.rows} row{'s' if self.rows != 1 else ''} kept in {self.part} (continue with --resume "
                f"{self.part})")


class _Noise:
    """The reading noise of the run: the spread of the readings taken at each
    pose (the stability window), pooled per sensor over the three axes."""

    def __init__(self):
        self.ss = [0.0, 0.0]
        self.dof = 0
        self.n = 0

    def add(self, window) -> None:
        if len(window) < 2:
            return
        import numpy as np

        a = np.array([w.acc for w in window], float) * ACC_LSB_G
        m = np.array([w.mag for w in window], float) * MAG_LSB_NT
        self.ss[0] += float(((a - a.mean(0)) ** 2).sum())
        self.ss[1] += float(((m - m.mean(0)) ** 2).sum())
        self.dof += 3 * (len(window) - 1)
        self.n = len(window)

    def lines(self) -> list:
        if self.dof < 6:
            return []
        sa, sm = (math.sqrt(x / self.dof) for x in self.ss)
        return [f"# reading_noise_acc_g={sa:.4g}\n", f"# reading_noise_mag_nT={sm:.4g}\n",
                f"# readings_per_row={self.n}\n"]


def _read_part(path: str, check: bool = True):
    """(header, rows) of a RUN.csv.part."""
    from inclino.formats.dataset import META_KEYS, NUMERIC_META

    if check and not path.endswith(".part"):
        raise DataError(f"--resume {path}: the .part file an interrupted run left (RUN.csv.part)")
    meta, rows, cols, cut, end = {}, 0, None, None, 0
    try:
        with open(path, "rb") as f:
            for raw in f:
                line = raw.decode("utf-8")
                end += len(raw)
                if line.startswith("#"):
                    if "=" in line:
                        k, v = (t.strip() for t in line[1:].split("=", 1))
                        if k in META_KEYS:
                            try:
                                meta[k] = float(v) if k in NUMERIC_META else v
                            except ValueError:
                                raise DataError(f"{path}: header {k}={v!r} is not a number") from None
                            if k in ("samples_averaged", "readings_per_row") and float(meta[k]).is_integer():
                                meta[k] = int(meta[k])
                elif cols is None:
                    cols = line.strip().split(",")
                elif line.strip():
                    if cut is not None:  # a broken row with rows after it: not where a stop leaves one
                        raise DataError(f"{path}: row {rows + 1} is cut short in the middle of the run "
                                        f"(the file was edited or damaged): not resumed; start the run again")
                    cut = None if _whole_row(line, len(cols)) else end - len(raw)
                    rows += cut is None
    except OSError as e:
        raise DataError(f"cannot read {path}: {e.strerror}") from None
    except UnicodeDecodeError:
        raise DataError(f"{path}: not a text file") from None
    if check and (tuple(cols or ()) != COLUMNS or "start_utc" not in meta):
        raise DataError(f"{path}: not a run inclino acquire left (its columns or header differ): not resumed")
    return meta, rows, cut


def _whole_row(line: str, cells: int) -> bool:
    """A row as _RowWriter writes it: ended by its newline, every cell a
    number (a run stopped while writing one leaves it cut short)."""
    if not line.endswith("\n"):
        return False
    parts = line.strip().split(",")
    try:
        return len(parts) == cells and len([float(p) for p in parts]) == cells
    except ValueError:
        return False


def acquire(link, procedure: str, out_path: str, table, *, points: int = 36, d1: float = 30.0,
            azimuth: float = 2.0, step_deg: float = 10.0, tol: Tolerance | None = None,
            max_reads: int = 30, world: dict | None = None, quiet: bool = False,
            turn_timeout_s: float = 120.0, average: int | None = None, resume: str | None = None) -> AcquireResult:
    """Take the procedure's positions on `table` (turntable.ManualTurntable or
    turntable_emulated.EmulatedTurntable) and
    write the raw dataset to out_path.  world: field_nT / dip_deg /
    declination_deg known to the caller (the bench's own take precedence
    over none)."""
    tol = tol or Tolerance()
    tol.check()
    steps = procedure_steps(procedure, points=points, d1=d1, azimuth=azimuth, step_deg=step_deg)
    t0 = time.monotonic()
    ident, meta = run_header(link, table, world, average)
    who = f"bench {table.spec}" if table.unattended else "operator"
    meta["source"] = (f"inclino acquire {procedure} ({who}; probe {ident.product} fw "
                      f"{'.'.join(map(str, ident.fw_version))}, {tol.reads} reads within {tol.acc_mg:g} mg "
                      f"/ {tol.mag_nT:g} nT)")
    if resume is not None and procedure == "continuous" and not table.unattended:
        raise DataError("--resume: an operator's continuous run is read as whole turns; start it again")
    out = _RowWriter(out_path, meta, resume)
    res = AcquireResult(out_path, procedure, 0, ident.serial, meta)
    done = out.rows
    bar = progress_bar(len(steps), procedure, quiet)
    def say(m):  # instructions and warnings stay visible with --quiet (an operator needs them)
        bar.write(m, file=sys.stderr)

    for m in out.notes:
        say(f"note: {m}")
    if getattr(table, "default_say", False):  # a person at the turntable, told above the bar
        table.say = say
    with recording(out, bar, res, t0):
        if procedure == "continuous" and not table.unattended:
            _continuous_operator(link, table, steps, out, res, bar, say, turn_timeout_s)
        else:
            if done >= len(steps):
                raise DataError(f"{out.part} already holds {done} rows, the whole procedure: nothing to resume")
            bar.update(done)
            for i, st in enumerate(steps, start=1):
                if i <= done:  # taken before the interruption (--resume)
                    continue
                table.move(st, i, len(steps))
                if st.rotation:  # the bench's stepped rotation: one reading per step
                    win = [read_once(link)]
                    res.reads += 1
                else:
                    def waiting(sa, sm, n, st=st):
                        res.unsettled_windows += 1
                        if not table.unattended:
                            say(f"  the probe is still moving (spread {sa:.2f} mg, {sm:.0f} nT): hold it still")

                    win = read_stable(link, tol, max_reads if table.unattended else None, waiting)
                    res.reads += len(win)
                out.write({**mean_row(win), "inc_deg": st.inc, "azi_deg": st.azi, "tf_deg": st.tf}, win)
                bar.update(1)
    return res


def _continuous_operator(link, table, steps, out, res, bar, say, timeout_s):
    """An operator turns the toolface by hand: read continuously, toolface
    from the raw accelerometer, until a full turn (plus one step) is covered."""
    for rot in (1, 2):
        st = next(s for s in steps if s.rotation == rot)
        per_turn = sum(1 for s in steps if s.rotation == rot)
        table.move(st, rot, 2)
        first = read_once(link)
        prev = gravity_toolface(first.acc)
        turned, n, t_start = 0.0, 0, time.monotonic()
        rows = [first]
        while abs(turned) < 360.0:
            r = read_once(link)
            tf = gravity_toolface(r.acc)
            d = (tf - prev + 180.0) % 360.0 - 180.0
            if abs(d) > 20.0:
                say(f"  toolface moved {abs(d):.0f} deg between readings: turn more slowly")
            turned += d
            prev = tf
            rows.append(r)
            n += 1
            bar.n = int(min(per_turn, per_turn * abs(turned) / 360.0)) + (rot - 1) * per_turn
            bar.refresh()
            if time.monotonic() - t_start > timeout_s:
                raise Unsettled(f"rotation {rot}: the toolface turned only {abs(turned):.0f} deg in {timeout_s:g} s")
        for r in rows:
            out.write({"t_s": r.t_s, "temp_c": r.temp_c, "ax_g": r.acc[0] * ACC_LSB_G, "ay_g": r.acc[1] * ACC_LSB_G,
                       "az_g": r.acc[2] * ACC_LSB_G, "mx_nT": r.mag[0] * MAG_LSB_NT, "my_nT": r.mag[1] * MAG_LSB_NT,
                       "mz_nT": r.mag[2] * MAG_LSB_NT, "inc_deg": st.inc, "azi_deg": st.azi,
                       "tf_deg": gravity_toolface(r.acc)})
        res.reads += len(rows)


# ---------------------------------------------------------------- CLI
