"""The reference field of a survey: declination, dip, total field, gravity,
and grid convergence.

* From a position and date with a maintained geomagnetic main-field model:
  IGRF through ppigrf (the default, already a dependency), or the World
  Magnetic Model through pygeomag when it is installed (optional:
  ``pip install pygeomag``).
* Or from values the user gives (in-field referencing, IFR: a local
  magnetometer survey or a crustal model in place of the main-field model).
* Gravity: WGS 84 normal gravity (Somigliana, with the free-air gradient)
  in units of standard gravity, the unit the probe reports G total in.
* Grid convergence and point scale factor of a projected CRS (EPSG code)
  from pyproj (PROJ's own factors), never hand-written projection formulas.

Conventions (docs/conventions.md section 8, pinned by tests/test_survey_conventions.py):
declination is east of true north, positive east: A_true = A_mag + dec.
Grid convergence gamma is the angle from true north to grid north, positive
when grid north lies east of true north (PROJ's meridian convergence; east
of the central meridian in the northern hemisphere for UTM):
A_grid = A_true - gamma.
"""
from __future__ import annotations

import contextlib
import datetime as _dt
import functools
import math
from dataclasses import asdict, dataclass, field

from inclino.errors import DataError
from inclino.formats.jsonout import dumps

G0 = 9.80665  # standard gravity, m/s^2: the probe's unit of G total
# QC windows (ISCWSA guidance quoted in docs/survey.md): field strength within
# 300 nT and dip within 0.25 deg of the reference are "within acceptable
# tolerances"; G total within 2.5 mg (the firmware's defaults, qc.h).
DEFAULT_TOL = {"gt_g": 0.0025, "bt_nT": 300.0, "dip_deg": 0.25}


# The rule of each number of a reference field (lo, hi, lo open): a reference
# file's fields and the command-line values alike.
RULES = {"declination_deg": (-180.0, 180.0, False), "dip_deg": (-90.0, 90.0, False),
         "field_nT": (0.0, 200_000.0, True),  # beyond what the +-100 000 nT fluxgate axes measure
         "gravity_g": (0.5, 1.5, False), "lat_deg": (-90.0, 90.0, False), "lon_deg": (-180.0, 360.0, False),
         "alt_m": (-12_000.0, 1.0e6, False), "convergence_deg": (-90.0, 90.0, False),
         "scale_factor": (0.5, 1.5, False), "easting_m": (-1e8, 1e8, False), "northing_m": (-1e8, 1e8, False)}
TOL_MAX = {"gt_g": 0.5, "bt_nT": 50_000.0, "dip_deg": 45.0}
POLE_LAT = 89.99  # closer to a geographic pole, north (and the declination) is not defined well enough


