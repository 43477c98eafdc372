"""The sensor description: how a log's columns become the probe's body frame.

A small TOML file (docs/dataset.md, "The sensor description") says, per
triad, which columns hold the readings, in what unit, with what resolution,
noise and range, which way the accelerometer counts gravity, and how the
sensor's axes map onto the body frame of docs/conventions.md (signed
permutations such as ``x = "-ay"``).  `inclino import LOG --sensor S.toml`
applies it (inclino.formats.importlog) and writes the canonical dataset.

    name = "MPU-9250 breakout"
    [log]
    time = "t_ms"
    time_unit = "ms"
    [accelerometer]
    columns = ["ax", "ay", "az"]
    unit = "counts"
    lsb = "1/16384 g"
    reads = "up"
    x = "ax"
    y = "ay"
    z = "az"
    [magnetometer]
    columns = ["mx", "my", "mz"]
    unit = "uT"
    x = "my"
    y = "mx"
    z = "-mz"

A description may start from a preset (`preset = "mpu9250"`, or
`--sensor mpu9250` alone): the preset's tables are taken, then the file's
keys replace them key by key.  Presets live beside this module
(sensors/*.toml), each citing the datasheet its numbers come from.

Quantities are strings with a unit ("0.15 uT", "1/2048 g", "16 g",
"2 counts"); plain numbers are taken in the triad's own logged unit.
Everything is converted to the canonical units, g and nT.  An optional
[gyroscope] table (columns, unit deg/s, rad/s or counts with lsb, an axis
map defaulting to the accelerometer's) brings the angular rate in deg/s,
which only the row-alignment check reads.
"""
from __future__ import annotations

import hashlib
import math
import re
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from inclino.errors import DataError

from . import dataset

STANDARD_GRAVITY = 9.80665  # m/s^2 per g (CGPM 1901)
PRESET_DIR = Path(__file__).with_name("sensors")

# logged unit -> canonical unit (g or nT) per logged unit
ACC_UNITS = {"g": 1.0, "mg": 1e-3, "ug": 1e-6, "µg": 1e-6, "m/s2": 1.0 / STANDARD_GRAVITY,
             "m/s^2": 1.0 / STANDARD_GRAVITY, "m/s²": 1.0 / STANDARD_GRAVITY, "mm/s2": 1e-3 / STANDARD_GRAVITY}
# the gyroscope's angular rate (optional [gyroscope]; only the row-alignment check reads it), in deg/s
GYRO_UNITS = {"deg/s": 1.0, "dps": 1.0, "°/s": 1.0, "degrees/s": 1.0, "rad/s": 180.0 / math.pi,
              "mrad/s": 0.18 / math.pi, "rpm": 6.0}
MAG_UNITS = {"nt": 1.0, "ut": 1e3, "µt": 1e3, "mt": 1e6, "t": 1e9, "g": 1e5, "gauss": 1e5, "mg": 100.0,
             "mgauss": 100.0, "gamma": 1.0}
TRIADS = {"accelerometer": ("acc", ACC_UNITS, "g", "a"), "magnetometer": ("mag", MAG_UNITS, "nT", "m")}
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9, "min": 60.0, "h": 3600.0}
TICK_UNITS = {"100 us": 1e-4}  # tick counters named as a unit: a 10 kHz counter of 100 us ticks (Xsens MT
                              # Manager's SampleTimeFine); declared as a sample period, "100 us" (time_scale)
SPLIT_STAMP = "s + ns"  # the time_unit recorded for a stamp in two columns, whole seconds and nanoseconds
NS_PER_S = 1_000_000_000  # a stamp's nanoseconds column reads 0 ... NS_PER_S - 1
READS = ("up", "down")
BAD_ROWS = ("refuse", "drop")
TOP_KEYS = {"name", "preset", "notes", "source", "log", "accelerometer", "magnetometer", "gyroscope", "header",
            "poses"}
LOG_KEYS = {"delimiter", "comment", "header", "skip_rows", "time", "time_unit", "rate_hz", "temperature",
            "temperature_unit", "temperature_lsb", "temperature_offset", "samples_averaged", "static", "keep", "decimal", "bad_rows", "strip"}
FIELD_UNIT = "field"  # magnetometer readings normalised to the site's total field: 1.0 = field_nT
# a temperature column's unit: degrees C = reading x scale + offset ("counts": scale and offset from
# temperature_lsb and temperature_offset, a datasheet's T = offset + counts x lsb)
TEMP_UNITS = {"C": (1.0, 0.0), "degC": (1.0, 0.0), "°C": (1.0, 0.0), "celsius": (1.0, 0.0),
              "K": (1.0, -273.15), "kelvin": (1.0, -273.15),
              "F": (5.0 / 9.0, -32.0 * 5.0 / 9.0), "degF": (5.0 / 9.0, -32.0 * 5.0 / 9.0),
              "°F": (5.0 / 9.0, -32.0 * 5.0 / 9.0), "fahrenheit": (5.0 / 9.0, -32.0 * 5.0 / 9.0)}
DEGREES_C = {"C": 1.0, "degC": 1.0, "°C": 1.0}  # a temperature's lsb and offset (temperature_lsb, _offset)
RATE_UNITS = {"Hz": 1.0, "hz": 1.0, "kHz": 1e3, "khz": 1e3}
TRIAD_KEYS = {"columns", "unit", "lsb", "reads", "x", "y", "z", "axes", "reflection", "range", "noise", "lag", "zero",
              "file", "time", "time_unit", "time_offset", "counts"}
GYRO_KEYS = {"columns", "unit", "lsb", "x", "y", "z", "axes", "zero", "counts"}
POSE_UNITS = {"deg": 1.0, "degree": 1.0, "degrees": 1.0, "rad": 180.0 / math.pi, "radian": 180.0 / math.pi,
              "radians": 180.0 / math.pi}
POSE_KEYS = {"inc", "azi", "tf", "label", "labels", "unit"}


