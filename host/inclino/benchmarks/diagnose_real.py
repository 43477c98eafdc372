"""The real-data section of `inclino bench diagnose`: the diagnosis on real
sensors' readings (the corpus in tests/data/real, imported through each
log's sensor description), with known effects injected into them and
without.

Real readings carry what the emulator does not: a part's own noise and
quantisation, hand placement, motion between neighbouring rows (a tumbled
log), whatever the bench did.  An injected effect must be found through
all of that; on the untouched readings nothing tied to a variable the data
do not depend on may be named.

* **Injected** (per dataset, seeded): a temperature bias on a random axis
  against a synthetic temperature column cycling 2.5 times over the run; a
  scale nonlinearity on a random axis (raw += k2 (raw - offset)^2); a rig
  disturbance -- |b| as harmonics 1-2 of a synthetic rig angle column, the
  field's size changed along its own direction; a field drift of the total
  with the rows in a randomised order (a t_s column in that order).  Each at
  Z_INJECT noise standard deviations of its signature in that dataset's
  invariants once the baseline has absorbed what it can, under the data's
  own noise and serial correlation -- for a driven effect on a serially
  correlated log, the inflation its circular-shift test measures on the
  untouched data (diagnose.posefree.signature_z; the benchmark's sweep
  sizes, where its detection target holds).  On a step-and-hold log, on
  the holds the injected log reads as (an effect can change them: a
  drifting reading cuts a long hold where it turns past 0.5 deg), the
  readings without it; and on a log with an accelerometer whose holds
  alone leave the model undetermined, where an effect found on every row
  is named only where the holds alone confirm it, on the holds
  (posefree.holds_view; the record lists such datasets as
  sized_on_holds).  Not counted, and listed as not_testable: an injection
  whose signature one pose carries more than TOP_SHARE_MAX of (the other
  poses hold less than z / 2 of it: what that pose's being an outlier
  would show, and the diagnosis sets such a pose aside); one whose size
  does not settle on the holds it makes (after SIZING_ROUNDS sizings the
  injected log still reads holds it was not sized on, so z = 12 is not
  defined for it: a temperature bias on the MPU-6050 session drifts its
  37 s first hold past the 0.5 deg turn into 53-90 holds, and its size
  per unit on them moves 2-3x); and one so large
  at z = 12 that the pose-free calibration refuses the injected log (its
  readings on no ellipsoid its orientations determine).  Found = the right name,
  sensor and axis among the effects named; an effect tied to a driver the
  readings do not depend on, named beside it, is listed (also_driven).
* **Untouched, resampled**: a random 70 % of each dataset's poses (in their
  order; in a step-and-hold log without poses whose holds determine the
  model, of its holds, each with the rows read while moving on to the next;
  a log of fewer than 100 keeps them all) with null variables added -- a synthetic temperature column, a
  synthetic rig angle, a time column in a random order -- that the readings
  do not depend on.  A false alarm is any effect named that is tied to them
  (temperature, rig field, field drift).  Effects of the sensor itself named
  on the untouched data (a real nonlinearity may be there) are reported with
  the fraction of resamplings that name them and the confounds given.

Targets: every injected kind found in >= 95 % of its datasets; false alarms
<= 2 % of the resamplings.  The corpus' pose-free logs are used (SAP6's six
instruments, CK-Explorer's tumbled logs thinned to every third row,
BROAD's two trials, an MPU-6050's step-and-hold session and a QMC5883L
turned by hand);
imucal's six faces are too few orientations for a pose-free diagnosis (the
diagnosis says so).
"""
from __future__ import annotations

import copy
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from inclino.formats.jsonout import dumps

Z_INJECT = 12.0
NULL_FRACTION = 0.7
SUBSAMPLE_MIN = 100  # poses: below this the resamplings keep every pose and redraw the null variables only
TARGETS = {"found_min": 0.95, "false_alarm_max": 0.02, "prediction_ratio": (0.7, 1.4)}
NULL_DRIVERS = ("temperature-bias", "temperature-scale", "rig-field", "field-drift")
CK_THIN = 3


def corpus_dir() -> Path | None:
    import inclino

    p = Path(inclino.__file__).resolve().parents[2] / "tests" / "data" / "real"
    return p if p.is_dir() else None