@dataclass
class ReferenceField:
    declination_deg: float
    dip_deg: float
    field_nT: float  # the total field
    gravity_g: float = 1.0  # NaN when unknown (no position, no --gravity)
    ref_source: str = "user"  # "IGRF ...", "WMM ...", "user (...)" (in-field referencing)
    lat_deg: float | None = None
    lon_deg: float | None = None
    alt_m: float = 0.0
    date: str | None = None
    grid_epsg: int | None = None
    convergence_deg: float = 0.0  # gamma: A_grid = A_true - gamma
    scale_factor: float = 1.0  # the projection's point scale factor at the wellhead
    easting_m: float | None = None  # the wellhead's projected coordinates
    northing_m: float | None = None
    tol: dict = field(default_factory=lambda: dict(DEFAULT_TOL))

    def to_dict(self) -> dict:
        """The JSON's keys, in the order `inclino reffield` prints them; an unknown value is None."""
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in asdict(self).items()}

    def to_json(self) -> str:
        return dumps(self.to_dict())  # an unknown value is null

    @staticmethod
    def from_json(text: str, where: str = "reference-field file") -> "ReferenceField":
        from inclino.formats import safeio

        return ReferenceField.from_dict(safeio.parse_json(text, where), where)

    @staticmethod
    def load(path: str) -> "ReferenceField":
        """A reference-field file (`inclino reffield -o`): bounded JSON
        (inclino.formats.safeio) and every field checked (RULES)."""
        from inclino.formats import safeio

        where = f"reference-field file {path}"
        return ReferenceField.from_dict(safeio.load_json(path, "reference-field file"), where)

    @staticmethod
    def from_dict(d, where: str = "reference-field file") -> "ReferenceField":
        """Every field by its rule (RULES: type and range; unknown values
        null), one error line naming the file and the field."""
        from inclino.formats.fields import Fields

        f = Fields(d, where)
        for old, new in (("total_nT", "field_nT"), ("source", "ref_source")):  # files written before the renames
            if old in f.d and new not in f.d:
                f.d = {**f.d, new: f.d[old]}
                del f.d[old]
        f.known(*(k for k in ReferenceField.__dataclass_fields__))
        kw = {}
        for k, (lo, hi, lo_open) in RULES.items():
            v = f.number(k, lo, hi, lo_open=lo_open, null=True, required=k in ("declination_deg",))
            if k in ("declination_deg", "dip_deg", "field_nT", "gravity_g"):
                v = float("nan") if v is None else v
            elif v is None and k in ("alt_m", "convergence_deg", "scale_factor"):
                v = {"alt_m": 0.0, "convergence_deg": 0.0, "scale_factor": 1.0}[k]
            kw[k] = v
        if (kw["lat_deg"] is None) != (kw["lon_deg"] is None):
            raise DataError(f"{where}: lat_deg and lon_deg go together")
        kw["ref_source"] = f.string("ref_source", required=False, default="user", max_len=200)
        date = f.string("date", required=False, null=True, max_len=10)
        if date is not None:
            try:
                _dt.date.fromisoformat(date)
            except ValueError:
                raise DataError(f"{where}: date must be YYYY-MM-DD, not {date[:12]!r}") from None
        kw["date"] = date
        kw["grid_epsg"] = f.integer("grid_epsg", 1024, 32767, required=False, null=True)
        if kw["grid_epsg"] is not None and (kw["easting_m"] is None or kw["northing_m"] is None):
            raise DataError(f"{where}: grid_epsg {kw['grid_epsg']} needs the wellhead's easting_m and northing_m "
                            "(inclino reffield --grid writes them)")
        tol = f.obj("tol")
        tol.known(*DEFAULT_TOL)
        kw["tol"] = {k: tol.number(k, 0.0, TOL_MAX[k], lo_open=True) for k in DEFAULT_TOL}
        return ReferenceField(**kw)

    def header(self) -> dict:
        """key=value pairs written with a run (CSV '# key=value' lines, LAS ~Parameter)."""
        d = {"ref_source": self.ref_source, "declination_deg": f"{self.declination_deg:.4f}"}
        for k, v, f in (("dip_deg", self.dip_deg, ".4f"), ("field_nT", self.field_nT, ".1f"),
                        ("gravity_g", self.gravity_g, ".6f")):
            if v is not None and math.isfinite(v):  # unknown (declination-only referencing): left out
                d[k] = format(v, f)
        if self.lat_deg is not None:
            d.update(lat_deg=f"{self.lat_deg:.6f}", lon_deg=f"{self.lon_deg:.6f}", alt_m=f"{self.alt_m:g}")
        if self.date:
            d["date"] = self.date
        if self.grid_epsg is not None:
            d.update(grid_epsg=str(self.grid_epsg), convergence_deg=f"{self.convergence_deg:.6f}",
                     scale_factor=f"{self.scale_factor:.8f}")
            if self.easting_m is not None:
                d.update(easting_m=f"{self.easting_m:.3f}", northing_m=f"{self.northing_m:.3f}")
        return d


def parse_date(text) -> _dt.date:
    if isinstance(text, _dt.datetime):
        return text.date()
    if isinstance(text, _dt.date):
        return text
    try:
        return _dt.date.fromisoformat(str(text))
    except ValueError:
        raise DataError(f"--date {text!r} is not an ISO date (YYYY-MM-DD)")