# other spellings people log units in, after _norm (lower case, no spaces, micro as u, ^2/**2/² as 2)
UNIT_ALIASES = {
    "acc": {"gee": "g", "g0": "g", "gn": "g", "milli-g": "mg", "millig": "mg", "mgee": "mg", "micro-g": "ug",
            "m/s/s": "m/s2", "ms-2": "m/s2", "m.s-2": "m/s2", "m/sec2": "m/s2", "m/sec/sec": "m/s2",
            "mps2": "m/s2", "mpss": "m/s2", "meter/s2": "m/s2", "meters/s2": "m/s2", "metre/s2": "m/s2",
            "metres/s2": "m/s2", "mm/s/s": "mm/s2", "mms-2": "mm/s2", "cm/s2": "cm/s2", "cms-2": "cm/s2",
            "gal": "cm/s2"},
    "mag": {"nanotesla": "nt", "microtesla": "ut", "millitesla": "mt", "tesla": "t", "gs": "gauss",
            "milligauss": "mgauss", "mgs": "mgauss", "mgs.": "mgauss", "mgauss": "mgauss", "kgauss": "kgauss",
            "oe": "gauss", "oersted": "gauss", "mOe": "mgauss", "moe": "mgauss"},
}
ACC_UNITS["cm/s2"] = 1e-2 / STANDARD_GRAVITY
MAG_UNITS["kgauss"] = 1e8
TIME_ALIASES = {"sec": "s", "secs": "s", "second": "s", "seconds": "s", "msec": "ms", "millisecond": "ms",
                "milliseconds": "ms", "usec": "us", "microsecond": "us", "microseconds": "us",
                "nanosecond": "ns", "nanoseconds": "ns", "minute": "min", "minutes": "min", "hour": "h",
                "hours": "h", "hr": "h"}


def _norm(u: str) -> str:
    u = u.strip().lower().replace(" ", "").replace("\u00b7", ".").replace("*", "")
    for a, b in (("\u03bc", "u"), ("\u00b5", "u"), ("\u00b2", "2"), ("\u207b", "-"), ("^", ""), ("/sec", "/s")):
        u = u.replace(a, b)
    return u.replace("ms22", "ms2")


def _unit_key(u: str, units: dict) -> str | None:
    """The key of `units` (ACC_UNITS, MAG_UNITS, TIME_UNITS) that the
    spelling `u` means: exact, then case and spaces ignored, micro as u,
    "^2", "**2" and "²" as 2, then the usual other spellings."""
    u = u.strip()
    for k in (u, u.lower(), u.replace(" ", ""), u.lower().replace(" ", "")):
        if k in units:
            return k
    n = _norm(u)
    if n in units:
        return n
    n2 = n.replace("u", "µ", 1) if n.startswith("u") else n
    if n2 in units:
        return n2
    aliases = (UNIT_ALIASES["acc"] if units is ACC_UNITS else UNIT_ALIASES["mag"] if units is MAG_UNITS
               else TIME_ALIASES if units is TIME_UNITS else {})
    k = aliases.get(n)
    return k if k in units else None


def unit_size(u: str, triad: str) -> float | None:
    """The size of the unit spelt `u` in the canonical unit of the triad
    ("acc": g, "mag": nT), as the description reads it (m/s2: 1/9.80665);
    None for a unit that is not a size (counts, field) or not known."""
    units = ACC_UNITS if triad == "acc" else MAG_UNITS
    k = _unit_key(str(u), units)
    return float(units[k]) if k is not None else None


SIGNIFICANT = 15  # digits a unit conversion keeps: a double holds 15-17, no sensor resolves 10


def decimal_clean(x):
    """x rounded to SIGNIFICANT digits: a logged decimal times a decimal
    scale (0.27356 G x 100 000 nT/G) is the decimal it means (27356.0), not
    the binary product's 27356.000000000004.  Values beyond 1e15 or of
    exponent below -300 pass unchanged."""
    x = np.asarray(x, float)
    a = np.abs(x)
    ok = np.isfinite(x) & (a > 1e-300) & (a < 1e15)
    e = np.floor(np.log10(np.where(ok, a, 1.0)))
    f = 10.0 ** (SIGNIFICANT - 1 - e)  # an exact power of ten (exponent <= 22 for |x| > 1e-8)
    exact = ok & (SIGNIFICANT - 1 - e <= 22)
    return np.where(exact, np.round(np.where(exact, x, 0.0) * f) / f, x)


@dataclass
class Triad:
    """One triad's reading of the log, in canonical units."""

    kind: str                       # "acc", "mag" or "gyro" (the gyroscope: deg/s, never one of `triads`)
    columns: list                   # the sensor's x, y, z columns (names, or 1-based numbers)
    unit: str                       # as logged ("g", "m/s2", "uT", "counts", ...)
    scale: float | None             # canonical units (g or nT) per logged unit (None: unit "field" with the
                                    # site's field not yet known: the log's own field_nT line gives it)
    axes: list                      # body x, y, z <- (sign, sensor axis index): [[+1, 0], ...]
    reads: str = "down"             # accelerometer: "up" = +1 g on the axis pointing up at rest
    reflection: bool = False        # the axis map is a reflection on purpose
    lsb: float | None = None        # resolution, canonical units
    noise: float | None = None      # RMS noise of one sample, canonical units
    range: float | None = None      # full scale (+-), canonical units
    lag: int = 0                    # this triad's row i + lag belongs to the log's row i (two files joined out of step)
    zero: float = 0.0               # the reading at zero input, in the logged unit (unsigned counts: 2^(bits-1)),
                                    # subtracted before the scale
    counts: str | None = None       # the counts' word as logged ("int16": two's complement, a logged 65404 is
                                    # -132; "uint16": unsigned, as read); None: not declared (read as logged)
    file: str | None = None         # the triad logged to a file of its own (a path; relative: beside the log),
                                    # its samples paired with the log's by time, or without one row by row
                                    # (inclino.formats.importlog)
    time: str | int | tuple | None = None  # that file's time column, or two: (whole seconds, nanoseconds) (None:
                                    # the column(s) [log].time gives; without one, or time = false, its rows are
                                    # paired with the log's in order)
    time_unit: str | None = None    # ... and its unit (None: [log].time_unit)
    time_scale: float | None = None
    time_offset: float = 0.0        # seconds added to that file's times before pairing (its clock against the log's)

    @property
    def matrix(self) -> np.ndarray:
        """body = matrix @ sensor (the signed permutation of the axis map)."""
        return _axes_matrix(self.axes)

    @property
    def det(self) -> int:
        return int(round(np.linalg.det(self.matrix)))

    def convert(self, raw: np.ndarray) -> np.ndarray:
        """(n, 3) logged x, y, z -> (n, 3) body-frame readings in g or nT,
        with the gravity sign of docs/conventions.md (+1 g on the axis
        pointing down)."""
        raw = np.asarray(raw, float)
        bits = self.signed_bits
        if bits:  # two's-complement counts logged as unsigned words: 2^(bits-1) ... 2^bits - 1 are negative
            raw = np.where(raw >= 2.0 ** (bits - 1), raw - 2.0 ** bits, raw)
        if self.zero:
            raw = raw - self.zero
        out = (raw if self.scale == 1.0 else decimal_clean(raw * self.scale)) @ self.matrix.T
        return -out if self.reads == "up" else out

    @property
    def signed_bits(self) -> int | None:
        """The width of two's-complement counts (counts = "int16": 16), else None."""
        return int(self.counts[3:]) if self.counts and self.counts.startswith("int") else None

    def axes_text(self) -> str:
        p = {"acc": "a", "mag": "m", "gyro": "g"}[self.kind]
        return ", ".join(f"{b} = {'-' if s < 0 else ''}{p}{'xyz'[j]}" for b, (s, j) in zip("xyz", self.axes))