def corpus() -> list:
    """(name, RawDataset) of the corpus' pose-free logs."""
    from inclino.formats import importlog, sensor

    root = corpus_dir()
    if root is None:
        return []
    out = []
    for d in ("BB", "CF", "FG", "HC", "IB", "JG"):
        ds, _ = importlog.import_log(str(root / "sap6" / f"{d}.csv"), sensor.load(str(root / "sap6" / "sensor.toml")))
        out.append((f"sap6/{d}", ds))
    for log, desc in (("acc_mag_log.csv", "sensor.toml"), ("acc_log.csv", "acc_only.toml")):
        ds, _ = importlog.import_log(str(root / "ck_acc_mag" / log), sensor.load(str(root / "ck_acc_mag" / desc)))
        out.append((f"ck/{log}", _rows(ds, np.arange(0, len(ds), CK_THIN))))
    # BROAD's hand-turned IMU, its magnetometer alone, without the optical poses and the time (a pose-free log:
    # the bench's synthetic rig angle and time are then its only ones)
    for trial in ("05", "02"):
        ds, _ = importlog.import_log(str(root / "broad" / f"{trial}.csv"), sensor.load(str(root / "broad" / "sensor.toml")))
        for c in ("inc_deg", "azi_deg", "tf_deg", "t_s"):
            ds.columns.pop(c, None)
        out.append((f"broad/{trial}", ds))
    # an MPU-6050's accelerometer held by hand at one orientation after another (54 holds in 15 directions,
    # and one 10-row stop set aside: inclino.holds) and a QMC5883L magnetometer turned by hand;
    # last, so that the logs above keep their seeds
    for name, log in (("mpu6050_tedaldi", "example_data_calibration.csv"), ("qmc5883l", "filtered_raw_data.csv")):
        ds, _ = importlog.import_log(str(root / name / log), sensor.load(str(root / name / "sensor.toml")))
        out.append((name, ds))
    return out


def _rows(ds, rows):
    from inclino.formats.dataset import RawDataset

    return RawDataset({k: np.asarray(v)[rows].copy() for k, v in ds.columns.items()}, dict(ds.meta))


def _units(ds) -> np.ndarray:
    """What the diagnosis reads as its poses, one label per row, for a
    resampling to keep or drop whole: the poses
    (inclino.calib.covariance.cluster_labels); in a step-and-hold log
    without them whose holds determine the model (inclino.holds.determining),
    each hold with the rows read while moving on to the next, so that a
    resampling keeps holds whole.  (A log whose holds do not is read row by
    row, and resampled so.)"""
    from inclino import holds
    from inclino.calib.covariance import cluster_labels

    h = holds.determining(ds)
    if h is None:
        return cluster_labels(ds)
    labels = h[0]
    start = np.zeros(len(ds), bool)
    start[0] = True
    start[1:] = (labels[1:] >= 0) & (labels[1:] != labels[:-1])
    return np.cumsum(start) - 1


def _raw_offset(x):
    """The centre of a triad's readings (the ellipsoid's), for injecting."""
    from inclino.diagnose.posefree import _ellipsoid_start

    _, c = _ellipsoid_start(x, 1.0)
    return c


COLS = {"acc": ("ax_g", "ay_g", "az_g"), "mag": ("mx_nT", "my_nT", "mz_nT")}


def _with_nulls(ds, rng, time_order=None):
    """A copy with a synthetic temperature (2.5 cycles over the run, random
    phase), a synthetic rig angle (tf_deg, random per row) and, when
    time_order is given, t_s in that order (s)."""
    d = copy.deepcopy(ds)
    n = len(d)
    ph = rng.uniform(0, 2 * np.pi)
    d.columns["temp_c"] = 25.0 + 20.0 * np.sin(2 * np.pi * 2.5 * np.arange(n) / n + ph)
    d.columns["tf_deg"] = rng.uniform(0.0, 360.0, n)
    if time_order is not None:
        t = np.empty(n)
        t[time_order] = np.arange(n, dtype=float) * 10.0
        d.columns["t_s"] = t
    return d