def _check_position(lat, lon, alt_m):
    for name, v, lim in (("latitude", lat, 90.0), ("longitude", lon, 180.0)):
        if v is None or not math.isfinite(v) or abs(v) > lim:
            raise DataError(f"{name} {v} is outside +-{lim:g} deg")
    if abs(lat) > POLE_LAT:
        raise DataError(f"latitude {lat:g}: at a geographic pole north, and so the declination and every "
                        f"azimuth, is undefined (the model is used within +-{POLE_LAT:g} deg); give --declination "
                        "with the grid north you survey to")
    if not math.isfinite(alt_m) or not -12000.0 <= alt_m <= 1.0e6:
        raise DataError(f"altitude {alt_m} m is out of range")


def _decompose(bn, be, bd):
    h = math.hypot(bn, be)
    return (math.degrees(math.atan2(be, bn)), math.degrees(math.atan2(bd, h)), math.sqrt(h * h + bd * bd))


def main_field(lat_deg: float, lon_deg: float, date, alt_m: float = 0.0, model: str = "igrf"):
    """(declination deg, dip deg, total nT, source) of the main-field model
    at a geodetic position (WGS 84 latitude, longitude, height above the
    ellipsoid in m) and date."""
    _check_position(lat_deg, lon_deg, alt_m)
    d = parse_date(date)
    if model == "igrf":
        import numpy as np
        import ppigrf

        first, last = igrf_range()
        when = _dt.datetime(d.year, d.month, d.day)
        if not first <= when <= last:
            raise DataError(f"--date {d.isoformat()}: outside the IGRF model's validity, {first:%Y-%m-%d} to "
                            f"{last:%Y-%m-%d} (ppigrf {_version('ppigrf')}); give the field with --declination, "
                            "--dip, --field")
        with _library_output():
            be, bn, bu = ppigrf.igrf(lon_deg, lat_deg, alt_m / 1000.0, when)
        dec, dip, f = _decompose(float(np.ravel(bn)[0]), float(np.ravel(be)[0]), -float(np.ravel(bu)[0]))
        return dec, dip, f, f"IGRF (ppigrf {_version('ppigrf')})"
    if model == "wmm":
        try:
            from pygeomag import GeoMag
        except ImportError:
            raise DataError("--model wmm needs the pygeomag package (pip install pygeomag)")
        year0 = 2025 if d.year >= 2025 else 2020 if d.year >= 2020 else 2015
        if d.year >= 2030 or d.year < 2015:
            raise DataError(f"--date {d.isoformat()}: outside the WMM models' validity (pygeomag "
                            f"{_version('pygeomag')}: WMM2015, WMM2020, WMM2025), 2015-01-01 to 2029-12-31; give the "
                            "field with --declination, --dip, --field")
        with _library_output():
            gm = GeoMag(coefficients_file=f"wmm/WMM_{year0}.COF", high_resolution=False)
            r = gm.calculate(glat=lat_deg, glon=lon_deg, alt=alt_m / 1000.0, time=_decimal_year(d))
        return float(r.d), float(r.i), float(r.f), f"WMM{year0} (pygeomag {_version('pygeomag')})"
    raise DataError(f"unknown geomagnetic model {model!r} (igrf or wmm)")


@functools.lru_cache(maxsize=1)
def igrf_range():
    """(first, last) datetime of the IGRF coefficients ppigrf evaluates (the
    main field's validity: 1900-01-01 to 2030-01-01 for IGRF-14)."""
    import ppigrf

    with _library_output():
        from ppigrf import ppigrf as _pp

        g, _ = _pp.read_shc(_pp.shc_fn)
    return g.index[0].to_pydatetime(), g.index[-1].to_pydatetime()


@contextlib.contextmanager
def _library_output():
    """What a library prints (ppigrf prints its warnings) goes to standard
    error, never into standard output, where JSON and CSV results go."""
    import sys

    with contextlib.redirect_stdout(sys.stderr):
        yield