@dataclass
class SensorDescription:
    name: str = "the project's probe (ADIS16210 + fluxgate)"
    acc: Triad | None = None
    mag: Triad | None = None
    gyro: Triad | None = None         # the gyroscope, in deg/s (optional): read by the row-alignment check only
    # the log
    delimiter: str | None = None
    decimal: str = "."                # the decimal mark: "." or "," (then the delimiter is not a comma)
    comment: str = "#"
    has_header: bool = True
    skip_rows: int = 0
    time: str | int | tuple | None = None  # the time column, or two: (whole seconds, nanoseconds), a stamp split
                                      # as ROS writes header.stamp (sec and nanosec; ROS 1: secs and nsecs)
    time_unit: str = "s"
    time_scale: float = 1.0           # seconds per unit of the time column
    rate_hz: float | None = None      # no time column, a known sample rate: t_s = row index / rate_hz
    temperature: str | int | None = None
    temperature_unit: str = "C"
    temperature_scale: float = 1.0    # degrees C = the temperature column x temperature_scale + temperature_offset
    temperature_offset: float = 0.0
    samples_averaged: float | None = None
    static: bool | None = None
    keep: dict | None = None          # {column: [values]}: rows to keep (others dropped, counted)
    bad_rows: str = "refuse"          # a malformed row (cells missing, not a number): "refuse" or "drop"
    strip: str = ""                   # characters taken out of every line before it is split (brackets of a
                                      # tuple printed as text: "((ax, ay, az), (mx, my, mz))" with strip = "()")
    header: dict = field(default_factory=dict)  # canonical header values (dip_deg, field_nT, ...)
    poses: dict | None = None         # {"inc": col, "azi": col, "tf": col} or {"label": col, "labels": {...}}
    pose_scale: float = 1.0           # degrees per unit of the poses ([poses] unit: "deg", or "rad")
    notes: str = ""
    source: str = ""
    text_sha256: str = ""
    path: str = ""
    preset: str = ""                  # loaded as a preset by name (--sensor NAME, or the default): a triad
                                      # whose columns are all absent from a log is left out (a one-triad log)
    from_preset: tuple = ()           # the triads ("acc", "mag") whose table only the preset gave (a file with
                                      # preset = ... and no table of its own for them): left out likewise

    @property
    def triads(self) -> tuple:
        return tuple(t for t in (self.acc, self.mag) if t is not None)

    def to_dict(self) -> dict:
        d = asdict(self)
        return d

    def header_meta(self) -> dict:
        """The canonical header lines that record this description
        (docs/dataset.md): name, hash, axis maps, units, resolution, noise,
        range (canonical units), the declarations (static, reflection)."""
        m = {"sensor": self.name}
        if self.text_sha256:
            m["sensor_sha256"] = self.text_sha256
        for t in self.triads:
            u = "g" if t.kind == "acc" else "nT"
            m[f"{t.kind}_axes"] = t.axes_text()
            m[f"{t.kind}_unit"] = t.unit + (f" ({t.counts})" if t.counts else "") + \
                (f" x {t.scale:.10g} {u}" if t.unit in ("counts", FIELD_UNIT) and t.scale is not None else "") + \
                (f", less a zero of {t.zero:.10g}" if t.zero else "")
            if t.kind == "acc":
                m["acc_reads"] = t.reads + (" (an axis pointing up read +1 g: the sign was turned)"
                                            if t.reads == "up" else "")
            if t.lag:
                m[f"{t.kind}_lag_rows"] = str(t.lag)
            for k in ("lsb", "noise", "range"):
                v = getattr(t, k)
                if v is not None:
                    m[f"{t.kind}_{k}_{u}"] = float(decimal_clean(v))
        if self.gyro is not None:
            g = self.gyro
            m["gyro_axes"] = g.axes_text()
            m["gyro_unit"] = g.unit + (f" ({g.counts})" if g.counts else "") + \
                (f" x {g.scale:.10g} deg/s" if g.unit == "counts" else "") + (f", less a zero of {g.zero:.10g}"
                                                                               if g.zero else "")
        refl = [t.kind for t in self.triads if t.reflection]
        if refl:
            m["axes_reflection"] = ",".join(refl)
        if self.static is not None:
            m["static"] = "true" if self.static else "false"
        if self.samples_averaged is not None:
            m["samples_averaged"] = self.samples_averaged
        if self.rate_hz is not None:
            m["rate_hz"] = self.rate_hz
        if self.temperature is not None and self.temperature_unit != "C":
            m["temp_unit"] = self.temperature_unit + (
                f" x {self.temperature_scale:.10g} C {self.temperature_offset:+.10g} C"
                if self.temperature_unit == "counts" else "")
        if self.time is not None:
            m["time_unit"] = self.time_unit  # the checks name the unit the rows look like against it
        return m