def inject(ds, kind, rng, key=None, detail=False) -> tuple:
    """(dataset with the effect, the key it should be named as, the value);
    key: the candidate (its sensor and axis) instead of one drawn at
    random, for a temperature bias or a scale nonlinearity; detail: also
    the largest share of its signature one pose carries
    (posefree.signature_poses)."""
    from inclino.diagnose.posefree import signature_poses

    tris = [t for t in ("acc", "mag") if (ds.has_acc if t == "acc" else ds.has_mag)]
    if kind in ("rig-field", "field-drift") and not ds.has_mag:
        return None
    if kind == "field-drift":
        order = rng.permutation(len(ds))
        d = _with_nulls(_rows(ds, order), rng, time_order=np.arange(len(ds)))
        d.columns.pop("tf_deg")
        key = "field-drift:field:total"
    else:
        d = _with_nulls(ds, rng)
        if kind != "rig-field":
            d.columns.pop("tf_deg")
        elif (unit := _units(ds)).max() + 1 < len(ds):
            # a rig that drives the field holds its axis through each hold the diagnosis reads (and the motion on
            # to the next)
            d.columns["tf_deg"] = rng.uniform(0.0, 360.0, int(unit.max()) + 1)[unit]
        if key is None and kind in ("temperature-bias", "scale-nonlinearity"):
            tri = tris[int(rng.integers(len(tris)))]
            key = f"{kind}:{tri}:{'xyz'[int(rng.integers(3))]}"
        elif key is None:
            key = "rig-field:rig:tf"
    w = None
    if kind == "rig-field":
        c = rng.normal(size=4)
        c /= np.linalg.norm(c)
        nch = 2 if d.has_acc else 1
        w = np.concatenate([c, np.zeros(4 * (nch - 1))])
    sign = 1.0 if kind == "rig-field" or rng.random() < 0.5 else -1.0
    sized = signature_poses(d, key, w)
    value = sign * Z_INJECT / sized["z"]
    out = _apply(d, kind, key, value, w)
    used = d
    tried = []  # (holds sized on, value) of each round
    for _ in range(SIZING_ROUNDS + 1):
        # an effect can change which rows read as held (a drifting reading cuts a long hold where it turns past
        # 0.5 deg; a short stop settles into fewer rows): sized again on the holds the injected log has, the
        # readings without it
        if _same_holds(out, used):
            unsettled = None
            break
        tried.append((_hold_count(used), float(value)))
        if len(tried) > SIZING_ROUNDS:
            # the size read on the holds it makes does not settle: the log's last version reads holds it was not
            # sized on, and z = Z_INJECT is not defined for it (the MPU-6050 session: a temperature bias drifts
            # its 37 s first hold through the 0.5 deg turn into 53-90 holds, and the signature per unit on them
            # moves 2-3x with which holds the baseline sets aside as outliers)
            seen = ", ".join(f"{v:.3g} on {c} holds" for c, v in tried)
            unsettled = f"its size does not settle on the holds it makes ({seen}; the last reads {_hold_count(out)})"
            break
        used = out
        sized = signature_poses(d, key, w, holds_of=out)
        value = sign * Z_INJECT / sized["z"]
        out = _apply(d, kind, key, value, w)
    if detail:
        return out, key, float(value), sized["top_share"], unsettled
    return out, key, float(value)


SIZING_ROUNDS = 3
TOP_SHARE_MAX = 0.75  # one pose holding more of a signature's square: the others hold less than z / 2 of it


def _hold_count(ds) -> int:
    """How many static holds a log reads (0 when it is not step-and-hold)."""
    from inclino import holds

    h = holds.find(ds)
    return h.count if h.step_and_hold else 0


def _same_holds(a, b) -> bool:
    """Whether two versions of one log's rows read as the same static holds."""
    from inclino import holds

    ha, hb = holds.find(a), holds.find(b)
    if not (ha.step_and_hold or hb.step_and_hold):
        return True
    return ha.step_and_hold == hb.step_and_hold and np.array_equal(ha.labels, hb.labels)


def _apply(ds, kind, key, value, w):
    """A copy of ds with the effect `key` of size value (rig field: the
    harmonics' weights w) in its readings."""
    d = copy.deepcopy(ds)
    name, tri, ax = key.split(":")
    if kind == "temperature-bias":
        col = COLS[tri]["xyz".index(ax)]
        dT = d.columns["temp_c"] - d.columns["temp_c"].mean()
        d.columns[col] = d.columns[col] + value * dT
    elif kind == "scale-nonlinearity":
        col = COLS[tri]["xyz".index(ax)]
        x = np.stack([d.columns[c] for c in COLS[tri]], -1)
        o = _raw_offset(x)["xyz".index(ax)]
        d.columns[col] = d.columns[col] + value * (d.columns[col] - o) ** 2
    else:
        m = np.stack([d.columns[c] for c in COLS["mag"]], -1)
        u = m - _raw_offset(m)
        u = u / np.linalg.norm(u, axis=1, keepdims=True)
        if kind == "rig-field":
            ph = np.radians(d.columns["tf_deg"])
            a = value * (np.column_stack([np.cos(ph), np.sin(ph), np.cos(2 * ph), np.sin(2 * ph)]) @ w[:4])
        else:
            a = value * (d.columns["t_s"] - d.columns["t_s"].mean())
        for j, c in enumerate(COLS["mag"]):
            d.columns[c] = d.columns[c] + a * u[:, j]
    return d