def _version(dist: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(dist)
    except PackageNotFoundError:
        return "?"


def _decimal_year(d: _dt.date) -> float:
    start = _dt.date(d.year, 1, 1)
    days = (_dt.date(d.year + 1, 1, 1) - start).days
    return d.year + (d - start).days / days


def normal_gravity_g(lat_deg: float, alt_m: float = 0.0) -> float:
    """WGS 84 normal gravity (Somigliana's closed form) with the free-air
    gradient, in units of standard gravity."""
    s2 = math.sin(math.radians(lat_deg)) ** 2
    g = 9.7803253359 * (1 + 0.00193185265241 * s2) / math.sqrt(1 - 0.00669437999013 * s2)
    return (g - 3.086e-6 * alt_m) / G0


def grid(lat_deg: float, lon_deg: float, epsg: int):
    """(convergence deg, point scale factor, easting m, northing m) of a
    projected CRS at a geodetic WGS 84 position, from pyproj."""
    import pyproj

    try:
        crs = pyproj.CRS.from_epsg(int(epsg))
    except (pyproj.exceptions.CRSError, ValueError, OverflowError) as e:
        raise DataError(f"--grid {epsg}: not an EPSG code pyproj knows ({e})")
    if not crs.is_projected:
        raise DataError(f"--grid {epsg}: {crs.name} is not a projected CRS")
    _within_area_of_use(crs, epsg, lat_deg, lon_deg)
    proj = pyproj.Proj(crs)
    tr = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True)
    x, y = tr.transform(lon_deg, lat_deg)
    if not (math.isfinite(x) and math.isfinite(y)):
        raise DataError(f"--grid {epsg}: the position is outside {crs.name}")
    # the projection's factors at the position in the CRS's own datum (ED50, OSGB36, ...), not at the WGS 84
    # latitude and longitude read as if they were that datum's
    to_own = pyproj.Transformer.from_crs("EPSG:4326", crs.geodetic_crs, always_xy=True)
    lon_own, lat_own = to_own.transform(lon_deg, lat_deg)
    f = proj.get_factors(lon_own, lat_own, errcheck=False)
    gamma = float(f.meridian_convergence)
    k = math.sqrt(float(f.meridional_scale) * float(f.parallel_scale))
    if not (math.isfinite(gamma) and math.isfinite(k)):
        raise DataError(f"--grid {epsg}: the projection has no factors at this position")
    # PROJ's meridian convergence may be defined against the CRS's axis order; what matters
    # is the grid azimuth of true north, measured here from the projection itself
    tn = _grid_azimuth_of_true_north(tr, lat_deg, lon_deg)
    if abs(-tn - gamma) > abs(-tn + gamma):  # PROJ's sign convention for this CRS's axes: the value stays PROJ's
        gamma = -gamma
    return gamma, k, float(x), float(y)


GRID_AREA_MARGIN_DEG = 1.0  # a position this far outside a projected CRS's area of use is refused


