"""One JSON form for every result (inclino.formats.jsonout): numpy scalars and
arrays to Python, NaN and infinities to null, and the results that used to
carry their own sanitizer (accept, the fit report, the diagnosis) use it."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from inclino.formats.jsonout import dumps, json_safe


def test_numpy_values_become_python_and_nonfinite_becomes_null(rng):
    a = rng.normal(size=(2, 3))
    d = {1: np.float32(0.5), "b": np.int16(-7), "c": np.bool_(True), "d": a, "e": (np.nan, -np.inf, 2.0),
         "f": [np.float64(np.inf), {"g": np.array([1, 2], np.uint8)}]}
    out = json_safe(d)
    assert out == {"1": 0.5, "b": -7, "c": True, "d": a.tolist(), "e": [None, None, 2.0],
                   "f": [None, {"g": [1, 2]}]}
    assert type(out["b"]) is int and type(out["c"]) is bool and type(out["1"]) is float
    assert json.loads(dumps(d)) == out


def test_a_value_json_cannot_hold_is_an_error_not_nan_text():
    class Odd:
        pass
    with pytest.raises(TypeError):
        dumps({"x": Odd()})
    assert "NaN" not in dumps([float("nan"), np.float32("nan")])


def test_accept_result_writes_numpy_nan_as_null():
    from inclino.procedures.accept_result import AcceptResult

    r = AcceptResult(grid="li2021", probe_serial=np.int64(7), before="identity", after="cal",
                     declination_deg=np.float64(1.5),
                     stats={"after": {"azi_rms_deg": np.float64("nan"), "inc_rms_deg": np.float32(0.25)}},
                     passed=np.bool_(False), points=[{"set_inc": np.float64(5.0), "errs": np.arange(2.0)}])
    d = json.loads(r.to_json())
    assert d["probe_serial"] == 7 and d["passed"] is False and d["declination_deg"] == 1.5
    assert d["stats"]["after"] == {"azi_rms_deg": None, "inc_rms_deg": 0.25}
    assert d["points"] == [{"set_inc": 5.0, "errs": [0.0, 1.0]}]


def test_fit_report_and_diagnosis_use_the_one_form():
    from inclino.calib import report
    from inclino.diagnose import result

    assert report.json_safe is json_safe and result.json_safe is json_safe
    g = result.Gain(np.float64(1.0), np.float32(0.5), math.nan, np.float64(0.4), None, np.float64(np.inf),
                    np.float64(0.1), 0.05)
    d = g.to_dict()
    assert d["cv_rms_before"] is None and d["azi_rms_after_deg"] is None and d["azi_rms_before_deg"] is None
    assert type(d["rms_before"]) is float and d["rms_after"] == 0.5


def test_the_diagnosis_json_is_the_object_docs_diagnose_md_names():
    """docs/diagnose.md says what `diagnose --json` prints "exactly": its
    top-level keys and an effect's are those of Diagnosis.to_dict()."""
    import re
    from pathlib import Path

    from inclino.diagnose.result import Diagnosis, Effect, Gain

    text = (Path(__file__).parents[1] / "docs" / "diagnose.md").read_text(encoding="utf-8")
    shown = re.search(r"`--json` prints exactly\s*`\{(.*?)\}`\s", text, re.S)[1]
    effect = re.search(r'"effects": \[\{(.*?)\}\]', shown)[1]

    def keys(obj):  # the keys at the top level of an object's text: nested objects and lists emptied first
        while re.search(r"\{[^{}\[\]]*\}|\[[^{}\[\]]*\]", obj):
            obj = re.sub(r"\{[^{}\[\]]*\}|\[[^{}\[\]]*\]", "_", obj)
        return [k.strip().strip('"').split('"')[0] for k in obj.split(",")]
    top, effect_keys = keys(shown), keys(effect)
    g = Gain(1.0, 1.0, 1.0, 1.0, None, None, 0.0, 0.0)
    d = Diagnosis(baseline={}, effects=[Effect("e", "mag", "x", 0.0, 0.0, "nT", g)]).to_dict()
    assert set(top) == set(d), (top, list(d))
    assert set(effect_keys) == set(d["effects"][0]), (effect_keys, list(d["effects"][0]))