def _temperature_unit(s, log: dict, what: str) -> None:
    """[log].temperature_unit (C, K, F, or counts with temperature_lsb and
    temperature_offset) into s.temperature_scale and s.temperature_offset:
    degrees C = column x scale + offset."""
    given = [k for k in ("temperature_unit", "temperature_lsb", "temperature_offset") if k in log]
    if given and s.temperature is None:
        raise DataError(f"{what}[log].{given[0]} without a temperature column ([log].temperature = ...)")
    unit = str(log.get("temperature_unit", "C")).strip()
    counts = unit.lower() in ("count", "counts", "lsb")
    if not counts:
        key = next((k for k in TEMP_UNITS if k.lower() == unit.lower()), None)
        if key is None:
            raise DataError(f"{what}[log].temperature_unit: C, K, F, or counts (with temperature_lsb and "
                            f"temperature_offset), not {unit!r}")
        for k in ("temperature_lsb", "temperature_offset"):
            if k in log:
                raise DataError(f"{what}[log].{k} goes with temperature_unit = \"counts\" (the column is in "
                                f"{key})")
        s.temperature_unit = key
        s.temperature_scale, s.temperature_offset = TEMP_UNITS[key]
        return
    if "temperature_lsb" not in log or "temperature_offset" not in log:
        raise DataError(f"{what}[log]: a temperature in counts needs temperature_lsb (a count in degrees C, e.g. "
                        f"\"1/340 C\") and temperature_offset (the temperature a count of 0 reads, e.g. "
                        f"\"36.53 C\"): the datasheet's T = offset + counts x lsb")
    s.temperature_unit = "counts"
    s.temperature_scale = _degrees(log["temperature_lsb"], f"{what}[log].temperature_lsb", positive=True)
    s.temperature_offset = _degrees(log["temperature_offset"], f"{what}[log].temperature_offset", positive=False)