def _within_area_of_use(crs, epsg, lat, lon) -> None:
    """Refuse a position more than GRID_AREA_MARGIN_DEG outside the CRS's
    area of use (EPSG's, through pyproj): a UTM zone far away gives a
    convergence of any size (98.8 deg at 52 N 100 E in zone 31N; one zone off,
    5.5 deg where 0.6 is right), taken as the site's without a word.  A CRS
    without an area of use is not judged."""
    a = crs.area_of_use
    if a is None:
        return
    west, south, east, north = a.west, a.south, a.east, a.north
    lon_in = (lon - west) % 360.0  # east of the area's west edge (an area across 180 deg wraps)
    span = (east - west) % 360.0 or 360.0
    m = GRID_AREA_MARGIN_DEG
    off_lon = 0.0 if lon_in <= span else min(lon_in - span, 360.0 - lon_in)
    off_lat = max(south - lat, lat - north, 0.0)
    if off_lon > m or off_lat > m:
        zone = ""
        if "UTM zone" in crs.name and -80.0 <= lat <= 84.0:
            z = int((lon + 180.0) // 6.0) % 60 + 1
            zone = f"; the UTM zone there is {z}{'N' if lat >= 0 else 'S'} (EPSG:{(32600 if lat >= 0 else 32700) + z})"
        raise DataError(f"--grid {epsg}: {crs.name} is for {west:g} to {east:g} deg E, {south:g} to "
                        f"{north:g} deg N; the position {lat:g} N, {lon:g} E is outside it, where its convergence "
                        f"and scale factor are no grid's the survey uses{zone}")


def _grid_azimuth_of_true_north(tr, lat, lon, dlat=1e-5):
    x0, y0 = tr.transform(lon, lat - dlat)
    x1, y1 = tr.transform(lon, lat + dlat)
    return math.degrees(math.atan2(x1 - x0, y1 - y0))


def reference(lat=None, lon=None, date=None, alt_m=0.0, model="igrf", declination=None, dip=None,
              field=None, gravity=None, grid_epsg=None, tol=None) -> ReferenceField:
    """The reference field of a survey.  A position and date give the
    model's values; any of declination, dip, field (the total, nT), gravity (g) given
    override it (in-field referencing).  Declination alone is enough for
    azimuths (dip and total then default to NaN: no field QC)."""
    have_pos = lat is not None or lon is not None
    if have_pos and (lat is None or lon is None):
        raise DataError("--lat and --lon go together")
    if model is None:
        model = "igrf"
    src = "user"
    dec0 = dip0 = f0 = float("nan")
    dstr = None
    if have_pos and date is not None:
        dec0, dip0, f0, src = main_field(lat, lon, date, alt_m, model)
        dstr = parse_date(date).isoformat()
    elif have_pos and declination is None:
        raise DataError("--lat/--lon need --date (or give --declination)")
    elif not have_pos and declination is None:
        raise DataError("give the position and date (--lat --lon --date) or --declination")
    user = []
    for name, key, v in (("declination", "declination_deg", declination), ("dip", "dip_deg", dip),
                         ("field", "field_nT", field), ("gravity", "gravity_g", gravity)):
        if v is not None:
            lo, hi, lo_open = RULES[key]
            unit = {"field": "nT", "gravity": "g"}.get(name, "deg")
            if not (math.isfinite(v) and (lo < v if lo_open else lo <= v) and v <= hi):
                raise DataError(f"--{name} {v:g}: {unit} within {'(' if lo_open else '['}{lo:g}, {hi:g}]")
            if name != "gravity":
                user.append(name)
    if declination is not None:
        dec0 = float(declination)
    if dip is not None:
        dip0 = float(dip)
    if field is not None:
        f0 = float(field)
    if user:
        src = f"user ({', '.join(user)})" + ("" if src == "user" else f"; else {src}")
    if gravity is not None:
        g = float(gravity)
    else:
        g = normal_gravity_g(lat, alt_m) if have_pos else float("nan")  # unknown: no G-total QC
    rf = ReferenceField(dec0, dip0, f0, g, src, lat, lon, float(alt_m), dstr)
    if tol:
        rf.tol.update(tol)
    if grid_epsg is not None:
        if not have_pos:
            raise DataError("--grid needs the wellhead position (--lat --lon)")
        add_grid(rf, grid_epsg)
    return rf


def add_grid(rf: ReferenceField, epsg: int, where: str = "") -> ReferenceField:
    """The grid of a projected CRS (convergence, scale factor, the
    wellhead's easting and northing) at the reference's position: a
    property of the site and the projection, so it is added as well to a
    reference read from a file (`--ref REF.json --grid EPSG`)."""
    if rf.lat_deg is None or rf.lon_deg is None:
        raise DataError(f"--grid {epsg} needs the wellhead position, and {where or 'the reference'} has none "
                        "(lat_deg, lon_deg unknown): write it with inclino reffield --lat --lon ... --grid EPSG")
    rf.grid_epsg = int(epsg)
    rf.convergence_deg, rf.scale_factor, rf.easting_m, rf.northing_m = grid(rf.lat_deg, rf.lon_deg, epsg)
    return rf