@dataclass
class RealDiagnoseBench:
    datasets: list = field(default_factory=list)
    z_inject: float = Z_INJECT
    injected: dict = field(default_factory=dict)  # kind -> {"cases", "found", "rate", "missed": [...]}
    nulls: dict = field(default_factory=dict)
    untouched: dict = field(default_factory=dict)  # dataset -> the effects named on the whole untouched log
    # dataset -> invariant -> predicted and achieved residual RMS on held-out blocks of poses, their ratio
    prediction: dict = field(default_factory=dict)
    targets: dict = field(default_factory=lambda: dict(TARGETS))
    met: dict = field(default_factory=dict)
    passed: bool = False
    elapsed_s: float = 0.0
    note: str = ""

    def to_json(self) -> str:
        return dumps(asdict(self))

    def lines(self) -> list:
        if not self.datasets:
            return [f"real data: {self.note}"]
        out = [f"real data ({', '.join(self.datasets)}), pose-free, effects injected at z = {self.z_inject:g}:"]
        for k, v in self.injected.items():
            if not v["cases"] and not v.get("not_testable"):
                out.append(f"  {k:20s} no case: the logs have no magnetometer")
                continue
            out.append(f"  {k:20s} found {v['found']}/{v['cases']} ({v['rate']:.0%})"
                       + (f"; missed {v['missed']}" if v["missed"] else "")
                       + (f"; with a null driver's effect named too: {v['also_driven']}" if v.get("also_driven")
                          else "")
                       + (f"; sized on the holds: {', '.join(v['sized_on_holds'])}" if v.get("sized_on_holds")
                          else "")
                       + (f"; not testable at this size (not counted): {v['not_testable']}" if v.get("not_testable")
                          else ""))
        n = self.nulls
        if n:
            out.append(f"  untouched, resampled with null temperature, rig angle and time: {n['false_alarms']} false "
                       f"alarm(s) in {n['resamplings']} ({n['rate']:.1%}; target <= "
                       f"{self.targets['false_alarm_max']:.0%}); sensor effects named: "
                       + (", ".join(f"{k} {v:.0%}" for k, v in n["sensor_effects_named"].items()) or "none"))
        for name, u in self.untouched.items():
            out.append(f"  {name}: " + (", ".join(u["named"]) or "nothing named")
                       + ("; unexplained structure" if u["unexplained"] else "")
                       + ("; confounded: " + ", ".join(u["confounded"]) if u["confounded"] else ""))
        if self.prediction:
            lo, hi = self.targets["prediction_ratio"]
            rs = [v["ratio"] for p in self.prediction.values() for v in p.values()]
            inside = sum(lo <= r <= hi for r in rs)
            out.append(f"  held-out poses, achieved/predicted residual RMS of the invariants: {inside} of {len(rs)} "
                       f"inside {lo:g}-{hi:g} (ratios {min(rs):.2f}-{max(rs):.2f})")
            for name, p in self.prediction.items():
                out.append(f"    {name}: " + ", ".join(f"{k} {v['ratio']:.2f}" for k, v in p.items()))
        out.append("  verdict: " + ("met" if self.passed else "NOT met: " + ", ".join(k for k, v in self.met.items()
                                                                                    if not v)))
        return out


def _named(r):
    return [f"{e.name}:{e.sensor}:{e.axis}" for e in r.effects]