def _degrees(value, what: str, positive: bool) -> float:
    """A temperature (difference) in degrees C: "1/340 C", "36.53 C", "-40 C"
    or a plain number of degrees C; > 0 when positive.  A string is read as
    _signed_time reads a time: its sign, then _quantity."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        v = float(value)
    elif isinstance(value, str):
        t = value.strip()
        try:
            v = (-1.0 if t.startswith("-") else 1.0) * _quantity(t.lstrip("+-"), DEGREES_C, "C", what, 1.0,
                                                                 zero=True)
        except DataError:
            raise DataError(f"{what}: {value!r} is not a number of degrees C (e.g. \"1/340 C\", \"36.53 C\")") from None
    else:
        raise DataError(f"{what}: {value!r} is not a number of degrees C")
    if not math.isfinite(v) or (positive and v <= 0):
        raise DataError(f"{what}: {value!r} must be a finite number of degrees C" + (" > 0" if positive else ""))
    return v


def split_stamp(time) -> bool:
    """Whether a description's time is a stamp in two columns (whole
    seconds, nanoseconds)."""
    return isinstance(time, tuple)


def _time_column(value, what: str, false: bool = False):
    """A time column as a description gives it: a name, a number from 1, or
    a list of two, [whole seconds, nanoseconds] (a stamp split as ROS 2's
    header.stamp.sec and .nanosec, ROS 1's .secs and .nsecs), returned as a
    tuple; False where `false` allows it (a triad's file paired in order)."""
    if value is None or (false and value is False):
        return value
    if isinstance(value, list):
        if len(value) == 2 and all(isinstance(c, (str, int)) and not isinstance(c, bool) for c in value) \
                and value[0] != value[1]:
            return tuple(value)
        raise DataError(f"{what}: a stamp in two columns is a list of two different columns, [whole seconds, "
                        f"nanoseconds] (e.g. [\"header.stamp.sec\", \"header.stamp.nanosec\"]), not {value!r}")
    if isinstance(value, bool) or not isinstance(value, (str, int)):
        raise DataError(f"{what}: the name (or 1-based number) of the time column, or two: [whole seconds, "
                        f"nanoseconds]" + (", or false (its rows paired with the log's in order)" if false else ""))
    return value


def _split_unit(spec: dict, time, what: str) -> None:
    """A stamp in two columns is whole seconds and nanoseconds: a time_unit
    other than "s" (the seconds column's) is refused."""
    if split_stamp(time) and "time_unit" in spec and _unit_key(str(spec["time_unit"]), TIME_UNITS) != "s":
        raise DataError(f"{what}.time_unit: the time is a stamp in two columns, whole seconds and nanoseconds "
                        f"(time = [seconds, nanoseconds]); leave time_unit out (or \"s\"), not "
                        f"{spec['time_unit']!r}")


def time_scale(text: str, what: str = "[log].time_unit") -> float:
    """Seconds per unit of a time column: a unit of TIME_UNITS ("ms") or a
    sample period ("1/102.4 s": the column counts samples of 1/102.4 s)."""
    tu = str(text).strip()
    tk = _unit_key(tu, TIME_UNITS)
    if tk is not None:
        return TIME_UNITS[tk]
    return _quantity(tu, TIME_UNITS, "s", what, None)


def _quantity(value, units: dict, canon: str, what: str, logged_scale: float | None, lsb: float | None = None,
              zero: bool = False):
    """A quantity in canonical units: "0.15 uT", "1/2048 g", "2 counts" (needs
    lsb), or a plain number in the triad's logged unit (logged_scale); > 0
    (>= 0 with zero)."""
    if isinstance(value, bool):
        raise DataError(f"{what}: {value!r} is not a quantity")
    if isinstance(value, (int, float)):
        if logged_scale is None:
            raise DataError(f"{what}: give a unit ({value} {canon}?)")
        v = float(value) * logged_scale
    elif isinstance(value, str):
        m = re.fullmatch(r"\s*([-+0-9.eE]+(?:\s*/\s*[0-9.eE+]+)?)\s*(\S.*?)?\s*", value)
        if not m:
            raise DataError(f"{what}: {value!r} is not a number with a unit (e.g. '0.15 uT', '1/2048 g')")
        num = m.group(1).replace(" ", "")
        try:
            if "/" in num:
                a, b = num.split("/")
                v = float(a) / float(b)
            else:
                v = float(num)
        except (ValueError, ZeroDivisionError):
            raise DataError(f"{what}: {value!r} is not a number with a unit") from None
        u = (m.group(2) or "").strip()
        if not u:
            if logged_scale is None:
                raise DataError(f"{what}: {value!r} needs a unit ({canon})")
            v *= logged_scale
        elif u.lower() in ("count", "counts", "lsb"):
            if lsb is None:
                raise DataError(f"{what}: {value!r} in counts needs the triad's lsb")
            v *= lsb
        else:
            k = _unit_key(u, units)
            if k is None:
                raise DataError(f"{what}: unknown unit {u!r} (one of {', '.join(units)})")
            v *= units[k]
    else:
        raise DataError(f"{what}: {value!r} is not a quantity")
    if not (math.isfinite(v) and (v >= 0 if zero else v > 0)):
        raise DataError(f"{what}: {value!r} must be a positive finite quantity")
    return v


def _signed_time(value, logged_scale: float, what: str) -> float:
    """A time offset in seconds, either sign: "-30 ms", "12.5 s", or a plain
    number in the time column's unit."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if not math.isfinite(value):
            raise DataError(f"{what}: {value!r} is not a finite time")
        return float(value) * logged_scale
    if not isinstance(value, str):
        raise DataError(f"{what}: {value!r} is not a time (e.g. '-30 ms', '12.5 s')")
    t = value.strip()
    sign = -1.0 if t.startswith("-") else 1.0
    return sign * _quantity(t.lstrip("+-"), TIME_UNITS, "s", what, logged_scale, zero=True)


def _field_quantity(value, units, canon, what, scale, lsb=None):
    """A quantity of a triad logged in field units: a plain number is in
    field units, so it needs the field (the description's [header] field_nT)."""
    if scale is None and (isinstance(value, (int, float)) and not isinstance(value, bool) or isinstance(value, str)
                          and re.fullmatch(r"\s*[-+0-9.eE]+(?:\s*/\s*[0-9.eE+]+)?\s*", value)):
        raise DataError(f"{what}: {value!r} in field units needs the site's field in the description ([header] "
                        f"field_nT = ...); or give it with a unit ('0.15 uT')")
    return _quantity(value, units, canon, what, scale, lsb)


_AXIS = re.compile(r"\s*([+-]?)\s*([amg]?)([xyz])\s*", re.I)


_COMPACT = re.compile(r"\s*([+-]?)\s*([xyz])\s*,?\s*([+-]?)\s*([xyz])\s*,?\s*([+-]?)\s*([xyz])\s*", re.I)


def _axes_matrix(axes: list) -> np.ndarray:
    m = np.zeros((3, 3))
    for i, (s, j) in enumerate(axes):
        m[i, j] = s
    return m


def axis_matrix(text: str, kind: str, what: str = "axes") -> np.ndarray:
    """body = matrix @ sensor for an `axes` string of a description (as a
    dataset's header records it: "x = mx, y = -my, z = -mz"); DataError when
    it is not one."""
    return _axes_matrix(_axis_map({"axes": str(text)}, kind, what))


def _axis_map(spec: dict, kind: str, what: str, columns=()) -> list:
    """[[sign, sensor index] for body x, y, z] from x/y/z keys or an `axes`
    string ("x = -ay, y = ax, z = az"; or body x, y, z in order: "-y, -x, z",
    "-Y-X+Z"); a sensor axis by its letter (with or without the triad's
    a/m) or by its column's name ("-acc_y"); default identity."""
    letter = {"acc": "a", "mag": "m", "gyro": "g"}[kind]
    entries = {}
    if "axes" in spec:
        text = spec["axes"]
        if isinstance(text, list):
            if len(text) != 3:
                raise DataError(f"{what}.axes: three entries (body x, y, z)")
            entries = dict(zip("xyz", text))
        elif isinstance(text, str) and "=" not in text and _COMPACT.fullmatch(text):
            g = _COMPACT.fullmatch(text).groups()
            entries = {b: g[2 * i] + g[2 * i + 1] for i, b in enumerate("xyz")}
        elif isinstance(text, str):
            for part in text.split(","):
                if "=" not in part:
                    raise DataError(f"{what}.axes: {part.strip()!r} is not 'body = sensor axis' (e.g. 'x = -ay')")
                b, s = (t.strip() for t in part.split("=", 1))
                entries[b.lower()] = s
        else:
            raise DataError(f"{what}.axes: a string such as 'x = -ay, y = ax, z = az'")
    for b in "xyz":
        if b in spec:
            entries[b] = spec[b]
    if not entries:
        return [[1, 0], [1, 1], [1, 2]]
    if set(entries) != set("xyz"):
        raise DataError(f"{what}: the axis map needs body x, y and z (has {', '.join(sorted(entries))})")
    out = []
    names = [str(c).strip().lower() for c in columns]
    for b in "xyz":
        s = entries[b]
        m = _AXIS.fullmatch(str(s))
        if m and (not m.group(2) or m.group(2).lower() == letter):
            out.append([-1 if m.group(1) == "-" else 1, "xyz".index(m.group(3).lower())])
            continue
        t = str(s).strip()
        sign = -1 if t.startswith("-") else 1
        t = t.lstrip("+-").strip().lower()
        if t in names:
            out.append([sign, names.index(t)])
            continue
        raise DataError(f"{what}: {b} = {s!r} is not an axis of this triad (e.g. '-{letter}y', or a column "
                        f"name with a sign: '-{columns[1] if len(columns) == 3 else 'ay'}')")
    if sorted(j for _, j in out) != [0, 1, 2]:
        raise DataError(f"{what}: the axis map uses a sensor axis twice ({', '.join(f'{b} = {entries[b]}' for b in 'xyz')})")
    return out


def _field_nT(header: dict, what: str) -> float | None:
    """The site's total field from the description's [header] (None: not given)."""
    v = header.get("field_nT") if isinstance(header, dict) else None
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise DataError(f"{what}[header].field_nT: the site's total field in nT, a number")
    dataset.check_meta("field_nT", float(v), f"{what}[header].field_nT")
    return float(v)


def _three_columns(spec: dict, what: str, keys, whose: str) -> list:
    """A triad table's keys checked against `keys` and its three columns
    (names or 1-based numbers), each refused in one line naming the table."""
    extra = set(spec) - keys
    if extra:
        raise DataError(f"{what}: unknown key(s) {', '.join(sorted(extra))} (known: {', '.join(sorted(keys))})")
    cols = spec.get("columns")
    if not (isinstance(cols, list) and len(cols) == 3 and all(isinstance(c, (str, int)) and not isinstance(c, bool)
                                                               for c in cols)):
        raise DataError(f"{what}.columns: three column names (or 1-based numbers) for {whose} x, y, z")
    return cols


def _triad(spec: dict, section: str, log_what: str, field_nT: float | None = None) -> Triad:
    kind, units, canon, _ = TRIADS[section]
    what = f"{log_what}[{section}]"
    cols = _three_columns(spec, what, TRIAD_KEYS, "the sensor's")
    unit = str(spec.get("unit", canon)).strip()
    lsb = None
    if unit.lower() in ("count", "counts", "lsb", "raw"):
        unit = "counts"
        if "lsb" not in spec:
            # the example in the triad's own units: a magnetometer told "lsb = '1/2048 g'" was shown an
            # accelerometer's resolution (the AK8963's 0.15 uT, 16 bits, for the magnetometer)
            eg = "1/2048 g" if kind == "acc" else "0.15 uT"
            raise DataError(f"{what}: unit = 'counts' needs lsb, what one count is (e.g. lsb = '{eg}')")
        scale = _quantity(spec["lsb"], units, canon, f"{what}.lsb", None)
        lsb = scale
    elif kind == "mag" and unit.lower() in (FIELD_UNIT, "fields"):
        # readings normalised to the local field (|b| about 1): 1.0 = the site's total field; from the
        # description's [header] field_nT, else from the log's own '# field_nT=' line at import
        unit = FIELD_UNIT
        scale = field_nT
        if "lsb" in spec:
            lsb = _field_quantity(spec["lsb"], units, canon, f"{what}.lsb", scale)
    else:
        k = _unit_key(unit, units)
        if k is None:
            raise DataError(f"{what}.unit: unknown unit {unit!r} (one of {', '.join(sorted(set(units)))}, counts)")
        scale = units[k]
        if "lsb" in spec:
            lsb = _quantity(spec["lsb"], units, canon, f"{what}.lsb", scale)
    reads = str(spec.get("reads", "down" if kind == "acc" else "down")).lower()
    if kind == "acc" and reads not in READS:
        raise DataError(f"{what}.reads: 'up' (an axis pointing up reads +1 g at rest: most MEMS parts) or 'down' "
                        f"(+1 g on the axis pointing down: the probe's convention)")
    if kind == "mag" and "reads" in spec:
        raise DataError(f"{what}.reads: only the accelerometer has a gravity sign")
    refl = spec.get("reflection", False)
    if not isinstance(refl, bool):
        raise DataError(f"{what}.reflection: true or false")
    t = Triad(kind=kind, columns=list(cols), unit=unit, scale=scale, axes=_axis_map(spec, kind, what, cols), reads=reads,
              reflection=refl, lsb=lsb)
    lag = spec.get("lag", 0)
    if isinstance(lag, bool) or not isinstance(lag, int) or abs(lag) > 1000:
        raise DataError(f"{what}.lag: a whole number of rows (-1000 ... 1000)")
    t.lag = lag
    zero = spec.get("zero", 0)
    if isinstance(zero, bool) or not isinstance(zero, (int, float)) or not np.isfinite(zero):
        raise DataError(f"{what}.zero: a number, the reading at zero input in the logged unit (e.g. 32768 for "
                        f"unsigned 16-bit counts)")
    t.zero = float(zero)
    if "counts" in spec:
        w = spec["counts"]
        m = re.fullmatch(r"(u?int)(\d+)", w.strip().lower()) if isinstance(w, str) else None
        if not m or not 2 <= int(m.group(2)) <= 64:
            raise DataError(f"{what}.counts: the counts' word as logged: \"int16\" (two's complement: a logged 65404 "
                            f"is -132), \"uint16\" (unsigned, as read), or another width (int8, int24, int32, ...)")
        if unit != "counts":
            raise DataError(f"{what}.counts: only with unit = \"counts\" (the readings are {unit})")
        t.counts = m.group(1) + m.group(2)
    if "file" in spec:
        if not (isinstance(spec["file"], str) and spec["file"].strip()):
            raise DataError(f"{what}.file: the path of the file this triad was logged to (relative: beside the log)")
        t.file = spec["file"].strip()
    for k in ("time", "time_unit", "time_offset"):
        if k in spec and "file" not in spec:
            raise DataError(f"{what}.{k}: only for a triad logged to a file of its own (file = ...); the log's time "
                            f"column is [log].{k}")
    if "time" in spec:
        t.time = _time_column(spec["time"], f"{what}.time", false=True)
        _split_unit(spec, t.time, what)
    if "time_unit" in spec:
        t.time_unit = str(spec["time_unit"]).strip()
        t.time_scale = time_scale(t.time_unit, f"{what}.time_unit")
    for k in ("noise", "range"):
        if k in spec:
            setattr(t, k, _field_quantity(spec[k], units, canon, f"{what}.{k}", scale, lsb) if unit == FIELD_UNIT
                    else _quantity(spec[k], units, canon, f"{what}.{k}", scale, lsb))
    if t.det < 0 and not t.reflection:
        raise DataError(f"{what}: the axis map ({t.axes_text()}) is a reflection (determinant -1): a left-handed "
                        f"frame; fix the map (flip one sign), or say reflection = true if the sensor's own axes are "
                        f"left-handed")
    return t


def _gyro(spec, what: str, default_axes: list | None) -> Triad:
    """The [gyroscope] table: columns, unit (deg/s, rad/s, or counts with
    lsb), an axis map (default: the accelerometer's, else the
    magnetometer's: a 9-axis part's gyroscope shares its accelerometer's
    axes), zero and counts as for a triad."""
    what = f"{what}[gyroscope]"
    if not isinstance(spec, dict):
        raise DataError(f"{what}: must be a table")
    cols = _three_columns(spec, what, GYRO_KEYS, "the gyroscope's")
    if "unit" not in spec:
        raise DataError(f"{what}.unit: the angular rate's unit, \"deg/s\", \"rad/s\", or \"counts\" with lsb")
    unit = str(spec["unit"]).strip()
    lsb = None
    if unit.lower() in ("count", "counts", "lsb", "raw"):
        unit = "counts"
        if "lsb" not in spec:
            raise DataError(f"{what}: unit = 'counts' needs lsb, what one count is (e.g. lsb = '1/131 deg/s')")
        scale = lsb = _quantity(spec["lsb"], GYRO_UNITS, "deg/s", f"{what}.lsb", None)
    else:
        k = _unit_key(unit, GYRO_UNITS)
        if k is None:
            raise DataError(f"{what}.unit: unknown unit {unit!r} (deg/s, rad/s, mrad/s, rpm, or counts with lsb)")
        scale = GYRO_UNITS[k]
        if "lsb" in spec:
            lsb = _quantity(spec["lsb"], GYRO_UNITS, "deg/s", f"{what}.lsb", scale)
    given = any(k in spec for k in ("axes", "x", "y", "z"))
    axes = _axis_map(spec, "gyro", what, cols) if given or default_axes is None else [list(a) for a in default_axes]
    t = Triad(kind="gyro", columns=list(cols), unit=unit, scale=scale, axes=axes, lsb=lsb)
    zero = spec.get("zero", 0)
    if isinstance(zero, bool) or not isinstance(zero, (int, float)) or not np.isfinite(zero):
        raise DataError(f"{what}.zero: a number, the reading at zero rate in the logged unit")
    t.zero = float(zero)
    if "counts" in spec:
        w = spec["counts"]
        m = re.fullmatch(r"(u?int)(\d+)", w.strip().lower()) if isinstance(w, str) else None
        if not m or not 2 <= int(m.group(2)) <= 64 or unit != "counts":
            raise DataError(f"{what}.counts: with unit = \"counts\", the counts' word as logged (\"int16\", ...)")
        t.counts = m.group(1) + m.group(2)
    if t.det < 0:
        # an angular rate is an axial vector: a mirrored map turns it the other way about the mirrored axes, which
        # no sign fixes for every turn
        raise DataError(f"{what}: the axis map ({t.axes_text()}) is a reflection (determinant -1): a gyroscope's "
                        f"map is a rotation of its axes; fix the map (flip one sign)")
    return t


def _merge(base: dict, over: dict) -> dict:
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.items()}
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = v
    return out


def presets() -> list:
    return sorted(p.stem for p in PRESET_DIR.glob("*.toml"))


def _load_toml(text: str, what: str) -> dict:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise DataError(f"{what}: not valid TOML ({e})") from None


def load(spec: str) -> SensorDescription:
    """A description from a TOML file path or a preset name."""
    p = Path(spec)
    if p.suffix.lower() != ".toml" and not p.exists():
        if spec not in presets():
            raise DataError(f"--sensor {spec}: no such file, and not a preset (presets: {', '.join(presets())})")
        p = PRESET_DIR / f"{spec}.toml"
    try:
        raw = p.read_bytes()
    except OSError as e:
        raise DataError(f"cannot read sensor description {spec}: {e.strerror}") from None
    if len(raw) > 1 << 20:
        raise DataError(f"{spec}: a sensor description is a small file (this one is {len(raw)} bytes)")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise DataError(f"{spec}: not UTF-8 text") from None
    d = from_toml(text, str(p))
    d.text_sha256 = hashlib.sha256(raw).hexdigest()
    d.path = str(p)
    if p.parent == PRESET_DIR and p.stem == spec:
        d.preset = spec
    return d


def from_toml(text: str, what: str = "sensor description") -> SensorDescription:
    d = _load_toml(text, what)
    only = ()
    if "preset" in d:
        name = d["preset"]
        if not isinstance(name, str) or name not in presets():
            raise DataError(f"{what}: preset {name!r} is not one of {', '.join(presets())}")
        base = _load_toml((PRESET_DIR / f"{name}.toml").read_text(encoding="utf-8"), f"preset {name}")
        only = tuple(TRIADS[s][0] for s in ("accelerometer", "magnetometer") if s in base and s not in d)
        d = _merge(base, {k: v for k, v in d.items() if k != "preset"})
    s = from_dict(d, what)
    s.from_preset = only
    return s


def from_dict(d: dict, what: str = "sensor description") -> SensorDescription:
    extra = set(d) - TOP_KEYS
    if extra:
        raise DataError(f"{what}: unknown key(s) {', '.join(sorted(extra))} (known: {', '.join(sorted(TOP_KEYS))})")
    log = d.get("log", {})
    if not isinstance(log, dict):
        raise DataError(f"{what}: [log] must be a table")
    extra = set(log) - LOG_KEYS
    if extra:
        raise DataError(f"{what}[log]: unknown key(s) {', '.join(sorted(extra))} (known: {', '.join(sorted(LOG_KEYS))})")
    s = SensorDescription(name=str(d.get("name", "unnamed sensor")), notes=str(d.get("notes", "")),
                          source=str(d.get("source", "")))
    for section in ("accelerometer", "magnetometer"):
        if section in d:
            if not isinstance(d[section], dict):
                raise DataError(f"{what}: [{section}] must be a table")
            setattr(s, TRIADS[section][0], _triad(d[section], section, what, _field_nT(d.get("header", {}), what)))
    if "gyroscope" in d:
        ref = s.acc or s.mag
        s.gyro = _gyro(d["gyroscope"], what, None if ref is None or ref.det < 0 else ref.axes)
    if not s.triads:
        raise DataError(f"{what}: describes no triad (an [accelerometer] and/or a [magnetometer] table)")
    s.delimiter = log.get("delimiter")
    if s.delimiter is not None and (not isinstance(s.delimiter, str) or len(s.delimiter) not in (1,) and
                                    s.delimiter not in ("whitespace", "\\t")):
        raise DataError(f"{what}[log].delimiter: one character, or 'whitespace'")
    dec = log.get("decimal", ".")
    if dec not in (".", ","):
        raise DataError(f"{what}[log].decimal: \".\" or \",\"")
    if dec == "," and s.delimiter == ",":
        raise DataError(f"{what}[log]: decimal = \",\" needs another delimiter (\";\", a tab, or whitespace)")
    s.decimal = dec
    s.comment = str(log.get("comment", "#"))
    hdr = log.get("header", True)
    if not isinstance(hdr, bool):
        raise DataError(f"{what}[log].header: true (the first line names the columns) or false")
    s.has_header = hdr
    sk = log.get("skip_rows", 0)
    if not isinstance(sk, int) or isinstance(sk, bool) or sk < 0:
        raise DataError(f"{what}[log].skip_rows: a whole number >= 0")
    s.skip_rows = sk
    s.time = _time_column(log.get("time"), f"{what}[log].time")
    _split_unit(log, s.time, f"{what}[log]")
    tu = str(log.get("time_unit", "s")).strip()
    s.time_scale = time_scale(tu, f"{what}[log].time_unit")
    s.time_unit = SPLIT_STAMP if split_stamp(s.time) else tu
    rate = log.get("rate_hz")
    if rate is not None:
        try:  # 100, "100 Hz", "1.5 kHz"; within the canonical header's rule
            rate = _quantity(rate, RATE_UNITS, "Hz", f"{what}[log].rate_hz", 1.0)
            dataset.check_meta("rate_hz", rate, f"{what}[log].rate_hz")
        except DataError:
            raise DataError(f"{what}[log].rate_hz: the sample rate in Hz, a finite number > 0 (e.g. rate_hz = 100), "
                            f"not {log.get('rate_hz')!r}") from None
        if s.time is not None:
            raise DataError(f"{what}[log]: rate_hz and time both give the time of a row: keep the time column "
                            f"(time = {s.time!r}) or the rate, not both")
        s.rate_hz = float(rate)
    s.temperature = log.get("temperature")
    _temperature_unit(s, log, what)
    apart = [t for t in s.triads if t.file is not None]
    if len(apart) == 2:
        raise DataError(f"{what}: both triads name a file of their own; the log given to inclino import holds one "
                        f"of them (leave out that triad's file)")
    if apart:
        # paired by time when the log has a time column (the file's own: [section].time, else the same name),
        # else (or with time = false) row by row, in order
        a = apart[0]
        section = "magnetometer" if a.kind == "mag" else "accelerometer"
        if a.time is None:
            a.time = s.time
        if a.time is False:
            a.time = None
        if a.time is not None and s.time is None:
            raise DataError(f"{what}: [{section}].time pairs that file's samples with the log's by time: the log "
                            f"needs its time column ([log].time = ...), or leave time out to pair the rows in order")
        if a.time is None and a.time_scale is not None:
            raise DataError(f"{what}: [{section}].time_unit without a time column: the rows are paired in order")
        if split_stamp(a.time):
            a.time_unit, a.time_scale = SPLIT_STAMP, 1.0
        elif a.time is not None and a.time_scale is None:
            a.time_unit, a.time_scale = ("s", 1.0) if split_stamp(s.time) else (s.time_unit, s.time_scale)
        off = d[section].get("time_offset")
        if off is not None:
            if a.time is None:
                raise DataError(f"{what}: [{section}].time_offset without a time column: the rows are paired in "
                                f"order (a line lost or added is a lag in rows: [{section}].lag)")
            a.time_offset = _signed_time(off, a.time_scale, f"{what}[{section}].time_offset")
    sa = log.get("samples_averaged")
    if sa is not None:
        if isinstance(sa, bool) or not isinstance(sa, (int, float)) or not 1 <= sa <= 1_000_000:
            raise DataError(f"{what}[log].samples_averaged: a number 1 ... 1 000 000")
        s.samples_averaged = float(sa)
    st = log.get("static")
    if st is not None and not isinstance(st, bool):
        raise DataError(f"{what}[log].static: true (a step-and-hold run: every row is at rest) or false")
    s.static = st
    br = log.get("bad_rows", "refuse")
    if br not in BAD_ROWS:
        raise DataError(f"{what}[log].bad_rows: \"refuse\" (the first malformed row stops the import) or \"drop\" "
                        "(malformed rows are dropped and counted)")
    s.bad_rows = br
    st = log.get("strip", "")
    if not isinstance(st, str) or any(c.isalnum() or c in ".+-" or c.isspace() for c in st):
        raise DataError(f"{what}[log].strip: the characters to take out of every line before it is split (brackets: "
                        f"\"()\" or \"[]\"), never a digit, a letter, a sign, a point or a space")
    s.strip = st
    keep = log.get("keep")
    if keep is not None:
        if not (isinstance(keep, dict) and all(isinstance(v, list) for v in keep.values())):
            raise DataError(f"{what}[log].keep: a table of column = [values to keep]")
        s.keep = {str(k): [str(x) for x in v] for k, v in keep.items()}
    hd = d.get("header", {})
    if not isinstance(hd, dict):
        raise DataError(f"{what}: [header] must be a table of canonical header values (dip_deg = 64.6, ...)")
    s.header = dict(hd)
    poses = d.get("poses")
    if poses is not None:
        if not isinstance(poses, dict):
            raise DataError(f"{what}: [poses] must be a table")
        extra = set(poses) - POSE_KEYS
        if extra:
            raise DataError(f"{what}[poses]: unknown key(s) {', '.join(sorted(extra))}")
        if "label" in poses:
            labels = poses.get("labels")
            if not isinstance(labels, dict) or not labels:
                raise DataError(f"{what}[poses]: label = COLUMN needs a [poses.labels] table (label = "
                                f"{{inc = ..., azi = ..., tf = ...}})")
            for k, v in labels.items():
                if not (isinstance(v, dict) and set(v) <= {"inc", "azi", "tf"} and "inc" in v and all(
                        isinstance(x, (int, float)) and not isinstance(x, bool) for x in v.values())):
                    raise DataError(f"{what}[poses.labels].{k}: {{inc = deg, azi = deg, tf = deg}} (inc required)")
        elif not all(k in poses for k in ("inc", "tf")):
            raise DataError(f"{what}[poses]: the pose columns (inc, tf and, with a magnetometer, azi) or label")
        if "unit" in poses:
            u = poses["unit"]
            if not isinstance(u, str) or u.strip().lower() not in POSE_UNITS:
                raise DataError(f"{what}[poses].unit: the unit of the pose angles, columns and labels alike: \"deg\" "
                                f"(the default) or \"rad\", not {u!r}")
            s.pose_scale = POSE_UNITS[u.strip().lower()]
        s.poses = dict(poses)
    return s


def default() -> SensorDescription:
    """The project's probe: the canonical columns, as they are."""
    return load("adis16210")


def description_hash(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()