def bench_real(seeds: int = 2, resamplings: int = 12, seed0: int = 2024, quick: bool = False,
               logs=None) -> RealDiagnoseBench:
    """The real-data section; logs: only the corpus logs whose names start
    with one of these (each keeps its place in the corpus, so its draws are
    the ones it has in the whole section); quick: SAP6's six logs only (small: for the
    tests, not the targets' figures)."""
    from inclino.diagnose.analysis import diagnose
    from inclino.diagnose.posefree import calibration_refused, holds_view
    from inclino.errors import DataError

    t0 = time.perf_counter()
    out = RealDiagnoseBench()
    data = [(i, n, d) for i, (n, d) in enumerate(corpus())]  # i: the log's place in the corpus, in its seeds
    if quick:
        data = [(i, n, d) for i, n, d in data if n.startswith("sap6/")]
    if not data:
        out.note = "the corpus (tests/data/real) is not in this checkout"
        return out
    if logs:
        data = [(i, n, d) for i, n, d in data if any(n.startswith(x) for x in logs)]
        if not data:
            out.note = f"no corpus log's name starts with {', '.join(logs)}"
            return out
    out.datasets = [n for _, n, _ in data]
    on_holds = {n for _, n, d in data if holds_view(d) is not None}
    for _, name, ds in data:
        r = diagnose(ds)
        out.untouched[name] = {"named": _named(r), "unexplained": bool(r.unexplained),
                               "confounded": [f"{c['effect']} ~ {c['with']} ({c['correlation']:.2f})"
                                              for c in r.confounded]}
        # the held-out prediction of the model the diagnosis ends with (the named effects in it, where any)
        pr = (r.baseline.get("prediction_with_effects") or r.baseline.get("prediction") or {}).get("by_invariant")
        if pr:
            out.prediction[name] = pr
    for kind in ("temperature-bias", "scale-nonlinearity", "rig-field", "field-drift"):
        rec = {"cases": 0, "found": 0, "missed": [], "errors": [], "also_driven": [], "sized_on_holds": [],
               "not_testable": []}
        for i, name, ds in data:
            for s in range(seeds):
                rng = np.random.default_rng([seed0, i, s, len(kind)])
                got = inject(ds, kind, rng, detail=True)
                if got is None:
                    continue
                d, key, value, top, unsettled = got
                # what the log cannot show at this size is no test of the diagnosis: a signature one pose carries
                # most of (it is what that pose's being an outlier shows: the other poses hold less than z / 2),
                # an effect whose size at z = 12 changes the holds it is read on past settling, or an effect so
                # large at z = 12 that the readings no longer lie on an ellipsoid their orientations determine
                why = (f"one pose carries {top:.0%} of its signature" if top > TOP_SHARE_MAX else
                       unsettled or calibration_refused(d))
                if why:
                    rec["not_testable"].append(f"{name} {key} ({value:.3g}): {why}")
                    continue
                rec["cases"] += 1
                if name in on_holds and name not in rec["sized_on_holds"]:
                    rec["sized_on_holds"].append(name)
                try:
                    r = diagnose(d)
                except DataError as e:
                    rec["errors"].append(f"{name}: {e}")
                    rec["missed"].append(f"{name} {key}")
                    continue
                # beside the injected effect, anything tied to a driver the readings do not depend on
                also = [k for k in _named(r) if k != key and k.split(":")[0] in NULL_DRIVERS]
                if also:
                    rec["also_driven"].append(f"{name} {key}: {', '.join(also)}")
                if key in _named(r):
                    rec["found"] += 1
                else:
                    rec["missed"].append(f"{name} {key} (named {', '.join(_named(r)) or 'nothing'})")
        rec["rate"] = rec["found"] / max(rec["cases"], 1)
        out.injected[kind] = rec
    fa, total, sensor_named, fa_list = 0, 0, {}, []
    for i, name, ds in data:
        for s in range(resamplings):
            rng = np.random.default_rng([seed0, i, s, 99])
            lab = _units(ds)
            if lab.max() + 1 >= SUBSAMPLE_MIN:
                keep_c = np.sort(rng.choice(lab.max() + 1, int(NULL_FRACTION * (lab.max() + 1)), replace=False))
                sub = _rows(ds, np.flatnonzero(np.isin(lab, keep_c)))
            else:  # a small log keeps every pose: the null variables are what is drawn afresh
                sub = ds
            d = _with_nulls(sub, rng, time_order=np.arange(len(sub)))
            total += 1
            try:
                r = diagnose(d)
            except DataError:
                continue
            named = _named(r)
            bad = [k for k in named if k.split(":")[0] in NULL_DRIVERS]
            if bad:
                fa += 1
                fa_list.append(f"{name}#{s}: {', '.join(bad)}")
            for k in named:
                if k.split(":")[0] not in NULL_DRIVERS:
                    sensor_named[f"{name} {k}"] = sensor_named.get(f"{name} {k}", 0) + 1
    out.nulls = {"resamplings": total, "false_alarms": fa, "rate": fa / max(total, 1), "which": fa_list,
                 "sensor_effects_named": {k: v / resamplings for k, v in sensor_named.items()}}
    out.met = {"injected_found": all(v["rate"] >= TARGETS["found_min"] for v in out.injected.values() if v["cases"]),
               "false_alarms": out.nulls["rate"] <= TARGETS["false_alarm_max"],
               "prediction": all(TARGETS["prediction_ratio"][0] <= v["ratio"] <= TARGETS["prediction_ratio"][1]
                                 for p in out.prediction.values() for v in p.values())}
    out.passed = all(out.met.values())
    out.elapsed_s = time.perf_counter() - t0
    return out
